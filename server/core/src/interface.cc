#include "mdr/core/interface.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "mdr/base/validate.h"

namespace mdr {
namespace {

// Largest mu F_N one contact may reach (N). Far below the overflow of a double, so that the sum
// over kMaxInterfaceContacts contacts and the energies stay finite; a step beyond it is refused.
constexpr double kForceCap = 1e250;
// Approaches are kept in [-kMaxApproach, ...] so that delta - h_i never overflows.
constexpr double kMaxApproach = 1e300;
// Below this many contacts a pass runs on the calling thread (waking workers costs more).
constexpr std::size_t kMinParallelContacts = 2048;
// Force-target solves stop at this residual (relative), well inside kInterfaceForceTolerance.
constexpr double kSolveStopTolerance = 1e-14;
constexpr int kMaxSolveIterations = 200;
// In-place steps (Interface::Move): the slide scale |dux| + 2 mu kappa delta of a step and the
// bound on every contact's accumulated energy up to which no contact's energy can overflow. A
// contact's step dissipates at most mu F_N * (|dux| + 2 mu kappa delta_max) (each spring slides
// at most that far against at most its friction force), and mu F_N <= kForceCap.
constexpr double kMaxInPlaceSlide = 1e40;
constexpr double kMaxInPlaceEnergy = 1e300;

// Field names of the interface's normal channel, which is the approach delta (the tangential
// channel's are a contact's: FieldName).
const char* NormalField(NormalControl c) {
  switch (c) {
    case NormalControl::kDepth:
      return "approach";
    case NormalControl::kDepthIncrement:
      return "approach_increment";
    case NormalControl::kForce:
      return "normal_force";
  }
  return "normal";
}

double Sum(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return sum;
}

// What a step must leave for the state to stay valid (and restorable), the limits that
// Contact::Apply enforces after its own steps; field relative to the contact.
Status CheckSteppedContact(const Contact& contact) {
  const std::size_t vertices = contact.memory().vertex_count();
  if (vertices > contact.config().max_memory_vertices) {
    return ResourceExhausted("max_memory_vertices",
                             "the step needs " + std::to_string(vertices) +
                                 " memory vertices, above the limit of " +
                                 std::to_string(contact.config().max_memory_vertices));
  }
  if (!std::isfinite(contact.dissipated_energy())) {
    return InvalidArgument("dissipated_energy",
                           "the energy dissipated by this step overflows a double");
  }
  return OkStatus();
}

// Room for one more step: a step turns n memory vertices into at most 3n + 1 (one new vertex at
// the new depth, two bound crossings per segment) before merging.
bool HasVertexHeadroom(const Contact& contact) {
  return 3 * contact.memory().vertex_count() + 1 <= contact.config().max_memory_vertices;
}

// Moves contact i to (depth, ux) and checks what an interface needs after it; errors name
// contacts[i].
Status MoveContact(Contact& contact, std::size_t i, double depth, double ux) {
  if (Status s = contact.MoveTo(depth, ux); !s.ok()) {
    return s.WithFieldPrefix(Indexed("contacts", i));
  }
  if (Status s = CheckSteppedContact(contact); !s.ok()) {
    return s.WithFieldPrefix(Indexed("contacts", i));
  }
  return OkStatus();
}

// The depth at which a contact of this config reaches mu F_N = kForceCap (+inf if never).
double MaxDepth(const ContactConfig& config) {
  const double depth = DepthAtNormalForce(config, kForceCap / std::max(config.friction, 1.0));
  return std::isfinite(depth) ? depth : std::numeric_limits<double>::infinity();
}

Status CheckDepthLimit(const std::string& field, double depth, double max_depth) {
  if (depth <= max_depth) return OkStatus();
  return InvalidArgument(field, "gives the depth " + FormatNumber(depth) +
                                    " m, beyond this contact's limit of " +
                                    FormatNumber(max_depth) + " m (where mu F_N reaches " +
                                    FormatNumber(kForceCap) + " N)");
}

enum class SlipState { kOut, kSticking, kPartial, kGross };

struct SlipSummary {
  SlipState state;
  double fraction;  // slipping radius / contact radius
};

// Gross slip: the slip intervals cover [0, a] without a gap (contact.cc merges touching
// intervals of one direction from the same radii, so the comparisons are exact).
SlipSummary ClassifySlip(const Contact& contact) {
  const double a = contact.contact_radius();
  if (!(contact.depth() > 0) || !(a > 0)) return {SlipState::kOut, 0};
  const std::vector<SlipInterval> intervals = contact.slip_intervals();
  if (intervals.empty()) return {SlipState::kSticking, 0};
  double slipping = 0;
  bool covers = intervals.front().r_begin <= 0 && intervals.back().r_end >= a;
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    slipping += intervals[k].r_end - intervals[k].r_begin;
    if (k > 0 && intervals[k].r_begin != intervals[k - 1].r_end) covers = false;
  }
  if (covers) return {SlipState::kGross, 1};
  return {SlipState::kPartial, std::clamp(slipping / a, 0.0, 1.0)};
}

// Waits until ready() holds: first by spinning for up to `spin`, then by blocking on cv. A step
// sequence calls Run every millisecond or so with only a short serial part between two calls; a
// thread that blocks there lets its vCPU sleep. In a replica of this pool on the 2-vCPU VM, the
// woken worker then took 55 of 128 chunks in many rounds (it started ~60 us late, a tenth of a
// 10^4-contact pass). Spinning through the gap keeps the vCPU awake; the budget bounds what an
// idle pool burns.
template <typename Ready>
void SpinThenWait(std::mutex& mutex, std::condition_variable& cv, std::chrono::nanoseconds spin,
                  const Ready& ready) {
  const auto give_up = std::chrono::steady_clock::now() + spin;
  for (int round = 1;; ++round) {
    if (ready()) return;
    if (round % 64 == 0 && std::chrono::steady_clock::now() >= give_up) break;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
  std::unique_lock lock(mutex);
  cv.wait(lock, ready);
}

class ThreadParallelFor final : public ParallelFor {
 public:
  explicit ThreadParallelFor(int workers) : workers_(workers) {
    for (int w = 1; w < workers; ++w) threads_.emplace_back([this, w] { Loop(w); });
  }
  ~ThreadParallelFor() override {
    {
      std::lock_guard lock(mutex_);
      stop_.store(true);
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  int workers() const override { return workers_; }

  void Run(std::size_t n, const Body& body) override {
    std::lock_guard one_run(run_mutex_);
    {
      std::lock_guard lock(mutex_);
      body_ = &body;
      const auto w_count = static_cast<std::size_t>(workers_);
      chunk_ = std::max<std::size_t>(kMinChunk, n / (kChunksPerWorker * w_count));
      for (std::size_t w = 0; w < w_count; ++w) {
        ranges_[w].next.store(n * w / w_count, std::memory_order_relaxed);
        ranges_[w].end = n * (w + 1) / w_count;
      }
      pending_.store(workers_ - 1, std::memory_order_relaxed);
      generation_.fetch_add(1, std::memory_order_release);  // publishes the run's fields
    }
    wake_.notify_all();
    TakeChunks(0);
    SpinThenWait(mutex_, done_, spin_,
                 [&] { return pending_.load(std::memory_order_acquire) == 0; });
    body_ = nullptr;
  }

 private:
  // Many small chunks per worker: they even out uneven contacts and a late waker, and the worker
  // that finishes first waits at most one chunk (a few microseconds) for the others. A chunk costs
  // one fetch_add on its range's counter.
  static constexpr std::size_t kMinChunk = 32;
  static constexpr std::size_t kChunksPerWorker = 64;

  // Worker w runs its own range first (the contacts it ran last time: still in its cache), then
  // takes what is left of the others'.
  void TakeChunks(int w) {
    for (int k = 0; k < workers_; ++k) {
      Range& range = ranges_[static_cast<std::size_t>((w + k) % workers_)];
      for (;;) {
        const std::size_t begin = range.next.fetch_add(chunk_, std::memory_order_relaxed);
        if (begin >= range.end) break;
        (*body_)(begin, std::min(begin + chunk_, range.end));
      }
    }
  }
  void Loop(int w) {
    std::uint64_t seen = 0;
    for (;;) {
      SpinThenWait(mutex_, wake_, spin_, [&] {
        return stop_.load(std::memory_order_acquire) ||
               generation_.load(std::memory_order_acquire) != seen;
      });
      if (stop_.load(std::memory_order_acquire)) return;
      seen = generation_.load(std::memory_order_acquire);
      TakeChunks(w);
      if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        // Under the mutex, so that a caller that checked pending_ and is about to block cannot
        // miss the notification.
        std::lock_guard lock(mutex_);
        done_.notify_one();
      }
    }
  }

  const int workers_;
  // More threads than cores: a spinning one would hold a core another needs for its chunks.
  const std::chrono::nanoseconds spin_ =
      static_cast<unsigned>(workers_) <= std::thread::hardware_concurrency()
          ? std::chrono::microseconds(100)
          : std::chrono::nanoseconds(0);
  std::vector<std::thread> threads_;
  std::mutex run_mutex_;  // one Run at a time
  std::mutex mutex_;      // only for blocking waits and their notifications
  std::condition_variable wake_, done_;
  // Written before a run's generation is published (release); read by the workers after they
  // see it (acquire).
  const Body* body_ = nullptr;
  std::size_t chunk_ = kMinChunk;
  struct alignas(64) Range {
    std::atomic<std::size_t> next{0};  // the first index of the range no worker has taken yet
    std::size_t end = 0;
  };
  std::unique_ptr<Range[]> ranges_ = std::make_unique<Range[]>(static_cast<std::size_t>(workers_));
  std::atomic<int> pending_{0};  // workers that have not finished this run
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> stop_{false};
};

}  // namespace

Result<std::shared_ptr<ParallelFor>> MakeThreadParallelFor(int workers) {
  if (workers < 1 || workers > 64) {
    return InvalidArgument("workers", "must be in [1, 64], got " + std::to_string(workers));
  }
  return std::shared_ptr<ParallelFor>(std::make_shared<ThreadParallelFor>(workers));
}

Result<InterfaceConfig> HertzInterfaceConfig(const Population& population,
                                             const EffectiveMaterial& material, double friction,
                                             bool track_energy) {
  if (population.radii.size() != population.heights.size()) {
    return InvalidArgument("radii", "must have one radius per height (" +
                                        std::to_string(population.heights.size()) + "), got " +
                                        std::to_string(population.radii.size()));
  }
  const std::size_t n = population.radii.size();
  Result<std::vector<ProfilePtr>> spheres = MakeSpheres(population.radii);  // equal radii: one
  if (!spheres.ok()) return spheres.status();
  InterfaceConfig config;
  config.contacts.reserve(n);
  config.heights.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    ContactConfig contact;
    contact.profile = std::move((*spheres)[i]);
    contact.material = material;
    contact.friction = friction;
    contact.track_energy = track_energy;
    config.contacts.push_back(std::move(contact));
    config.heights.push_back(-population.heights[i]);
  }
  return config;
}

Result<InterfaceConfig> SharedProfileInterfaceConfig(const Population& population,
                                                     const ContactConfig& contact) {
  if (!population.radii.empty()) {
    return InvalidArgument("radii", "must be empty: every contact has the shared profile, got " +
                                        std::to_string(population.radii.size()) + " radii");
  }
  InterfaceConfig config;
  config.contacts.assign(population.heights.size(), contact);
  config.heights.reserve(population.heights.size());
  for (double s : population.heights) config.heights.push_back(-s);
  return config;
}

namespace {

// The error of the lowest failing contact index, whatever the split into ranges.
class FirstFailure {
 public:
  explicit FirstFailure(std::size_t n) : failed_at_(n) {}
  void Add(std::size_t i, Status s) {
    std::lock_guard lock(mutex_);
    if (i < failed_at_) failed_at_ = i, failure_ = std::move(s);
  }
  Status Take() { return std::move(failure_); }

