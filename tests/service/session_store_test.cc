// Unit tests of the session set (session_store.h) without a server: names, ownership, limits,
// paging and expiry.
#include "mdr/service/session_store.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <thread>

#include "mdr/bridge/conversion.h"
#include "service_test_util.h"

namespace mdr::service_testing {
namespace {

using service::Principal;
using service::RecentSessions;
using service::Session;
using service::SessionOrigin;
using service::SessionStore;

SessionOrigin FreshState(std::chrono::nanoseconds idle_timeout = std::chrono::hours(1)) {
  const v1::Scene scene = SteelSphereOnSteelFlat();
  SessionOrigin state{.scene = scene,
                      .limits = {},
                      .contact = *Contact::Create(*bridge::ToContactConfig(scene, 1 << 16))};
  state.limits.set_max_steps_per_batch(100);
  state.limits.mutable_idle_timeout()->set_seconds(
      std::chrono::duration_cast<std::chrono::seconds>(idle_timeout).count());
  state.limits.mutable_idle_timeout()->set_nanos(
      static_cast<int>((idle_timeout % std::chrono::seconds(1)).count()));
  return state;
}

// "sessions/{id}" with an idle timeout of 1 ns, expired once the test has slept 2 ms.
std::shared_ptr<Session> CreateExpiredOrDie(SessionStore& store, const std::string& id) {
  std::shared_ptr<Session> session;
  const Status status =
      store.Create("session_id", id, {}, FreshState(std::chrono::nanoseconds(1)), &session);
  EXPECT_TRUE(status.ok()) << status.ToString();
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  return session;
}

std::string CreateOrDie(SessionStore& store, const std::string& id, const Principal& caller = {}) {
  std::shared_ptr<Session> session;
  const Status status = store.Create("session_id", id, caller, FreshState(), &session);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return session ? session->name() : "";
}

TEST(SessionStoreTest, NamesAreGivenOrGeneratedAndUnique) {
  SessionStore store(100, 0);
  EXPECT_EQ(CreateOrDie(store, "rig-1"), "sessions/rig-1");
  const std::string a = CreateOrDie(store, ""), b = CreateOrDie(store, "");
  EXPECT_TRUE(SessionStore::IsSessionName(a));
  EXPECT_NE(a, b);
  std::shared_ptr<Session> session;
  const Status taken = store.Create("session_id", "rig-1", {}, FreshState(), &session);
  EXPECT_EQ(taken.code(), StatusCode::kAlreadyExists);
  EXPECT_EQ(taken.field(), "session_id");
  const Status bad = store.Create("session_id", "no/slashes", {}, FreshState(), &session);
  EXPECT_EQ(bad.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(bad.field(), "session_id");
  EXPECT_EQ(store.size(), 3u);
}

TEST(SessionStoreTest, ASessionIsVisibleOnlyToItsOwner) {
  SessionStore store(100, 0);
  const std::string name = CreateOrDie(store, "owned", Principal("alice"));
  std::shared_ptr<Session> found;
  EXPECT_TRUE(store.Find("name", name, Principal("alice"), &found).ok());
  EXPECT_EQ(store.Find("name", name, Principal("bob"), &found).code(), StatusCode::kNotFound);
  EXPECT_EQ(store.Erase("name", name, Principal("bob")).code(), StatusCode::kNotFound);
  // The name is global: bob cannot take it either.
  std::shared_ptr<Session> session;
  EXPECT_EQ(store.Create("session_id", "owned", Principal("bob"), FreshState(), &session).code(),
            StatusCode::kAlreadyExists);
  EXPECT_TRUE(store.Erase("name", name, Principal("alice")).ok());
  EXPECT_EQ(store.size(), 0u);
  EXPECT_EQ(store.Find("name", "not-a-name", {}, &found).field(), "name");
}

TEST(SessionStoreTest, LimitsAreResourceExhaustedAndFreedByDeletes) {
  SessionStore store(3, 2);
  CreateOrDie(store, "a1", Principal("alice"));
  CreateOrDie(store, "a2", Principal("alice"));
  std::shared_ptr<Session> session;
  const Status per_owner =
      store.Create("session_id", "a3", Principal("alice"), FreshState(), &session);
  EXPECT_EQ(per_owner.code(), StatusCode::kResourceExhausted);
  CreateOrDie(store, "b1", Principal("bob"));
  EXPECT_EQ(store.Create("session_id", "b2", Principal("bob"), FreshState(), &session).code(),
            StatusCode::kResourceExhausted);
  ASSERT_TRUE(store.Erase("name", "sessions/a1", Principal("alice")).ok());
  CreateOrDie(store, "b2", Principal("bob"));
}

TEST(SessionStoreTest, ListsInNameOrderByPages) {
  SessionStore store(100, 0);
  for (const char* id : {"d", "b", "e", "a", "c"}) CreateOrDie(store, id);
  CreateOrDie(store, "z", Principal("someone-else"));
  bool more = false;
  std::vector<std::string> names;
  std::string after;
  do {
    for (const auto& session : store.ListAfter(after, 2, {}, &more)) {
      names.push_back(session->name());
      after = session->name();
    }
  } while (more);
  // Without authentication (no caller) every session is listed, in name order.
  EXPECT_EQ(names, (std::vector<std::string>{"sessions/a", "sessions/b", "sessions/c", "sessions/d",
                                             "sessions/e", "sessions/z"}));
  const auto mine = store.ListAfter("", 10, Principal("someone-else"), &more);
  ASSERT_EQ(mine.size(), 1u);
  EXPECT_EQ(mine[0]->name(), "sessions/z");
  EXPECT_FALSE(more);
}

TEST(SessionStoreTest, AnExpiredSessionIsGoneAndErased) {
  SessionStore store(100, 0);
  ASSERT_NE(CreateExpiredOrDie(store, "short"), nullptr);
  CreateOrDie(store, "long");
  std::shared_ptr<Session> found;
  EXPECT_EQ(store.Find("name", "sessions/short", {}, &found).code(), StatusCode::kNotFound);
  // Erased by the sweep, not by the lookup (which may run on a transport thread).
  EXPECT_EQ(store.size(), 2u);
  EXPECT_EQ(store.EraseExpired(), std::vector<std::string>{"sessions/short"});
  EXPECT_EQ(store.size(), 1u);
  // Its name is free again.
  CreateOrDie(store, "short");
}

// FindAgain (a stream's lookup) reuses a session an earlier lookup found only while the store
// holds it under that name, for that caller; everything else is decided as by Find.
TEST(SessionStoreTest, FindAgainReusesOnlyASessionTheStoreStillHolds) {
  SessionStore store(100, 0);
  const Principal alice("alice");
  const std::string name = CreateOrDie(store, "kept", alice);
  RecentSessions last;
  std::shared_ptr<Session> first, again;
  ASSERT_TRUE(store.FindAgain("session", name, alice, &last, &first).ok());
  EXPECT_EQ(last.Lookup(name), first);
  ASSERT_TRUE(store.FindAgain("session", name, alice, &last, &again).ok());
  EXPECT_EQ(again, first);

  // Someone else's lookup with it kept: not found, as by Find.
  std::shared_ptr<Session> found;
  EXPECT_EQ(store.FindAgain("session", name, Principal("bob"), &last, &found).code(),
            StatusCode::kNotFound);
  // Another name: that session, which is kept beside the first from now on.
  const std::string other = CreateOrDie(store, "other", alice);
  ASSERT_TRUE(store.FindAgain("session", other, alice, &last, &found).ok());
  EXPECT_EQ(found->name(), other);
  EXPECT_EQ(last.Lookup(other), found);
  EXPECT_EQ(last.Lookup(name), first);
  // A malformed name is refused as by Find, naming the field.
  EXPECT_EQ(store.FindAgain("session", "not-a-name", alice, &last, &found).field(), "session");

  // Deleted while a reference is still held (a call in flight): the kept one is not found.
  ASSERT_TRUE(store.FindAgain("session", name, alice, &last, &found).ok());
  const std::shared_ptr<Session> in_flight = found;
  ASSERT_TRUE(store.Erase("name", name, alice).ok());
  EXPECT_TRUE(in_flight->removed());
  EXPECT_EQ(store.FindAgain("session", name, alice, &last, &found).code(), StatusCode::kNotFound);
  // Created again under the same name: the new session, not the kept one.
  CreateOrDie(store, "kept", alice);
  ASSERT_TRUE(store.FindAgain("session", name, alice, &last, &found).ok());
  EXPECT_NE(found, in_flight);
  EXPECT_FALSE(found->removed());
}

TEST(SessionStoreTest, FindAgainDoesNotReuseAnExpiredSession) {
  SessionStore store(100, 0);
  const std::shared_ptr<Session> session = CreateExpiredOrDie(store, "short");
  ASSERT_NE(session, nullptr);
  RecentSessions last;
  last.Remember("sessions/short", session);
  std::shared_ptr<Session> found;
  EXPECT_EQ(store.FindAgain("session", "sessions/short", {}, &last, &found).code(),
            StatusCode::kNotFound);
  EXPECT_FALSE(session->removed()) << "left to the sweep";
  EXPECT_EQ(store.EraseExpired(), std::vector<std::string>{"sessions/short"});
  EXPECT_TRUE(session->removed());
  last.Remember("sessions/short", session);
  EXPECT_EQ(store.FindAgain("session", "sessions/short", {}, &last, &found).code(),
            StatusCode::kNotFound);
}

// A stream cycling through more sessions than RecentSessions keeps finds each one, every time,
// and the ones it remembers are the sessions of their names.
TEST(SessionStoreTest, FindAgainCyclingThroughMoreSessionsThanItRemembers) {
  SessionStore store(100, 0);
  const Principal alice("alice");
  std::vector<std::string> names;
  for (std::size_t i = 0; i < RecentSessions::kCapacity + 5; ++i) {
    names.push_back(CreateOrDie(store, "s" + std::to_string(i), alice));
  }
  RecentSessions recent;
  for (int round = 0; round < 3; ++round) {
    for (const std::string& name : names) {
      std::shared_ptr<Session> found;
      ASSERT_TRUE(store.FindAgain("session", name, alice, &recent, &found).ok()) << name;
      EXPECT_EQ(found->name(), name);
      EXPECT_EQ(recent.Lookup(name), found) << "just found: remembered";
    }
  }
  std::size_t remembered = 0;
  for (const std::string& name : names) {
    if (const std::shared_ptr<Session> kept = recent.Lookup(name)) {
      EXPECT_EQ(kept->name(), name);
      ++remembered;
    }
  }
  EXPECT_EQ(remembered, RecentSessions::kCapacity);
  // A refused lookup remembers nothing (a client's name is kept only once found valid).
  std::shared_ptr<Session> found;
  EXPECT_EQ(store.FindAgain("session", "sessions/none", alice, &recent, &found).code(),
            StatusCode::kNotFound);
  EXPECT_EQ(recent.Lookup("sessions/none"), nullptr);
}

// A sweep leaves an expired session that a call holds (it is in use, and the call may journal):
// the batch commits, and a later sweep erases the session.
TEST(SessionStoreTest, ASweepLeavesAnExpiredSessionThatACallHolds) {
  SessionStore store(100, 0);
  const std::shared_ptr<Session> session = CreateExpiredOrDie(store, "busy");
  ASSERT_NE(session, nullptr);
  std::promise<void> entered, release;
  std::shared_future<void> released = release.get_future().share();
  std::thread batch([&] {
    v1::ApplyResponse response;
    const Status status = session->Apply(
        ApplyRequestFor(session->name(), {DepthStep(kDepth)}), {},
        [&](int) {
          entered.set_value();
          released.wait();
          return OkStatus();
        },
        std::size_t{1} << 20, &response);
    EXPECT_TRUE(status.ok()) << status.ToString();
  });
  entered.get_future().wait();
  EXPECT_EQ(store.EraseExpired(), std::vector<std::string>{});
  EXPECT_FALSE(session->removed());
  release.set_value();
  batch.join();
  std::this_thread::sleep_for(std::chrono::milliseconds(2));  // expired again after its use
  EXPECT_EQ(store.EraseExpired(), std::vector<std::string>{"sessions/busy"});
  EXPECT_TRUE(session->removed());
  v1::ApplyResponse response;
  EXPECT_EQ(session
                ->Apply(ApplyRequestFor(session->name(), {DepthStep(kDepth)}), {}, {},
                        std::size_t{1} << 20, &response)
                .code(),
            StatusCode::kNotFound)
      << "a batch on a removed session";
}

}  // namespace
}  // namespace mdr::service_testing
