// libmdr_c through its C header only (this test links no other project library): errors that
// name the argument and change nothing, snapshots, and no allocation in a steady fretting cycle.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "mdr/mdr.h"

// Every allocation of the process goes through malloc (operator new of libstdc++ included): these
// definitions interpose glibc's for the executable and every shared library, libmdr_c's engine,
// protobuf and libstdc++ among them, and count while counting is on.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* pointer, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void __libc_free(void* pointer);
}

namespace {
std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
void Count() {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1);
}
}  // namespace

extern "C" {
void* malloc(std::size_t size) {
  Count();
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  Count();
  return __libc_calloc(count, size);
}
void* realloc(void* pointer, std::size_t size) {
  Count();
  return __libc_realloc(pointer, size);
}
void* memalign(std::size_t alignment, std::size_t size) {
  Count();
  return __libc_memalign(alignment, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  Count();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** pointer, std::size_t alignment, std::size_t size) {
  Count();
  *pointer = __libc_memalign(alignment, size);
  return *pointer == nullptr ? ENOMEM : 0;
}
void free(void* pointer) { __libc_free(pointer); }
}

namespace {

// H1 (tests/fixtures/reference_scenes.h): a steel sphere R = 10 mm on a steel flat, mu = 0.3.
constexpr char kScene[] = R"(
scene:
  sphere: {radius: 0.01}
  elastic_pair:
    youngs_modulus_1: 210e9
    poisson_ratio_1: 0.3
    youngs_modulus_2: 210e9
    poisson_ratio_2: 0.3
  friction: 0.3
)";

template <typename Body>
long CountAllocations(Body body) {
  allocations = 0;
  counting = true;
  body();
  counting = false;
  return allocations.load();
}

class CapiTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(mdr_contact_create_from_text(kScene, "h1.yaml", &contact_), MDR_OK)
        << mdr_last_error_message();
    ASSERT_EQ(Step(MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_HOLD, 0), MDR_OK)
        << mdr_last_error_message();
  }
  void TearDown() override { mdr_contact_destroy(contact_); }

  int Step(int normal_control, double normal_value, int tangential_control,
           double tangential_value) {
    return mdr_contact_step(contact_, normal_control, normal_value, tangential_control,
                            tangential_value, nullptr);
  }
  mdr_state State() const {
    mdr_state state{};
    EXPECT_EQ(mdr_contact_state(contact_, &state), MDR_OK);
    return state;
  }
  std::vector<unsigned char> Snapshot() const {
    std::size_t size = 0;
    EXPECT_EQ(mdr_contact_snapshot(contact_, nullptr, 0, &size), MDR_OUT_OF_RANGE);
    std::vector<unsigned char> bytes(size);
    EXPECT_EQ(mdr_contact_snapshot(contact_, bytes.data(), bytes.size(), &size), MDR_OK);
    return bytes;
  }
  // The state is unchanged since `before` (a refused call changed nothing).
  void ExpectUnchanged(const std::vector<unsigned char>& before) const {
    EXPECT_EQ(Snapshot(), before);
  }

  mdr_contact* contact_ = nullptr;
};

void ExpectError(int status, int code, const std::string& field) {
  EXPECT_EQ(status, code);
  EXPECT_EQ(mdr_last_error_code(), code);
  EXPECT_EQ(std::string(mdr_last_error_field()), field) << mdr_last_error_message();
  EXPECT_NE(std::string(mdr_last_error_message()).find(field), std::string::npos)
      << mdr_last_error_message();
}

TEST(CapiVersion, MatchesTheHeader) {
  EXPECT_EQ(mdr_version(), MDR_C_API_VERSION);
  EXPECT_STRNE(mdr_version_string(), "");
  static_assert(sizeof(mdr_state) == 96 && offsetof(mdr_state, applied_steps) == 80);
  static_assert(sizeof(mdr_step_report) == 24 && offsetof(mdr_step_report, path_error) == 8);
  static_assert(sizeof(mdr_torsional_state) == 88 &&
                offsetof(mdr_torsional_state, friction_limit) == 64 &&
                offsetof(mdr_torsional_state, applied_steps) == 72);
}

TEST_F(CapiTest, LoadsToTheHertzForce) {
  const mdr_state state = State();
  EXPECT_NEAR(state.normal_force, 100, 1e-9);  // to the inverse of F_N(delta)'s round-off
  EXPECT_EQ(state.applied_steps, 1u);
  EXPECT_GT(state.depth, 0);
  EXPECT_EQ(state.friction_limit, 0.3 * state.normal_force);
}

TEST(CapiCreate, InvalidScenesNameTheField) {
  mdr_contact* contact = reinterpret_cast<mdr_contact*>(1);
  ExpectError(mdr_contact_create_from_text("scene: {sphere: {radius: -1}}", "bad.yaml", &contact),
              MDR_INVALID_ARGUMENT, "scene.sphere.radius");
  EXPECT_EQ(contact, nullptr);
  EXPECT_NE(std::string(mdr_last_error_message()).find("bad.yaml:1"), std::string::npos)
      << mdr_last_error_message();
  ExpectError(mdr_contact_create_from_text(nullptr, nullptr, &contact), MDR_INVALID_ARGUMENT,
              "text");
  ExpectError(mdr_contact_create_from_text(kScene, nullptr, nullptr), MDR_INVALID_ARGUMENT, "out");
  ExpectError(mdr_contact_create_from_text("path: []", "x.yaml", &contact), MDR_INVALID_ARGUMENT,
              "scene");
  // A YAML syntax error is the text's, located by line and column; the file is not a field.
  ExpectError(mdr_contact_create_from_text("scene: [1, 2\n", "broken.yaml", &contact),
              MDR_INVALID_ARGUMENT, "text");
  EXPECT_NE(std::string(mdr_last_error_message()).find("broken.yaml: line "), std::string::npos)
      << mdr_last_error_message();
  ExpectError(mdr_contact_create("\xff\xff\xff", 3, &contact), MDR_INVALID_ARGUMENT, "scene");
  ExpectError(mdr_contact_create(nullptr, 4, &contact), MDR_INVALID_ARGUMENT, "scene");
  // An empty Scene has no profile.
  EXPECT_EQ(mdr_contact_create(nullptr, 0, &contact), MDR_INVALID_ARGUMENT);
  EXPECT_EQ(contact, nullptr);
}

constexpr char kContactList[] = R"(
scene:
  sphere: {radius: 0.01}
  elastic_pair:
    youngs_modulus_1: 210e9
    poisson_ratio_1: 0.3
    youngs_modulus_2: 210e9
    poisson_ratio_2: 0.3
  friction: 0.3
  interface:
    kind: KIND_CONTACT_LIST
    explicit_list: {heights: [0, 0, 0], radii: [0.01, 0.01, 0.01]}
)";

TEST(CapiCreate, EachKindOfSceneHasItsHandle) {
  mdr_contact* contact = nullptr;
  ExpectError(mdr_contact_create_from_text(kContactList, "i.yaml", &contact), MDR_INVALID_ARGUMENT,
              "scene.interface");
  EXPECT_EQ(contact, nullptr);
  mdr_interface* interface = nullptr;
  ExpectError(mdr_interface_create_from_text(kScene, "c.yaml", &interface), MDR_INVALID_ARGUMENT,
              "scene.interface");
  EXPECT_EQ(interface, nullptr);
}

// A contact list is independent contacts (docs/interfaces.md): each one bit for bit a single
// contact driven by its own values.
TEST(CapiInterface, ContactListMatchesSingleContacts) {
  mdr_interface* list = nullptr;
  ASSERT_EQ(mdr_interface_create_from_text(kContactList, "list.yaml", &list), MDR_OK)
      << mdr_last_error_message();
  std::size_t n = 0;
  ASSERT_EQ(mdr_interface_size(list, &n), MDR_OK);
  ASSERT_EQ(n, 3u);
  mdr_contact* single[3];
  for (mdr_contact*& c : single) ASSERT_EQ(mdr_contact_create_from_text(kScene, "", &c), MDR_OK);
  const double depths[3] = {3.5e-6, 2e-6, 1e-6};
  const double forces[3][3] = {{10, 5, 2}, {-10, -5, -2}, {3, 0, -1}};
  ASSERT_EQ(mdr_interface_step(list, MDR_NORMAL_DEPTH_INCREMENT, 0, MDR_TANGENTIAL_HOLD, 0, depths,
                               nullptr, 3),
            MDR_OK)
      << mdr_last_error_message();
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(mdr_contact_step(single[i], MDR_NORMAL_DEPTH_INCREMENT, depths[i],
                               MDR_TANGENTIAL_HOLD, 0, nullptr),
              MDR_OK);
  }
  for (const auto& step : forces) {
    ASSERT_EQ(
        mdr_interface_step(list, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_FORCE, 0, nullptr, step, 3),
        MDR_OK)
        << mdr_last_error_message();
    for (int i = 0; i < 3; ++i) {
      ASSERT_EQ(
          mdr_contact_step(single[i], MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_FORCE, step[i], nullptr),
          MDR_OK);
    }
  }
  mdr_state states[3], total{};
  ASSERT_EQ(mdr_interface_contact_states(list, states, 3, &n), MDR_OK);
  ASSERT_EQ(mdr_interface_state(list, &total), MDR_OK);
  double normal_force = 0;
  for (int i = 0; i < 3; ++i) {
    mdr_state expected;
    ASSERT_EQ(mdr_contact_state(single[i], &expected), MDR_OK);
    EXPECT_EQ(std::memcmp(&states[i], &expected, sizeof expected), 0) << "contact " << i;
    normal_force += expected.normal_force;
    mdr_contact_destroy(single[i]);
  }
  EXPECT_EQ(total.normal_force, normal_force);  // summed in contact order
  EXPECT_EQ(total.applied_steps, 4u);

  // Bad steps name the argument and change nothing.
  const double nan[3] = {0, std::numeric_limits<double>::quiet_NaN(), 0};
  ExpectError(mdr_interface_step(list, MDR_NORMAL_DEPTH_INCREMENT, 0, MDR_TANGENTIAL_HOLD, 0, nan,
                                 nullptr, 3),
              MDR_INVALID_ARGUMENT, "normal_values[1]");
  ExpectError(mdr_interface_step(list, MDR_NORMAL_DEPTH_INCREMENT, 0, MDR_TANGENTIAL_HOLD, 0,
                                 depths, nullptr, 2),
              MDR_INVALID_ARGUMENT, "normal_values");
  ExpectError(mdr_interface_step(list, MDR_NORMAL_DEPTH_INCREMENT, 0, MDR_TANGENTIAL_HOLD, 0,
                                 nullptr, nullptr, 3),
              MDR_INVALID_ARGUMENT, "n");
  ExpectError(mdr_interface_step(nullptr, 0, 0, 0, 0, nullptr, nullptr, 0), MDR_INVALID_ARGUMENT,
              "interface");
  ExpectError(mdr_interface_contact_states(list, states, 2, &n), MDR_OUT_OF_RANGE, "capacity");
  EXPECT_EQ(n, 3u);
  mdr_state after[3];
  ASSERT_EQ(mdr_interface_contact_states(list, after, 3, &n), MDR_OK);
  EXPECT_EQ(std::memcmp(after, states, sizeof after), 0);

  // A snapshot continues bit for bit.
  std::size_t size = 0;
  EXPECT_EQ(mdr_interface_snapshot(list, nullptr, 0, &size), MDR_OUT_OF_RANGE);
  std::vector<unsigned char> bytes(size);
  ASSERT_EQ(mdr_interface_snapshot(list, bytes.data(), size, &size), MDR_OK);
  mdr_interface* copy = nullptr;
  ASSERT_EQ(mdr_interface_restore(bytes.data(), size, &copy), MDR_OK) << mdr_last_error_message();
  mdr_contact* wrong = nullptr;
  ExpectError(mdr_contact_restore(bytes.data(), size, &wrong), MDR_INVALID_ARGUMENT,
              "snapshot.scene.interface");
  for (mdr_interface* h : {list, copy}) {
    ASSERT_EQ(mdr_interface_step(h, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT_INCREMENT, 0,
                                 nullptr, depths, 3),
              MDR_OK);
  }
  mdr_state a[3], b[3];
  ASSERT_EQ(mdr_interface_contact_states(list, a, 3, &n), MDR_OK);
  ASSERT_EQ(mdr_interface_contact_states(copy, b, 3, &n), MDR_OK);
  EXPECT_EQ(std::memcmp(a, b, sizeof a), 0);
  mdr_interface_destroy(copy);
  mdr_interface_destroy(list);
}

