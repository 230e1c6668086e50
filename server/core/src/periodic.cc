#include "mdr/core/periodic.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>
#include <utility>

#include "mdr/base/validate.h"

namespace mdr {
namespace {

constexpr double kMaxDisplacement = 1;  // m, as the loop analysis' samples
constexpr std::size_t kMaxSamples = std::size_t{1} << 24;
constexpr std::uint32_t kInterruptPeriod = 4096;  // samples between interrupt checks

Status CheckSamples(std::span<const double> u) {
  if (u.size() < 2 || u.size() > kMaxSamples) {
    return InvalidArgument("displacement", "needs 2 to " + std::to_string(kMaxSamples) +
                                               " samples of one period, got " +
                                               std::to_string(u.size()));
  }
  for (std::size_t j = 0; j < u.size(); ++j) {
    if (!(std::abs(u[j]) <= kMaxDisplacement)) {
      return RequireInRange(Indexed("displacement", j), u[j], -kMaxDisplacement, kMaxDisplacement);
    }
  }
  return OkStatus();
}

// The sample of each turning point of the path, by the bits of its displacement: a memory
// segment's anchor is the contact's ux at the turning point, exactly that sample's value. Few
// turning points stay remembered, so a flat list searched from the latest is the fastest map.
class TurningPoints {
 public:
  void Set(double value, std::uint32_t sample) {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(value);
    for (auto& [key, at] : points_) {
      if (key == bits) {
        at = sample;
        return;
      }
    }
    points_.emplace_back(bits, sample);
  }
  const std::uint32_t* Find(double value) const {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(value);
    for (auto it = points_.rbegin(); it != points_.rend(); ++it) {
      if (it->first == bits) return &it->second;
    }
    return nullptr;
  }

 private:
  std::vector<std::pair<std::uint64_t, std::uint32_t>> points_;
};

// The entries of the sensitivities, summed over contacts, compressed into rows at the end.
class Rows {
 public:
  explicit Rows(std::size_t samples) : samples_(samples) {}
  void Add(std::uint32_t row, std::uint32_t column, double value) {
    entries_.push_back({row, column, value});
  }
  void Clear() { entries_.clear(); }
  // Another contact's entries after this one's.
  void Append(const Rows& other) {
    entries_.insert(entries_.end(), other.entries_.begin(), other.entries_.end());
  }
  // By row (a counting sort, stable), columns increasing within a row, repeats summed in the
  // order they were added.
  PeriodicJacobian Compress() const {
    PeriodicJacobian j;
    j.samples = samples_;
    std::vector<std::uint32_t> start(samples_ + 1, 0);
    for (const Entry& e : entries_) ++start[e.row + 1];
    for (std::size_t i = 0; i < samples_; ++i) start[i + 1] += start[i];
    std::vector<Entry> sorted(entries_.size());
    std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
    for (const Entry& e : entries_) sorted[next[e.row]++] = e;
    j.row_begin.push_back(0);
    for (std::size_t i = 0; i < samples_; ++i) {
      const auto first = sorted.begin() + start[i], last = sorted.begin() + start[i + 1];
      std::stable_sort(first, last,
                       [](const Entry& a, const Entry& b) { return a.column < b.column; });
      const std::size_t row_start = j.column.size();
      for (auto it = first; it != last; ++it) {
        if (j.column.size() > row_start && j.column.back() == it->column) {
          j.value.back() += it->value;
        } else {
          j.column.push_back(it->column);
          j.value.push_back(it->value);
        }
      }
      j.row_begin.push_back(static_cast<std::uint32_t>(j.column.size()));
    }
    return j;
  }

 private:
  struct Entry {
    std::uint32_t row, column;
    double value;
  };
  std::size_t samples_;
  std::vector<Entry> entries_;
};

// One contact driven around the period: the start (the period's maximum, minimum and maximum
// again), warm-up periods, then the recorded one.
class Marcher {
 public:
  Marcher(Contact& contact, std::span<const double> u, const Interrupt& interrupt)
      : c_(contact), u_(u), interrupt_(interrupt) {
    const auto [lowest, highest] = std::minmax_element(u.begin(), u.end());
    max_ = static_cast<std::uint32_t>(highest - u.begin());
    min_ = static_cast<std::uint32_t>(lowest - u.begin());
  }

