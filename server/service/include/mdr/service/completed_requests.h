// The responses of a session's last successful batches by request_id, so that a retried batch is
// answered from memory instead of applied twice (ApplyRequest.request_id). The journal stores
// the same records so that retries stay idempotent across a restart.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>

#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

// One completed batch: the request id, the fingerprint of its steps and step mask (to detect a
// reused request_id) and the response.
struct CompletedRequest {
  std::string request_id;
  std::uint64_t fingerprint = 0;
  v1::ApplyResponse response;
};

// The last kCapacity completed batches that carried a request_id, oldest first.
class CompletedRequests {
 public:
  static constexpr std::size_t kCapacity = 64;

  const CompletedRequest* Find(const std::string& request_id) const;
  // Forgets the oldest entry beyond kCapacity.
  void Add(CompletedRequest entry);
  const std::deque<CompletedRequest>& entries() const { return entries_; }

 private:
  std::deque<CompletedRequest> entries_;  // oldest first
};

}  // namespace mdr::service
