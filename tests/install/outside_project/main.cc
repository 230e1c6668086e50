// Uses the installed mdr client: an unreachable server is an error value (UNAVAILABLE, after the
// retries of an idempotent call), a bearer token without TLS is refused, and the generated
// messages are usable.
#include <mdr/client/channel.h>
#include <mdr/client/contact_client.h>

#include <chrono>
#include <cstdio>

int main() {
  auto channel = mdr::client::MakeChannel({.address = "127.0.0.1:1"});
  if (!channel.ok())
    return std::printf("MakeChannel: %s\n", channel.status().error_message().c_str()), 1;
  mdr::client::ContactClient client(
      *channel, mdr::client::ClientOptions{.timeout = std::chrono::seconds(5), .max_attempts = 2});
  auto session = client.GetSession("sessions/none");
  if (session.ok() || session.status().error_code() != grpc::StatusCode::UNAVAILABLE) {
    std::printf("expected UNAVAILABLE, got code %d\n",
                static_cast<int>(session.status().error_code()));
    return 1;
  }
  auto insecure_token = mdr::client::MakeChannel({.address = "127.0.0.1:1", .bearer_token = "t"});
  if (insecure_token.ok() ||
      insecure_token.status().error_code() != grpc::StatusCode::INVALID_ARGUMENT) {
    std::printf("a token without TLS must be refused\n");
    return 1;
  }
  mdr::v1::Scene scene;
  scene.mutable_sphere()->set_radius(0.01);
  std::printf("ok: UNAVAILABLE as a value (%s); %s; scene %s\n",
              session.status().error_message().c_str(),
              insecure_token.status().error_message().c_str(), scene.ShortDebugString().c_str());
  return 0;
}