 private:
  std::mutex mutex_;
  std::size_t failed_at_;
  Status failure_;
};

}  // namespace

Result<Interface> Interface::Create(InterfaceConfig config) {
  const std::size_t n = config.contacts.size();
  if (n < 1 || n > kMaxInterfaceContacts) {
    return InvalidArgument("contacts", "must hold [1, " + std::to_string(kMaxInterfaceContacts) +
                                           "] contacts, got " + std::to_string(n));
  }
  const bool shared = config.kind == InterfaceKind::kSharedMotion;
  if (!shared && !config.heights.empty()) {
    return InvalidArgument("heights",
                           "must be empty for a contact list (its contacts move "
                           "independently), got " +
                               std::to_string(config.heights.size()) + " values");
  }
  if (shared && !config.heights.empty() && config.heights.size() != n) {
    return InvalidArgument("heights", "must be empty or hold one value per contact (" +
                                          std::to_string(n) + "), got " +
                                          std::to_string(config.heights.size()));
  }
  for (std::size_t i = 0; i < config.heights.size(); ++i) {
    if (Status s = RequireInRange(Indexed("heights", i), config.heights[i], -kMaxSceneScale,
                                  kMaxSceneScale);
        !s.ok()) {
      return s;
    }
  }
  Interface built;
  built.kind_ = config.kind;
  built.heights_ = std::move(config.heights);
  built.max_approach_ = std::numeric_limits<double>::infinity();
  // Each distinct config once (validated once).
  std::vector<std::uint32_t> config_of(n);
  for (std::size_t i = 0; i < n; ++i) {
    const ContactConfig& c = config.contacts[i];
    bool added = false;
    config_of[i] = built.configs_.Add(c, &added);
    if (added) {
      if (Status s = ValidateContactConfig(c); !s.ok()) {
        return s.WithFieldPrefix(Indexed("contacts", i));
      }
      built.max_depth_.push_back(MaxDepth(c));
      built.all_exact_ = built.all_exact_ && c.method == Method::kExact;
      built.max_mu_kappa_ = std::max(built.max_mu_kappa_, MuKappa(c));
    }
    built.max_approach_ =
        std::min(built.max_approach_, built.height(i) + built.max_depth_[config_of[i]]);
  }
  built.configs_.FinishAdding();
  built.max_depth_.shrink_to_fit();
  // Every config is in the table now: the list (a ContactConfig per contact) is freed before the
  // record array is written, so that the two never take memory at once (the creation's peak).
  config.contacts.clear();
  config.contacts.shrink_to_fit();
  built.contacts_ = PackedContacts(n);
  if (shared) {
    // Touching the highest contact: every depth delta - h_i <= 0, so nothing is loaded.
    built.approach_ = built.heights_.empty()
                          ? 0.0
                          : *std::min_element(built.heights_.begin(), built.heights_.end());
    built.min_height_ = built.approach_;
  }
  ContactCursor cursor(built.configs_);
  for (std::size_t i = 0; i < n; ++i) {
    Contact& contact = cursor.Fresh(config_of[i]);
    if (shared) {
      Status s = contact.MoveTo(built.approach_ - built.height(i), 0.0);
      if (!s.ok()) return s.WithFieldPrefix(Indexed("contacts", i));
    }
    built.contacts_.Put(i, contact, config_of[i]);
    built.vertex_count_ += built.contacts_.vertex_count(i);
  }
  return built;
}

Result<Interface> Interface::Restore(InterfaceConfig config, const InterfaceSnapshot& snapshot) {
  if (snapshot.contacts.size() != config.contacts.size()) {
    return InvalidArgument("contacts",
                           "the snapshot holds " + std::to_string(snapshot.contacts.size()) +
                               " contacts, the config " + std::to_string(config.contacts.size()));
  }
  Result<Interface> created = Create(std::move(config));
  if (!created.ok()) return created;
  Interface& restored = *created;
  const bool shared = restored.kind_ == InterfaceKind::kSharedMotion;
  if (shared) {
    if (Status s =
            RequireInRange("approach", snapshot.approach, -kMaxApproach, restored.max_approach_);
        !s.ok()) {
      return s;
    }
    if (Status s = RequireFinite("tangential_displacement", snapshot.tangential_displacement);
        !s.ok()) {
      return s;
    }
  }
  restored.vertex_count_ = 0;  // counted again as the snapshot's contacts replace the fresh ones
  for (std::size_t i = 0; i < restored.size(); ++i) {
    const auto prefix = [i] { return Indexed("contacts", i); };  // only for an error
    const std::uint32_t k = restored.contacts_.config_index(i);
    Result<Contact> contact = Contact::Restore(restored.configs_.Config(k), snapshot.contacts[i]);
    if (!contact.ok()) return contact.status().WithFieldPrefix(prefix());
    const double expected_depth = snapshot.approach - restored.height(i);
    if (shared && contact->depth() != expected_depth) {
      return InvalidArgument(prefix() + ".depth",
                             "must equal approach - heights[i] = " + FormatNumber(expected_depth) +
                                 " m, got " + FormatNumber(contact->depth()));
    }
    if (shared && contact->tangential_displacement() != snapshot.tangential_displacement) {
      return InvalidArgument(prefix() + ".tangential_displacement",
                             "must equal the interface's " +
                                 FormatNumber(snapshot.tangential_displacement) + " m, got " +
                                 FormatNumber(contact->tangential_displacement()));
    }
    if (!(contact->depth() <= restored.max_depth(i))) {
      return CheckDepthLimit(prefix() + ".depth", contact->depth(), restored.max_depth(i));
    }
    restored.energy_bound_ = std::max(restored.energy_bound_, contact->dissipated_energy());
    restored.vertex_headroom_ = restored.vertex_headroom_ && HasVertexHeadroom(*contact);
    restored.contacts_.Put(i, *contact, k);
    restored.vertex_count_ += restored.contacts_.vertex_count(i);
  }
  if (shared) {
    restored.approach_ = snapshot.approach;
    restored.ux_ = snapshot.tangential_displacement;
  }
  return created;
}

InterfaceSnapshot Interface::Snapshot() const {
  InterfaceSnapshot snapshot;
  snapshot.approach = approach_;
  snapshot.tangential_displacement = ux_;
  snapshot.contacts.reserve(contacts_.size());
  SnapshotEach(
      [&](std::size_t, const ContactSnapshot& contact) { snapshot.contacts.push_back(contact); });
  return snapshot;
}

void Interface::SnapshotEach(
    const std::function<void(std::size_t i, const ContactSnapshot&)>& fn) const {
  ContactCursor cursor(configs_);
  for (std::size_t i = 0; i < contacts_.size(); ++i) fn(i, cursor.Load(contacts_, i).Snapshot());
}

Contact Interface::contact(std::size_t i) const {
  ContactCursor cursor(configs_);
  return cursor.Copy(contacts_, i);
}

Status Interface::ForEach(const std::function<Status(std::size_t)>& fn,
                          const Interrupt& interrupt) const {
  FirstFailure failure(contacts_.size());
  RunOverContacts([&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      // Each Status is constructed in place, never assigned: an assignment per contact (two
      // strings) costs about as much as a contact's bookkeeping.
      if (Status s = interrupt.CheckEvery(kInterruptPeriod, i - begin); !s.ok()) {
        return failure.Add(i, std::move(s));
      }
      if (Status s = fn(i); !s.ok()) return failure.Add(i, std::move(s));
    }
  });
  return failure.Take();
}