TEST_F(CapiTest, NullHandlesNameTheArgument) {
  mdr_state state;
  double a, b;
  std::size_t n;
  ExpectError(mdr_contact_step(nullptr, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_HOLD, 0, nullptr),
              MDR_INVALID_ARGUMENT, "contact");
  ExpectError(mdr_contact_state(nullptr, &state), MDR_INVALID_ARGUMENT, "contact");
  ExpectError(mdr_contact_state(contact_, nullptr), MDR_INVALID_ARGUMENT, "out");
  ExpectError(mdr_contact_stiffness(nullptr, &a, &b), MDR_INVALID_ARGUMENT, "contact");
  ExpectError(mdr_contact_stiffness(contact_, &a, nullptr), MDR_INVALID_ARGUMENT, "negative");
  ExpectError(mdr_contact_jager_weights(nullptr, nullptr, nullptr, nullptr, 0, &n, nullptr),
              MDR_INVALID_ARGUMENT, "contact");
  ExpectError(mdr_contact_jager_weights(contact_, nullptr, nullptr, nullptr, 0, nullptr, nullptr),
              MDR_INVALID_ARGUMENT, "count");
  ExpectError(mdr_contact_slip_intervals(nullptr, nullptr, nullptr, nullptr, 0, &n),
              MDR_INVALID_ARGUMENT, "contact");
  ExpectError(mdr_contact_snapshot(nullptr, nullptr, 0, &n), MDR_INVALID_ARGUMENT, "contact");
  ExpectError(mdr_contact_snapshot(contact_, nullptr, 0, nullptr), MDR_INVALID_ARGUMENT, "size");
  const double radius = 0;
  ExpectError(
      mdr_contact_tractions(nullptr, &radius, 1, MDR_ROUTE_BOTH, &a, nullptr, nullptr, nullptr, 1),
      MDR_INVALID_ARGUMENT, "contact");
  mdr_contact_destroy(nullptr);  // allowed, like free(NULL)
}

TEST_F(CapiTest, BadStepsNameTheArgumentAndChangeNothing) {
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, 5e-7), MDR_OK);
  const std::vector<unsigned char> before = Snapshot();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ExpectError(Step(MDR_NORMAL_DEPTH, nan, MDR_TANGENTIAL_HOLD, 0), MDR_INVALID_ARGUMENT,
              "normal_value");
  ExpectError(Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT_INCREMENT, nan),
              MDR_INVALID_ARGUMENT, "tangential_value");
  ExpectError(Step(MDR_NORMAL_FORCE, -1, MDR_TANGENTIAL_HOLD, 0), MDR_INVALID_ARGUMENT,
              "normal_value");
  // Beyond the friction limit of mu F_N = 30 N.
  ExpectError(Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_FORCE, 31), MDR_FAILED_PRECONDITION,
              "tangential_value");
  ExpectError(Step(7, 0, MDR_TANGENTIAL_HOLD, 0), MDR_INVALID_ARGUMENT, "normal_control");
  ExpectError(Step(MDR_NORMAL_HOLD, 0, 7, 0), MDR_INVALID_ARGUMENT, "tangential_control");
  ExpectError(Step(MDR_NORMAL_HOLD, 1e-6, MDR_TANGENTIAL_HOLD, 0), MDR_INVALID_ARGUMENT,
              "normal_value");
  ExpectUnchanged(before);
  EXPECT_EQ(State().applied_steps, 2u);
}

TEST_F(CapiTest, SmallBuffersReturnTheSizeNeeded) {
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, 5e-7), MDR_OK);
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, -2e-7), MDR_OK);
  std::size_t count = 0;
  double edge = -1;
  ExpectError(mdr_contact_jager_weights(contact_, nullptr, nullptr, nullptr, 0, &count, &edge),
              MDR_OUT_OF_RANGE, "capacity");
  ASSERT_GE(count, 2u);
  EXPECT_EQ(edge, -1);  // untouched on error
  std::vector<double> r_begin(count), r_end(count), weight(count);
  ExpectError(mdr_contact_jager_weights(contact_, r_begin.data(), r_end.data(), weight.data(),
                                        count - 1, &count, &edge),
              MDR_OUT_OF_RANGE, "capacity");
  ASSERT_EQ(mdr_contact_jager_weights(contact_, r_begin.data(), r_end.data(), weight.data(), count,
                                      &count, &edge),
            MDR_OK);
  EXPECT_EQ(edge, 0);  // a sphere has no edge weight
  EXPECT_EQ(r_end.back(), State().contact_radius);
  ExpectError(mdr_contact_jager_weights(contact_, nullptr, r_end.data(), weight.data(), count,
                                        &count, nullptr),
              MDR_INVALID_ARGUMENT, "r_begin");

  const double radii[3] = {0, 1e-5, -1};
  double tau[3];
  ExpectError(
      mdr_contact_tractions(contact_, radii, 2, MDR_ROUTE_JAGER, tau, nullptr, nullptr, nullptr, 1),
      MDR_OUT_OF_RANGE, "capacity");
  ExpectError(
      mdr_contact_tractions(contact_, radii, 3, MDR_ROUTE_JAGER, tau, nullptr, nullptr, nullptr, 3),
      MDR_INVALID_ARGUMENT, "radii[2]");
  ExpectError(mdr_contact_tractions(contact_, radii, 2, 9, tau, nullptr, nullptr, nullptr, 2),
              MDR_INVALID_ARGUMENT, "route");

  std::size_t size = 0;
  std::vector<unsigned char> bytes(8);
  ExpectError(mdr_contact_snapshot(contact_, bytes.data(), bytes.size(), &size), MDR_OUT_OF_RANGE,
              "capacity");
  EXPECT_GT(size, bytes.size());
}

TEST_F(CapiTest, SnapshotsContinueBitForBit) {
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_FORCE, 12), MDR_OK);
  const std::vector<unsigned char> bytes = Snapshot();
  mdr_contact* copy = nullptr;
  ASSERT_EQ(mdr_contact_restore(bytes.data(), bytes.size(), &copy), MDR_OK)
      << mdr_last_error_message();
  for (double force : {-7.0, 3.0, -12.5}) {
    ASSERT_EQ(Step(MDR_NORMAL_FORCE, 90, MDR_TANGENTIAL_FORCE, force), MDR_OK);
    ASSERT_EQ(mdr_contact_step(copy, MDR_NORMAL_FORCE, 90, MDR_TANGENTIAL_FORCE, force, nullptr),
              MDR_OK);
  }
  mdr_state original = State(), restored{};
  ASSERT_EQ(mdr_contact_state(copy, &restored), MDR_OK);
  EXPECT_EQ(std::memcmp(&original, &restored, sizeof original), 0);
  EXPECT_EQ(original.applied_steps, 5u);
  mdr_contact_destroy(copy);
}

TEST(CapiRestore, DamagedSnapshotsNameTheField) {
  mdr_contact* contact = nullptr;
  ASSERT_EQ(mdr_contact_create_from_text(kScene, nullptr, &contact), MDR_OK);
  std::size_t size = 0;
  mdr_contact_snapshot(contact, nullptr, 0, &size);
  std::vector<unsigned char> bytes(size);
  ASSERT_EQ(mdr_contact_snapshot(contact, bytes.data(), size, &size), MDR_OK);
  mdr_contact_destroy(contact);
  // Field 1 (version) is the first byte pair: 0x08 0x01. Version 2 is not read.
  ASSERT_EQ(bytes[0], 0x08);
  ASSERT_EQ(bytes[1], 0x01);
  bytes[1] = 0x02;
  contact = reinterpret_cast<mdr_contact*>(1);
  ExpectError(mdr_contact_restore(bytes.data(), bytes.size(), &contact), MDR_INVALID_ARGUMENT,
              "snapshot.version");
  EXPECT_EQ(contact, nullptr);
  ExpectError(mdr_contact_restore("\x0a\xff", 2, &contact), MDR_INVALID_ARGUMENT, "snapshot");
}

