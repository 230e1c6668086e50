// mdr-health-probe: a grpc.health.v1 check for container health checks (plaintext, loopback):
// exits 0 if the named service is SERVING, 1 otherwise, 2 on a usage error. The request and
// response are encoded by hand (field 1 of each: the service name, the status enum), so no
// generated health stubs are needed and the runtime image needs no Python.
//   mdr-health-probe [ADDRESS] [SERVICE]   (defaults: the port of $MDR_LISTEN, else 50051, on
//                                           127.0.0.1; "readiness")
#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/byte_buffer.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <string>
#include <vector>

namespace {

constexpr int kServing = 1;

// 127.0.0.1 with the port mdrd listens on according to its environment (the container's).
std::string DefaultAddress() {
  const char* listen = std::getenv("MDR_LISTEN");
  const std::string text = listen != nullptr ? listen : "";
  const std::size_t colon = text.rfind(':');
  return "127.0.0.1:" + (colon == std::string::npos ? "50051" : text.substr(colon + 1));
}

grpc::ByteBuffer CheckRequest(const std::string& service) {
  std::string bytes;
  if (!service.empty()) bytes = std::string{'\x0a', static_cast<char>(service.size())} + service;
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

// HealthCheckResponse.status (field 1, varint); absent means UNKNOWN (0).
int StatusOf(const grpc::ByteBuffer& response) {
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return 0;
  std::string bytes;
  for (const grpc::Slice& slice : slices) bytes.append(slice.begin(), slice.end());
  return bytes.size() >= 2 && bytes[0] == 0x08 ? bytes[1] : 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 3 || (argc > 1 && argv[1][0] == '-')) {
    std::fprintf(stderr, "usage: mdr-health-probe [ADDRESS] [SERVICE]\n");
    return 2;
  }
  const std::string address = argc > 1 ? argv[1] : DefaultAddress();
  const std::string service = argc > 2 ? argv[2] : "readiness";
  if (service.size() > 127) {
    std::fprintf(stderr, "mdr-health-probe: SERVICE must be at most 127 bytes\n");
    return 2;
  }
  grpc::GenericStub stub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(2));
  const grpc::ByteBuffer request = CheckRequest(service);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(status); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok()) {
    std::fprintf(stderr, "mdr-health-probe: %s: %s\n", address.c_str(),
                 status.error_message().c_str());
    return 1;
  }
  const int serving = StatusOf(response);
  if (serving != kServing) {
    std::fprintf(stderr, "mdr-health-probe: %s: %s is not serving (status %d)\n", address.c_str(),
                 service.c_str(), serving);
    return 1;
  }
  return 0;
}
