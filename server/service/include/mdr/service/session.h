// One contact session: the resource's immutable parts (name, scene, limits, creation time), the
// contact behind the session's own mutex (calls on one session are serialised), the idle clock,
// and the responses of its last successful batches by request_id (idempotent retries).
#pragma once

#include <google/protobuf/repeated_field.h>
#include <google/protobuf/timestamp.pb.h>
#include <grpcpp/support/status.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>

#include "mdr/core/contact.h"
#include "mdr/service/outputs.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

// The responses of a session's last kCapacity successful batches that carried a request_id.
class CompletedRequests {
 public:
  static constexpr std::size_t kCapacity = 64;

  struct Entry {
    std::string request_id;
    std::size_t fingerprint;  // of the steps and step mask, to detect a reused request_id
    v1::ApplyResponse response;
  };

  const Entry* Find(const std::string& request_id) const;
  // Forgets the oldest entry beyond kCapacity.
  void Add(Entry entry);

 private:
  std::deque<Entry> entries_;  // oldest first
};

// Everything a session starts from (a fresh contact, or an imported one).
struct SessionState {
  v1::Scene scene;
  v1::SessionLimits limits;  // effective
  Contact contact;
  std::uint64_t applied_steps = 0;
};

class Session {
 public:
  using Clock = std::chrono::steady_clock;
  // Called before every step of a batch; a non-OK status (deadline, cancellation) abandons the
  // batch, which then changes nothing.
  using StepGuard = std::function<grpc::Status(int step_index)>;
  // SessionSnapshot.version written by Export and accepted by ImportSession.
  static constexpr std::uint32_t kSnapshotVersion = 1;

  Session(std::string name, SessionState state);

  const std::string& name() const { return name_; }
  const v1::SessionLimits& limits() const { return limits_; }

  // Applies request.steps atomically: all succeed and are committed, or the first failure is
  // returned (field "steps[i]...") and the session is unchanged. A request_id seen among the
  // last successful batches returns the stored response (replayed) without applying anything.
  // The request must be validated (non-empty steps, request_id form); the batch size limit is
  // checked here.
  // A response above max_response_bytes fails with RESOURCE_EXHAUSTED, uncommitted.
  grpc::Status Apply(const v1::ApplyRequest& request, const OutputSelection& step_outputs,
                     const StepGuard& guard, std::size_t max_response_bytes,
                     v1::ApplyResponse* response);

  // The selected outputs of the current state; on error (an output this contact does not have)
  // the response is cleared.
  grpc::Status Query(const OutputSelection& selection, const RadialSampling& sampling,
                     OutputCounters* counters, v1::QueryResponse* response) const;

  // Scene, limits, state, creation and expiry time as the API resource.
  void ReadResource(v1::Session* resource) const;
  // The exact, portable state.
  void Export(v1::SessionSnapshot* snapshot) const;

  // Restarts the idle timer; IsExpired tells whether it ran out (never without an idle timeout).
  void Touch();
  bool IsExpired(Clock::time_point now) const;

 private:
  grpc::Status RunBatch(const v1::ApplyRequest& request, const OutputSelection& step_outputs,
                        const StepGuard& guard, std::size_t max_response_bytes,
                        v1::ApplyResponse* response);
  Clock::time_point last_used() const;

  const std::string name_;
  const v1::Scene scene_;
  const v1::SessionLimits limits_;
  const std::chrono::nanoseconds idle_timeout_;  // 0: never expires
  const google::protobuf::Timestamp create_time_;
  std::atomic<Clock::rep> last_used_;

  mutable std::mutex mutex_;
  Contact contact_;              // guarded by mutex_
  std::uint64_t applied_steps_;  // guarded by mutex_
  CompletedRequests completed_;  // guarded by mutex_
};

}  // namespace mdr::service