// A Hertz fretting cycle by displacement targets, 1000 steps a cycle in partial slip: after two
// warm-up cycles, 10^6 steps (with a state read each) allocate nothing.
TEST_F(CapiTest, SteadyFrettingAllocatesNothing) {
  constexpr int kPerCycle = 1000;
  std::vector<double> targets(kPerCycle);
  for (int i = 0; i < kPerCycle; ++i) {
    targets[i] = 1e-6 * std::sin(2 * std::numbers::pi * (i + 1) / kPerCycle);
  }
  auto cycles = [&](int count) {
    mdr_state state;
    for (int c = 0; c < count; ++c) {
      for (double ux : targets) {
        if (Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, ux) != MDR_OK ||
            mdr_contact_state(contact_, &state) != MDR_OK) {
          ADD_FAILURE() << mdr_last_error_message();
          return;
        }
      }
    }
  };
  cycles(2);
  const double dissipated_before = State().dissipated_energy;
  EXPECT_EQ(CountAllocations([&] { cycles(1000); }), 0);
  EXPECT_GT(State().dissipated_energy, dissipated_before);  // it did slip
  EXPECT_EQ(State().applied_steps, 1u + 1002u * kPerCycle);
  // The counter sees allocations where there are some.
  EXPECT_GT(CountAllocations([&] { Snapshot(); }), 0);
}

// The same by tangential force at a constant normal force (a straight path solved for its
// increment): 10^5 steady steps allocate nothing.
TEST_F(CapiTest, SteadyForceFrettingAllocatesNothing) {
  constexpr int kPerCycle = 200;
  std::vector<double> forces(kPerCycle);
  for (int i = 0; i < kPerCycle; ++i) {
    forces[i] = 15 * std::sin(2 * std::numbers::pi * (i + 1) / kPerCycle);
  }
  auto cycles = [&](int count) {
    for (int c = 0; c < count; ++c) {
      for (double force : forces) {
        if (Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_FORCE, force) != MDR_OK) {
          ADD_FAILURE() << mdr_last_error_message();
          return;
        }
      }
    }
  };
  cycles(2);
  EXPECT_EQ(CountAllocations([&] { cycles(500); }), 0);
}

// The buffers a step reuses are the handle's, not the thread's: a handle warmed up on one thread
// steps without allocating on any other, from its very first step there (LabVIEW runs a call in
// any thread of its pool). Each new thread runs a cycle by displacement targets and one by
// tangential force, counted from the first step.
TEST_F(CapiTest, AWarmHandleAllocatesNothingOnANewThread) {
  constexpr int kPerCycle = 200;
  auto cycle = [&] {
    for (int i = 0; i < kPerCycle; ++i) {
      const double phase = std::sin(2 * std::numbers::pi * (i + 1) / kPerCycle);
      if (Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, 1e-6 * phase) != MDR_OK) {
        ADD_FAILURE() << mdr_last_error_message();
        return;
      }
    }
    for (int i = 0; i < kPerCycle; ++i) {
      const double phase = std::sin(2 * std::numbers::pi * (i + 1) / kPerCycle);
      if (Step(MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_FORCE, 15 * phase) != MDR_OK) {
        ADD_FAILURE() << mdr_last_error_message();
        return;
      }
    }
  };
  cycle();
  cycle();
  for (int thread = 0; thread < 4; ++thread) {
    long counted = -1;
    std::thread([&] { counted = CountAllocations(cycle); }).join();
    EXPECT_EQ(counted, 0) << "thread " << thread;
  }
  EXPECT_EQ(State().applied_steps, 1u + 6u * 2 * kPerCycle);
}

// The tangential controls are numbered 0..3; 4..6, the values of the header's revision 1 (the
// proto Step's field numbers), still mean the same controls, bit for bit.
TEST_F(CapiTest, RevisionOneControlValuesStillMeanTheSame) {
  mdr_contact* other = nullptr;
  ASSERT_EQ(mdr_contact_create_from_text(kScene, "h1.yaml", &other), MDR_OK);
  ASSERT_EQ(mdr_contact_step(other, MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_HOLD, 0, nullptr),
            MDR_OK);
  const int controls[][2] = {{MDR_TANGENTIAL_DISPLACEMENT, 4},
                             {MDR_TANGENTIAL_DISPLACEMENT_INCREMENT, 5},
                             {MDR_TANGENTIAL_FORCE, 6}};
  const double values[] = {4e-7, -1e-7, -5};
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(controls[k][0], k + 1);
    ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, controls[k][0], values[k]), MDR_OK);
    ASSERT_EQ(mdr_contact_step(other, MDR_NORMAL_HOLD, 0, controls[k][1], values[k], nullptr),
              MDR_OK);
  }
  std::size_t size = 0;
  ASSERT_EQ(mdr_contact_snapshot(other, nullptr, 0, &size), MDR_OUT_OF_RANGE);
  std::vector<unsigned char> bytes(size);
  ASSERT_EQ(mdr_contact_snapshot(other, bytes.data(), size, &size), MDR_OK);
  EXPECT_EQ(bytes, Snapshot());
  mdr_contact_destroy(other);
  ExpectError(Step(MDR_NORMAL_HOLD, 0, 7, 0), MDR_INVALID_ARGUMENT, "tangential_control");
}

// ---- Torsional contacts (mdr_torsion): H1 twisted about its axis ----

const std::string kTorsionScene = std::string(kScene) + "  torsion: {}\n";
// H1's moduli: E* = E / (2 (1 - nu^2)), 1/G_t = 2 * 2 (1 + nu) / E.
constexpr double kEffectiveModulus = 210e9 / (2 * (1 - 0.3 * 0.3));
constexpr double kTorsionalModulus = 210e9 / (4 * 1.3);

double HertzRadius(double normal_force) {
  return std::cbrt(3 * normal_force * 0.01 / (4 * kEffectiveModulus));
}

std::vector<unsigned char> TorsionSnapshot(const mdr_torsion* torsion) {
  std::size_t size = 0;
  EXPECT_EQ(mdr_torsion_snapshot(torsion, nullptr, 0, &size), MDR_OUT_OF_RANGE);
  std::vector<unsigned char> bytes(size);
  EXPECT_EQ(mdr_torsion_snapshot(torsion, bytes.data(), bytes.size(), &size), MDR_OK);
  return bytes;
}

class CapiTorsionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(mdr_torsion_create_from_text(kTorsionScene.c_str(), "h1_torsion.yaml", &torsion_),
              MDR_OK)
        << mdr_last_error_message();
    ASSERT_EQ(Step(MDR_NORMAL_FORCE, 100, MDR_TWIST_HOLD, 0), MDR_OK) << mdr_last_error_message();
  }
  void TearDown() override { mdr_torsion_destroy(torsion_); }

  int Step(int normal_control, double normal_value, int twist_control, double twist_value,
           mdr_step_report* report = nullptr) {
    return mdr_torsion_step(torsion_, normal_control, normal_value, twist_control, twist_value,
                            report);
  }
  mdr_torsional_state State() const {
    mdr_torsional_state state{};
    EXPECT_EQ(mdr_torsion_state(torsion_, &state), MDR_OK);
    return state;
  }
  std::vector<unsigned char> Snapshot() const { return TorsionSnapshot(torsion_); }

  mdr_torsion* torsion_ = nullptr;
};

// A twist to half the full-slip moment of H1 at 100 N: the closed forms of Hertz in torsion.
TEST_F(CapiTorsionTest, TwistsToTheHertzClosedForms) {
  const double a = HertzRadius(100);
  const double full_slip = 3 * std::numbers::pi * 0.3 * 100 * a / 16;
  mdr_torsional_state state = State();
  EXPECT_NEAR(state.contact_radius / a, 1, 1e-12);
  EXPECT_NEAR(state.full_slip_moment / full_slip, 1, 1e-12);
  EXPECT_EQ(state.friction_limit, 0.3 * state.normal_force);
  EXPECT_EQ(state.memory_pieces, 1u);  // the unloaded springs: one constant piece
  double positive = 0, negative = 0;
  ASSERT_EQ(mdr_torsion_stiffness(torsion_, &positive, &negative), MDR_OK);
  EXPECT_NEAR(positive / (16 * kTorsionalModulus * a * a * a / 3), 1, 1e-12);
  EXPECT_EQ(negative, positive);

  mdr_step_report report{.substeps = -1, .reserved = -1, .path_error = -1, .dissipated = -1};
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_MOMENT, 0.5 * full_slip, &report), MDR_OK)
      << mdr_last_error_message();
  state = State();
  EXPECT_NEAR(state.twisting_moment / (0.5 * full_slip), 1, 1e-12);
  EXPECT_GT(state.twist, 0);
  EXPECT_EQ(state.applied_steps, 2u);
  EXPECT_EQ(report.substeps, 1);
  EXPECT_EQ(report.reserved, 0);
  EXPECT_EQ(report.path_error, 0);
  EXPECT_EQ(report.dissipated, state.last_step_dissipation);
  EXPECT_GT(report.dissipated, 0);  // the slip annulus dissipates
  EXPECT_EQ(state.dissipated_energy, report.dissipated);

  // One slip annulus at the edge, slipping in +phi; there tau_phi = mu p(r).
  double r_begin[2], r_end[2];
  std::int32_t direction[2];
  std::size_t count = 0;
  ASSERT_EQ(mdr_torsion_slip_intervals(torsion_, r_begin, r_end, direction, 2, &count), MDR_OK);
  ASSERT_EQ(count, 1u);
  EXPECT_EQ(direction[0], 1);
  EXPECT_EQ(r_end[0], state.contact_radius);
  EXPECT_GT(r_begin[0], 0);
  const double radii[3] = {0, 0.5 * a, 0.99 * a};
  double tau[3], difference[3];
  ASSERT_EQ(mdr_torsion_tractions(torsion_, radii, 3, tau, difference, 3), MDR_OK);
  const double p0 = 3 * 100 / (2 * std::numbers::pi * a * a);
  EXPECT_EQ(tau[0], 0);
  EXPECT_NEAR(tau[2] / (0.3 * p0 * std::sqrt(1 - 0.99 * 0.99)), 1, 1e-9);
  for (double d : difference) EXPECT_LT(d, 1e-6 * p0);
  double stored = 0;
  ASSERT_EQ(mdr_torsion_stored_energy(torsion_, &stored), MDR_OK);
  EXPECT_GT(stored, 0);
  EXPECT_LT(stored, 0.5 * full_slip * state.twist);  // below the work of M, some of it dissipated
}

