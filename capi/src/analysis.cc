// The analysis through the C interface: the service's own operations (analysis_ops.h: the same
// validation, limits and error fields) on a request given as a serialized message or as proto3
// JSON, the response in the same encoding in a buffer the library owns.
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/stubs/logging.h>
#include <google/protobuf/util/json_util.h>

#include <atomic>
#include <chrono>
#include <climits>
#include <string>
#include <utility>

#include "boundary.h"
#include "inputs.h"
#include "mdr/bridge/analysis_ops.h"
#include "mdr/bridge/scene_file.h"
#include "mdr/mdr.h"
#include "mdr/v1/analysis.pb.h"

// A response: its bytes, owned by the library until mdr_buffer_destroy.
struct mdr_buffer {
  std::string bytes;
};

namespace mdr::capi {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The request in its encoding; errors name "request" (not a message of this type, not JSON) or
// the request's field that protobuf's JSON parser names.
Status ReadRequest(int encoding, const void* request, std::size_t size,
                   google::protobuf::Message* message) {
  if (size > 0 && request == nullptr) {
    return InvalidArgument("request", "must not be NULL when size is " + std::to_string(size));
  }
  if (size > static_cast<std::size_t>(INT_MAX)) {
    return InvalidArgument("size", "must be at most " + std::to_string(INT_MAX) +
                                       " bytes (a protobuf message's limit), got " +
                                       std::to_string(size));
  }
  if (encoding == MDR_ENCODING_PROTO) {
    google::protobuf::LogSilencer silence;  // a library answers through its status
    if (!message->ParseFromArray(request, static_cast<int>(size))) {
      return InvalidArgument("request",
                             "is not a serialized mdr.v1." + message->GetDescriptor()->name());
    }
    return OkStatus();
  }
  const std::string json(static_cast<const char*>(request), size);
  Status parsed = bridge::ParseJsonMessage(json, message);
  if (parsed.ok()) return parsed;
  if (parsed.field().empty()) {
    return InvalidArgument("request", "is not proto3 JSON of mdr.v1." +
                                          message->GetDescriptor()->name() + ": " +
                                          parsed.message());
  }
  return parsed;
}

Status WriteResponse(int encoding, const google::protobuf::Message& message, std::string* out) {
  if (encoding == MDR_ENCODING_PROTO) {
    // Deterministic (maps in key order): the same response is the same bytes, the service's
    // included when it serializes so.
    out->clear();
    google::protobuf::io::StringOutputStream stream(out);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    if (!message.SerializeToCodedStream(&coded)) {
      return Internal("", "the response could not be serialized");
    }
    return OkStatus();
  }
  out->clear();  // MessageToJsonString appends; the progress buffer is reused
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;     // the proto's names, as docs/analysis.md uses
  options.always_print_primitive_fields = true;  // a figure of 0 is there, not missing
  const auto status = google::protobuf::util::MessageToJsonString(message, out, options);
  if (!status.ok()) return Internal("", "the response could not be written as JSON");
  return OkStatus();
}

// Runs `run` on the request with an interrupt that the progress callback's non-zero return
// sets; the response, with compute_seconds filled as the service fills it, into *out.
template <typename Request, typename Response, typename Run>
CallStatus RunAnalysis(int encoding, const void* request, std::size_t size,
                       const std::atomic<bool>& cancelled, Run run, std::string* out) {
  Request parsed;
  if (Status s = ReadRequest(encoding, request, size, &parsed); !s.ok()) return s;
  Response response;
  const Clock::time_point start = Clock::now();
  const Interrupt interrupt(Clock::time_point::max(), &cancelled);
  if (Status s = run(parsed, MaxMemoryVertices(), interrupt, &response); !s.ok()) return s;
  response.set_compute_seconds(SecondsSince(start));
  return WriteResponse(encoding, response, out);
}

CallStatus Run(int analysis, int encoding, const void* request, std::size_t size,
               mdr_progress_callback progress, void* user, mdr_buffer** response) {
  if (Status s = RequireNonNull(response, "response"); !s.ok()) return s;
  *response = nullptr;
  if (encoding != MDR_ENCODING_PROTO && encoding != MDR_ENCODING_JSON) {
    return InvalidArgument(
        "encoding",
        "must be MDR_ENCODING_PROTO (0) or MDR_ENCODING_JSON (1), got " + std::to_string(encoding));
  }
  std::atomic<bool> cancelled{false};
  std::string bytes;
  CallStatus status = OkStatus();
  switch (analysis) {
    case MDR_ANALYZE_LOOPS:
      status = RunAnalysis<v1::AnalyzeLoopsRequest, v1::AnalyzeLoopsResponse>(
          encoding, request, size, cancelled, bridge::RunAnalyzeLoops, &bytes);
      break;
    case MDR_FRETTING_MAP:
      status = RunAnalysis<v1::FrettingMapRequest, v1::FrettingMapResponse>(
          encoding, request, size, cancelled, bridge::RunFrettingMap, &bytes);
      break;
    case MDR_BACKBONE:
      status = RunAnalysis<v1::BackboneRequest, v1::BackboneResponse>(
          encoding, request, size, cancelled, bridge::RunBackbone, &bytes);
      break;
    case MDR_FIT_LOOPS: {
      // The progress of every iteration, in the request's encoding; a non-zero return cancels.
      std::string progress_bytes;
      auto report = [&](const v1::FitProgress& p) {
        if (progress == nullptr || cancelled.load()) return;
        if (!WriteResponse(encoding, p, &progress_bytes).ok()) return;
        if (progress(progress_bytes.data(), progress_bytes.size(), user) != 0) {
          cancelled.store(true);
        }
      };
      auto run = [&](const v1::FitLoopsRequest& r, std::size_t max_memory_vertices,
                     const Interrupt& interrupt, v1::FitResult* result) {
        return bridge::RunFitLoops(r, max_memory_vertices, interrupt, report, result);
      };
      status = RunAnalysis<v1::FitLoopsRequest, v1::FitResult>(encoding, request, size, cancelled,
                                                               run, &bytes);
      break;
    }
    default:
      return InvalidArgument("analysis",
                             "must be MDR_ANALYZE_LOOPS (1), MDR_FIT_LOOPS (2), MDR_FRETTING_MAP "
                             "(3) or MDR_BACKBONE (4), got " +
                                 std::to_string(analysis));
  }
  if (!status.ok()) {
    if (cancelled.load()) {
      return Cancelled("progress", "the progress callback asked to stop; nothing was returned");
    }
    return status;
  }
  *response = new mdr_buffer{std::move(bytes)};
  return OkStatus();
}

}  // namespace
}  // namespace mdr::capi

extern "C" {

int mdr_analysis_run(int analysis, int encoding, const void* request, size_t size,
                     mdr_progress_callback progress, void* user, mdr_buffer** response) {
  return mdr::capi::Boundary("mdr_analysis_run", [&] {
    return mdr::capi::Run(analysis, encoding, request, size, progress, user, response);
  });
}

const void* mdr_buffer_data(const mdr_buffer* buffer) {
  return buffer != nullptr ? buffer->bytes.data() : nullptr;
}

size_t mdr_buffer_size(const mdr_buffer* buffer) {
  return buffer != nullptr ? buffer->bytes.size() : 0;
}

void mdr_buffer_destroy(mdr_buffer* buffer) { delete buffer; }

}  // extern "C"