Status Interface::ForEachContact(const ContactStep& fn, const Interrupt& interrupt) const {
  FirstFailure failure(contacts_.size());
  RunOverContacts([&](std::size_t begin, std::size_t end) {
    ContactCursor cursor(configs_);
    for (std::size_t i = begin; i < end; ++i) {
      if (Status s = interrupt.CheckEvery(kInterruptPeriod, i - begin); !s.ok()) {
        return failure.Add(i, std::move(s));
      }
      if (Status s = fn(i, cursor.Load(contacts_, i)); !s.ok()) return failure.Add(i, std::move(s));
    }
  });
  return failure.Take();
}

void Interface::RunOverContacts(const ParallelFor::Body& body) const {
  if (parallel_ && parallel_->workers() > 1 && contacts_.size() >= kMinParallelContacts) {
    parallel_->Run(contacts_.size(), body);
  } else {
    body(0, contacts_.size());
  }
}

Status Interface::StepContacts(const ContactStep& step, bool in_place, const Interrupt& interrupt,
                               const CommitGate& gate) {
  if (in_place) {
    // Nothing can fail below, so the gate is passed first (with the bounds of what the step may
    // hold) and the pass is not interrupted.
    if (Status s = interrupt.Check(); !s.ok()) return s;
    if (gate) {
      if (Status s = gate({StepBytesBound(), CountVertices().after_one_move, false}); !s.ok()) {
        return s;
      }
    }
  }
  kept_forces_valid_ = false;
  const std::size_t n = contacts_.size();
  // A large interface writes into the array its last step replaced: its records are valid and
  // hold no block (Put overwrites them), so they need no clearing either.
  const bool recycled = !in_place && n > kMaxInPlaceContacts && spare_.records.size() == n;
  PackedContacts next = in_place   ? PackedContacts()
                        : recycled ? std::move(spare_.records)
                                   : PackedContacts::Unwritten(n);
  PackedContacts& into = in_place ? contacts_ : next;
  const Interrupt& checked = in_place ? Interrupt{} : interrupt;
  FirstFailure failure(n);
  std::mutex mutex;
  bool headroom_lost = false;
  double max_energy = 0;
  std::size_t vertices_after = 0;
  RunOverContacts([&](std::size_t begin, std::size_t end) {
    ContactCursor cursor(configs_);
    bool lost = false;
    double energy = 0;
    std::size_t vertices = 0;
    if (!in_place && !recycled) {  // valid before anything can stop the range (freed on failure)
      for (std::size_t i = begin; i < end; ++i) next.Clear(i);
    }
    for (std::size_t i = begin; i < end; ++i) {
      if (Status s = checked.CheckEvery(kInterruptPeriod, i - begin); !s.ok()) {
        failure.Add(i, std::move(s));
        break;
      }
      Contact& contact = cursor.Load(contacts_, i);
      if (Status s = step(i, contact); !s.ok()) {
        failure.Add(i, std::move(s));
        break;
      }
      lost = lost || !HasVertexHeadroom(contact);
      energy = std::max(energy, contact.dissipated_energy());
      if (keep_step_forces_) {  // while the contact is decoded
        kept_normal_forces_[i] = contact.normal_force();
        kept_tangential_forces_[i] = contact.tangential_force();
      }
      into.Put(i, contact, contacts_.config_index(i));
      vertices += into.vertex_count(i);
    }
    std::lock_guard lock(mutex);
    headroom_lost = headroom_lost || lost;
    max_energy = std::max(max_energy, energy);
    vertices_after += vertices;  // an integer sum: the split does not matter
  });
  // A large step keeps the array it did not commit (every record valid) as the spare, without
  // its heap blocks: the spare holds exactly n records whatever the step wrote.
  const auto keep_spare = [&] {
    if (n <= kMaxInPlaceContacts || !reuse_records_) return;
    next.ReleaseBlocks();
    spare_.records = std::move(next);
  };
  if (Status s = failure.Take(); !s.ok()) {
    if (!in_place) {
      keep_spare();
      return s;
    }
    return Internal(s.field(), "an in-place step failed although its limits were checked (" +
                                   s.message() + "); the interface is inconsistent");
  }
  if (!in_place) {
    if (gate) {
      if (Status s = gate({next.MemoryBytes(), vertices_after, true}); !s.ok()) {
        keep_spare();
        return s;
      }
    }
    std::swap(contacts_, next);
    keep_spare();  // the replaced array
  }
  vertex_headroom_ = !headroom_lost;
  energy_bound_ = max_energy;  // every contact was stepped: the exact largest energy
  vertex_count_ = vertices_after;
  kept_forces_valid_ = keep_step_forces_;
  return OkStatus();
}

