// libFuzzer target for the engine's apply path: bytes -> scene + step sequence; checks that no
// NaN/inf leaves the engine, |F_x| <= mu F_N, dissipation >= 0, that a failed step changes
// nothing, and that every state restores from its snapshot and continues bit-identically.
// Byte 0 with its top bit set drives an Interface instead of one Contact (FuzzInterface: 1-8
// contacts, shared motion or contact list, force targets), with the same checks plus the
// totals as in-order sums over the contacts.
// Byte 0 in [0x70, 0x7f] drives a TorsionalContact (FuzzTorsion): normal and twist steps, a step
// moving both refused, every refusal changing nothing, and every state exact, within the
// full-slip moment and restored from its snapshot unchanged.
// Build and run: tests/fuzz/run.sh (clang-14, ASan + UBSan).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include "fixtures/slip_state_check.h"
#include "mdr/core/contact.h"
#include "mdr/core/interface.h"
#include "mdr/core/tabulated_profile.h"
#include "mdr/core/torsion.h"

namespace {

// Reads values from the fuzzer's bytes; zeros when they run out.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  std::uint8_t Byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  // A value in [lo, hi] on a log scale, or (rarely) a special value to probe validation.
  double Scaled(double lo, double hi) {
    const std::uint8_t selector = Byte();
    if (selector == 255) return std::numeric_limits<double>::quiet_NaN();
    if (selector == 254) return std::numeric_limits<double>::infinity();
    if (selector == 253) return -1;
    if (selector == 252) return 0;
    return InRange(lo, hi);
  }
  // A value in [lo, hi] on a log scale, never special (scales of the harness itself).
  double InRange(double lo, double hi) {
    const double t = (Byte() * 256.0 + Byte()) / 65535.0;
    return lo * std::pow(hi / lo, t);
  }
  double Signed(double scale) { return (Byte() & 1 ? -1 : 1) * Scaled(1e-6 * scale, 4 * scale); }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

bool SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

bool SameBits(const std::vector<mdr::SegmentAnchor>& a, const std::vector<mdr::SegmentAnchor>& b) {
  auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].bound != b[i].bound || !same(a[i].depth, b[i].depth) ||
        !same(a[i].tangential_displacement, b[i].tangential_displacement)) {
      return false;
    }
  }
  return true;
}

// Two snapshots equal field by field, bit for bit.
bool SameSnapshot(const mdr::ContactSnapshot& a, const mdr::ContactSnapshot& b) {
  auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return same(a.depth, b.depth) && same(a.tangential_displacement, b.tangential_displacement) &&
         same(a.dissipated_energy, b.dissipated_energy) &&
         same(a.last_step_dissipation, b.last_step_dissipation) && SameBits(a.z, b.z) &&
         SameBits(a.u, b.u) && a.tags == b.tags && SameBits(a.anchors, b.anchors) &&
         SameBits(a.grid_u, b.grid_u);
}

void Check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "invariant violated: %s\n", what);
  std::abort();
}

mdr::Result<mdr::ProfilePtr> FuzzProfile(ByteReader& in) {
  switch (in.Byte() % 4) {
    case 0:
      return mdr::MakeSphere(in.Scaled(1e-4, 1));
    case 1:
      return mdr::MakeCone(in.Scaled(1e-3, 1.5));
    case 2:
      return mdr::MakePowerLaw(in.Scaled(1e-3, 1e3), in.Scaled(0.3, 10));
    default:
      return mdr::MakeFlatPunch(in.Scaled(1e-5, 1e-1));
  }
}

