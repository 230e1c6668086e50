// Shared helpers for the tests of the bridge and of the service: the H1 reference scene (steel
// sphere on steel flat), step builders, closed forms and field masks. No gRPC.
#pragma once

#include <google/protobuf/field_mask.pb.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "fixtures/reference_scenes.h"
#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene.pb.h"

namespace mdr::bridge_testing {

// Reference vector H1 (tests/fixtures/reference_scenes.h): steel sphere R = 10 mm on a steel
// flat, mu = 0.3.
constexpr double kYoungsModulus = reference::H1::kYoungsModulus;
constexpr double kPoissonRatio = reference::H1::kPoissonRatio;
constexpr double kRadius = reference::H1::kRadius;
constexpr double kFriction = reference::H1::kFriction;
constexpr double kDepth = reference::H1::kDepth;                          // gives F_N = 100 N
constexpr double kDisplacementAt15N = reference::H1::kDisplacementAt15N;  // gives F_x = 15 N

// Closed forms (docs/physics.md) for two equal elastic bodies.
inline double EffectiveYoungsModulus() {
  return 1 / (2 * (1 - kPoissonRatio * kPoissonRatio) / kYoungsModulus);
}
inline double EffectiveShearModulus() {
  const double shear_modulus = kYoungsModulus / (2 * (1 + kPoissonRatio));
  return 1 / (2 * (2 - kPoissonRatio) / (4 * shear_modulus));
}
inline double Kappa() { return EffectiveYoungsModulus() / EffectiveShearModulus(); }
inline double HertzNormalForce(double depth) {
  return 4.0 / 3.0 * EffectiveYoungsModulus() * std::sqrt(kRadius) * std::pow(depth, 1.5);
}
// Cattaneo-Mindlin at constant depth: ux = mu kappa d [1 - (1-s)^(2/3)], F_x = s mu F_N.
inline double CattaneoMindlinTangentialForce(double depth, double displacement) {
  const double full_slip = kFriction * Kappa() * depth;
  const double s = 1 - std::pow(1 - displacement / full_slip, 1.5);
  return s * kFriction * HertzNormalForce(depth);
}

inline v1::Scene SteelSphereOnSteelFlat() { return reference::H1Scene<v1::Scene>(); }

inline v1::Step DepthStep(double depth) {
  v1::Step step;
  step.set_depth(depth);
  return step;
}
inline v1::Step DisplacementStep(double displacement) {
  v1::Step step;
  step.set_displacement(displacement);
  return step;
}
inline v1::Step DisplacementIncrementStep(double increment) {
  v1::Step step;
  step.set_displacement_increment(increment);
  return step;
}
inline v1::Step TangentialForceStep(double force) {
  v1::Step step;
  step.set_tangential_force(force);
  return step;
}
inline v1::Step NormalForceStep(double force) {
  v1::Step step;
  step.set_normal_force(force);
  return step;
}

// Torsion about the contact's axis (docs/physics.md, "Torsion"): H1 twisted, G_t = G/2 for the
// two equal steels, the Hertz contact radius and the closed forms of the twist.
inline v1::Scene TwistedSteelSphere() {
  v1::Scene scene = SteelSphereOnSteelFlat();
  scene.mutable_torsion();
  return scene;
}
inline double TorsionalModulus() { return kYoungsModulus / (2 * (1 + kPoissonRatio)) / 2; }
inline double HertzContactRadius(double normal_force) {
  return std::cbrt(3 * normal_force * kRadius / (4 * EffectiveYoungsModulus()));
}
// 3 pi mu F_N a / 16 and 16 G_t a^3 / 3.
inline double HertzFullSlipMoment(double normal_force) {
  return 3 * M_PI * kFriction * normal_force * HertzContactRadius(normal_force) / 16;
}
inline double HertzTorsionalStiffness(double normal_force) {
  return 16 * TorsionalModulus() * std::pow(HertzContactRadius(normal_force), 3) / 3;
}
inline v1::Step TwistStep(double angle) {
  v1::Step step;
  step.set_twist(angle);
  return step;
}
inline v1::Step TwistIncrementStep(double increment) {
  v1::Step step;
  step.set_twist_increment(increment);
  return step;
}
inline v1::Step TwistingMomentStep(double moment) {
  v1::Step step;
  step.set_twisting_moment(moment);
  return step;
}
// A reproducible torsional step of the H1 contact between 40 and 160 N: a normal force, a twist
// increment (up to a few stick-slip widths) or a moment target below the smallest full-slip
// moment. A decrease of the load may be refused (FAILED_PRECONDITION: it would break |F| <= 1).
template <typename Random>
v1::Step RandomTorsionStep(Random& random) {
  std::uniform_real_distribution<double> unit(0, 1);
  switch (random() % 3) {
    case 0:
      return NormalForceStep(40 + 120 * unit(random));
    case 1:
      return TwistIncrementStep((2 * unit(random) - 1) * 4e-3);
    default:
      return TwistingMomentStep((2 * unit(random) - 1) * 0.8 * HertzFullSlipMoment(40));
  }
}

inline google::protobuf::FieldMask Mask(const std::vector<std::string>& paths) {
  google::protobuf::FieldMask mask;
  for (const std::string& path : paths) mask.add_paths(path);
  return mask;
}

inline void ExpectRelativelyNear(double actual, double expected, double tolerance) {
  EXPECT_NEAR(actual, expected, tolerance * std::abs(expected));
}

}  // namespace mdr::bridge_testing
