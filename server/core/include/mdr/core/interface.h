// Many exact contacts in one container (issue #17, docs/interfaces.md): a rough interface of N
// contacts under one shared rigid motion, or a contact list where every step carries one
// increment (or target) per contact. Each contact is an ordinary Contact (contact.h), kept
// compactly between steps (PackedContacts: one 128-byte record per contact, issue #25) and
// decoded to be stepped or read through the Contact's public API, so a one-contact interface is
// bit-identical to a single Contact and the totals are sums over independent contacts. No gRPC
// in here.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interrupt.h"
#include "mdr/core/packed_contacts.h"
#include "mdr/core/population.h"

namespace mdr {

// Runs body over contiguous ranges that together cover [0, n) once, on any of its workers, and
// returns when all are done. The interface's results do not depend on the split: every contact
// is stepped on its own and every sum is taken afterwards in index order. The service may supply
// its own executor.
class ParallelFor {
 public:
  using Body = std::function<void(std::size_t begin, std::size_t end)>;
  virtual ~ParallelFor() = default;
  virtual int workers() const = 0;
  virtual void Run(std::size_t n, const Body& body) = 0;
};

// A parallel-for on `workers` persistent std::threads (the calling thread is one of them), which
// take chunks of the range as they come free, so a worker that wakes late (or a core taken by
// another process) costs no more than its share; workers in [1, 64] (field "workers").
Result<std::shared_ptr<ParallelFor>> MakeThreadParallelFor(int workers);

enum class InterfaceKind {
  // One rigid motion (approach delta, tangential displacement ux) for all contacts: contact i has
  // depth delta - heights[i] and tangential displacement ux. Steps are Interface::Apply.
  kSharedMotion,
  // Independent contacts: every step carries one value per channel and contact
  // (Interface::ApplyEach). Contacts start like new single contacts (depth 0, ux 0).
  kContactList,
};

struct InterfaceConfig {
  InterfaceKind kind = InterfaceKind::kSharedMotion;
  // One config per contact; contacts may share a ProfilePtr. The interface keeps each distinct
  // config (SameConfig) once.
  std::vector<ContactConfig> contacts;
  // Shared motion: height offset h_i of each contact (m, finite, |h| <= 1e100), or empty for all
  // 0. Contact i touches at delta = h_i. Must be empty for a contact list.
  std::vector<double> heights;
};

// Hertz asperities from a population: contact i is a sphere of radius radii[i] at offset
// h_i = -heights[i] (the summits' reference plane at delta = 0), all of one material and friction.
// Equal radii share one profile. Fields: radii[i], material.*, friction.
Result<InterfaceConfig> HertzInterfaceConfig(const Population& population,
                                             const EffectiveMaterial& material, double friction,
                                             bool track_energy = true);

// Contacts that all have `contact`'s config (one shared profile of any kind: cone, power law,
// tabulated, ...) at offsets h_i = -population.heights[i]; the population's radii must be empty
// (field "radii"), since the profile fixes the shape.
Result<InterfaceConfig> SharedProfileInterfaceConfig(const Population& population,
                                                     const ContactConfig& contact);

// One step of a contact list: contact i gets Step{normal, normal_values[i], tangential,
// tangential_values[i]} (contact.h semantics, force targets per contact). Both spans have one
// value per contact.
struct ContactListStep {
  NormalControl normal = NormalControl::kDepthIncrement;
  std::span<const double> normal_values;
  TangentialControl tangential = TangentialControl::kDisplacementIncrement;
  std::span<const double> tangential_values;
};

struct InterfaceStepReport {
  // Evaluations of the interface's total force by a force-target solve (0 otherwise).
  int solver_iterations = 0;
  // |total force - target| after the step for a force target, 0 otherwise (N). A step with both
  // targets (the normal one at the current force, so the approach holds) solves only the
  // tangential one: this is the tangential residual.
  double force_residual = 0;
};

// Relative tolerance of the interface's force targets: |F - F*| <= kInterfaceForceTolerance *
// F* for a normal target, <= kInterfaceForceTolerance * (sum of mu F_N) for a tangential one.
inline constexpr double kInterfaceForceTolerance = 1e-12;

// Totals over all contacts, each summed in index order.
struct InterfaceTotals {
  double normal_force = 0;                         // N
  double tangential_force = 0;                     // N
  double dissipated_energy = 0;                    // J, since the start
  double last_step_dissipation = 0;                // J, by the last step
  double friction_limit = 0;                       // sum of mu F_N (N)
  double normal_stiffness = 0;                     // dF_N/d(delta) = sum of 2 E* a_i (N/m)
  TangentialStiffness tangential_stiffness{0, 0};  // sums of each contact's (N/m)
  std::size_t in_contact = 0;                      // depth > 0
  std::size_t sticking = 0;                        // in contact, no spring slips
  std::size_t partial_slip = 0;                    // in contact, some springs slip
  std::size_t gross_slip = 0;                      // in contact, every spring slips
};

// The state of an interface besides its config (export, journal).
struct InterfaceSnapshot {
  double approach = 0;                 // shared motion only
  double tangential_displacement = 0;  // shared motion only
  std::vector<ContactSnapshot> contacts;
};

class Interface {
 public:
  // What a step holds when it commits, for a caller that pays for it first: the bytes beyond
  // MemoryBytes() and the memory vertices of all contacts after it. exact: a step through a new
  // record array, computed by then (the new array's MemoryBytes, its vertex count); else, for a
  // step made in place, the bounds known before it runs (StepBytesBound(),
  // CountVertices().after_one_move).
  struct StepCommit {
    std::size_t extra_bytes = 0;
    std::size_t vertices = 0;
    bool exact = false;
  };
  // Called by Apply and ApplyEach once every check of the step has passed, just before the step
  // changes the interface (in place, or by swapping the new record array in): an error from it
  // abandons the step, which then changes nothing; after it returned OK the step cannot fail. A
  // caller that must record or pay for a step before it happens (a journal, a budget) does it
  // here.
  using CommitGate = std::function<Status(const StepCommit&)>;