void FuzzContact(ByteReader& in) {
  mdr::Result<mdr::ProfilePtr> profile = FuzzProfile(in);
  mdr::Result<mdr::EffectiveMaterial> material =
      mdr::RigidOnHalfSpace(in.Scaled(1e6, 1e12), in.Scaled(0.01, 1.5) - 1.0);
  if (!profile.ok() || !material.ok()) return;
  mdr::ContactConfig config;
  config.profile = *profile;
  config.material = *material;
  config.friction = in.Byte() == 0 ? 0.0 : in.Scaled(1e-3, 1e3);
  config.force_path_tolerance = 1e-4;  // keeps curved paths cheap under sanitizers
  config.max_memory_vertices = 4096;
  mdr::Result<mdr::Contact> created = mdr::Contact::Create(config);
  if (!created.ok()) return;
  mdr::Contact contact = std::move(created).value();
  const double depth_scale = in.InRange(1e-9, 1e-3);
  mdr::Contact twin = contact;  // restored from the last snapshot
  bool have_twin = false;
  std::vector<double> visited = {0.0};  // displacements, for exact returns to turning points

  for (int i = 0; i < 64 && !in.empty(); ++i) {
    mdr::Step step;
    const std::uint8_t kind = in.Byte();
    step.normal = static_cast<mdr::NormalControl>(kind % 3);
    step.tangential = static_cast<mdr::TangentialControl>((kind / 3) % 3);
    const double slip = contact.mu_kappa() * depth_scale + 1e-300;
    step.normal_value = step.normal == mdr::NormalControl::kForce
                            ? contact.NormalForceAtDepth(depth_scale) * in.Scaled(1e-3, 3)
                            : in.Signed(depth_scale);
    step.tangential_value = step.tangential == mdr::TangentialControl::kForce
                                ? in.Signed(contact.friction_limit() + 1e-300)
                                : in.Signed(slip);
    if (kind >= 216) {  // back to a visited displacement or its mirror image, exactly
      step.tangential = mdr::TangentialControl::kDisplacement;
      step.tangential_value = (kind & 1 ? -1 : 1) * visited[in.Byte() % visited.size()];
    }
    const mdr::ContactSnapshot before = contact.Snapshot();
    const mdr::Contact previous = contact;
    mdr::StepReport report;
    const mdr::Status status = contact.Apply(step, &report);
    const mdr::ContactSnapshot after = contact.Snapshot();
    if (have_twin) {
      // The twin leaves a failed step's contact to be dropped (a batch on a copy does): saving
      // the undo copy must change nothing else.
      const mdr::Status twin_status =
          twin.Apply(step, nullptr, {}, mdr::Contact::OnFailure::kDiscarded);
      Check(twin_status.ToString() == status.ToString() &&
                (!status.ok() || SameSnapshot(twin.Snapshot(), after)),
            "a restored contact continues bit-identically");
      if (!status.ok()) twin = mdr::Contact::Restore(config, before).value();  // dropped
    }
    if (!status.ok()) {
      Check(!status.field().empty() && !status.message().empty(), "error names a field");
      Check(after.z == before.z && after.u == before.u && after.depth == before.depth &&
                after.tangential_displacement == before.tangential_displacement &&
                after.dissipated_energy == before.dissipated_energy,
            "a failed step leaves the contact unchanged");
      continue;
    }
    const double fn = contact.normal_force(), fx = contact.tangential_force();
    auto check = [&](bool ok, const char* what) {
      if (ok) return;
      std::fprintf(stderr,
                   "%s mu=%g E*=%g G*=%g step %d: normal %d %g tangential %d %g\n"
                   "before depth %g ux %g; after depth %g ux %g F_N %g F_x %g; W %g total %g\n",
                   config.profile->Describe().c_str(), config.friction, config.material.e_star,
                   config.material.g_star, i, static_cast<int>(step.normal), step.normal_value,
                   static_cast<int>(step.tangential), step.tangential_value, before.depth,
                   before.tangential_displacement, after.depth, after.tangential_displacement, fn,
                   fx, report.dissipated, contact.dissipated_energy());
      Check(false, what);
    };
    check(std::isfinite(fn) && std::isfinite(fx), "forces are finite");
    check(std::isfinite(contact.dissipated_energy()), "energy is finite");
    check(std::abs(fx) <= contact.friction_limit() * (1 + 1e-9) + 1e-300, "|F_x| <= mu F_N");
    check(report.dissipated >= -1e-9 * (contact.friction_limit() * slip + 1e-300),
          "dissipation >= 0");
    check(std::isfinite(report.path_error) && report.path_error >= 0, "path error is finite");
    visited.push_back(contact.tangential_displacement());
    const std::string slip_state =
        mdr::testing::SlipStateViolation(previous, contact, report.substeps == 1);
    if (!slip_state.empty()) std::fprintf(stderr, "%s\n", slip_state.c_str());
    check(slip_state.empty(), "slip state, weights and stiffness agree with the memory");
    // Every state the engine reaches restores (ImportSession, the journal) and continues bit
    // for bit: the restored copy takes the next step too and must land on the same snapshot.
    mdr::Result<mdr::Contact> restored = mdr::Contact::Restore(config, after);
    if (!restored.ok()) std::fprintf(stderr, "%s\n", restored.status().ToString().c_str());
    check(restored.ok(), "the state restores from its snapshot");
    check(SameSnapshot(restored->Snapshot(), after), "the restored state is the same");
    twin = std::move(restored).value();
    have_twin = true;
  }
}