void Interface::set_keep_step_forces(bool keep) {
  keep_step_forces_ = keep;
  kept_forces_valid_ = false;
  kept_normal_forces_.assign(keep ? contacts_.size() : 0, 0.0);
  kept_tangential_forces_.assign(keep ? contacts_.size() : 0, 0.0);
  kept_normal_forces_.shrink_to_fit();
  kept_tangential_forces_.shrink_to_fit();
}

double Interface::SlideScale(double delta1, double ux1) const {
  const double reach = std::max(std::max(approach_, delta1) - min_height_, 0.0);
  return std::abs(ux1 - ux_) + 2 * max_mu_kappa_ * reach;
}

bool Interface::CanStepInPlace(double slide_scale) const {
  return all_exact_ && vertex_headroom_ && contacts_.size() <= kMaxInPlaceContacts &&
         slide_scale <= kMaxInPlaceSlide &&
         energy_bound_ + kForceCap * slide_scale <= kMaxInPlaceEnergy;
}

Status Interface::Move(double delta1, double ux1, const Interrupt& interrupt,
                       const CommitGate& gate) {
  const bool in_place = CanStepInPlace(SlideScale(delta1, ux1));
  if (Status s = StepContacts(
          [&](std::size_t i, Contact& contact) {
            return MoveContact(contact, i, delta1 - height(i), ux1);
          },
          in_place, interrupt, gate);
      !s.ok()) {
    return s;
  }
  approach_ = delta1;
  ux_ = ux1;
  return OkStatus();
}

