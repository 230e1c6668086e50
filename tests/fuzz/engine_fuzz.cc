// libFuzzer target for the engine's apply path: bytes -> scene + step sequence; checks that no
// NaN/inf leaves the engine, |F_x| <= mu F_N, dissipation >= 0, that a failed step changes
// nothing, and that every state restores from its snapshot and continues bit-identically.
// Build and run: tests/fuzz/run.sh (clang-14, ASan + UBSan).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

#include "mdr/core/contact.h"

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

// Two snapshots equal field by field, bit for bit.
bool SameSnapshot(const mdr::ContactSnapshot& a, const mdr::ContactSnapshot& b) {
  auto same = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return same(a.depth, b.depth) && same(a.tangential_displacement, b.tangential_displacement) &&
         same(a.dissipated_energy, b.dissipated_energy) &&
         same(a.last_step_dissipation, b.last_step_dissipation) && SameBits(a.z, b.z) &&
         SameBits(a.u, b.u) && a.tags == b.tags && SameBits(a.grid_u, b.grid_u);
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

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  mdr::Result<mdr::ProfilePtr> profile = FuzzProfile(in);
  mdr::Result<mdr::EffectiveMaterial> material =
      mdr::RigidOnHalfSpace(in.Scaled(1e6, 1e12), in.Scaled(0.01, 1.5) - 1.0);
  if (!profile.ok() || !material.ok()) return 0;
  mdr::ContactConfig config;
  config.profile = *profile;
  config.material = *material;
  config.friction = in.Byte() == 0 ? 0.0 : in.Scaled(1e-3, 1e3);
  config.force_path_tolerance = 1e-4;  // keeps curved paths cheap under sanitizers
  config.max_memory_vertices = 4096;
  mdr::Result<mdr::Contact> created = mdr::Contact::Create(config);
  if (!created.ok()) return 0;
  mdr::Contact contact = std::move(created).value();
  const double depth_scale = in.InRange(1e-9, 1e-3);
  mdr::Contact twin = contact;  // restored from the last snapshot
  bool have_twin = false;

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
    const mdr::ContactSnapshot before = contact.Snapshot();
    mdr::StepReport report;
    const mdr::Status status = contact.Apply(step, &report);
    const mdr::ContactSnapshot after = contact.Snapshot();
    if (have_twin) {
      const mdr::Status twin_status = twin.Apply(step);
      Check(twin_status.code() == status.code() && SameSnapshot(twin.Snapshot(), after),
            "a restored contact continues bit-identically");
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
    // Every state the engine reaches restores (ImportSession, the journal) and continues bit
    // for bit: the restored copy takes the next step too and must land on the same snapshot.
    mdr::Result<mdr::Contact> restored = mdr::Contact::Restore(config, after);
    if (!restored.ok()) std::fprintf(stderr, "%s\n", restored.status().ToString().c_str());
    check(restored.ok(), "the state restores from its snapshot");
    check(SameSnapshot(restored->Snapshot(), after), "the restored state is the same");
    twin = std::move(restored).value();
    have_twin = true;
  }
  return 0;
}