// ---------------------------------------------------------------- interfaces

bool SameInterfaceState(const mdr::InterfaceSnapshot& a, const mdr::InterfaceSnapshot& b) {
  if (std::memcmp(&a.approach, &b.approach, sizeof a.approach) != 0 ||
      std::memcmp(&a.tangential_displacement, &b.tangential_displacement,
                  sizeof a.tangential_displacement) != 0 ||
      a.contacts.size() != b.contacts.size()) {
    return false;
  }
  for (std::size_t i = 0; i < a.contacts.size(); ++i) {
    if (!SameSnapshot(a.contacts[i], b.contacts[i])) return false;
  }
  return true;
}

// An interface of 1-8 contacts from `header` and the bytes: each contact with its own profile,
// material and friction or all with the first's (one shared ProfilePtr), now and then a
// grid-method contact (which fails when a step outgrows its grid, so steps go through the step
// buffer), shared-motion heights around the depth scale (or none).
bool FuzzInterfaceConfig(ByteReader& in, std::uint8_t header, double depth_scale,
                         mdr::InterfaceConfig* config) {
  config->kind =
      header & 0x40 ? mdr::InterfaceKind::kContactList : mdr::InterfaceKind::kSharedMotion;
  const int count = 1 + (header & 7);
  const bool one_scene = header & 0x20;
  for (int i = 0; i < count; ++i) {
    mdr::ContactConfig contact;
    if (i > 0 && one_scene) {
      contact = config->contacts[0];
      contact.method = mdr::Method::kExact;
    } else {
      mdr::Result<mdr::ProfilePtr> profile = FuzzProfile(in);
      mdr::Result<mdr::EffectiveMaterial> material =
          mdr::RigidOnHalfSpace(in.Scaled(1e6, 1e12), in.Scaled(0.01, 1.5) - 1.0);
      if (!profile.ok() || !material.ok()) return false;
      contact.profile = *profile;
      contact.material = *material;
      contact.friction = in.Byte() == 0 ? 0.0 : in.Scaled(1e-3, 1e3);
      contact.force_path_tolerance = 1e-4;
      contact.max_memory_vertices = 4096;
    }
    if (in.Byte() % 8 == 7) {
      contact.method = mdr::Method::kGrid;
      contact.grid_size = 8 + in.Byte() % 57;
      contact.grid_max_radius = contact.profile->RadiusAtDepth(depth_scale * in.InRange(0.5, 8));
    }
    config->contacts.push_back(contact);
  }
  if (config->kind == mdr::InterfaceKind::kSharedMotion && (header & 0x10) == 0) {
    for (int i = 0; i < count; ++i) config->heights.push_back(in.Signed(depth_scale));
  }
  return true;
}