Status Interface::Apply(const Step& step, InterfaceStepReport* report, const Interrupt& interrupt,
                        const CommitGate& gate) {
  if (kind_ != InterfaceKind::kSharedMotion) {
    return FailedPrecondition("kind", "a contact list is stepped per contact (ApplyEach)");
  }
  const char* normal_field = NormalField(step.normal);
  const char* tangential_field = FieldName(step.tangential);
  if (Status s = RequireFinite(normal_field, step.normal_value); !s.ok()) return s;
  if (Status s = RequireFinite(tangential_field, step.tangential_value); !s.ok()) return s;
  InterfaceStepReport local;

  const bool normal_force = step.normal == NormalControl::kForce;
  const bool tangential_force = step.tangential == TangentialControl::kForce;
  double ux1 = step.tangential == TangentialControl::kDisplacement ? step.tangential_value
               : step.tangential == TangentialControl::kDisplacementIncrement
                   ? ux_ + step.tangential_value
                   : ux_;
  if (Status s = RequireFinite(tangential_field, ux1); !s.ok()) return s;
  // A force target with the other channel moving is a curved path in (delta, ux).
  if (normal_force && ux1 != ux_) {
    return InvalidArgument(tangential_field,
                           "must hold still in a step with a normal force target (that path is "
                           "curved in (delta, ux), which interfaces do not follow): apply the "
                           "two as separate steps");
  }

  double delta1 = approach_;
  if (normal_force) {
    if (Status s = RequireNonNegative(normal_field, step.normal_value); !s.ok()) return s;
    Result<double> solved = SolveApproach(step.normal_value, &local, interrupt);
    if (!solved.ok()) return solved.status();
    delta1 = *solved;
  } else {
    delta1 =
        step.normal == NormalControl::kDepth ? step.normal_value : approach_ + step.normal_value;
    if (Status s = RequireInRange(normal_field, delta1, -kMaxApproach, max_approach_); !s.ok()) {
      return InvalidArgument(normal_field, "the approach after the step " + s.message() +
                                               " (beyond it some contact's mu F_N exceeds " +
                                               FormatNumber(kForceCap) + " N)");
    }
  }
  if (tangential_force && delta1 != approach_) {
    return InvalidArgument(normal_field,
                           "must hold still in a step with a tangential force target (that path "
                           "is curved in (delta, ux), which interfaces do not follow): apply the "
                           "two as separate steps");
  }
  if (tangential_force) {
    Result<double> solved = SolveTangential(step.tangential_value, &local, interrupt);
    if (!solved.ok()) return solved.status();
    ux1 = *solved;
  }
  if (Status s = Move(delta1, ux1, interrupt, gate); !s.ok()) return s;
  if (report) *report = local;
  return OkStatus();
}

double Interface::TotalNormalForce(double delta, double* stiffness, const Interrupt& interrupt,
                                   Status* status) const {
  std::vector<double> force(contacts_.size()), slope(contacts_.size());
  *status = ForEach(
      [&](std::size_t i) {
        const EffectiveMaterial& material = settings_of(i).material;
        const Profile& profile = profile_of(i);
        const double depth = delta - height(i);
        force[i] = NormalForceAtDepth(profile, material, depth);
        // dF_N/d(delta) = 2 E* a (docs/physics.md).
        slope[i] = depth > 0 ? 2 * material.e_star * profile.RadiusAtDepth(depth) : 0.0;
        return OkStatus();
      },
      interrupt);
  *stiffness = Sum(slope);
  return Sum(force);
}