TEST_F(CapiTorsionTest, BadStepsNameTheArgumentAndChangeNothing) {
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 3e-3), MDR_OK);
  const std::vector<unsigned char> before = Snapshot();
  const mdr_torsional_state state = State();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ExpectError(Step(MDR_NORMAL_DEPTH, nan, MDR_TWIST_HOLD, 0), MDR_INVALID_ARGUMENT, "normal_value");
  ExpectError(Step(MDR_NORMAL_FORCE, -1, MDR_TWIST_HOLD, 0), MDR_INVALID_ARGUMENT, "normal_value");
  ExpectError(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, nan), MDR_INVALID_ARGUMENT, "twist_value");
  ExpectError(
      Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE_INCREMENT, std::numeric_limits<double>::infinity()),
      MDR_INVALID_ARGUMENT, "twist_value");
  // A moment at or beyond the full-slip moment is reached by no finite twist.
  ExpectError(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_MOMENT, 1.01 * state.full_slip_moment),
              MDR_FAILED_PRECONDITION, "twist_value");
  // Both channels in one step: refused for the choice of controls, with the core's reason.
  ExpectError(Step(MDR_NORMAL_FORCE, 120, MDR_TWIST_ANGLE_INCREMENT, 1e-3), MDR_INVALID_ARGUMENT,
              "twist_control");
  EXPECT_NE(std::string(mdr_last_error_message()).find("moves both"), std::string::npos)
      << mdr_last_error_message();
  ExpectError(Step(7, 0, MDR_TWIST_HOLD, 0), MDR_INVALID_ARGUMENT, "normal_control");
  ExpectError(Step(MDR_NORMAL_HOLD, 0, 4, 0), MDR_INVALID_ARGUMENT, "twist_control");
  ExpectError(Step(MDR_NORMAL_HOLD, 0, -1, 0), MDR_INVALID_ARGUMENT, "twist_control");
  ExpectError(Step(MDR_NORMAL_HOLD, 1e-6, MDR_TWIST_HOLD, 0), MDR_INVALID_ARGUMENT, "normal_value");
  ExpectError(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_HOLD, 1e-3), MDR_INVALID_ARGUMENT, "twist_value");
  ExpectError(mdr_torsion_step(nullptr, MDR_NORMAL_HOLD, 0, MDR_TWIST_HOLD, 0, nullptr),
              MDR_INVALID_ARGUMENT, "torsion");
  EXPECT_EQ(Snapshot(), before);
  EXPECT_EQ(State().applied_steps, 2u);
  // Both held is an empty step, counted as the service counts it.
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_HOLD, 0), MDR_OK);
  EXPECT_EQ(State().applied_steps, 3u);
  EXPECT_EQ(State().twist, state.twist);
}

// Twist to c = 0.1 a, reverse by 30 %, drop the load to a fifth: the springs would leave the
// exact state (Jager's |F| > 1), so the decrease is refused on the normal channel.
TEST_F(CapiTorsionTest, ALoadDecreaseBeyondTheExactStateChangesNothing) {
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_MOMENT, 0.999 * State().full_slip_moment), MDR_OK);
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 0.7 * State().twist), MDR_OK);
  const std::vector<unsigned char> before = Snapshot();
  ExpectError(Step(MDR_NORMAL_FORCE, 20, MDR_TWIST_HOLD, 0), MDR_FAILED_PRECONDITION,
              "normal_value");
  EXPECT_EQ(Snapshot(), before);
}

// A memory beyond scene.options.max_memory_vertices pieces is refused, and nothing changes: the
// step runs on a copy (the core's step succeeded; the piece limit is checked after it).
TEST(CapiTorsion, TheMemoryLimitRefusesAndChangesNothing) {
  const std::string scene = kTorsionScene + "  options: {max_memory_vertices: 8}\n";
  mdr_torsion* torsion = nullptr;
  ASSERT_EQ(mdr_torsion_create_from_text(scene.c_str(), "limited.yaml", &torsion), MDR_OK)
      << mdr_last_error_message();
  ASSERT_EQ(mdr_torsion_step(torsion, MDR_NORMAL_FORCE, 100, MDR_TWIST_HOLD, 0, nullptr), MDR_OK);
  // Reversals of shrinking amplitude nest: each keeps the older ones and adds a piece.
  int status = MDR_OK;
  double twist = 4e-3;
  for (int reversal = 0; reversal < 20 && status == MDR_OK; ++reversal, twist *= -0.5) {
    const std::vector<unsigned char> before = TorsionSnapshot(torsion);
    status =
        mdr_torsion_step(torsion, MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE_INCREMENT, twist, nullptr);
    if (status != MDR_OK) {
      ExpectError(status, MDR_RESOURCE_EXHAUSTED, "twist_value");
      EXPECT_EQ(TorsionSnapshot(torsion), before);
      mdr_torsional_state state;
      ASSERT_EQ(mdr_torsion_state(torsion, &state), MDR_OK);
      EXPECT_LE(state.memory_pieces, 8u);
      EXPECT_GE(reversal, 3);
    }
  }
  EXPECT_EQ(status, MDR_RESOURCE_EXHAUSTED);
  mdr_torsion_destroy(torsion);
}

TEST_F(CapiTorsionTest, SmallArraysAndNullArgumentsNameTheArgument) {
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 3e-3), MDR_OK);
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 1e-3), MDR_OK);  // a reversal
  std::size_t count = 0;
  ExpectError(mdr_torsion_slip_intervals(torsion_, nullptr, nullptr, nullptr, 0, &count),
              MDR_OUT_OF_RANGE, "capacity");
  ASSERT_EQ(count, 1u);
  double r_begin[1] = {-1}, r_end[1];
  std::int32_t direction[1];
  ExpectError(mdr_torsion_slip_intervals(torsion_, r_begin, r_end, direction, 0, &count),
              MDR_OUT_OF_RANGE, "capacity");
  EXPECT_EQ(r_begin[0], -1);  // untouched on error
  ExpectError(mdr_torsion_slip_intervals(torsion_, r_begin, nullptr, direction, 1, &count),
              MDR_INVALID_ARGUMENT, "r_end");
  ExpectError(mdr_torsion_slip_intervals(torsion_, r_begin, r_end, direction, 1, nullptr),
              MDR_INVALID_ARGUMENT, "count");
  ASSERT_EQ(mdr_torsion_slip_intervals(torsion_, r_begin, r_end, direction, 1, &count), MDR_OK);
  // The reversal slips at the edge; the older annulus inside sticks again.
  EXPECT_EQ(direction[0], -1);
  EXPECT_EQ(r_end[0], State().contact_radius);

  const double radii[3] = {0, 1e-5, -1};
  double tau[3] = {-1, -1, -1}, difference[3];
  ExpectError(mdr_torsion_tractions(torsion_, radii, 2, tau, difference, 1), MDR_OUT_OF_RANGE,
              "capacity");
  ExpectError(mdr_torsion_tractions(torsion_, radii, 3, tau, difference, 3), MDR_INVALID_ARGUMENT,
              "radii[2]");
  ExpectError(mdr_torsion_tractions(torsion_, nullptr, 2, tau, nullptr, 2), MDR_INVALID_ARGUMENT,
              "radii");
  EXPECT_EQ(tau[0], -1);
  ASSERT_EQ(mdr_torsion_tractions(torsion_, radii, 2, nullptr, difference, 2), MDR_OK);
  ASSERT_EQ(mdr_torsion_tractions(torsion_, radii, 2, tau, nullptr, 2), MDR_OK);
  EXPECT_GT(tau[1], 0);
  ASSERT_EQ(mdr_torsion_tractions(torsion_, nullptr, 0, nullptr, nullptr, 0), MDR_OK);

  double a = 0, b = 0;
  mdr_torsional_state state;
  std::size_t size = 0;
  ExpectError(mdr_torsion_state(nullptr, &state), MDR_INVALID_ARGUMENT, "torsion");
  ExpectError(mdr_torsion_state(torsion_, nullptr), MDR_INVALID_ARGUMENT, "out");
  ExpectError(mdr_torsion_stiffness(nullptr, &a, &b), MDR_INVALID_ARGUMENT, "torsion");
  ExpectError(mdr_torsion_stiffness(torsion_, nullptr, &b), MDR_INVALID_ARGUMENT, "positive");
  ExpectError(mdr_torsion_stiffness(torsion_, &a, nullptr), MDR_INVALID_ARGUMENT, "negative");
  ExpectError(mdr_torsion_stored_energy(nullptr, &a), MDR_INVALID_ARGUMENT, "torsion");
  ExpectError(mdr_torsion_stored_energy(torsion_, nullptr), MDR_INVALID_ARGUMENT, "energy");
  ExpectError(mdr_torsion_slip_intervals(nullptr, nullptr, nullptr, nullptr, 0, &count),
              MDR_INVALID_ARGUMENT, "torsion");
  ExpectError(mdr_torsion_tractions(nullptr, radii, 1, tau, nullptr, 1), MDR_INVALID_ARGUMENT,
              "torsion");
  ExpectError(mdr_torsion_snapshot(nullptr, nullptr, 0, &size), MDR_INVALID_ARGUMENT, "torsion");
  ExpectError(mdr_torsion_snapshot(torsion_, nullptr, 0, nullptr), MDR_INVALID_ARGUMENT, "size");
  std::vector<unsigned char> small(8);
  ExpectError(mdr_torsion_snapshot(torsion_, small.data(), small.size(), &size), MDR_OUT_OF_RANGE,
              "capacity");
  EXPECT_GT(size, small.size());
  mdr_torsion_destroy(nullptr);  // allowed, like free(NULL)
}