// One shared-motion step, scaled like FuzzContact's: depths and increments around depth_scale,
// total force targets around the force at depth_scale, tangential targets around the friction
// limit. A force target holds the other channel still, except one time in four (then it is
// refused: interfaces do not follow curved paths).
mdr::Step SharedMotionStep(ByteReader& in, const mdr::Interface& interface, double depth_scale,
                           double force_scale, double slip, double friction_limit) {
  mdr::Step step;
  const std::uint8_t kind = in.Byte();
  step.normal = static_cast<mdr::NormalControl>(kind % 3);
  step.tangential = static_cast<mdr::TangentialControl>((kind / 3) % 3);
  step.normal_value = step.normal == mdr::NormalControl::kForce ? force_scale * in.Scaled(1e-3, 3)
                      : step.normal == mdr::NormalControl::kDepth
                          ? interface.approach() + in.Signed(depth_scale)
                          : in.Signed(depth_scale);
  step.tangential_value = step.tangential == mdr::TangentialControl::kForce
                              ? in.Signed(friction_limit + 1e-300)
                              : in.Signed(slip);
  const bool force_target = step.normal == mdr::NormalControl::kForce ||
                            step.tangential == mdr::TangentialControl::kForce;
  if (!force_target || kind >= 192) return step;
  if (step.normal != mdr::NormalControl::kForce) {
    step.normal_value = step.normal == mdr::NormalControl::kDepth ? interface.approach() : 0;
  }
  if (step.tangential != mdr::TangentialControl::kForce) {
    step.tangential_value = step.tangential == mdr::TangentialControl::kDisplacement
                                ? interface.tangential_displacement()
                                : 0;
  }
  return step;
}

// One contact-list step: one control per channel, one value per contact on each contact's own
// scale; now and then one value short (refused).
mdr::ContactListStep ContactListStep(ByteReader& in, const mdr::Interface& list, double depth_scale,
                                     std::vector<double>* normal_values,
                                     std::vector<double>* tangential_values) {
  mdr::ContactListStep step;
  const std::uint8_t kind = in.Byte();
  step.normal = static_cast<mdr::NormalControl>(kind % 3);
  step.tangential = static_cast<mdr::TangentialControl>((kind / 3) % 3);
  normal_values->clear();
  tangential_values->clear();
  for (std::size_t i = 0; i < list.size(); ++i) {
    const mdr::Contact& c = list.contact(i);
    normal_values->push_back(step.normal == mdr::NormalControl::kForce
                                 ? c.NormalForceAtDepth(depth_scale) * in.Scaled(1e-3, 3)
                                 : in.Signed(depth_scale));
    tangential_values->push_back(step.tangential == mdr::TangentialControl::kForce
                                     ? in.Signed(c.friction_limit() + 1e-300)
                                     : in.Signed(c.mu_kappa() * depth_scale + 1e-300));
  }
  if (kind >= 240) normal_values->pop_back();
  step.normal_values = *normal_values;
  step.tangential_values = *tangential_values;
  return step;
}