Result<double> Interface::SolveApproach(double target, InterfaceStepReport* report,
                                        const Interrupt& interrupt) const {
  Status status;
  double slope = 0;
  const double now = TotalNormalForce(approach_, &slope, interrupt, &status);
  if (!status.ok()) return status;
  // A target equal to the current force (to round-off) holds the approach exactly.
  if (std::abs(target - now) <= 1e-14 * now) {
    report->force_residual = std::abs(target - now);
    return approach_;
  }
  // The highest contact touches at h_min: F = 0 there, and it alone carries the target at
  // h_min + its depth at the target, so the root lies between.
  const std::size_t first =
      heights_.empty() ? 0
                       : static_cast<std::size_t>(
                             std::min_element(heights_.begin(), heights_.end()) - heights_.begin());
  double lo = height(first);
  if (target == 0) return lo;
  double hi =
      std::min(lo + DepthAtNormalForce(profile_of(first), settings_of(first).material, target),
               max_approach_);
  if (hi == max_approach_) {
    double unused = 0;
    const double largest = TotalNormalForce(hi, &unused, interrupt, &status);
    if (!status.ok()) return status;
    if (largest < target) {
      return InvalidArgument("normal_force", "must be <= " + FormatNumber(largest) +
                                                 " N, the total force at the largest approach "
                                                 "the interface's contacts allow, got " +
                                                 FormatNumber(target));
    }
  }
  // The current state is a point of F too: it narrows the bracket, and Newton starts from it.
  if (now < target) {
    lo = std::max(lo, approach_);
  } else {
    hi = std::min(hi, approach_);
  }
  double x = slope > 0 ? approach_ + (target - now) / slope : hi;
  if (!(x > lo && x < hi)) x = hi;
  double f = TotalNormalForce(x, &slope, interrupt, &status) - target;
  if (!status.ok()) return status;
  report->solver_iterations = 1;
  double best_x = x, best_f = f;
  // Safeguarded Newton: F is monotone (each F_i is), so [lo, hi] keeps a sign change; a Newton
  // iterate outside it, or one that does not move, is replaced by the midpoint.
  for (int iteration = 0; iteration < kMaxSolveIterations; ++iteration) {
    if (std::abs(f) <= kSolveStopTolerance * target) break;
    (f < 0 ? lo : hi) = x;
    if (!(std::nextafter(lo, hi) < hi)) break;  // adjacent doubles: resolution reached
    double next = slope > 0 ? x - f / slope : lo;
    if (!(next > lo && next < hi) || next == x) next = 0.5 * (lo + hi);
    x = next;
    f = TotalNormalForce(x, &slope, interrupt, &status) - target;
    if (!status.ok()) return status;
    ++report->solver_iterations;
    if (std::abs(f) < std::abs(best_f)) best_x = x, best_f = f;
  }
  report->force_residual = std::abs(best_f);
  return best_x;
}

Result<Interface::TangentialState> Interface::MeasureTangentialState(
    const Interrupt& interrupt) const {
  const std::size_t n = contacts_.size();
  std::vector<double> force(n), limit(n), lo(n), hi(n);
  Status s = ForEachContact(
      [&](std::size_t i, Contact& c) {
        force[i] = c.tangential_force();
        limit[i] = c.friction_limit();
        const double m = c.mu_kappa(), d = c.depth();
        const GridMemory* grid = c.grid_memory();
        lo[i] = !(d > 0) ? 0
                : grid   ? grid->GrossSlipIncrement(d, m, -1)
                         : c.memory().GrossSlipIncrement(d, m, -1);
        hi[i] = !(d > 0) ? 0
                : grid   ? grid->GrossSlipIncrement(d, m, +1)
                         : c.memory().GrossSlipIncrement(d, m, +1);
        return OkStatus();
      },
      interrupt);
  if (!s.ok()) return s;
  return TangentialState{Sum(force), Sum(limit), *std::min_element(lo.begin(), lo.end()),
                         *std::max_element(hi.begin(), hi.end())};
}

Result<double> Interface::SolveTangential(double target, InterfaceStepReport* report,
                                          const Interrupt& interrupt) const {
  Result<TangentialState> state = MeasureTangentialState(interrupt);
  if (!state.ok()) return state.status();
  const double total_limit = state->friction_limit;
  if (!(std::abs(target) <= total_limit * (1 + 1e-12))) {
    return FailedPrecondition("tangential_force",
                              "|F_x| = " + FormatNumber(std::abs(target)) +
                                  " N exceeds the interface's friction limit sum mu F_N = " +
                                  FormatNumber(total_limit) + " N");
  }
  double lo = state->gross_slip_down, hi = state->gross_slip_up;
  double x = 0, f = state->tangential_force - target;
  const double stop = kSolveStopTolerance * total_limit;
  const std::size_t n = contacts_.size();
  std::vector<double> force(n), up(n), down(n);  // each contact's stiffness toward +x and -x
  double slope = 0;                              // the total's toward the target
  std::optional<double> evaluated;               // the increment last measured
  // F_x and its slope toward the target after a step by dux (none: the state itself), each
  // contact stepped in its cursor only: nothing is stored until Apply moves to the solution.
  auto measure = [&](std::optional<double> dux) -> Status {
    if (dux) {
      evaluated = dux;
      ++report->solver_iterations;
    }
    Status s = ForEachContact(
        [&](std::size_t i, Contact& c) {
          if (dux) {
            if (Status moved = MoveContact(c, i, approach_ - height(i), ux_ + *dux); !moved.ok()) {
              return moved;
            }
          }
          force[i] = c.tangential_force();
          const TangentialStiffness k = c.tangential_stiffness();
          up[i] = k.positive;
          down[i] = k.negative;
          return OkStatus();
        },
        interrupt);
    f = Sum(force) - target;
    slope = f < 0 ? Sum(up) : Sum(down);
    return s;
  };
  if (total_limit == 0 || std::abs(f) <= stop) {
    x = 0;  // F_x = 0 for any ux without contact; a held target keeps ux
  } else if (target >= total_limit) {
    x = hi;  // onset of gross slip
  } else if (target <= -total_limit) {
    x = lo;
  } else {
    // Newton from the current state: F_x(dux) is monotone, concave toward +x and convex toward
    // -x (slip zones only grow along a monotone path), so Newton approaches the root from the
    // start side; the bracket and the midpoint guard round-off and the kinks.
    if (Status s = measure(std::nullopt); !s.ok()) return s;
    for (int iteration = 0; iteration < kMaxSolveIterations; ++iteration) {
      (f < 0 ? lo : hi) = x;
      const double resolution =
          4 * std::numeric_limits<double>::epsilon() * std::max({std::abs(ux_), lo, -lo, hi, -hi});
      if (hi - lo <= resolution) break;
      double next = slope > 0 ? x - f / slope : 0.5 * (lo + hi);
      if (!(next > lo && next < hi) || next == x) next = 0.5 * (lo + hi);
      x = next;
      if (Status s = measure(x); !s.ok()) return s;
      if (std::abs(f) <= stop) break;
    }
  }
  if (!(evaluated == x)) {  // the residual (and the contacts' checks) of the step to be applied
    if (Status s = measure(x); !s.ok()) return s;
  }
  report->force_residual = std::abs(f);
  return ux_ + x;
}