// The snapshot restores a contact that goes on bit for bit like the original, through every
// control; the restored contact's snapshot is the same bytes.
TEST_F(CapiTorsionTest, SnapshotsContinueBitForBit) {
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 3e-3), MDR_OK);
  ASSERT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE_INCREMENT, -4e-3), MDR_OK);
  const std::vector<unsigned char> bytes = Snapshot();
  mdr_torsion* copy = nullptr;
  ASSERT_EQ(mdr_torsion_restore(bytes.data(), bytes.size(), &copy), MDR_OK)
      << mdr_last_error_message();
  EXPECT_EQ(TorsionSnapshot(copy), bytes);
  const struct {
    int normal_control;
    double normal_value;
    int twist_control;
    double twist_value;
  } steps[] = {{MDR_NORMAL_FORCE, 130, MDR_TWIST_HOLD, 0},
               {MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 1e-3},
               {MDR_NORMAL_HOLD, 0, MDR_TWIST_MOMENT, -1e-3},
               {MDR_NORMAL_DEPTH_INCREMENT, 1e-8, MDR_TWIST_HOLD, 0},
               {MDR_NORMAL_DEPTH, 4.5e-6, MDR_TWIST_HOLD, 0},
               {MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE_INCREMENT, 2e-4}};
  for (const auto& s : steps) {
    mdr_step_report original{}, restored{};
    ASSERT_EQ(Step(s.normal_control, s.normal_value, s.twist_control, s.twist_value, &original),
              MDR_OK)
        << mdr_last_error_message();
    ASSERT_EQ(mdr_torsion_step(copy, s.normal_control, s.normal_value, s.twist_control,
                               s.twist_value, &restored),
              MDR_OK);
    EXPECT_EQ(std::memcmp(&original, &restored, sizeof original), 0);
    mdr_torsional_state a = State(), b{};
    ASSERT_EQ(mdr_torsion_state(copy, &b), MDR_OK);
    EXPECT_EQ(std::memcmp(&a, &b, sizeof a), 0);
  }
  EXPECT_EQ(TorsionSnapshot(copy), Snapshot());
  EXPECT_EQ(State().applied_steps, 9u);
  mdr_torsion_destroy(copy);
}

// Each kind of scene has its handle: the contact and torsion functions refuse each other's
// scenes and snapshots naming scene.torsion, and point to the right functions.
TEST(CapiTorsion, EachKindOfSceneHasItsHandle) {
  mdr_contact* contact = nullptr;
  ExpectError(mdr_contact_create_from_text(kTorsionScene.c_str(), "t.yaml", &contact),
              MDR_INVALID_ARGUMENT, "scene.torsion");
  EXPECT_NE(std::string(mdr_last_error_message()).find("mdr_torsion_create"), std::string::npos)
      << mdr_last_error_message();
  EXPECT_EQ(contact, nullptr);
  mdr_torsion* torsion = reinterpret_cast<mdr_torsion*>(1);
  ExpectError(mdr_torsion_create_from_text(kScene, "c.yaml", &torsion), MDR_INVALID_ARGUMENT,
              "scene.torsion");
  EXPECT_NE(std::string(mdr_last_error_message()).find("mdr_contact_create"), std::string::npos)
      << mdr_last_error_message();
  EXPECT_EQ(torsion, nullptr);
  ExpectError(mdr_torsion_create_from_text(kContactList, "i.yaml", &torsion), MDR_INVALID_ARGUMENT,
              "scene.torsion");

  // Snapshots: each restore function refuses the other kind's.
  ASSERT_EQ(mdr_contact_create_from_text(kScene, nullptr, &contact), MDR_OK);
  std::size_t size = 0;
  mdr_contact_snapshot(contact, nullptr, 0, &size);
  std::vector<unsigned char> tangential(size);
  ASSERT_EQ(mdr_contact_snapshot(contact, tangential.data(), size, &size), MDR_OK);
  mdr_contact_destroy(contact);
  ExpectError(mdr_torsion_restore(tangential.data(), tangential.size(), &torsion),
              MDR_INVALID_ARGUMENT, "snapshot.scene.torsion");
  EXPECT_EQ(torsion, nullptr);
  ASSERT_EQ(mdr_torsion_create_from_text(kTorsionScene.c_str(), nullptr, &torsion), MDR_OK);
  const std::vector<unsigned char> twisted = TorsionSnapshot(torsion);
  mdr_torsion_destroy(torsion);
  contact = reinterpret_cast<mdr_contact*>(1);
  ExpectError(mdr_contact_restore(twisted.data(), twisted.size(), &contact), MDR_INVALID_ARGUMENT,
              "snapshot.scene.torsion");
  EXPECT_EQ(contact, nullptr);
  // A serialized Scene is read like the text.
  ExpectError(mdr_torsion_create("\xff\xff\xff", 3, &torsion), MDR_INVALID_ARGUMENT, "scene");
  ExpectError(mdr_torsion_create(nullptr, 0, &torsion), MDR_INVALID_ARGUMENT, "scene.torsion");
  ExpectError(mdr_torsion_create_from_text(kTorsionScene.c_str(), nullptr, nullptr),
              MDR_INVALID_ARGUMENT, "out");
  ExpectError(mdr_torsion_restore(twisted.data(), twisted.size(), nullptr), MDR_INVALID_ARGUMENT,
              "out");
}

// What torsion does not cover is refused naming the scene's field, as the service refuses it;
// errors of the text name their line.
TEST(CapiTorsion, ScenesTorsionDoesNotCoverNameTheField) {
  const struct {
    std::string text;
    const char* field;
  } scenes[] = {
      {std::string(kContactList) + "  torsion: {}\n", "scene.interface"},
      {kTorsionScene + "  method: METHOD_GRID\n  grid: {max_radius: 1e-3}\n", "scene.method"},
      {kTorsionScene + "  rig: {tangential_compliance: 1e-9}\n", "scene.rig"},
      {"scene:\n  flat_punch: {radius: 1e-3}\n  elastic_pair: {youngs_modulus_1: 210e9, "
       "poisson_ratio_1: 0.3, youngs_modulus_2: 210e9, poisson_ratio_2: 0.3}\n  friction: 0.3\n"
       "  torsion: {}\n",
       "scene.flat_punch"},
      {"scene:\n  sphere: {radius: 0.01}\n  elastic_pair: {youngs_modulus_1: 210e9, "
       "poisson_ratio_1: 0.3, youngs_modulus_2: 210e9, poisson_ratio_2: 0.3}\n  friction: 0\n"
       "  torsion: {}\n",
       "scene.friction"},
      {"scene:\n  sphere: {radius: -1}\n  torsion: {}\n", "scene.sphere.radius"},
  };
  for (const auto& scene : scenes) {
    mdr_torsion* torsion = reinterpret_cast<mdr_torsion*>(1);
    ExpectError(mdr_torsion_create_from_text(scene.text.c_str(), "bad.yaml", &torsion),
                MDR_INVALID_ARGUMENT, scene.field);
    EXPECT_EQ(torsion, nullptr);
    EXPECT_NE(std::string(mdr_last_error_message()).find("bad.yaml:"), std::string::npos)
        << mdr_last_error_message();
  }
}

// A damaged torsion state is ImportSession's to refuse: its field named from the snapshot.
TEST_F(CapiTorsionTest, DamagedSnapshotsNameTheField) {
  std::vector<unsigned char> bytes = Snapshot();
  ASSERT_EQ(bytes[0], 0x08);  // version, field 1
  bytes[1] = 0x02;
  mdr_torsion* restored = reinterpret_cast<mdr_torsion*>(1);
  ExpectError(mdr_torsion_restore(bytes.data(), bytes.size(), &restored), MDR_INVALID_ARGUMENT,
              "snapshot.version");
  EXPECT_EQ(restored, nullptr);
  ExpectError(mdr_torsion_restore("\x0a\xff", 2, &restored), MDR_INVALID_ARGUMENT, "snapshot");
}

// Reading a torsional contact allocates nothing once the process has read one of each kind (each
// integral of the core builds its Gauss-Legendre rule, a static, on first use); its steps allocate.
// The core builds each step's memory as new vectors (the clipped pieces, their cuts, the merge; a
// moment target does so once per Newton iteration), so a step's allocations grow with the memory's
// pieces, and the memory of a periodic cycle does not grow: after the first cycle every cycle
// allocates the same.
TEST_F(CapiTorsionTest, WarmTwistsAndReadsAllocateNothing) {
  constexpr int kPerCycle = 100;
  // A cycle of twists by angle, then the same by increments.
  auto cycle = [&](int control) {
    double last = 0;
    for (int i = 0; i < kPerCycle; ++i) {
      const double twist = 3e-3 * std::sin(2 * std::numbers::pi * (i + 1) / kPerCycle);
      const double value = control == MDR_TWIST_ANGLE ? twist : twist - last;
      last = twist;
      if (Step(MDR_NORMAL_HOLD, 0, control, value) != MDR_OK) {
        ADD_FAILURE() << mdr_last_error_message();
        return;
      }
    }
  };
  cycle(MDR_TWIST_ANGLE);
  cycle(MDR_TWIST_ANGLE);
  EXPECT_EQ(CountAllocations([&] { cycle(MDR_TWIST_ANGLE); }), 0);
  EXPECT_EQ(CountAllocations([&] { cycle(MDR_TWIST_ANGLE_INCREMENT); }), 0);
  // A moment target's Newton iteration steps trial copies: those allocate (docs/capi.md).
  const double target = 0.5 * State().full_slip_moment;
  EXPECT_GT(CountAllocations(
                [&] { EXPECT_EQ(Step(MDR_NORMAL_HOLD, 0, MDR_TWIST_MOMENT, target), MDR_OK); }),
            0);
  EXPECT_LE(State().memory_pieces, 8u);
  mdr_torsional_state state;
  double positive, negative, stored;
  auto read = [&](int times) {
    for (int i = 0; i < times; ++i) {
      mdr_torsion_state(torsion_, &state);
      mdr_torsion_stiffness(torsion_, &positive, &negative);
      mdr_torsion_stored_energy(torsion_, &stored);
    }
  };
  read(1);  // the process's first reads, if they are
  EXPECT_EQ(CountAllocations([&] { read(1000); }), 0);
  EXPECT_GT(state.twisting_moment, -state.full_slip_moment);
}