// The invariants of every accepted state: finite forces and |F_x| <= mu F_N per contact, a
// shared motion's contacts exactly at (delta - h_i, ux), the totals the in-order sums over the
// contacts bit for bit, the slip counts and histogram consistent, and a force target's residual
// the one the totals show.
void CheckInterfaceState(const mdr::Interface& interface, int bins, const mdr::Step* step,
                         const mdr::InterfaceStepReport& report) {
  const bool shared = interface.kind() == mdr::InterfaceKind::kSharedMotion;
  auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  mdr::InterfaceTotals sums;
  std::size_t positive_depths = 0;
  for (std::size_t i = 0; i < interface.size(); ++i) {
    const mdr::Contact& c = interface.contact(i);
    Check(std::isfinite(c.normal_force()) && std::isfinite(c.tangential_force()) &&
              std::isfinite(c.dissipated_energy()),
          "interface: every contact's forces and energy are finite");
    // A grid contact's F_x is a sum over its springs, within O(h^2) of the exact bound.
    if (c.config().method == mdr::Method::kExact &&
        !(std::abs(c.tangential_force()) <= c.friction_limit() * (1 + 1e-9) + 1e-300)) {
      std::fprintf(stderr, "contact %zu: %s mu=%g E*=%g G*=%g depth %g ux %g F_N %g F_x %g\n", i,
                   c.config().profile->Describe().c_str(), c.config().friction,
                   c.config().material.e_star, c.config().material.g_star, c.depth(),
                   c.tangential_displacement(), c.normal_force(), c.tangential_force());
      Check(false, "interface: |F_x| <= mu F_N for every exact contact");
    }
    if (shared) {
      Check(same(c.depth(), interface.approach() - interface.height(i)) &&
                same(c.tangential_displacement(), interface.tangential_displacement()),
            "shared motion: contact i is at (delta - h_i, ux) exactly");
    }
    sums.normal_force += c.normal_force();
    sums.tangential_force += c.tangential_force();
    sums.dissipated_energy += c.dissipated_energy();
    sums.last_step_dissipation += c.last_step_dissipation();
    sums.friction_limit += c.friction_limit();
    positive_depths += c.depth() > 0;
  }
  mdr::Result<mdr::InterfaceTotals> totals = interface.Totals();
  Check(totals.ok(), "interface: the totals are computed");
  Check(same(totals->normal_force, sums.normal_force) &&
            same(totals->tangential_force, sums.tangential_force) &&
            same(totals->dissipated_energy, sums.dissipated_energy) &&
            same(totals->last_step_dissipation, sums.last_step_dissipation) &&
            same(totals->friction_limit, sums.friction_limit),
        "interface: the totals are the in-order sums over the contacts");
  Check(std::isfinite(totals->normal_stiffness) &&
            std::isfinite(totals->tangential_stiffness.positive) &&
            std::isfinite(totals->tangential_stiffness.negative),
        "interface: the stiffnesses are finite");
  Check(totals->in_contact <= positive_depths &&
            totals->sticking + totals->partial_slip + totals->gross_slip == totals->in_contact,
        "interface: every contact in contact sticks, slips partly or slides");
  mdr::Result<std::vector<std::size_t>> histogram = interface.SlipHistogram(bins);
  Check(histogram.ok() && histogram->size() == static_cast<std::size_t>(bins),
        "interface: the slip histogram has its bins");
  std::size_t binned = 0;
  for (std::size_t n : *histogram) binned += n;
  Check(binned == totals->in_contact, "interface: the histogram bins every contact in contact");
  if (step == nullptr) return;
  // With both targets (the normal one held at the current approach) the report holds the
  // tangential residual, the one solved last.
  if (step->normal == mdr::NormalControl::kForce &&
      step->tangential != mdr::TangentialControl::kForce) {
    Check(report.force_residual == std::abs(totals->normal_force - step->normal_value),
          "shared motion: the normal force residual is the totals'");
    // The stated tolerance, or the approach's resolution: the force between adjacent doubles.
    const double delta = interface.approach();
    double up = 0, down = 0;
    for (std::size_t i = 0; i < interface.size(); ++i) {
      const mdr::Contact& c = interface.contact(i);
      up += c.NormalForceAtDepth(std::nextafter(delta, INFINITY) - interface.height(i));
      down += c.NormalForceAtDepth(std::nextafter(delta, -INFINITY) - interface.height(i));
    }
    Check(report.force_residual <= mdr::kInterfaceForceTolerance * step->normal_value + (up - down),
          "shared motion: a total normal force target is reached to its tolerance");
  }
  if (step->tangential == mdr::TangentialControl::kForce) {
    Check(report.force_residual == std::abs(totals->tangential_force - step->tangential_value),
          "shared motion: the tangential force residual is the totals'");
  }
}

