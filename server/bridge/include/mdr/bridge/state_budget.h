// What a session's state costs: bytes held in memory (grid springs, memory vertices), charged to
// the server-wide budget (mdrd --max-state-bytes), and the size of its ExportSession message,
// which must fit the message limit (mdrd --max-message-bytes) so that every session the server
// accepts can be exported. Both are checked when a session is created or imported and before
// every batch is committed: a state that would break either is refused (RESOURCE_EXHAUSTED)
// and nothing changes.
#pragma once

#include <atomic>
#include <cstddef>
#include <string>
#include <utility>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interface.h"
#include "mdr/v1/scene.pb.h"

namespace mdr::bridge {

// Bytes of the contact's state in memory: its profile's (Profile::MemoryBytes: a tabulated
// profile's tables), and 41 per grid spring and per memory vertex (z, u, the slip tag and the
// anchor: GridMemory::kBytesPerSpring, PiecewiseLinearMemory::kBytesPerVertex).
std::size_t StateBytes(const Contact& contact);

// The encoded size of the scene an export writes (with the contact's effective options).
std::size_t ExportedSceneBytes(const v1::Scene& scene, const Contact& contact);

// An upper bound of the ExportSession message of a session with this contact, given
// ExportedSceneBytes (every other field of the snapshot fits in a fixed allowance).
std::size_t ExportBytesBound(const Contact& contact, std::size_t scene_bytes);

// An interface session's state: Interface::MemoryBytes (contacts, the core's step buffer,
// heights, profiles). A batch copy exists only while a batch runs on one (Session::Apply), like a
// single contact's.
std::size_t StateBytes(const Interface& interface);
// An upper bound of the ExportSession message of an interface session: every contact's snapshot
// as for a single contact, beside the scene.
std::size_t ExportBytesBound(const Interface& interface, std::size_t scene_bytes);

// What one step that moves every contact once (Interface::Apply of any kind, a contact list's
// displacement step) holds when it commits (Interface::StepCommit, handed to the commit gate):
// the bytes beyond StateBytes while it runs and ExportBytesBound after it. Exact for a step
// through a new record array; bounds from the state before the step for one made in place
// (Interface::StepBytesBound: StateBytes may grow by at most that much). Not for a contact list's
// force targets, whose curved paths take many substeps.
struct StepBounds {
  std::size_t growth_bytes = 0;
  std::size_t export_bytes = 0;
};
StepBounds BoundsAtCommit(const Interface& interface, const Interface::StepCommit& commit,
                          std::size_t scene_bytes);
// The same for one exact linear step of a single exact contact (n vertices become at most
// 3n + 1).
StepBounds BoundsAfterOneStraightStep(const Contact& contact, std::size_t scene_bytes);

// RESOURCE_EXHAUSTED (field: `field`) when a snapshot of export_bytes would not fit
// max_message_bytes.
Status CheckExportable(std::size_t export_bytes, int max_message_bytes, const std::string& field);

// What a budget and its parents still admit, and which of them is the tightest: the one a refusal
// names.
struct StateRoom {
  std::size_t bytes = 0;  // 0: no limit
  std::string whose;      // e.g. "this caller's session state quota"
  std::string flag;       // its mdrd flag, e.g. "--max-state-bytes-per-token"
};

// The sum of the state bytes of sessions against a limit: the server's (every session), or one
// caller's inside it (its parent), which every charge also goes to. Thread-safe.
class StateBudget {
 public:
  // limit_bytes 0: unlimited (still counted). `whose` names the budget in errors ("the server's
  // session state budget", "this caller's session state quota"), `flag` its mdrd flag.
  explicit StateBudget(std::size_t limit_bytes, StateBudget* parent = nullptr,
                       std::string whose = "the server's session state budget",
                       std::string flag = "--max-state-bytes")
      : limit_(limit_bytes), parent_(parent), whose_(std::move(whose)), flag_(std::move(flag)) {}

  // Adds `bytes` here and to the parent, or fails with RESOURCE_EXHAUSTED naming the budget
  // that would be exceeded and adds nothing to either.
  Status Charge(std::size_t bytes);
  // Adds `bytes` whatever the limits (sessions restored from the journal are never dropped).
  void ForceCharge(std::size_t bytes);
  void Release(std::size_t bytes);
  std::size_t used() const { return used_.load(); }
  std::size_t limit() const { return limit_; }
  // Bytes that can still be charged here and in the parents (0 when none limits).
  std::size_t Left() const;
  // Left() with the budget it comes from.
  StateRoom Room() const;

 private:
  const std::size_t limit_;
  StateBudget* const parent_;
  const std::string whose_, flag_;
  std::atomic<std::size_t> used_{0};
};

// Bytes charged to a budget for one session's state, released when destroyed (move-only).
class StateCharge {
 public:
  StateCharge() = default;
  // Charges `bytes` to budget (null: nothing to charge); RESOURCE_EXHAUSTED beyond its limit.
  static Status Take(StateBudget* budget, std::size_t bytes, StateCharge* charge);
  // Charges `bytes` whatever the limit (sessions restored from the journal are never dropped).
  static StateCharge Force(StateBudget* budget, std::size_t bytes);

  StateCharge(StateCharge&& other) noexcept;
  StateCharge& operator=(StateCharge&& other) noexcept;
  ~StateCharge();

  // Changes the charge to `bytes`; on failure (RESOURCE_EXHAUSTED) it stays as it was.
  Status Resize(std::size_t bytes);
  // Changes the charge to `bytes` whatever the limit: for bytes already held (a step whose
  // growth was checked before it ran, measured after it).
  void ForceResize(std::size_t bytes);
  std::size_t bytes() const { return bytes_; }

 private:
  StateCharge(StateBudget* budget, std::size_t bytes) : budget_(budget), bytes_(bytes) {}

  StateBudget* budget_ = nullptr;
  std::size_t bytes_ = 0;
};

}  // namespace mdr::bridge
