#include "mdr/service/completed_requests.h"

#include <utility>

namespace mdr::service {

const CompletedRequest* CompletedRequests::Find(const std::string& request_id) const {
  for (const CompletedRequest& entry : entries_) {
    if (entry.request_id == request_id) return &entry;
  }
  return nullptr;
}

void CompletedRequests::Add(CompletedRequest entry) {
  entries_.push_back(std::move(entry));
  if (entries_.size() > kCapacity) entries_.pop_front();
}

}  // namespace mdr::service