void FuzzInterface(ByteReader& in) {
  const std::uint8_t header = in.Byte();
  const double depth_scale = in.InRange(1e-9, 1e-3);
  mdr::InterfaceConfig config;
  if (!FuzzInterfaceConfig(in, header, depth_scale, &config)) return;
  mdr::Result<mdr::Interface> created = mdr::Interface::Create(config);
  if (!created.ok()) {
    Check(!created.status().field().empty(), "interface: a refused config names its field");
    return;
  }
  mdr::Interface interface = std::move(created).value();
  CheckInterfaceState(interface, 1, nullptr, {});
  double force_scale = 0, max_mu_kappa = 0;
  for (std::size_t i = 0; i < interface.size(); ++i) {
    force_scale += interface.contact(i).NormalForceAtDepth(depth_scale);
    max_mu_kappa = std::max(max_mu_kappa, interface.contact(i).mu_kappa());
  }
  const double slip = max_mu_kappa * depth_scale + 1e-300;
  std::optional<mdr::Interface> twin;  // restored from the last snapshot
  std::vector<double> normal_values, tangential_values;

  for (int i = 0; i < 32 && !in.empty(); ++i) {
    const bool shared = config.kind == mdr::InterfaceKind::kSharedMotion;
    mdr::Step step;
    mdr::ContactListStep list_step;
    if (shared) {
      double friction_limit = 0;
      for (std::size_t k = 0; k < interface.size(); ++k) {
        friction_limit += interface.contact(k).friction_limit();
      }
      step = SharedMotionStep(in, interface, depth_scale, force_scale, slip, friction_limit);
    } else {
      list_step = ContactListStep(in, interface, depth_scale, &normal_values, &tangential_values);
    }
    auto apply = [&](mdr::Interface& target, mdr::InterfaceStepReport* report) {
      return shared ? target.Apply(step, report) : target.ApplyEach(list_step);
    };
    const mdr::InterfaceSnapshot before = interface.Snapshot();
    const mdr::Interface previous = interface;
    mdr::InterfaceStepReport report;
    const mdr::Status status = apply(interface, &report);
    const mdr::InterfaceSnapshot after = interface.Snapshot();
    Check(interface.vertex_count() == interface.CountVertices().now,
          "the interface's kept vertex count is its contacts' after every step");
    if (twin) {
      const mdr::Status twin_status = apply(*twin, nullptr);
      Check(twin_status.code() == status.code() && SameInterfaceState(twin->Snapshot(), after),
            "a restored interface continues bit-identically");
    }
    if (!status.ok()) {
      Check(!status.field().empty() && !status.message().empty(), "interface: error names a field");
      Check(SameInterfaceState(after, before), "a failed step leaves the interface unchanged");
      continue;
    }
    CheckInterfaceState(interface, 1 + in.Byte() % 16, shared ? &step : nullptr, report);
    // A shared motion moves each contact by one linear step; a contact list may take a curved
    // force path per contact when it sets a force target.
    const bool straight = shared || (list_step.normal != mdr::NormalControl::kForce &&
                                     list_step.tangential != mdr::TangentialControl::kForce);
    for (std::size_t k = 0; k < interface.size(); ++k) {
      const std::string slip_state =
          mdr::testing::SlipStateViolation(previous.contact(k), interface.contact(k), straight);
      if (!slip_state.empty()) std::fprintf(stderr, "contact %zu: %s\n", k, slip_state.c_str());
      Check(slip_state.empty(), "interface: each contact's slip state agrees with its memory");
    }
    // Every accepted state restores (ImportSession, the journal) and continues bit for bit.
    mdr::Result<mdr::Interface> restored = mdr::Interface::Restore(config, after);
    if (!restored.ok()) std::fprintf(stderr, "%s\n", restored.status().ToString().c_str());
    Check(restored.ok(), "the interface restores from its snapshot");
    Check(SameInterfaceState(restored->Snapshot(), after), "the restored interface is the same");
    Check(restored->vertex_count() == interface.vertex_count(),
          "the restored interface counts the same vertices");
    twin = std::move(restored).value();
  }
}

}  // namespace

// A tabulated profile: 4 to 11 samples of C r^n uniform on [0, extent] (its grid, and so the
// cost of every bound evaluation, grows with the samples).
mdr::Result<mdr::ProfilePtr> FuzzSampledPowerLaw(ByteReader& in) {
  const double coefficient = in.Scaled(1e-3, 1e3), exponent = in.Scaled(1, 4);
  const double extent = in.Scaled(1e-5, 1e-2);
  const int count = 4 + in.Byte() % 8;
  std::vector<double> radii, heights;
  for (int i = 0; i < count; ++i) {
    radii.push_back(extent * i / (count - 1));
    heights.push_back(coefficient * std::pow(radii.back(), exponent));
  }
  return mdr::MakeTabulatedProfile(radii, heights);
}