  // Validates the config (fields contacts[i].*, heights[i], heights). A shared-motion interface
  // starts touching its highest contact: delta = min h_i, ux = 0, every depth <= 0.
  static Result<Interface> Create(InterfaceConfig config);
  // Rebuilds an interface from a snapshot (fields contacts[i].*); for shared motion every
  // contact's depth must be delta - h_i and its ux the interface's, exactly.
  static Result<Interface> Restore(InterfaceConfig config, const InterfaceSnapshot& snapshot);
  InterfaceSnapshot Snapshot() const;
  // Each contact's snapshot in index order, one at a time (an export of millions of contacts
  // need not hold them all as ContactSnapshots at once).
  void SnapshotEach(const std::function<void(std::size_t i, const ContactSnapshot&)>& fn) const;

  // Shared motion: one step of the rigid motion (contact.h Step; depth = approach delta, normal
  // force = total F_N, tangential force = total F_x). A force target is solved exactly for the
  // whole interface when the other channel holds still (a force target together with a moving
  // other channel is refused: split it into two steps). Atomic: on error no contact changes.
  // interrupt is checked every kInterruptPeriod contacts (in-place steps: once, before they
  // start; see kMaxInPlaceContacts).
  Status Apply(const Step& step, InterfaceStepReport* report = nullptr,
               const Interrupt& interrupt = {}, const CommitGate& gate = {});
  // Contact list: one step per contact, atomic over all of them.
  Status ApplyEach(const ContactListStep& step, const Interrupt& interrupt = {},
                   const CommitGate& gate = {});

  // Runs the per-contact work on `parallel` (null: on the calling thread). Results do not depend
  // on it.
  void set_parallel(std::shared_ptr<ParallelFor> parallel) { parallel_ = std::move(parallel); }
  // Keeps every contact's F_N and F_x from each in-place step, computed in the step's own pass
  // while the contact is in cache, so that SumForces after such a step only adds them up: for a
  // caller that reads the forces after every step (the service), one pass over the contacts
  // instead of two. Off by default: a stepping loop does not pay for forces it does not read.
  // The buffers (16 bytes per contact, in MemoryBytes) are allocated here. Results do not depend
  // on it.
  void set_keep_step_forces(bool keep);