Status Interface::ApplyEach(const ContactListStep& step, const Interrupt& interrupt,
                            const CommitGate& gate) {
  if (kind_ != InterfaceKind::kContactList) {
    return FailedPrecondition("kind", "an interface under a shared motion is stepped by Apply");
  }
  const std::size_t n = contacts_.size();
  if (step.normal_values.size() != n) {
    return InvalidArgument("normal_values", "must hold one value per contact (" +
                                                std::to_string(n) + "), got " +
                                                std::to_string(step.normal_values.size()));
  }
  if (step.tangential_values.size() != n) {
    return InvalidArgument("tangential_values", "must hold one value per contact (" +
                                                    std::to_string(n) + "), got " +
                                                    std::to_string(step.tangential_values.size()));
  }
  const bool displacements =
      step.normal != NormalControl::kForce && step.tangential != TangentialControl::kForce;
  bool in_place = false;
  if (displacements && all_exact_ && vertex_headroom_ && n <= kMaxInPlaceContacts) {
    Result<bool> fits = ListStepFitsInPlace(step, interrupt);
    if (!fits.ok()) return fits.status();
    in_place = *fits;
  }
  return StepContacts(
      [&](std::size_t i, Contact& contact) {
        Status status;
        if (displacements) {
          // The exact linear step of Contact::Apply for displacement channels (the same depth
          // and ux arithmetic), without its undo copy: the record is written only after it.
          const ContactTarget target =
              DisplacementTarget(step, i, contact.depth(), contact.tangential_displacement());
          if (Status c = CheckListTarget(i, target); !c.ok()) return c;
          status = contact.MoveTo(target.depth, target.ux);
          if (status.ok()) status = CheckSteppedContact(contact);
        } else {
          // A failed step's decoded contact is dropped: the record is written only after it.
          status = contact.Apply(
              {step.normal, step.normal_values[i], step.tangential, step.tangential_values[i]},
              nullptr, interrupt, Contact::OnFailure::kDiscarded);
        }
        if (!status.ok()) return status.WithFieldPrefix(Indexed("contacts", i));
        if (contact.depth() <= max_depth(i)) return OkStatus();
        return CheckDepthLimit(Indexed("normal_values", i), contact.depth(), max_depth(i));
      },
      in_place, interrupt, gate);
}

Interface::ContactTarget Interface::DisplacementTarget(const ContactListStep& step, std::size_t i,
                                                       double depth, double ux) {
  return {
      step.normal == NormalControl::kDepth ? step.normal_values[i] : depth + step.normal_values[i],
      step.tangential == TangentialControl::kDisplacement ? step.tangential_values[i]
                                                          : ux + step.tangential_values[i]};
}

Status Interface::CheckListTarget(std::size_t i, const ContactTarget& target) const {
  // The common case without building field names (a string per contact and step).
  if (std::isfinite(target.depth) && std::isfinite(target.ux) && target.depth <= max_depth(i)) {
    return OkStatus();
  }
  if (Status s = RequireFinite(Indexed("normal_values", i), target.depth); !s.ok()) return s;
  if (Status s = RequireFinite(Indexed("tangential_values", i), target.ux); !s.ok()) return s;
  return CheckDepthLimit(Indexed("normal_values", i), target.depth, max_depth(i));
}

Result<bool> Interface::ListStepFitsInPlace(const ContactListStep& step,
                                            const Interrupt& interrupt) const {
  // Every target is checked first, and the largest slide scale decides (as in Move); the
  // records' scalars suffice, no memory is decoded.
  std::vector<double> scale(contacts_.size());
  Status checked = ForEach(
      [&](std::size_t i) {
        const double depth = contacts_.depth(i), ux = contacts_.tangential_displacement(i);
        const ContactTarget target = DisplacementTarget(step, i, depth, ux);
        if (Status s = CheckListTarget(i, target); !s.ok()) return s;
        scale[i] = std::abs(target.ux - ux) +
                   2 * MuKappa(settings_of(i)) * std::max({depth, target.depth, 0.0});
        return OkStatus();
      },
      interrupt);
  if (!checked.ok()) return checked;
  const double slide_scale = *std::max_element(scale.begin(), scale.end());
  return slide_scale <= kMaxInPlaceSlide &&
         energy_bound_ + kForceCap * slide_scale <= kMaxInPlaceEnergy;
}