// ---- The analysis (mdr_analysis_run) on loops the library's own contact recorded ----

// Three fretting cycles of H1 at F_N = 100 N by displacement targets, as JSON arrays of the
// displacement and the tangential force (%.17g: every double exactly).
struct RecordedLoops {
  std::string displacement = "[", force = "[";
};
RecordedLoops RecordLoops(double amplitude = 1e-6) {
  mdr_contact* contact = nullptr;
  EXPECT_EQ(mdr_contact_create_from_text(kScene, "h1.yaml", &contact), MDR_OK);
  EXPECT_EQ(mdr_contact_step(contact, MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_HOLD, 0, nullptr),
            MDR_OK);
  RecordedLoops loops;
  char number[40];
  for (int i = 0; i <= 300; ++i) {
    const double ux = amplitude * std::sin(2 * std::numbers::pi * i / 100);
    EXPECT_EQ(
        mdr_contact_step(contact, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, ux, nullptr),
        MDR_OK);
    mdr_state state;
    mdr_contact_state(contact, &state);
    const char* comma = i > 0 ? "," : "";
    std::snprintf(number, sizeof number, "%s%.17g", comma, state.tangential_displacement);
    loops.displacement += number;
    std::snprintf(number, sizeof number, "%s%.17g", comma, state.tangential_force);
    loops.force += number;
  }
  loops.displacement += "]";
  loops.force += "]";
  mdr_contact_destroy(contact);
  return loops;
}

constexpr char kSceneJson[] =
    R"({"sphere": {"radius": 0.01}, "elastic_pair": {"youngs_modulus_1": 210e9,
        "poisson_ratio_1": 0.3, "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3},
        "friction": 0.3})";

std::string RunAnalysis(int analysis, const std::string& request, int expected = MDR_OK,
                        mdr_progress_callback progress = nullptr, void* user = nullptr) {
  mdr_buffer* response = reinterpret_cast<mdr_buffer*>(1);
  const int status = mdr_analysis_run(analysis, MDR_ENCODING_JSON, request.data(), request.size(),
                                      progress, user, &response);
  EXPECT_EQ(status, expected) << mdr_last_error_message();
  if (status != MDR_OK) {
    EXPECT_EQ(response, nullptr);
    return "";
  }
  std::string json(static_cast<const char*>(mdr_buffer_data(response)), mdr_buffer_size(response));
  EXPECT_EQ(std::strlen(static_cast<const char*>(mdr_buffer_data(response))), json.size());
  mdr_buffer_destroy(response);
  return json;
}

// Three cycles found, each with the loop's figures; the scene classifies them.
TEST(CapiAnalysis, AnalyzesLoopsGivenAsJson) {
  const RecordedLoops loops = RecordLoops();
  const std::string json = RunAnalysis(
      MDR_ANALYZE_LOOPS,
      R"({"samples": {"displacement": )" + loops.displacement + R"(, "tangential_force": )" +
          loops.force + R"(}, "options": {"normal_force": 100}, "scene": )" + kSceneJson + "}");
  std::size_t cycles = 0;
  for (std::size_t at = json.find("\"first_sample\""); at != std::string::npos;
       at = json.find("\"first_sample\"", at + 1)) {
    ++cycles;
  }
  EXPECT_GE(cycles, 2u) << json;
  EXPECT_NE(json.find("\"regime\":\"REGIME_PARTIAL_SLIP\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"compute_seconds\""), std::string::npos);
}

// Bad requests are refused naming the argument or the request's field; nothing is returned.
TEST(CapiAnalysis, BadRequestsNameTheField) {
  mdr_buffer* response = reinterpret_cast<mdr_buffer*>(1);
  ExpectError(mdr_analysis_run(0, MDR_ENCODING_JSON, "{}", 2, nullptr, nullptr, &response),
              MDR_INVALID_ARGUMENT, "analysis");
  EXPECT_EQ(response, nullptr);
  ExpectError(mdr_analysis_run(MDR_ANALYZE_LOOPS, 7, "{}", 2, nullptr, nullptr, &response),
              MDR_INVALID_ARGUMENT, "encoding");
  ExpectError(mdr_analysis_run(MDR_ANALYZE_LOOPS, MDR_ENCODING_JSON, nullptr, 4, nullptr, nullptr,
                               &response),
              MDR_INVALID_ARGUMENT, "request");
  ExpectError(
      mdr_analysis_run(MDR_ANALYZE_LOOPS, MDR_ENCODING_JSON, "{}", 2, nullptr, nullptr, nullptr),
      MDR_INVALID_ARGUMENT, "response");
  ExpectError(mdr_analysis_run(MDR_ANALYZE_LOOPS, MDR_ENCODING_JSON, "{oops", 5, nullptr, nullptr,
                               &response),
              MDR_INVALID_ARGUMENT, "request");
  ExpectError(mdr_analysis_run(MDR_ANALYZE_LOOPS, MDR_ENCODING_PROTO, "\xff\xff\xff", 3, nullptr,
                               nullptr, &response),
              MDR_INVALID_ARGUMENT, "request");
  EXPECT_EQ(response, nullptr);
  // The service's checks, with its fields.
  RunAnalysis(MDR_ANALYZE_LOOPS,
              R"({"samples": {"displacement": [0, 1e-6, 0], "tangential_force": [0]}})",
              MDR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(mdr_last_error_field()), "samples.tangential_force");
  RunAnalysis(MDR_BACKBONE,
              std::string(R"({"scene": )") + kSceneJson +
                  R"(, "normal_force": 100, "kind": "AMPLITUDE_KIND_FORCE", "amplitudes": [40]})",
              MDR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(mdr_last_error_field()).rfind("amplitudes", 0), 0u)
      << mdr_last_error_field();
  RunAnalysis(MDR_FRETTING_MAP,
              std::string(R"({"scene": )") + kSceneJson +
                  R"(, "normal_forces": [100], "relative_amplitudes": [0]})",
              MDR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(mdr_last_error_field()).rfind("relative_amplitudes", 0), 0u)
      << mdr_last_error_field();
}

// A backbone and a fretting map of the scene.
TEST(CapiAnalysis, BackboneAndFrettingMap) {
  const std::string backbone =
      RunAnalysis(MDR_BACKBONE, std::string(R"({"scene": )") + kSceneJson +
                                    R"(, "normal_force": 100, "kind": "AMPLITUDE_KIND_FORCE",
                               "amplitudes": [5, 15, 29]})");
  EXPECT_NE(backbone.find("\"dissipated_energy\""), std::string::npos) << backbone;
  const std::string map = RunAnalysis(
      MDR_FRETTING_MAP, std::string(R"({"scene": )") + kSceneJson +
                            R"(, "normal_forces": [50, 100], "relative_amplitudes": [0.5, 2]})");
  EXPECT_NE(map.find("REGIME_GROSS_SLIP"), std::string::npos) << map;
}

std::string FitRequest(const RecordedLoops& loops) {
  return std::string(R"({"scene": )") + kSceneJson + R"(, "sets": [{"samples": {"displacement": )" +
         loops.displacement + R"(, "tangential_force": )" + loops.force +
         R"(}, "normal_force": 100}], "free": [{"parameter": "FIT_PARAMETER_FRICTION",
         "initial": 0.25, "lower": 0.05, "upper": 0.9}], "displacement_noise": 1e-9,
         "force_noise": 0.01})";
}

// The fit reports its progress through the callback, and stops when the callback asks.
TEST(CapiAnalysis, FitReportsProgressAndStopsWhenAsked) {
  const RecordedLoops loops = RecordLoops();
  struct Calls {
    int count = 0;
    int stop_at = 0;  // 0: never
  };
  auto progress = [](const void* message, size_t size, void* user) -> int {
    Calls& calls = *static_cast<Calls*>(user);
    ++calls.count;
    // One FitProgress object per call, this iteration's alone.
    const std::string json(static_cast<const char*>(message), size);
    EXPECT_EQ(json.find("\"iteration\""), 1u) << json;
    EXPECT_EQ(json.find("\"iteration\"", 2), std::string::npos) << json;
    EXPECT_EQ(json.back(), '}') << json;
    return calls.count == calls.stop_at ? 1 : 0;
  };
  Calls all;
  const std::string result = RunAnalysis(MDR_FIT_LOOPS, FitRequest(loops), MDR_OK, progress, &all);
  EXPECT_GT(all.count, 0);
  EXPECT_NE(result.find("\"estimates\""), std::string::npos) << result;
  Calls stopped{.stop_at = 1};
  RunAnalysis(MDR_FIT_LOOPS, FitRequest(loops), MDR_CANCELLED, progress, &stopped);
  EXPECT_EQ(stopped.count, 1);
  EXPECT_EQ(std::string(mdr_last_error_field()), "progress");
}

// A caller that declares the structs itself checks their layout against the library's.
TEST(CapiVersion, StructSizesAndRevisionAreReported) {
  EXPECT_EQ(mdr_version(), MDR_C_API_VERSION);
  EXPECT_EQ(mdr_api_revision(), MDR_C_API_REVISION);
  EXPECT_EQ(MDR_C_API_REVISION, 4);
  EXPECT_EQ(mdr_struct_size(MDR_STRUCT_STATE), 96u);
  EXPECT_EQ(mdr_struct_size(MDR_STRUCT_STEP_REPORT), 24u);
  EXPECT_EQ(mdr_struct_size(MDR_STRUCT_TORSIONAL_STATE), 88u);
  EXPECT_EQ(mdr_struct_size(0), 0u);
  EXPECT_EQ(mdr_struct_size(99), 0u);
  EXPECT_TRUE(MDR_LAYOUT_MATCHES());
}

}  // namespace