  InterfaceKind kind() const { return kind_; }
  std::size_t size() const { return contacts_.size(); }
  // Contact i, decoded into a Contact of its own (a copy: it allocates; passes over all contacts
  // use the accessors below or the interface's own outputs).
  Contact contact(std::size_t i) const;
  // Contact i's config (a copy that owns its profile).
  ContactConfig contact_config(std::size_t i) const {
    return configs_.Config(contacts_.config_index(i));
  }
  double contact_depth(std::size_t i) const { return contacts_.depth(i); }
  double contact_dissipated_energy(std::size_t i) const { return contacts_.dissipated_energy(i); }
  double contact_last_step_dissipation(std::size_t i) const {
    return contacts_.last_step_dissipation(i);
  }
  // The distinct configs and profiles the contacts share.
  std::size_t distinct_configs() const { return configs_.size(); }
  std::size_t distinct_profiles() const { return configs_.profiles(); }
  double height(std::size_t i) const { return heights_.empty() ? 0.0 : heights_[i]; }
  double approach() const { return approach_; }
  double tangential_displacement() const { return ux_; }

  // Outputs, computed on request.
  Result<InterfaceTotals> Totals(const Interrupt& interrupt = {}) const;
  // Only the force sums (no stiffnesses or slip states), each only if asked, with Totals' values
  // and order: F_N, F_x, dissipated energy and mu F_N (friction * F_N per contact); the
  // per-contact values are computed on the workers, the sums taken in index order.
  struct ForceSums {
    double normal_force = 0, tangential_force = 0, dissipated_energy = 0, friction_limit = 0;
  };
  ForceSums SumForces(bool normal, bool tangential, bool energy) const;
  // Memory vertices over all contacts, now and at most after one more move of every contact
  // (each of n vertices becomes at most 3n + 1, never above its max_memory_vertices); counted on
  // the workers.
  struct VertexTotals {
    std::size_t now = 0, after_one_move = 0;
  };
  VertexTotals CountVertices() const;
  // Memory vertices over all contacts now (CountVertices().now), kept by every step: no pass.
  std::size_t vertex_count() const { return vertex_count_; }
  // Contacts in contact by slip fraction (slipping radius / contact radius) in `bins` equal bins
  // of [0, 1] (the last one closed); bins in [1, 1000].
  Result<std::vector<std::size_t>> SlipHistogram(int bins, const Interrupt& interrupt = {}) const;
  // Bytes held between steps (the contacts' records and heap blocks, heights, kept forces,
  // configs and profiles), counted from sizes and capacities.
  std::size_t MemoryBytes() const;
  // Bytes a step may hold beyond MemoryBytes() while it runs, at most: a step that is not made
  // in place writes every contact into a new record array (and heap blocks for memories that do
  // not fit a record, each of at most 3n + 1 vertices for n now) before the old one goes.
  std::size_t StepBytesBound() const;
  // Whether a large interface keeps the array its last step replaced for the next step (the
  // default; spare_). Off, every such step writes a fresh array: for benchmarks comparing both.
  void set_reuse_records(bool reuse) {
    reuse_records_ = reuse;
    if (!reuse) spare_.records = PackedContacts();
  }

  static constexpr std::size_t kInterruptPeriod = 4096;
  // Displacement steps of at most this many exact contacts, far from every limit, run in place
  // (each record overwritten as it is stepped) and are not interrupted once started (at
  // ~0.2 us per contact that is ~13 ms); all others write into a new record array that replaces
  // the old one only when every contact has succeeded, checking interrupt every
  // kInterruptPeriod contacts.
  static constexpr std::size_t kMaxInPlaceContacts = 1 << 16;

 private:
  Interface() = default;

  // What a step does to contact i, decoded in `contact` (a cursor's: changes to it are kept only
  // by StepContacts).
  using ContactStep = std::function<Status(std::size_t i, Contact& contact)>;
  // Steps every contact and keeps the results: in place when the caller has checked that no
  // contact can fail (not interrupted once started: an error is Internal), else into a new record
  // array that replaces the old one only when every contact succeeded and the gate passed (on an
  // error, the lowest index's, or an interrupt nothing changes). Keeps the step's forces if asked
  // (set_keep_step_forces), and the vertex headroom and the energy bound.
  Status StepContacts(const ContactStep& step, bool in_place, const Interrupt& interrupt,
                      const CommitGate& gate);
  // Runs fn(i, contact) on every contact decoded, split by parallel_, checking interrupt; the
  // lowest failing index's error.
  Status ForEachContact(const ContactStep& fn, const Interrupt& interrupt) const;
  // Runs fn(i) for every contact index, split by parallel_, checking interrupt.
  Status ForEach(const std::function<Status(std::size_t)>& fn, const Interrupt& interrupt) const;
  // Runs body over [0, size()) in ranges: on parallel_ when it has several workers and there are
  // at least kMinParallelContacts contacts (fewer cost more to hand out), else in one call here.
  void RunOverContacts(const ParallelFor::Body& body) const;

