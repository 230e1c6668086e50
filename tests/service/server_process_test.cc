// What starting a server sets for its whole process.
#include <absl/synchronization/mutex.h>
#include <gtest/gtest.h>

#include "mdr/service/server.h"

namespace mdr::service_testing {
namespace {

// Debian's abseil runs its debug deadlock detector on every absl::Mutex (gRPC's among them) and
// aborts the process on a cycle in the lock-order graph it records. A started server turns it
// off (ContactServer::Start): two mutexes locked in both orders no longer abort.
TEST(ServerProcessTest, StartTurnsOffAbseilsDeadlockAbort) {
  service::ServerOptions options;
  options.listen_address = "127.0.0.1:0";
  auto server = service::ContactServer::Start(options);
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  absl::Mutex first, second;
  {
    absl::MutexLock a(&first);
    absl::MutexLock b(&second);
  }
  {
    absl::MutexLock b(&second);
    absl::MutexLock a(&first);  // with the detector on, the process aborts here
  }
  SUCCEED();
}

}  // namespace
}  // namespace mdr::service_testing