namespace {

// Random inputs through every entry point (deterministic: fixed seeds), as a fuzzer would send:
// no crash, every error has a code the header lists and names a field, and a refused step
// changes nothing.
bool IsListedCode(int code) {
  for (int listed : {MDR_CANCELLED, MDR_INVALID_ARGUMENT, MDR_DEADLINE_EXCEEDED, MDR_NOT_FOUND,
                     MDR_FAILED_PRECONDITION, MDR_RESOURCE_EXHAUSTED, MDR_OUT_OF_RANGE,
                     MDR_UNIMPLEMENTED, MDR_INTERNAL, MDR_DATA_LOSS}) {
    if (code == listed) return true;
  }
  return false;
}

double RandomValue(std::mt19937_64& rng) {
  constexpr double kSpecial[] = {0.0,
                                 -0.0,
                                 std::numeric_limits<double>::quiet_NaN(),
                                 std::numeric_limits<double>::infinity(),
                                 -std::numeric_limits<double>::infinity(),
                                 1e300,
                                 -1e300,
                                 5e-324,
                                 100,
                                 30,
                                 -30};
  std::uniform_int_distribution<int> kind(0, 3);
  switch (kind(rng)) {
    case 0:
      return kSpecial[rng() % std::size(kSpecial)];
    case 1:  // a depth or a displacement of a fretting contact
      return std::uniform_real_distribution<double>(-5e-6, 5e-6)(rng);
    case 2:  // a force
      return std::uniform_real_distribution<double>(-40, 140)(rng);
    default: {
      double value;
      const std::uint64_t bits = rng();
      std::memcpy(&value, &bits, sizeof value);
      return value;
    }
  }
}

TEST_F(CapiTest, RandomStepsFailCleanlyOrApply) {
  std::mt19937_64 rng(26);
  constexpr int kNormal[] = {0, 1, 2, 3, -1, 4, 7}, kTangential[] = {0, 4, 5, 6, 3, -2, 9};
  int applied = 0, refused = 0;
  for (int i = 0; i < 3000; ++i) {
    const int nc = kNormal[rng() % std::size(kNormal)];
    const int tc = kTangential[rng() % std::size(kTangential)];
    const double nv = nc == 0 && rng() % 2 ? 0 : RandomValue(rng);
    const double tv = tc == 0 && rng() % 2 ? 0 : RandomValue(rng);
    mdr_state before{}, after{};
    ASSERT_EQ(mdr_contact_state(contact_, &before), MDR_OK);
    const int status = Step(nc, nv, tc, tv);
    ASSERT_EQ(mdr_contact_state(contact_, &after), MDR_OK);
    if (status == MDR_OK) {
      ++applied;
      ASSERT_EQ(after.applied_steps, before.applied_steps + 1);
      ASSERT_TRUE(std::isfinite(after.normal_force) && std::isfinite(after.tangential_force));
      continue;
    }
    ++refused;
    ASSERT_TRUE(IsListedCode(status)) << status;
    ASSERT_STRNE(mdr_last_error_field(), "") << mdr_last_error_message();
    ASSERT_EQ(std::memcmp(&before, &after, sizeof before), 0) << mdr_last_error_message();
  }
  EXPECT_GT(applied, 300);
  EXPECT_GT(refused, 300);
}

TEST(CapiRandomBytes, ScenesAndSnapshotsFailCleanly) {
  std::mt19937_64 rng(126);
  mdr_contact* contact = nullptr;
  ASSERT_EQ(mdr_contact_create_from_text(kScene, nullptr, &contact), MDR_OK);
  mdr_contact_step(contact, MDR_NORMAL_FORCE, 100, MDR_TANGENTIAL_FORCE, 12, nullptr);
  std::size_t size = 0;
  mdr_contact_snapshot(contact, nullptr, 0, &size);
  std::vector<unsigned char> valid(size);
  ASSERT_EQ(mdr_contact_snapshot(contact, valid.data(), size, &size), MDR_OK);
  mdr_contact_destroy(contact);
  int created = 0;
  for (int i = 0; i < 5000; ++i) {
    // Mutations of a valid snapshot (a few bytes changed, cut short) and random bytes.
    std::vector<unsigned char> bytes = valid;
    if (i % 3 == 2) {
      bytes.resize(rng() % 64);
      for (unsigned char& b : bytes) b = static_cast<unsigned char>(rng());
    } else {
      for (int k = 0; k < 1 + i % 4; ++k)
        bytes[rng() % bytes.size()] = static_cast<unsigned char>(rng());
      if (i % 3 == 1) bytes.resize(rng() % bytes.size());
    }
    for (int which = 0; which < 2; ++which) {
      contact = nullptr;
      const int status = which == 0 ? mdr_contact_restore(bytes.data(), bytes.size(), &contact)
                                    : mdr_contact_create(bytes.data(), bytes.size(), &contact);
      if (status == MDR_OK) {
        ++created;
        mdr_state state;
        ASSERT_EQ(mdr_contact_state(contact, &state), MDR_OK);
        mdr_contact_step(contact, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT_INCREMENT, 1e-7,
                         nullptr);
        mdr_contact_destroy(contact);
      } else {
        ASSERT_TRUE(IsListedCode(status)) << status;
        ASSERT_EQ(contact, nullptr);
        ASSERT_STRNE(mdr_last_error_message(), "");
      }
    }
  }
  EXPECT_GT(created, 0);  // some mutations are still valid states (a changed u inside the cone)
}

}  // namespace

namespace {

// ---- The harmonic-balance element (docs/dynamics.md) ----

// H1 at 100 N: mu F_N = 30 N; its slip distance mu kappa delta is about 1.27 um.
constexpr double kPressForce = 100;
constexpr double kSlip = 1.27e-6;
const std::vector<int32_t> kElementHarmonics = {0, 1, 2, 3};
constexpr int kPeriodSamples = 64;

// u(tau_j) of the coefficients [U_0, U_1^c, U_1^s, ...] of kElementHarmonics, summed directly.
std::vector<double> SamplesOf(const std::vector<double>& u) {
  std::vector<double> samples(kPeriodSamples, u[0]);
  for (int j = 0; j < kPeriodSamples; ++j) {
    const double tau = 2 * std::numbers::pi * j / kPeriodSamples;
    for (std::size_t k = 1; k < kElementHarmonics.size(); ++k) {
      const int h = kElementHarmonics[k];
      samples[j] += u[2 * k - 1] * std::cos(h * tau) + u[2 * k] * std::sin(h * tau);
    }
  }
  return samples;
}

// The coefficients of force samples, summed directly (mean; 2/N sum f cos; 2/N sum f sin).
std::vector<double> CoefficientsOf(const std::vector<double>& f) {
  std::vector<double> out(2 * kElementHarmonics.size() - 1, 0);
  for (int j = 0; j < kPeriodSamples; ++j) {
    const double tau = 2 * std::numbers::pi * j / kPeriodSamples;
    out[0] += f[j] / kPeriodSamples;
    for (std::size_t k = 1; k < kElementHarmonics.size(); ++k) {
      const int h = kElementHarmonics[k];
      out[2 * k - 1] += 2 * f[j] * std::cos(h * tau) / kPeriodSamples;
      out[2 * k] += 2 * f[j] * std::sin(h * tau) / kPeriodSamples;
    }
  }
  return out;
}

struct Evaluation {
  std::vector<double> force, jacobian;
  double loss = 0;
};

Evaluation Aft(const mdr_element* element, const std::vector<double>& u, bool jacobian = true) {
  Evaluation e;
  e.force.resize(u.size());
  if (jacobian) e.jacobian.resize(u.size() * u.size());
  EXPECT_EQ(mdr_element_aft(element, u.data(), u.size(), kElementHarmonics.data(),
                            kElementHarmonics.size(), kPeriodSamples, e.force.data(),
                            jacobian ? e.jacobian.data() : nullptr, &e.loss),
            MDR_OK)
      << mdr_last_error_message();
  return e;
}

// What the element computes, stepped by hand: a contact (or the interface, its tangential force
// the total) pressed to kPressForce, moved to the period's largest sample, its smallest and its
// largest again, then marched two periods from there; the second one's forces and loss.
template <typename StepTo, typename ForceOf>
Evaluation SteppedPeriod(const std::vector<double>& samples, StepTo step_to, ForceOf force_of) {
  const auto [lo, hi] = std::minmax_element(samples.begin(), samples.end());
  const int top = static_cast<int>(hi - samples.begin());
  step_to(*hi), step_to(*lo), step_to(*hi);
  Evaluation e;
  std::vector<double> force(kPeriodSamples);
  for (int period = 0; period < 2; ++period) {
    e.loss = 0;
    for (int i = 1; i <= kPeriodSamples; ++i) {
      const int j = (top + i) % kPeriodSamples;
      e.loss += step_to(samples[j]);
      force[j] = force_of();
    }
  }
  e.force = CoefficientsOf(force);
  return e;
}

void ExpectSameCoefficients(const Evaluation& element, const Evaluation& stepped) {
  double largest = 0;
  for (double f : stepped.force) largest = std::max(largest, std::abs(f));
  ASSERT_EQ(element.force.size(), stepped.force.size());
  for (std::size_t i = 0; i < stepped.force.size(); ++i) {
    EXPECT_NEAR(element.force[i], stepped.force[i], 1e-12 * largest) << "F[" << i << "]";
  }
  EXPECT_NEAR(element.loss, stepped.loss, 1e-12 * stepped.loss);
}

// A displacement with inner reversals: a first harmonic of `amplitude` with a third.
std::vector<double> Displacement(double amplitude) {
  return {0.05 * amplitude, amplitude, 0.2 * amplitude, 0, 0.1 * amplitude, 0.3 * amplitude, 0};
}

TEST(CapiElement, IsTheContactSteppedThroughItsSteadyPeriod) {
  mdr_element* element = nullptr;
  ASSERT_EQ(mdr_element_create_from_text(kScene, "h1.yaml", kPressForce, &element), MDR_OK)
      << mdr_last_error_message();
  for (double amplitude : {0.3 * kSlip, 0.9 * kSlip, 2.5 * kSlip}) {
    SCOPED_TRACE(amplitude / kSlip);
    const std::vector<double> u = Displacement(amplitude);
    mdr_contact* contact = nullptr;
    ASSERT_EQ(mdr_contact_create_from_text(kScene, "h1.yaml", &contact), MDR_OK);
    ASSERT_EQ(
        mdr_contact_step(contact, MDR_NORMAL_FORCE, kPressForce, MDR_TANGENTIAL_HOLD, 0, nullptr),
        MDR_OK);
    const Evaluation stepped = SteppedPeriod(
        SamplesOf(u),
        [&](double x) {
          mdr_step_report report{};
          EXPECT_EQ(mdr_contact_step(contact, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, x,
                                     &report),
                    MDR_OK);
          return report.dissipated;
        },
        [&] {
          mdr_state state{};
          EXPECT_EQ(mdr_contact_state(contact, &state), MDR_OK);
          return state.tangential_force;
        });
    mdr_contact_destroy(contact);
    const Evaluation first = Aft(element, u);
    ExpectSameCoefficients(first, stepped);
    // |F| <= mu F_N = 30 N at every instant bounds the fundamental by 4/pi of it (a square wave).
    EXPECT_LE(std::hypot(first.force[1], first.force[2]), 4 / std::numbers::pi * 30 * (1 + 1e-12));
    // The element is unchanged by a call: the same bits again, with or without the Jacobian.
    const Evaluation again = Aft(element, u, false);
    EXPECT_EQ(std::memcmp(first.force.data(), again.force.data(), 8 * u.size()), 0);
    EXPECT_EQ(first.loss, again.loss);
  }
  mdr_element_destroy(element);
}

TEST(CapiElement, TheJacobianIsTheCentralDifferences) {
  mdr_element* element = nullptr;
  ASSERT_EQ(mdr_element_create_from_text(kScene, "h1.yaml", kPressForce, &element), MDR_OK);
  for (double amplitude : {0.3 * kSlip, 0.9 * kSlip, 2.5 * kSlip}) {
    SCOPED_TRACE(amplitude / kSlip);
    const std::vector<double> u = Displacement(amplitude);
    const Evaluation at = Aft(element, u);
    const std::size_t m = u.size();
    double largest = 0;
    for (double d : at.jacobian) largest = std::max(largest, std::abs(d));
    EXPECT_GT(largest, 1e7);  // of the order of the contact's stiffness, 8 a G*
    const double h = 1e-7 * kSlip;
    for (std::size_t b = 0; b < m; ++b) {
      std::vector<double> plus = u, minus = u;
      plus[b] += h, minus[b] -= h;
      const Evaluation up = Aft(element, plus, false), down = Aft(element, minus, false);
      for (std::size_t a = 0; a < m; ++a) {
        EXPECT_NEAR(at.jacobian[a * m + b], (up.force[a] - down.force[a]) / (2 * h), 1e-6 * largest)
            << "dF[" << a << "]/dU[" << b << "]";
      }
    }
  }
  mdr_element_destroy(element);
}

// Three asperities under a shared motion (docs/interfaces.md), one of them 0.5 um low.
constexpr char kSharedMotion[] = R"(
scene:
  sphere: {radius: 0.01}
  elastic_pair:
    youngs_modulus_1: 210e9
    poisson_ratio_1: 0.3
    youngs_modulus_2: 210e9
    poisson_ratio_2: 0.3
  friction: 0.3
  interface:
    kind: KIND_SHARED_MOTION
    explicit_list: {heights: [0, -0.5e-6, 0], radii: [0.01, 0.005, 0.02]}
)";