  Status Start() {
    for (const std::uint32_t j : {max_, min_, max_}) {
      if (Status s = c_.MoveTo(c_.depth(), u_[j]); !s.ok()) return s;
    }
    turning_.Set(u_[max_], max_);
    turning_.Set(u_[min_], min_);
    direction_ = u_[max_] > u_[min_] ? 1 : 0;  // arrived at the maximum rising (unless flat)
    return OkStatus();
  }

  // One period from the maximum back to it; with `rows`, each sample's forces and sensitivities;
  // the period's loss summed from its steps (a difference of the contact's running total would
  // round with the warm-up before it).
  Status Period(std::vector<double>* force, Rows* rows, double* loss = nullptr) {
    const std::size_t n = u_.size();
    std::uint32_t previous = max_;
    for (std::size_t k = 1; k <= n; ++k) {
      if (Status s = interrupt_.CheckEvery(kInterruptPeriod, k); !s.ok()) return s;
      const auto j = static_cast<std::uint32_t>((max_ + k) % n);
      // The path turned at the previous sample when it now moves the other way.
      const double move = u_[j] - u_[previous];
      if (move != 0) {
        const int direction = move > 0 ? 1 : -1;
        if (direction_ != 0 && direction != direction_) turning_.Set(u_[previous], previous);
        direction_ = direction;
      }
      if (Status s = c_.MoveTo(c_.depth(), u_[j]); !s.ok()) return s;
      if (loss) *loss += c_.last_step_dissipation();
      if (force) (*force)[j] += c_.tangential_force();
      if (rows) {
        if (Status s = Sensitivities(j, *rows); !s.ok()) return s;
      }
      previous = j;
    }
    return OkStatus();
  }

 private:
  // Row j: +k of every sticking segment on the diagonal, -k at the turning point it is anchored
  // to (none for springs that never slid: they follow u from where they were pressed), k = 2 G*
  // times the segment's radius measure; sliding segments follow their bound, not u.
  Status Sensitivities(std::uint32_t row, Rows& rows) const {
    const PiecewiseLinearMemory& m = c_.memory();
    const std::vector<double>& z = m.z();
    const std::vector<std::uint8_t>& tags = m.tags();
    const std::vector<SegmentAnchor>& anchors = m.anchors();
    if (z.empty()) return OkStatus();
    const Profile& profile = *c_.config().profile;
    const double k = 2 * c_.config().material.g_star;
    auto stick = [&](double measure, const SegmentAnchor& anchor) {
      rows.Add(row, row, k * measure);
      if (anchor.bound == kInside) return OkStatus();
      const std::uint32_t* column = turning_.Find(anchor.tangential_displacement);
      if (column == nullptr) {
        return Internal("anchor", "a sticking segment's anchor is no turning point of the period");
      }
      rows.Add(row, *column, -k * measure);
      return OkStatus();
    };
    // A flat punch's face is an atom at z = 0, moving as the first vertex.
    if (const double atom = profile.RadiusAtDepth(0); atom > 0 && tags[0] == kInside) {
      if (Status s = stick(atom, anchors[0]); !s.ok()) return s;
    }
    double x0 = profile.RadiusAtDepth(z[0]);
    for (std::size_t i = 0; i + 1 < z.size(); ++i) {
      const double x1 = profile.RadiusAtDepth(z[i + 1]);
      const bool on_bound = (tags[i] & tags[i + 1] & kOnBoth) != 0;
      if (!on_bound && x1 > x0) {
        if (Status s = stick(x1 - x0, anchors[i]); !s.ok()) return s;
      }
      x0 = x1;
    }
    return OkStatus();
  }

