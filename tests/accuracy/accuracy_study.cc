// Accuracy against run time: runs canonical scenes with every method and resolution and writes
// one CSV row per run (scene, method, resolution, max F_x error over the path relative to mu F_N,
// traction error, time per increment and per forces query). tests/accuracy/run.sh turns the CSV
// into docs/report/accuracy.md and the error-vs-time plots.
//   mdr_accuracy_study [--quick] > accuracy.csv
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "mdr/core/contact.h"
#include "mdr/core/tabulated_profile.h"
#include "mdr/core/traction.h"

namespace mdr {
namespace {

using Clock = std::chrono::steady_clock;

// A displacement-controlled path with its closed-form F_x at every point.
struct PathPoint {
  double depth, ux, reference_fx;
};

struct Scene {
  std::string name;
  ProfilePtr profile;
  double exponent;  // power law n of the analytic profile (0: flat punch)
  EffectiveMaterial material;
  double mu;
  std::vector<PathPoint> path;
};

struct Method {
  std::string name, rule;
  double resolution;  // grid springs, tabulated samples, force-path tolerance, or 0
  ContactConfig config;
};

// Cattaneo-Mindlin: mu [F_N(d) - F_N(d - ux/(mu kappa))], without cancellation for power laws.
double CattaneoMindlin(const Scene& s, double depth, double ux) {
  const double m = s.mu * s.material.kappa();
  const double fn = s.material.e_star * s.profile->NormalForcePerModulus(depth);
  if (s.exponent == 0)
    return std::min(2 * s.material.g_star * s.profile->RadiusAtDepth(0) * ux, s.mu * fn);
  if (ux >= m * depth) return s.mu * fn;
  const double p = (s.exponent + 1) / s.exponent;
  return -s.mu * fn * std::expm1(p * std::log1p(-ux / (m * depth)));
}

Scene MakeScene(std::string name, ProfilePtr profile, double exponent) {
  return {
      std::move(name), std::move(profile), exponent, *ElasticPair(210e9, 0.3, 210e9, 0.3), 0.3, {}};
}

// Normal load to depth d, then a Mindlin-Deresiewicz loop of amplitude 0.6 of the slip length.
Scene FrettingLoop(std::string name, ProfilePtr profile, double exponent, double d, int steps) {
  Scene s = MakeScene(std::move(name), std::move(profile), exponent);
  const double a = 0.6 * s.mu * s.material.kappa() * d;
  s.path.push_back({d, 0, 0});
  for (int i = 1; i <= steps; ++i)
    s.path.push_back({d, a * i / steps, CattaneoMindlin(s, d, a * i / steps)});
  const double top = CattaneoMindlin(s, d, a);
  for (int i = 1; i <= 2 * steps; ++i) {
    const double ux = a - 2 * a * i / steps / 2;
    s.path.push_back({d, ux, top - 2 * CattaneoMindlin(s, d, (a - ux) / 2)});
  }
  for (int i = 1; i <= 2 * steps; ++i) {
    const double ux = -a + 2 * a * i / steps / 2;
    s.path.push_back({d, ux, -top + 2 * CattaneoMindlin(s, d, (ux + a) / 2)});
  }
  return s;
}

// delta and ux rise together, ux = 0.7 mu kappa delta: complete stick, F_x = 0.7 mu F_N.
Scene ObliqueLoading(double d, int steps) {
  Scene s = MakeScene("oblique_hertz", *MakeSphere(0.01), 2);
  const double r = 0.7 * s.mu * s.material.kappa();
  for (int i = 1; i <= steps; ++i) {
    const double depth = d * i / steps;
    s.path.push_back({depth, r * depth,
                      0.7 * s.mu * s.material.e_star * s.profile->NormalForcePerModulus(depth)});
  }
  return s;
}

// Tangential load to 0.4 of the slip length, then normal unloading to half the depth at fixed ux.
Scene NormalUnloading(double d, int steps) {
  Scene s = MakeScene("normal_unloading_hertz", *MakeSphere(0.01), 2);
  const double ux = 0.4 * s.mu * s.material.kappa() * d;
  s.path.push_back({d, 0, 0});
  s.path.push_back({d, ux, CattaneoMindlin(s, d, ux)});
  for (int i = 1; i <= steps; ++i) {
    const double depth = d * (1 - 0.5 * i / steps);
    s.path.push_back({depth, ux, CattaneoMindlin(s, depth, ux)});
  }
  return s;
}

ContactConfig BaseConfig(const Scene& s) {
  ContactConfig c;
  c.profile = s.profile;
  c.material = s.material;
  c.friction = s.mu;
  c.track_energy = false;
  return c;
}

double MaxDepth(const Scene& s) {
  double d = 0;
  for (const PathPoint& p : s.path) d = std::max(d, p.depth);
  return d;
}

std::vector<Method> Methods(const Scene& s, bool quick) {
  std::vector<Method> methods{{"exact", "exact", 0, BaseConfig(s)}};
  const std::vector<std::size_t> sizes =
      quick ? std::vector<std::size_t>{64, 1024}
            : std::vector<std::size_t>{64, 256, 1024, 4096, 16384, 65536};
  for (GridStepRule rule : {GridStepRule::kExact, GridStepRule::kNaive}) {
    for (std::size_t n : sizes) {
      ContactConfig c = BaseConfig(s);
      c.method = mdr::Method::kGrid;
      c.grid_size = n;
      c.grid_max_radius = s.profile->RadiusAtDepth(MaxDepth(s));
      c.grid_step_rule = rule;
      methods.push_back(
          {"grid", rule == GridStepRule::kExact ? "exact" : "naive", static_cast<double>(n), c});
    }
  }
  return methods;
}

struct Outcome {
  double max_error = 0;  // max |F_x - reference| / (mu F_N) over the path
  double ns_per_increment = 0;
  double us_per_query = 0;
  Contact final_state;
};

// Runs the path once for the error, then repeats it until ~0.2 s have passed for the timing.
Outcome Run(const Scene& s, const ContactConfig& config) {
  auto run_once = [&](double* max_error) {
    Contact c = std::move(Contact::Create(config)).value();
    for (const PathPoint& p : s.path) {
      if (!c.MoveTo(p.depth, p.ux).ok()) std::abort();
      if (max_error) {
        const double limit = s.mu * c.normal_force();
        *max_error = std::max(
            *max_error, std::abs(c.tangential_force() - p.reference_fx) / (limit > 0 ? limit : 1));
      }
    }
    return c;
  };
  Outcome out{0, 0, 0, run_once(nullptr)};
  out.final_state = run_once(&out.max_error);
  int repeats = 0;
  const auto start = Clock::now();
  while (Clock::now() - start < std::chrono::milliseconds(200) || repeats < 2) {
    run_once(nullptr);
    ++repeats;
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  out.ns_per_increment = 1e9 * seconds / (repeats * static_cast<double>(s.path.size()));
  int queries = 0;
  double sink = 0;
  const auto query_start = Clock::now();
  while (Clock::now() - query_start < std::chrono::milliseconds(50) || queries < 10) {
    sink += out.final_state.tangential_force() + out.final_state.normal_force();
    ++queries;
  }
  out.us_per_query =
      1e6 * std::chrono::duration<double>(Clock::now() - query_start).count() / queries;
  if (sink == 12345.678) std::puts("");  // keeps the loop from being optimised away
  return out;
}

// Max |tau - mu[p(r;a) - p(r;c)]| / max|tau| at 64 radii after Cattaneo-Mindlin loading
// (the fretting loop's first branch), by the chosen traction route of the exact memory.
double TractionError(const Scene& s, const Contact& loaded, double depth, double ux) {
  const double m = s.mu * s.material.kappa();
  const double stick_depth = depth - ux / m;
  std::vector<double> radii;
  const double a = s.profile->RadiusAtDepth(depth);
  for (int i = 0; i < 64; ++i) radii.push_back(a * (i + 0.5) / 64);
  Result<std::vector<RadialValue>> tau = ComputeTangentialTraction(loaded, radii);
  if (!tau.ok()) return NAN;
  double max_error = 0, peak = 0;
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const double expected = s.mu * s.material.e_star *
                            (s.profile->PressurePerModulus(radii[i], depth) -
                             s.profile->PressurePerModulus(radii[i], stick_depth));
    if (!std::isfinite(expected)) continue;
    max_error = std::max(max_error, std::abs((*tau)[i].value - expected));
    peak = std::max(peak, std::abs(expected));
  }
  return max_error / peak;
}

// A CSV cell in %.3e, or empty for NaN (not applicable).
std::string Cell(double value) {
  if (std::isnan(value)) return "";
  char text[32];
  std::snprintf(text, sizeof text, "%.3e", value);
  return text;
}

void PrintRow(const std::string& scene, const Method& m, std::size_t increments, const Outcome& o,
              double traction_error, double error_estimate = NAN) {
  std::printf("%s,%s,%s,%g,%zu,%.3e,%s,%s,%.1f,%.3f\n", scene.c_str(), m.name.c_str(),
              m.rule.c_str(), m.resolution, increments, o.max_error, Cell(traction_error).c_str(),
              Cell(error_estimate).c_str(), o.ns_per_increment, o.us_per_query);
  std::fflush(stdout);
}

// A force-controlled step whose path is curved in (delta, ux): F_N 100 -> 150 N while ux goes
// from the Cattaneo-Mindlin state at 15 N to 3e-7 m. Reference: the same step at tolerance 1e-11.
void ForcePathStudy(bool quick) {
  Scene s = MakeScene("curved_force_path_hertz", *MakeSphere(0.01), 2);
  auto run = [&](double tolerance, double* seconds) {
    ContactConfig c = BaseConfig(s);
    c.force_path_tolerance = tolerance;
    Contact contact = std::move(Contact::Create(c)).value();
    Step normal, tangential, curved;
    normal.normal = NormalControl::kForce;
    normal.normal_value = 100;
    tangential.tangential = TangentialControl::kForce;
    tangential.tangential_value = 15;
    curved.normal = NormalControl::kForce;
    curved.normal_value = 150;
    curved.tangential = TangentialControl::kDisplacement;
    curved.tangential_value = 3e-7;
    (void)contact.Apply(normal);
    (void)contact.Apply(tangential);
    const auto start = Clock::now();
    StepReport report;
    (void)contact.Apply(curved, &report);
    *seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return std::pair{contact.tangential_force(), report};
  };
  double seconds = 0;
  const double reference = run(1e-11, &seconds).first;
  for (double tolerance :
       quick ? std::vector<double>{1e-3, 1e-6}
             : std::vector<double>{1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9}) {
    auto [fx, report] = run(tolerance, &seconds);
    Outcome o{std::abs(fx - reference) / (0.3 * 150), 1e9 * seconds / report.substeps, 0,
              std::move(Contact::Create(BaseConfig(s))).value()};
    PrintRow(s.name, {"force_path", "exact", tolerance, BaseConfig(s)},
             static_cast<std::size_t>(report.substeps), o, NAN, report.path_error);
  }
}

void Study(bool quick) {
  const int steps = quick ? 10 : 25;
  const double d = 3.4829098839e-6;  // H1: F_N = 100 N on the steel sphere
  std::vector<Scene> scenes = {
      FrettingLoop("fretting_hertz", *MakeSphere(0.01), 2, d, steps),
      FrettingLoop("fretting_cone", *MakeCone(10 * std::numbers::pi / 180), 1, d, steps),
      FrettingLoop("fretting_power_law_n4", *MakePowerLaw(1e6, 4), 4, d, steps),
      FrettingLoop("fretting_flat_punch", *MakeFlatPunch(1e-4), 0, d, steps),
      ObliqueLoading(d, 4 * steps),
      NormalUnloading(d, 2 * steps),
  };
  std::puts(
      "scene,method,rule,resolution,increments,max_error_fx,traction_error,error_estimate,"
      "ns_per_increment,us_per_forces_query");
  for (const Scene& s : scenes) {
    for (const Method& m : Methods(s, quick)) {
      const Outcome o = Run(s, m.config);
      double traction_error = NAN;
      if (m.name == "exact" && s.name == "fretting_hertz") {
        Contact loaded = std::move(Contact::Create(m.config)).value();
        const PathPoint top = s.path[steps];
        (void)loaded.MoveTo(top.depth, 0);
        (void)loaded.MoveTo(top.depth, top.ux);
        traction_error = TractionError(s, loaded, top.depth, top.ux);
      }
      PrintRow(s.name, m, s.path.size(), o, traction_error);
    }
  }
  // Tabulated Hertz: f = r^2/(2R) sampled on [0, 2a] with N samples, exact memory.
  Scene hertz = FrettingLoop("fretting_hertz_tabulated", *MakeSphere(0.01), 2, d, steps);
  const double a = hertz.profile->RadiusAtDepth(d);
  for (std::size_t n : quick ? std::vector<std::size_t>{50, 200}
                             : std::vector<std::size_t>{50, 100, 200, 500, 1000}) {
    std::vector<double> radii(n), heights(n);
    for (std::size_t i = 0; i < n; ++i) {
      radii[i] = 2 * a * i / (n - 1);
      heights[i] = radii[i] * radii[i] / (2 * 0.01);
    }
    Result<ProfilePtr> tabulated = MakeTabulatedProfile(radii, heights);
    if (!tabulated.ok()) continue;
    ContactConfig c = BaseConfig(hertz);
    c.profile = *tabulated;
    const Outcome o = Run(hertz, c);
    PrintRow(hertz.name, {"tabulated", "exact", static_cast<double>(n), c}, hertz.path.size(), o,
             NAN);
  }
  ForcePathStudy(quick);
}

}  // namespace
}  // namespace mdr

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  mdr::Study(quick);
  return 0;
}