TEST(CapiElement, AnInterfacesAsperitiesAreTheInterfaceSteppedThroughItsPeriod) {
  mdr_element* element = nullptr;
  ASSERT_EQ(
      mdr_element_create_from_text(kSharedMotion, "interface.yaml", 3 * kPressForce, &element),
      MDR_OK)
      << mdr_last_error_message();
  mdr_interface* interface = nullptr;
  ASSERT_EQ(mdr_interface_create_from_text(kSharedMotion, "interface.yaml", &interface), MDR_OK);
  ASSERT_EQ(mdr_interface_step(interface, MDR_NORMAL_FORCE, 3 * kPressForce, MDR_TANGENTIAL_HOLD, 0,
                               nullptr, nullptr, 0),
            MDR_OK);
  const std::vector<double> u = Displacement(1.5 * kSlip);
  double dissipated = 0;
  const Evaluation stepped = SteppedPeriod(
      SamplesOf(u),
      [&](double x) {
        EXPECT_EQ(mdr_interface_step(interface, MDR_NORMAL_HOLD, 0, MDR_TANGENTIAL_DISPLACEMENT, x,
                                     nullptr, nullptr, 0),
                  MDR_OK);
        mdr_state state{};
        EXPECT_EQ(mdr_interface_state(interface, &state), MDR_OK);
        const double step = state.dissipated_energy - dissipated;
        dissipated = state.dissipated_energy;
        return step;
      },
      [&] {
        mdr_state state{};
        EXPECT_EQ(mdr_interface_state(interface, &state), MDR_OK);
        return state.tangential_force;
      });
  mdr_interface_destroy(interface);
  const Evaluation evaluated = Aft(element, u);
  double largest = 0;
  for (double f : stepped.force) largest = std::max(largest, std::abs(f));
  for (std::size_t i = 0; i < u.size(); ++i) {
    EXPECT_NEAR(evaluated.force[i], stepped.force[i], 1e-12 * largest) << "F[" << i << "]";
  }
  // The interface's loss is a difference of its running total: round-off of that total.
  EXPECT_NEAR(evaluated.loss, stepped.loss, 1e-9 * stepped.loss);
  mdr_element_destroy(element);
}

std::string ElementScene(const std::string& extra) { return std::string(kScene) + extra; }

TEST(CapiElement, BadScenesAndCallsNameTheArgument) {
  mdr_element* element = reinterpret_cast<mdr_element*>(1);
  ExpectError(mdr_element_create_from_text(kScene, "h1.yaml", 0, &element), MDR_INVALID_ARGUMENT,
              "normal_force");
  EXPECT_EQ(element, nullptr);
  ExpectError(mdr_element_create_from_text(kScene, "h1.yaml",
                                           std::numeric_limits<double>::quiet_NaN(), &element),
              MDR_INVALID_ARGUMENT, "normal_force");
  ExpectError(mdr_element_create_from_text(ElementScene("  torsion: {}\n").c_str(), "t.yaml",
                                           kPressForce, &element),
              MDR_INVALID_ARGUMENT, "scene.torsion");
  ExpectError(mdr_element_create_from_text(kContactList, "list.yaml", kPressForce, &element),
              MDR_INVALID_ARGUMENT, "scene.interface.kind");
  ExpectError(mdr_element_create_from_text(
                  ElementScene("  method: METHOD_GRID\n  grid: {max_radius: 1e-3}\n").c_str(),
                  "grid.yaml", kPressForce, &element),
              MDR_INVALID_ARGUMENT, "scene.method");
  ExpectError(
      mdr_element_create_from_text(ElementScene("  rig: {tangential_compliance: 1e-8}\n").c_str(),
                                   "rig.yaml", kPressForce, &element),
      MDR_INVALID_ARGUMENT, "scene.rig");
  ExpectError(mdr_element_create_from_text("scene: {sphere: {radius: -1}}", "bad.yaml", kPressForce,
                                           &element),
              MDR_INVALID_ARGUMENT, "scene.sphere.radius");
  ExpectError(mdr_element_create_from_text(kScene, "h1.yaml", kPressForce, nullptr),
              MDR_INVALID_ARGUMENT, "out");

  ASSERT_EQ(mdr_element_create_from_text(kScene, "h1.yaml", kPressForce, &element), MDR_OK);
  const std::vector<double> u = Displacement(kSlip);
  std::vector<double> force(u.size()), jacobian(u.size() * u.size());
  auto aft = [&](const mdr_element* e, const std::vector<double>& coefficients,
                 const std::vector<int32_t>& harmonics, int samples, double* f) {
    return mdr_element_aft(e, coefficients.data(), coefficients.size(), harmonics.data(),
                           harmonics.size(), samples, f, jacobian.data(), nullptr);
  };
  ExpectError(aft(nullptr, u, kElementHarmonics, 64, force.data()), MDR_INVALID_ARGUMENT,
              "element");
  ExpectError(aft(element, u, kElementHarmonics, 64, nullptr), MDR_INVALID_ARGUMENT, "force");
  ExpectError(aft(element, u, kElementHarmonics, 100, force.data()), MDR_INVALID_ARGUMENT,
              "samples");
  ExpectError(aft(element, u, kElementHarmonics, 4, force.data()), MDR_INVALID_ARGUMENT, "samples");
  ExpectError(aft(element, u, {0, 2, 1, 3}, 64, force.data()), MDR_INVALID_ARGUMENT,
              "harmonics[2]");
  ExpectError(aft(element, u, {0, 1, 2, 32}, 64, force.data()), MDR_INVALID_ARGUMENT,
              "harmonics[3]");
  ExpectError(aft(element, {1e-6, 0}, kElementHarmonics, 64, force.data()), MDR_INVALID_ARGUMENT,
              "coefficients");
  ExpectError(mdr_element_aft(element, u.data(), u.size(), kElementHarmonics.data(), SIZE_MAX, 64,
                              force.data(), nullptr, nullptr),
              MDR_INVALID_ARGUMENT, "harmonic_count");
  std::vector<double> bad = u;
  bad[3] = std::numeric_limits<double>::infinity();
  ExpectError(aft(element, bad, kElementHarmonics, 64, force.data()), MDR_INVALID_ARGUMENT,
              "coefficients[3]");
  bad = u;
  bad[0] = 2;  // every sample beyond 1 m
  EXPECT_EQ(aft(element, bad, kElementHarmonics, 64, force.data()), MDR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(mdr_last_error_field()).find("displacement["), std::string::npos)
      << mdr_last_error_field();
  // Refused calls wrote nothing and changed nothing: the next good call is the first's bits.
  std::vector<double> before(u.size());
  ASSERT_EQ(aft(element, u, kElementHarmonics, 64, before.data()), MDR_OK);
  ASSERT_EQ(aft(element, bad, kElementHarmonics, 64, force.data()), MDR_INVALID_ARGUMENT);
  ASSERT_EQ(aft(element, u, kElementHarmonics, 64, force.data()), MDR_OK);
  EXPECT_EQ(force, before);
  mdr_element_destroy(element);
  mdr_element_destroy(nullptr);  // as free(NULL)
}

}  // namespace