void FuzzTorsion(ByteReader& in) {
  // Spheres mostly (closed form); cones, power laws and tabulated profiles (a sampled power law),
  // whose bound is a quadrature, rarely and for fewer steps, so that the run stays short under
  // the sanitizers.
  const std::uint8_t choice = in.Byte();
  mdr::Result<mdr::ProfilePtr> profile = choice % 8 != 0    ? mdr::MakeSphere(in.Scaled(1e-4, 1))
                                         : choice % 32 == 8 ? FuzzSampledPowerLaw(in)
                                                            : FuzzProfile(in);
  const double shear_modulus = in.Scaled(1e6, 1e12);
  mdr::Result<mdr::EffectiveMaterial> material =
      mdr::RigidOnHalfSpace(shear_modulus, in.Scaled(0.01, 1.5) - 1.0);
  if (!profile.ok() || !material.ok()) return;
  const double friction = in.Scaled(1e-3, 1e3);
  mdr::Result<mdr::TorsionalContact> created =
      mdr::TorsionalContact::Create(*profile, friction, material->e_star, shear_modulus);
  if (!created.ok()) {
    Check(!created.status().field().empty(), "a refused torsional contact names its field");
    return;
  }
  mdr::TorsionalContact contact = std::move(created).value();
  const double depth_scale = in.InRange(1e-9, 1e-3);
  const int steps = choice % 8 != 0 ? 32 : choice % 32 == 8 ? 3 : 6;
  for (int i = 0; i < steps && !in.empty(); ++i) {
    const mdr::TorsionalMemory& memory = contact.memory();
    const double slip_moment = memory.FullSlipMoment();
    const double twist_scale = slip_moment / memory.Stiffness(+1) + 1e-300;
    mdr::TorsionStep step;
    const std::uint8_t kind = in.Byte() % 8;
    if (kind < 3 || kind == 7) {
      step.normal = static_cast<mdr::NormalControl>(kind % 3);
      step.normal_value = step.normal == mdr::NormalControl::kForce
                              ? contact.normal_force() * in.Scaled(1e-2, 3) +
                                    material->e_star *
                                        (**profile).NormalForcePerModulus(depth_scale) *
                                        in.Scaled(1e-3, 1)
                              : in.Signed(depth_scale);
    }
    if (kind >= 3) {
      step.twist = static_cast<mdr::TwistControl>(kind % 3);
      step.twist_value = step.twist == mdr::TwistControl::kMoment ? in.Signed(slip_moment + 1e-300)
                                                                  : in.Signed(twist_scale);
    }
    const mdr::TorsionSnapshot before = memory.Snapshot();
    const double depth = contact.depth();
    const mdr::Status status = contact.Apply(step);
    if (!status.ok()) {
      Check(!status.field().empty(), "a refused torsion step names its field");
      Check(memory.Snapshot() == before && mdr::SameBits(contact.depth(), depth),
            "a refused torsion step changes nothing");
      continue;
    }
    Check(!(step.normal && step.twist), "a step moving both channels is refused");
    Check(memory.IsExact(), "an accepted torsional state is exact (|F| <= 1)");
    const double moment = memory.Moment();
    // Within round-off for the sphere's closed form; a quadrature bound's moment and full-slip
    // moment are two quadratures of one integral (piece by piece, and single), which agree to
    // 1e-8 (tests/core/torsion_test.cc: a coarse tabulated profile, 6e-9).
    const double agreement = choice % 8 != 0 ? 1e-12 : 1e-7;
    Check(std::isfinite(moment) && std::abs(moment) <= memory.FullSlipMoment() * (1 + agreement),
          "the moment is finite and within the full-slip moment");
    Check(std::isfinite(memory.last_step_dissipation()) && memory.last_step_dissipation() >= 0,
          "a torsion step's dissipation is finite and >= 0");
    // The contact restores as a session's snapshot carries it: its depth and its memory.
    mdr::Result<mdr::TorsionalContact> restored = mdr::TorsionalContact::Restore(
        *profile, friction, material->e_star, shear_modulus, contact.depth(), memory.Snapshot());
    if (!restored.ok()) {
      std::fprintf(stderr, "restore refused: %s\n", restored.status().ToString().c_str());
    }
    Check(restored.ok() && restored->memory().Snapshot() == memory.Snapshot() &&
              mdr::SameBits(restored->depth(), contact.depth()),
          "a torsional state restores from its snapshot unchanged");
  }
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  if (size > 0 && (data[0] & 0x80) != 0) {
    FuzzInterface(in);
  } else if (size > 0 && (data[0] & 0xf0) == 0x70) {
    in.Byte();
    FuzzTorsion(in);
  } else {
    FuzzContact(in);
  }
  return 0;
}
