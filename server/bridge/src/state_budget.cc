#include "mdr/bridge/state_budget.h"

#include <algorithm>
#include <string>
#include <utility>

#include "mdr/bridge/conversion.h"

namespace mdr::bridge {
namespace {

constexpr std::size_t kBytesPerSpring = GridMemory::kBytesPerSpring;
constexpr std::size_t kBytesPerVertex = PiecewiseLinearMemory::kBytesPerVertex;
// Encoded: a packed double and an anchor byte per spring, two packed doubles per anchored
// spring; a MemoryVertex message (two doubles, an enum, its tag and
// length: 24) with its segment's MemoryAnchor (an enum, two doubles, tag and length: 22) per
// vertex; the rest of the snapshot (name, limits, depth, forces, ...) below 1 KiB.
constexpr std::size_t kExportBytesPerSpring = sizeof(double) + 1;
constexpr std::size_t kExportBytesPerAnchoredSpring = 2 * sizeof(double);
constexpr std::size_t kExportBytesPerVertex = 24 + 22;
constexpr std::size_t kExportAllowance = 1024;
// An interface's ContactSnapshot: four doubles with their tags, its own tag and length.
constexpr std::size_t kExportBytesPerContact = 48;

std::size_t InterfaceExportBytes(std::size_t contacts, std::size_t vertices,
                                 std::size_t scene_bytes) {
  return scene_bytes + kExportAllowance + contacts * kExportBytesPerContact +
         vertices * kExportBytesPerVertex;
}

std::size_t Springs(const Contact& contact) {
  const GridMemory* grid = contact.grid_memory();
  return grid == nullptr ? 0 : grid->size();
}

std::size_t AnchoredSprings(const Contact& contact) {
  const GridMemory* grid = contact.grid_memory();
  return grid == nullptr ? 0 : grid->AnchoredSprings();
}

}  // namespace

std::size_t StateBytes(const Contact& contact) {
  // The session's own profile too: a tabulated one holds its tables (up to ~12 MB).
  return contact.config().profile->MemoryBytes() + Springs(contact) * kBytesPerSpring +
         contact.memory().vertex_count() * kBytesPerVertex;
}

std::size_t ExportedSceneBytes(const v1::Scene& scene, const Contact& contact) {
  return WithEffectiveOptions(scene, contact.config()).ByteSizeLong();
}

std::size_t ExportBytesBound(const Contact& contact, std::size_t scene_bytes) {
  return scene_bytes + kExportAllowance + Springs(contact) * kExportBytesPerSpring +
         AnchoredSprings(contact) * kExportBytesPerAnchoredSpring +
         contact.memory().vertex_count() * kExportBytesPerVertex;
}

std::size_t StateBytes(const Interface& interface) { return interface.MemoryBytes(); }

std::size_t ExportBytesBound(const Interface& interface, std::size_t scene_bytes) {
  return InterfaceExportBytes(interface.size(), interface.vertex_count(), scene_bytes);
}

StepBounds BoundsAtCommit(const Interface& interface, const Interface::StepCommit& commit,
                          std::size_t scene_bytes) {
  return {commit.extra_bytes, InterfaceExportBytes(interface.size(), commit.vertices, scene_bytes)};
}

StepBounds BoundsAfterOneStraightStep(const Contact& contact, std::size_t scene_bytes) {
  const std::size_t n = contact.memory().vertex_count();
  const std::size_t after = 3 * n + 1;
  return {(after - n) * kBytesPerVertex,
          scene_bytes + kExportAllowance + after * kExportBytesPerVertex};
}

Status CheckExportable(std::size_t export_bytes, int max_message_bytes, const std::string& field) {
  if (export_bytes <= static_cast<std::size_t>(max_message_bytes)) return OkStatus();
  return ResourceExhausted(field, "the session's state would take up to " +
                                      std::to_string(export_bytes) +
                                      " bytes in an ExportSession message, above the message "
                                      "limit of " +
                                      std::to_string(max_message_bytes) +
                                      " bytes (mdrd --max-message-bytes): use a smaller grid or "
                                      "memory");
}

Status StateBudget::Charge(std::size_t bytes) {
  std::size_t used = used_.load();
  do {
    if (limit_ > 0 && used + bytes > limit_) {
      return ResourceExhausted("", whose_ + " of " + std::to_string(limit_) + " bytes (mdrd " +
                                       flag_ + ") would be exceeded: " + std::to_string(used) +
                                       " bytes are held, this needs " + std::to_string(bytes) +
                                       " more; delete sessions or use smaller ones");
    }
  } while (!used_.compare_exchange_weak(used, used + bytes));
  if (parent_ != nullptr) {
    if (Status status = parent_->Charge(bytes); !status.ok()) {
      used_.fetch_sub(bytes);
      return status;
    }
  }
  return OkStatus();
}

void StateBudget::ForceCharge(std::size_t bytes) {
  used_.fetch_add(bytes);
  if (parent_ != nullptr) parent_->ForceCharge(bytes);
}

void StateBudget::Release(std::size_t bytes) {
  used_.fetch_sub(bytes);
  if (parent_ != nullptr) parent_->Release(bytes);
}

std::size_t StateBudget::Left() const {
  std::size_t left = 0;  // 0: unlimited so far
  if (limit_ > 0) left = used() < limit_ ? limit_ - used() : 1;
  if (parent_ == nullptr) return left;
  const std::size_t above = parent_->Left();
  if (above == 0) return left;
  return left == 0 ? above : std::min(left, above);
}

StateRoom StateBudget::Room() const {
  StateRoom room;
  if (parent_ != nullptr) room = parent_->Room();
  const std::size_t left = limit_ == 0 ? 0 : (used() < limit_ ? limit_ - used() : 1);
  if (left > 0 && (room.bytes == 0 || left <= room.bytes)) room = {left, whose_, flag_};
  return room;
}

Status StateCharge::Take(StateBudget* budget, std::size_t bytes, StateCharge* charge) {
  if (budget != nullptr) {
    if (Status status = budget->Charge(bytes); !status.ok()) return status;
  }
  *charge = StateCharge(budget, bytes);
  return OkStatus();
}

StateCharge StateCharge::Force(StateBudget* budget, std::size_t bytes) {
  if (budget != nullptr) budget->ForceCharge(bytes);
  return StateCharge(budget, bytes);
}

StateCharge::StateCharge(StateCharge&& other) noexcept
    : budget_(std::exchange(other.budget_, nullptr)), bytes_(std::exchange(other.bytes_, 0)) {}

StateCharge& StateCharge::operator=(StateCharge&& other) noexcept {
  if (this != &other) {
    if (budget_ != nullptr) budget_->Release(bytes_);
    budget_ = std::exchange(other.budget_, nullptr);
    bytes_ = std::exchange(other.bytes_, 0);
  }
  return *this;
}

StateCharge::~StateCharge() {
  if (budget_ != nullptr) budget_->Release(bytes_);
}

void StateCharge::ForceResize(std::size_t bytes) {
  if (bytes == bytes_) return;
  if (budget_ != nullptr) {
    if (bytes > bytes_) {
      budget_->ForceCharge(bytes - bytes_);
    } else {
      budget_->Release(bytes_ - bytes);
    }
  }
  bytes_ = bytes;
}

Status StateCharge::Resize(std::size_t bytes) {
  if (bytes == bytes_) return OkStatus();  // most batches: no shared counter touched
  if (budget_ != nullptr) {
    if (bytes > bytes_) {
      if (Status status = budget_->Charge(bytes - bytes_); !status.ok()) return status;
    } else {
      budget_->Release(bytes_ - bytes);
    }
  }
  bytes_ = bytes;
  return OkStatus();
}

}  // namespace mdr::bridge
