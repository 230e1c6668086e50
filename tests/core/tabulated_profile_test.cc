// Tabulated profiles against the closed forms of the profiles they sample.
#include "mdr/core/tabulated_profile.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <vector>

#include "mdr/core/contact.h"
#include "test_util.h"

namespace mdr {
namespace {

using testing::MakeContact;
using testing::RelNear;

struct Samples {
  std::vector<double> radii, heights;
};

// count samples of f on [0, r_max], uniform in r.
Samples Sample(const std::function<double(double)>& f, double r_max, int count) {
  Samples s;
  for (int i = 0; i < count; ++i) {
    const double r = r_max * i / (count - 1);
    s.radii.push_back(r);
    s.heights.push_back(f(r));
  }
  return s;
}

// Hertz sphere R = 10 mm sampled to r = 5e-4 m, 2.7 times the contact radius of H1.
constexpr double kRadius = 0.01, kSampledTo = 5e-4;
double Sphere(double r) { return r * r / (2 * kRadius); }

// Largest relative errors of a tabulated sphere against Hertz over depths up to H1's.
struct HertzErrors {
  double g = 0, radius = 0, normal_force = 0, tangential_force = 0;
};

HertzErrors MeasureHertz(const ProfilePtr& tabulated) {
  const ProfilePtr exact = *MakeSphere(kRadius);
  const EffectiveMaterial steel = *ElasticPair(210e9, 0.3, 210e9, 0.3);
  HertzErrors e;
  auto track = [](double& worst, double actual, double expected) {
    worst = std::max(worst, std::abs(actual - expected) / std::abs(expected));
  };
  for (double x : {0.1, 0.2, 0.5, 0.8, 0.99})
    track(e.g, tabulated->G(x * kSampledTo), exact->G(x * kSampledTo));
  for (double a : {0.1, 0.2, 0.5, 0.8, 0.99}) {
    const double depth = exact->G(a * kSampledTo);
    track(e.radius, tabulated->RadiusAtDepth(depth), exact->RadiusAtDepth(depth));
    track(e.normal_force, tabulated->NormalForcePerModulus(depth),
          exact->NormalForcePerModulus(depth));
    // Cattaneo-Mindlin at s = 0.1, 0.5, 0.9: F_x = mu [F_N(d) - F_N(d - ux/(mu kappa))].
    for (double s : {0.1, 0.5, 0.9}) {
      Contact c = MakeContact(tabulated, steel, 0.3, false);
      EXPECT_TRUE(c.MoveTo(depth, 0).ok());
      const double ux = c.mu_kappa() * depth * (1 - std::cbrt((1 - s) * (1 - s)));
      EXPECT_TRUE(c.MoveTo(depth, ux).ok());
      Contact hertz = MakeContact(exact, steel, 0.3, false);
      const double expected = testing::CattaneoMindlinPowerLaw(hertz, 2, depth, ux);
      track(e.tangential_force, c.tangential_force(), expected);
    }
  }
  return e;
}

ProfilePtr TabulatedSphere(int count, TabulatedOptions::Interpolation interpolation) {
  const Samples s = Sample(Sphere, kSampledTo, count);
  TabulatedOptions options;
  options.interpolation = interpolation;
  Result<ProfilePtr> p = MakeTabulatedProfile(s.radii, s.heights, options);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return p.ok() ? *p : *MakeSphere(1);
}

void ExpectHertzWithin(int count, TabulatedOptions::Interpolation interpolation, double bound) {
  const ProfilePtr p = TabulatedSphere(count, interpolation);
  const HertzErrors e = MeasureHertz(p);
  EXPECT_LE(e.g, bound);
  EXPECT_LE(e.radius, bound);
  EXPECT_LE(e.normal_force, bound);
  EXPECT_LE(e.tangential_force, bound);
  const auto& tabulated = dynamic_cast<const TabulatedProfile&>(*p);
  EXPECT_LE(tabulated.ToleranceEstimate(), TabulatedOptions{}.tolerance);
}

// Measured largest relative errors of g, a(delta), F_N(delta) and the Cattaneo-Mindlin F_x for
// a = 0.1 ... 0.99 of the sampled radius (Steffen spline): N = 50: 4.0e-4, 2.0e-4, 4.4e-5,
// 5.8e-5; N = 200: 1.1e-7, 5.3e-8, 1.6e-7, 2.1e-7; N = 1000: 1.7e-10, 8.4e-11, 2.5e-10, 3.2e-10.
// Interior samples reproduce the parabola exactly; the error is Steffen's end condition f'(0) =
// first secant slope, whose effect decays fast with the number of samples.
TEST(TabulatedProfileTest, SampledSphereMatchesHertzSteffen50Within1e3) {
  ExpectHertzWithin(50, TabulatedOptions::Interpolation::kSteffen, 1e-3);
}
TEST(TabulatedProfileTest, SampledSphereMatchesHertzSteffen200Within5e7) {
  ExpectHertzWithin(200, TabulatedOptions::Interpolation::kSteffen, 5e-7);
}
TEST(TabulatedProfileTest, SampledSphereMatchesHertzSteffen1000Within1e9) {
  ExpectHertzWithin(1000, TabulatedOptions::Interpolation::kSteffen, 1e-9);
}

// Natural cubic spline (f'' = 0 at both ends instead of 1/R): N = 50: 2.5e-4, 1.3e-4, 1.7e-5,
// 2.2e-5; N = 200: 3.2e-6, 1.6e-6, 5.3e-8, 6.8e-8; N = 1000: 5.6e-11, 2.8e-11, 8.4e-11, 1.1e-10.
TEST(TabulatedProfileTest, SampledSphereMatchesHertzCubicSpline50Within1e3) {
  ExpectHertzWithin(50, TabulatedOptions::Interpolation::kCubicSpline, 1e-3);
}
TEST(TabulatedProfileTest, SampledSphereMatchesHertzCubicSpline200Within1e5) {
  ExpectHertzWithin(200, TabulatedOptions::Interpolation::kCubicSpline, 1e-5);
}
TEST(TabulatedProfileTest, SampledSphereMatchesHertzCubicSpline1000Within5e10) {
  ExpectHertzWithin(1000, TabulatedOptions::Interpolation::kCubicSpline, 5e-10);
}

// Many samples: g far from the samples comes from the far-field series, not a quadrature per
// sample interval; it must stay as accurate as the direct sum was (N = 1000: 1.7e-10).
TEST(TabulatedProfileTest, SampledSphereWith20000SamplesMatchesHertzWithin1e10) {
  const ProfilePtr p = TabulatedSphere(20000, TabulatedOptions::Interpolation::kSteffen);
  EXPECT_LE(MeasureHertz(p).g, 1e-10);
}

TEST(TabulatedProfileTest, ConstructionStopsWhenInterrupted) {
  const Samples s = Sample(Sphere, kSampledTo, 200);
  TabulatedOptions options;
  const std::atomic<bool> cancelled{true};
  options.interrupt = Interrupt(Interrupt::Clock::time_point::max(), &cancelled);
  EXPECT_EQ(MakeTabulatedProfile(s.radii, s.heights, options).status().code(),
            StatusCode::kCancelled);
  options.interrupt = Interrupt(Interrupt::Clock::now(), nullptr);
  EXPECT_EQ(MakeTabulatedProfile(s.radii, s.heights, options).status().code(),
            StatusCode::kDeadlineExceeded);
}

TEST(TabulatedProfileTest, SampleCountAboveTheLimitIsRejected) {
  Samples s = Sample(Sphere, kSampledTo, 4);
  s.radii.resize(kMaxTabulatedSamples + 1);
  s.heights.resize(kMaxTabulatedSamples + 1);
  const Status status = MakeTabulatedProfile(s.radii, s.heights).status();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(status.field(), "radii");
  EXPECT_NE(status.message().find(std::to_string(kMaxTabulatedSamples)), std::string::npos);
}

TEST(TabulatedProfileTest, InverseMomentsAndPressureAreConsistent) {
  const ProfilePtr p = TabulatedSphere(200, TabulatedOptions::Interpolation::kCubicSpline);
  for (double x : {1e-6, 3.3e-5, 2.5e-4, 4.9e-4, 7e-4}) {  // 7e-4: extrapolated
    EXPECT_TRUE(RelNear(p->RadiusAtDepth(p->G(x)), x, 1e-13)) << x;
    EXPECT_TRUE(RelNear(p->Rise(x, 0.999 * x), p->G(x) - p->G(0.999 * x), 1e-9)) << x;
  }
  const double depth = p->G(3e-4);
  const double force = p->NormalForcePerModulus(depth);
  EXPECT_TRUE(RelNear(p->DepthAtNormalForcePerModulus(force), depth, 1e-12));
  // F_N/E* = 2 pi integral_0^a p r dr, by the midpoint rule in t with r = a sin t.
  const double a = p->RadiusAtDepth(depth);
  const int kPoints = 400;
  double sum = 0;
  for (int i = 0; i < kPoints; ++i) {
    const double t = (i + 0.5) * (std::numbers::pi / 2) / kPoints;
    sum += p->PressurePerModulus(a * std::sin(t), depth) * a * a * std::sin(t) * std::cos(t);
  }
  EXPECT_TRUE(RelNear(2 * std::numbers::pi * sum * (std::numbers::pi / 2) / kPoints, force, 1e-5));
}

TEST(TabulatedProfileTest, InvalidSamplesNameFieldAndIndex) {
  const Samples good = Sample(Sphere, kSampledTo, 10);
  auto error_of = [](Samples s) { return MakeTabulatedProfile(s.radii, s.heights).status(); };
  Samples s = good;
  s.radii[3] = s.radii[2];
  Status status = error_of(s);
  EXPECT_EQ(status.field(), "radii[3]");
  EXPECT_NE(status.message().find("must be > radii[2]"), std::string::npos) << status.message();
  s = good;
  s.heights[0] = 1e-9;
  EXPECT_EQ(error_of(s).field(), "heights[0]");
  EXPECT_NE(error_of(s).message().find("f(0) must be 0"), std::string::npos);
  s = good;
  s.radii[0] = 1e-6;
  EXPECT_EQ(error_of(s).field(), "radii[0]");
  s = good;
  s.heights[5] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(error_of(s).field(), "heights[5]");
  s = good;
  s.radii[7] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of(s).field(), "radii[7]");
  s = Sample(Sphere, kSampledTo, 3);
  EXPECT_EQ(error_of(s).field(), "radii");
  s = good;
  s.heights.pop_back();
  EXPECT_EQ(error_of(s).field(), "heights");
  TabulatedOptions options;
  options.tolerance = 0;
  EXPECT_EQ(MakeTabulatedProfile(good.radii, good.heights, options).status().field(), "tolerance");
}

TEST(TabulatedProfileTest, ProfileWhoseEquivalentDecreasesIsRejected) {
  // A bump: f rises to r = 0.6 r_max and falls again, so g(x) has a maximum.
  const Samples s =
      Sample([](double r) { return std::sin(std::numbers::pi * r / 6e-4); }, kSampledTo, 40);
  const Status status = MakeTabulatedProfile(s.radii, s.heights).status();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(status.field(), "heights");
  EXPECT_NE(status.message().find("the equivalent profile g(x) decreases at x = "),
            std::string::npos)
      << status.message();
  EXPECT_NE(status.message().find("the contact would not be a disc"), std::string::npos);
}

TEST(TabulatedProfileTest, FlatEndedIndenterHasAFlatCentre) {
  // f = 0 for r < b, then (r - b)^2/(2R): contact radius b at zero depth, like a punch.
  const double b = 1e-4;
  const Samples s = Sample(
      [&](double r) { return r < b ? 0.0 : (r - b) * (r - b) / (2 * kRadius); }, kSampledTo, 101);
  Result<ProfilePtr> p = MakeTabulatedProfile(s.radii, s.heights);
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ((*p)->RadiusAtDepth(0), b);
  EXPECT_GT((*p)->RadiusAtDepth(1e-9), b);
  Contact c = MakeContact(*p, *RigidOnHalfSpace(1e9, 0.3), 0.3);
  ASSERT_TRUE(c.MoveTo(1e-7, 0).ok());
  ASSERT_TRUE(c.MoveTo(1e-7, 0.5 * c.mu_kappa() * 1e-7).ok());
  EXPECT_GT(c.tangential_force(), 0);
  EXPECT_LT(c.tangential_force(), c.friction_limit());
}

}  // namespace
}  // namespace mdr