Result<InterfaceTotals> Interface::Totals(const Interrupt& interrupt) const {
  struct PerContact {
    double fn, fx, energy, last, limit, kn, kt_plus, kt_minus;
    SlipState state;
  };
  std::vector<PerContact> per(contacts_.size());
  if (Status s = ForEachContact(
          [&](std::size_t i, Contact& c) {
            const TangentialStiffness kt = c.tangential_stiffness();
            per[i] = {c.normal_force(),      c.tangential_force(),
                      c.dissipated_energy(), c.last_step_dissipation(),
                      c.friction_limit(),    2 * c.config().material.e_star * c.contact_radius(),
                      kt.positive,           kt.negative,
                      ClassifySlip(c).state};
            return OkStatus();
          },
          interrupt);
      !s.ok()) {
    return s;
  }
  InterfaceTotals totals;
  for (const PerContact& p : per) {
    totals.normal_force += p.fn;
    totals.tangential_force += p.fx;
    totals.dissipated_energy += p.energy;
    totals.last_step_dissipation += p.last;
    totals.friction_limit += p.limit;
    totals.normal_stiffness += p.kn;
    totals.tangential_stiffness.positive += p.kt_plus;
    totals.tangential_stiffness.negative += p.kt_minus;
    totals.in_contact += p.state != SlipState::kOut;
    totals.sticking += p.state == SlipState::kSticking;
    totals.partial_slip += p.state == SlipState::kPartial;
    totals.gross_slip += p.state == SlipState::kGross;
  }
  return totals;
}

Interface::ForceSums Interface::SumForces(bool normal, bool tangential, bool energy) const {
  std::vector<ForceSums> per(contacts_.size());
  // After a step with kept forces, the same values as the contacts give. The normal force, the
  // friction limit and the energy need no decoding (a config and a record's scalars).
  const bool kept = kept_forces_valid_;
  auto take_scalars = [&](std::size_t i) {
    if (normal) {
      const ContactConfig& settings = settings_of(i);
      per[i].normal_force =
          kept ? kept_normal_forces_[i]
               : NormalForceAtDepth(profile_of(i), settings.material, contacts_.depth(i));
      per[i].friction_limit = settings.friction * per[i].normal_force;
    }
    if (tangential && kept) per[i].tangential_force = kept_tangential_forces_[i];
    if (energy) per[i].dissipated_energy = contacts_.dissipated_energy(i);
  };
  if (tangential && !kept) {
    (void)ForEachContact(
        [&](std::size_t i, Contact& c) {
          take_scalars(i);
          per[i].tangential_force = c.tangential_force();
          return OkStatus();
        },
        Interrupt{});
  } else if (kept) {
    for (std::size_t i = 0; i < contacts_.size(); ++i) take_scalars(i);  // reads only: no workers
  } else {
    (void)ForEach(
        [&](std::size_t i) {
          take_scalars(i);
          return OkStatus();
        },
        Interrupt{});
  }
  ForceSums sums;
  for (const ForceSums& p : per) {
    sums.normal_force += p.normal_force;
    sums.tangential_force += p.tangential_force;
    sums.dissipated_energy += p.dissipated_energy;
    sums.friction_limit += p.friction_limit;
  }
  return sums;
}

Interface::VertexTotals Interface::CountVertices() const {
  std::atomic<std::size_t> now{0}, after{0};
  RunOverContacts([&](std::size_t begin, std::size_t end) {
    std::size_t n = 0, bound = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t vertices = contacts_.vertex_count(i);
      n += vertices;
      bound += std::min(3 * vertices + 1, settings_of(i).max_memory_vertices);
    }
    now.fetch_add(n, std::memory_order_relaxed);  // integer sums: the split does not matter
    after.fetch_add(bound, std::memory_order_relaxed);
  });
  return {now.load(), after.load()};
}

Result<std::vector<std::size_t>> Interface::SlipHistogram(int bins,
                                                          const Interrupt& interrupt) const {
  if (bins < 1 || bins > 1000) {
    return InvalidArgument("bins", "must be in [1, 1000], got " + std::to_string(bins));
  }
  std::vector<SlipSummary> slip(contacts_.size());
  if (Status s = ForEachContact(
          [&](std::size_t i, Contact& c) {
            slip[i] = ClassifySlip(c);
            return OkStatus();
          },
          interrupt);
      !s.ok()) {
    return s;
  }
  std::vector<std::size_t> histogram(static_cast<std::size_t>(bins), 0);
  for (const SlipSummary& summary : slip) {
    if (summary.state == SlipState::kOut) continue;
    const auto bin = static_cast<std::size_t>(summary.fraction * bins);
    ++histogram[std::min(bin, histogram.size() - 1)];
  }
  return histogram;
}

std::size_t Interface::MemoryBytes() const {
  return sizeof(Interface) + contacts_.MemoryBytes() + spare_.records.MemoryBytes() +
         (heights_.capacity() + max_depth_.capacity() + kept_normal_forces_.capacity() +
          kept_tangential_forces_.capacity()) *
             sizeof(double) +
         configs_.MemoryBytes();
}

std::size_t Interface::StepBytesBound() const {
  // A new record array, and for every memory that may outgrow its record a heap block of the
  // raw encoding's size for 3n + 1 vertices (the compact one is smaller) plus the block's
  // granule; the cursors' vectors (per worker, a few memories' worth) are far below that.
  constexpr std::size_t kRawBytesPerVertex = 2 * sizeof(double) + 1 + 1 + 2 * sizeof(double);
  constexpr std::size_t kBlockSlack = 64 + 1;
  std::atomic<std::size_t> blocks{0};
  RunOverContacts([&](std::size_t begin, std::size_t end) {
    std::size_t bytes = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const ContactConfig& config = settings_of(i);
      if (config.method == Method::kGrid) {
        bytes += config.grid_size * (sizeof(double) + 1 + 1 + 2 * sizeof(double)) + kBlockSlack;
        continue;
      }
      const std::size_t after =
          std::min(3 * contacts_.vertex_count(i) + 1, config.max_memory_vertices);
      const std::size_t encoded = after * kRawBytesPerVertex + kBlockSlack;
      if (encoded > PackedContacts::kInlineBytes) bytes += encoded;
    }
    blocks.fetch_add(bytes, std::memory_order_relaxed);
  });
  return contacts_.size() * PackedContacts::kRecordBytes + blocks.load();
}

}  // namespace mdr