  Contact& c_;
  std::span<const double> u_;
  const Interrupt& interrupt_;
  std::uint32_t max_ = 0, min_ = 0;
  int direction_ = 0;
  TurningPoints turning_;
};

}  // namespace

Status CheckPeriodicContact(const Contact& contact) {
  const ContactConfig& config = contact.config();
  if (config.method != Method::kExact) {
    return InvalidArgument("method",
                           "must be the exact method: the grid's springs have no anchors");
  }
  if (config.rig.tangential != 0 || config.rig.normal != 0) {
    return InvalidArgument("rig",
                           "must be none: the periodic evaluation drives the contact itself");
  }
  if (!config.track_energy) {
    return InvalidArgument("track_energy", "must be on: the loss per period is the engine's");
  }
  if (contact.tangential_displacement() != 0) {
    return InvalidArgument("tangential_displacement", "must be 0: the contact is pressed at u = 0");
  }
  return OkStatus();
}

double PeriodicJacobian::At(std::size_t i, std::size_t j) const {
  for (std::uint32_t k = row_begin[i]; k < row_begin[i + 1]; ++k) {
    if (column[k] == j) return value[k];
  }
  return 0;
}

Result<PeriodicResponse> SteadyPeriod(const std::vector<Contact>& pressed,
                                      std::span<const double> displacement,
                                      const PeriodicOptions& options, const Interrupt& interrupt) {
  if (Status s = CheckSamples(displacement); !s.ok()) return s;
  if (options.warmup_periods < 0) {
    return InvalidArgument("warmup_periods",
                           "must be >= 0, got " + std::to_string(options.warmup_periods));
  }
  if (options.max_periods <= options.warmup_periods || options.max_periods > 1000) {
    return InvalidArgument("max_periods", "must be in (warmup_periods, 1000], got " +
                                              std::to_string(options.max_periods));
  }
  for (std::size_t i = 0; i < pressed.size(); ++i) {
    if (Status s = CheckPeriodicContact(pressed[i]); !s.ok())
      return s.WithFieldPrefix(Indexed("contacts", i));
  }
  const std::size_t n = displacement.size();
  PeriodicResponse response;
  response.force.assign(n, 0);
  response.steady = true;
  Rows rows(n);
  for (const Contact& original : pressed) {
    if (!(original.depth() > 0)) continue;
    Contact contact = original;
    Marcher marcher(contact, displacement, interrupt);
    if (Status s = marcher.Start(); !s.ok()) return s;
    for (int p = 0; p < options.warmup_periods; ++p) {
      if (Status s = marcher.Period(nullptr, nullptr); !s.ok()) return s;
    }
    // Recorded until a period ends where it began (its samples then repeat in every later one).
    std::vector<double> force(n);
    Rows own(n);
    double loss = 0;
    bool steady = false;
    int periods = options.warmup_periods;
    while (!steady && periods < options.max_periods) {
      const ContactSnapshot start = contact.Snapshot();
      std::fill(force.begin(), force.end(), 0.0);
      own.Clear();
      loss = 0;
      if (Status s = marcher.Period(&force, options.jacobian ? &own : nullptr, &loss); !s.ok()) {
        return s;
      }
      ++periods;
      const ContactSnapshot end = contact.Snapshot();
      steady = end.z == start.z && end.u == start.u && end.tags == start.tags &&
               end.anchors == start.anchors;
    }
    for (std::size_t j = 0; j < n; ++j) response.force[j] += force[j];
    response.dissipated_energy += loss;
    if (options.jacobian) rows.Append(own);
    response.steady = response.steady && steady;
    response.periods = std::max(response.periods, periods);
  }
  if (options.jacobian) response.jacobian = rows.Compress();
  return response;
}

Result<Contact> PressForPeriod(const ContactConfig& config, double normal_force) {
  if (Status s = RequirePositive("normal_force", normal_force); !s.ok()) return s;
  ContactConfig tracked = config;
  tracked.track_energy = true;
  Result<Contact> created = Contact::Create(tracked);
  if (!created.ok()) return created.status();
  Contact contact = std::move(created).value();
  if (Status s = CheckPeriodicContact(contact); !s.ok()) return s;
  Step press;
  press.normal = NormalControl::kForce;
  press.normal_value = normal_force;
  if (Status s = contact.Apply(press); !s.ok())
    return Status(s.code(), "normal_force", s.message());
  return contact;
}

Status AsSingleContact(const Status& status) {
  // The one contact's fields are the config's.
  const std::string prefix = "contacts[0].";
  return status.field().rfind(prefix, 0) == 0
             ? Status(status.code(), status.field().substr(prefix.size()), status.message())
             : status;
}

Result<PeriodicResponse> SteadyPeriod(const ContactConfig& config, double normal_force,
                                      std::span<const double> displacement,
                                      const PeriodicOptions& options, const Interrupt& interrupt) {
  Result<Contact> contact = PressForPeriod(config, normal_force);
  if (!contact.ok()) return contact.status();
  Result<PeriodicResponse> response = SteadyPeriod(std::vector<Contact>{std::move(contact).value()},
                                                   displacement, options, interrupt);
  if (!response.ok()) return AsSingleContact(response.status());
  return response;
}

}  // namespace mdr