  // Steps every contact to (delta1, ux1): in place when no contact can fail, else through a new
  // record array.
  Status Move(double delta1, double ux1, const Interrupt& interrupt, const CommitGate& gate);
  // |dux| + 2 max(mu kappa) (max(delta0, delta1) - min h): how far any spring can slide.
  double SlideScale(double delta1, double ux1) const;
  bool CanStepInPlace(double slide_scale) const;
  // The depth at which contact i's mu F_N reaches the force cap (its config's).
  double max_depth(std::size_t i) const { return max_depth_[contacts_.config_index(i)]; }
  // Contact i's config but for the profile, and its profile.
  const ContactConfig& settings_of(std::size_t i) const {
    return configs_.settings(contacts_.config_index(i));
  }
  const Profile& profile_of(std::size_t i) const {
    return configs_.profile(contacts_.config_index(i));
  }
  // Where a displacement step takes contact i: its depth and ux after the step.
  struct ContactTarget {
    double depth, ux;
  };
  static ContactTarget DisplacementTarget(const ContactListStep& step, std::size_t i, double depth,
                                          double ux);
  // Finite, and within contact i's depth limit (fields normal_values[i], tangential_values[i]).
  Status CheckListTarget(std::size_t i, const ContactTarget& target) const;
  // Whether a contact list's displacement step can run in place: every target passes (else its
  // error) and no contact can fail.
  Result<bool> ListStepFitsInPlace(const ContactListStep& step, const Interrupt& interrupt) const;

  Result<double> SolveApproach(double normal_force, InterfaceStepReport* report,
                               const Interrupt& interrupt) const;
  struct TangentialState {
    double tangential_force, friction_limit;
    // The increments at which every contact slides toward -x and +x: they bracket any target.
    double gross_slip_down, gross_slip_up;
  };
  Result<TangentialState> MeasureTangentialState(const Interrupt& interrupt) const;
  // The tangential displacement at which the total F_x is the target (nothing changes).
  Result<double> SolveTangential(double tangential_force, InterfaceStepReport* report,
                                 const Interrupt& interrupt) const;
  double TotalNormalForce(double delta, double* stiffness, const Interrupt& interrupt,
                          Status* status) const;

  InterfaceKind kind_ = InterfaceKind::kSharedMotion;
  ConfigTable configs_;            // the distinct configs, by PackedContacts::config_index
  std::vector<double> max_depth_;  // per config: the depth at which mu F_N reaches kForceCap
  PackedContacts contacts_;
  // The record array the last step through a new array replaced (its heap blocks freed), kept
  // for the next one when the interface is too large to step in place (more than
  // kMaxInPlaceContacts contacts): that step writes over its pages instead of a fresh array
  // whose pages the kernel zeroes (128 MB at 10^6 contacts, 13 % of the step). Counted in
  // MemoryBytes (kRecordBytes per contact); not part of the state, so a copy starts without one.
  struct SpareRecords {
    PackedContacts records;
    SpareRecords() = default;
    SpareRecords(const SpareRecords&) {}
    SpareRecords& operator=(const SpareRecords&) {
      records = PackedContacts();
      return *this;
    }
    SpareRecords(SpareRecords&&) noexcept = default;
    SpareRecords& operator=(SpareRecords&&) noexcept = default;
  };
  SpareRecords spare_;
  bool reuse_records_ = true;
  std::vector<double> heights_;  // shared motion; empty: all 0
  double max_approach_ = 0;      // min_i (h_i + max_depth_i)
  double approach_ = 0;
  double ux_ = 0;
  // What decides whether a step can run in place (Move).
  bool all_exact_ = true;         // no grid-method contact (whose reach a step may exceed)
  double max_mu_kappa_ = 0;       // over all contacts
  double min_height_ = 0;         // min h_i
  bool vertex_headroom_ = true;   // every contact has room for one more step's vertices
  double energy_bound_ = 0;       // >= every contact's dissipated energy
  std::size_t vertex_count_ = 0;  // over all contacts (vertex_count())
  std::shared_ptr<ParallelFor> parallel_;
  // set_keep_step_forces: F_N and F_x per contact as the last step left them, valid
  // (kept_forces_valid_) until anything else changes the contacts.
  bool keep_step_forces_ = false;
  bool kept_forces_valid_ = false;
  std::vector<double> kept_normal_forces_, kept_tangential_forces_;
};

}  // namespace mdr
