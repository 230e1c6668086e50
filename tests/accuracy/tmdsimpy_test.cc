// The exact engine on tmdsimpy's three published single-asperity paths
// (data/tmdsimpy/mif_tangential_asperity.yaml, MIT License, see the README there): the engine
// against the closed forms that hold on these paths, and tmdsimpy's Mindlin-Iwan Fit (100 radial
// sliders) against the engine. docs/comparisons.md explains the figures this prints.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mdr/core/contact.h"
#include "mdr/core/material.h"
#include "mdr/core/profile.h"

namespace mdr {
namespace {

// One path: tmdsimpy drives (x_disp[k], normal_disp[k]) in sequence and reports its forces there.
struct ReferencePath {
  std::vector<double> x_disp, normal_disp, x_force, normal_force;
  std::size_t size() const { return x_disp.size(); }
};

// The file: scalar parameters as written ("Sys : Inf" stays text) and the named paths.
struct Reference {
  std::map<std::string, std::string> scalars;
  std::map<std::string, ReferencePath> paths;
};

constexpr const char* kPathNames[] = {"constant_normal", "decreasing_normal", "increasing_normal"};

std::string_view Trim(std::string_view s) {
  const auto begin = s.find_first_not_of(" \t\r");
  if (begin == std::string_view::npos) return {};
  return s.substr(begin, s.find_last_not_of(" \t\r") - begin + 1);
}

// "[a,b,...]" into numbers; false on anything else.
bool ParseNumberList(std::string_view text, std::vector<double>* out) {
  if (text.size() < 2 || text.front() != '[' || text.back() != ']') return false;
  std::string list(text.substr(1, text.size() - 2));
  const char* p = list.c_str();
  while (*p != '\0') {
    char* end = nullptr;
    const double value = std::strtod(p, &end);
    if (end == p || !std::isfinite(value)) return false;
    out->push_back(value);
    p = end;
    if (*p == ',') {
      ++p;
    } else if (*p != '\0') {
      return false;
    }
  }
  return !out->empty();
}

std::vector<double>* PathArray(ReferencePath* path, std::string_view key) {
  if (key == "x_disp") return &path->x_disp;
  if (key == "normal_disp") return &path->normal_disp;
  if (key == "x_force") return &path->x_force;
  if (key == "normal_force") return &path->normal_force;
  return nullptr;
}

// The file's flat layout: "key : value" scalars at the left margin, "name : " opening a path, and
// indented "key : [numbers]" arrays of that path. Returns an error naming the line, "" if fine.
std::string ParseReference(std::istream& in, Reference* out) {
  std::string line;
  ReferencePath* path = nullptr;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto colon = line.find(':');
    if (Trim(line).empty()) continue;
    const std::string where = "line " + std::to_string(number) + ": ";
    if (colon == std::string::npos) return where + "no ':'";
    const std::string key(Trim(std::string_view(line).substr(0, colon)));
    const std::string_view value = Trim(std::string_view(line).substr(colon + 1));
    if (line.front() != ' ') {
      path = value.empty() ? &out->paths[key] : nullptr;
      if (!value.empty()) out->scalars[key] = std::string(value);
      continue;
    }
    std::vector<double>* array = path ? PathArray(path, key) : nullptr;
    if (array == nullptr) return where + "unexpected array '" + key + "'";
    if (!ParseNumberList(value, array)) return where + "'" + key + "' is not a list of numbers";
  }
  return "";
}

// Loads the file; a path's normal_force given as one value (constant_normal) holds at every point.
std::string LoadReference(Reference* reference) {
  std::ifstream in(MDR_TMDSIMPY_DATA);
  if (!in) return std::string("cannot open ") + MDR_TMDSIMPY_DATA;
  if (std::string error = ParseReference(in, reference); !error.empty()) return error;
  for (const char* name : kPathNames) {
    auto found = reference->paths.find(name);
    if (found == reference->paths.end()) return std::string("path '") + name + "' missing";
    ReferencePath& path = found->second;
    if (path.normal_force.size() == 1) path.normal_force.assign(path.size(), path.normal_force[0]);
    if (path.size() < 2 || path.normal_disp.size() != path.size() ||
        path.x_force.size() != path.size() || path.normal_force.size() != path.size()) {
      return std::string("path '") + name + "': arrays of different lengths";
    }
  }
  return "";
}

// The asperity: two like elastic bodies (E, nu), a sphere of radius R on a flat, friction mu.
struct Asperity {
  double youngs_modulus, poisson_ratio, radius, friction;
};

Asperity AsperityOf(const Reference& reference) {
  const auto number = [&](const char* key) { return std::stod(reference.scalars.at(key)); };
  return {number("E"), number("nu"), number("R"), number("mu")};
}

// Hertz-Mindlin closed forms for two like bodies, written out here rather than taken from the
// engine: E* = E/(2(1 - nu^2)), G* = E/((1 + nu)(2 - nu)), kappa = E*/G* = (2 - nu)/(2(1 - nu)).
struct HertzMindlin {
  explicit HertzMindlin(const Asperity& a)
      : e_star(a.youngs_modulus / (2 * (1 - a.poisson_ratio * a.poisson_ratio))),
        g_star(a.youngs_modulus / ((1 + a.poisson_ratio) * (2 - a.poisson_ratio))),
        mu_kappa(a.friction * e_star / g_star),
        friction(a.friction),
        radius(a.radius) {}
  double NormalForce(double depth) const {
    return 4.0 / 3.0 * e_star * std::sqrt(radius) * std::pow(depth, 1.5);
  }
  // Cattaneo-Mindlin at depth d after a monotone tangential displacement ux from the virgin state:
  // mu [F_N(d) - F_N(d - |ux|/(mu kappa))], gross slip mu F_N beyond |ux| = mu kappa d; written as
  // -mu F_N expm1(1.5 log1p(-h/d)) without the cancellation of the difference.
  double CattaneoMindlin(double depth, double ux) const {
    const double h = std::min(std::abs(ux) / mu_kappa, depth);
    const double force = -friction * NormalForce(depth) * std::expm1(1.5 * std::log1p(-h / depth));
    return std::copysign(force, ux);
  }
  double e_star, g_star, mu_kappa, friction, radius;
};

// The exact engine's forces along a path: a fresh contact (depth 0, u_x 0) moved by one exact
// linear step to each point in turn.
struct EngineRun {
  std::vector<double> normal_force, tangential_force;
};

EngineRun RunEngine(const Asperity& a, const ReferencePath& path) {
  ContactConfig config;
  config.profile = *MakeSphere(a.radius);
  config.material =
      *ElasticPair(a.youngs_modulus, a.poisson_ratio, a.youngs_modulus, a.poisson_ratio);
  config.friction = a.friction;
  config.track_energy = false;
  Result<Contact> contact = Contact::Create(config);
  EXPECT_TRUE(contact.ok()) << contact.status().ToString();
  EngineRun run;
  if (!contact.ok()) return run;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const Status status = contact->MoveTo(path.normal_disp[k], path.x_disp[k]);
    EXPECT_TRUE(status.ok()) << "point " << k << ": " << status.ToString();
    run.normal_force.push_back(contact->normal_force());
    run.tangential_force.push_back(contact->tangential_force());
  }
  return run;
}

// Mindlin-Deresiewicz at constant depth from the virgin state: Cattaneo-Mindlin on the first
// branch; after a reversal at (u_r, F_r), F = F_r + 2 CM(d, (u - u_r)/2) (Masing). That form needs
// the branch before the reversal to have reached gross slip, which is checked.
std::vector<double> MindlinDeresiewiczAtConstantDepth(const HertzMindlin& hm,
                                                      const ReferencePath& path) {
  const double depth = path.normal_disp[0];
  std::vector<double> force;
  double reversal_u = 0, reversal_force = 0, branch_start_u = 0;
  int direction = 0;
  bool reversed = false;
  for (std::size_t k = 0; k < path.size(); ++k) {
    EXPECT_EQ(path.normal_disp[k], depth) << "point " << k << ": depth not constant";
    const double u = path.x_disp[k];
    const int step_direction =
        k == 0 || u == path.x_disp[k - 1] ? 0 : (u > path.x_disp[k - 1] ? 1 : -1);
    if (step_direction != 0 && direction != 0 && step_direction != direction) {
      reversal_u = path.x_disp[k - 1];
      reversal_force = force.back();
      const double reach = reversed ? 2 * hm.mu_kappa * depth : hm.mu_kappa * depth;
      EXPECT_GE(std::abs(reversal_u - branch_start_u), reach)
          << "point " << k << ": reversal before gross slip, the Masing form does not apply";
      branch_start_u = reversal_u;
      reversed = true;
    }
    if (step_direction != 0) direction = step_direction;
    force.push_back(reversed ? reversal_force + 2 * hm.CattaneoMindlin(depth, (u - reversal_u) / 2)
                             : hm.CattaneoMindlin(depth, u));
  }
  return force;
}

// From a Cattaneo-Mindlin state u(z) = min(u_x, mu kappa (d - z)) (MDR springs indexed by
// z = g(x)), a linear step with du >= 0 and du >= mu kappa dd ends in the Cattaneo-Mindlin state
// of its end point: springs that enter, and those of the old slip zone, reach the bound; the
// stick zone stays below it. So wherever a path makes only such steps, F_x = CM(d, u_x) at every
// point, whatever the normal load did. A step that falls short by v = max(0, -du, mu kappa dd -
// du) leaves springs up to v below that state; shift and clamp do not enlarge such a difference,
// so |F_x - CM| <= 2 G* a_max sum(v), returned as *bound.
std::vector<double> CattaneoMindlinAlongPath(const HertzMindlin& hm, const ReferencePath& path,
                                             double* bound) {
  double shortfall = 0, max_depth = 0;
  std::vector<double> force;
  for (std::size_t k = 0; k < path.size(); ++k) {
    if (k > 0) {
      const double du = path.x_disp[k] - path.x_disp[k - 1];
      const double dd = path.normal_disp[k] - path.normal_disp[k - 1];
      shortfall += std::max({0.0, -du, hm.mu_kappa * dd - du});
    }
    max_depth = std::max(max_depth, path.normal_disp[k]);
    force.push_back(hm.CattaneoMindlin(path.normal_disp[k], path.x_disp[k]));
  }
  *bound = 2 * hm.g_star * std::sqrt(hm.radius * max_depth) * shortfall;
  return force;
}

// The closed-form F_x of each path and the bound of its premise's shortfall (N).
std::vector<double> ClosedForm(const HertzMindlin& hm, const std::string& name,
                               const ReferencePath& path, double* bound) {
  *bound = 0;
  if (name == "constant_normal") return MindlinDeresiewiczAtConstantDepth(hm, path);
  return CattaneoMindlinAlongPath(hm, path, bound);
}

class TmdsimpyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string error = LoadReference(&reference_);
    ASSERT_TRUE(error.empty()) << MDR_TMDSIMPY_DATA << ": " << error;
    asperity_ = AsperityOf(reference_);
  }
  Reference reference_;
  Asperity asperity_{};
};

// The data are the elastic asperity the engine models; a changed file shows here first.
TEST_F(TmdsimpyTest, ReferenceIsTheElasticHertzAsperity) {
  EXPECT_EQ(asperity_.youngs_modulus, 192.85e9);
  EXPECT_EQ(asperity_.poisson_ratio, 0.29);
  EXPECT_EQ(asperity_.radius, 4.174432305996625e-3);
  EXPECT_EQ(asperity_.friction, 0.2);
  EXPECT_EQ(reference_.scalars.at("Sys"), "Inf");  // yield stress: no plasticity
  EXPECT_EQ(reference_.scalars.at("asp_num_quad_points"), "100");
  EXPECT_EQ(reference_.paths.at("constant_normal").size(), 60u);
  EXPECT_EQ(reference_.paths.at("decreasing_normal").size(), 121u);
  EXPECT_EQ(reference_.paths.at("increasing_normal").size(), 117u);
}

// tmdsimpy starts its history at zero displacement (unlth0 = 0 in its test) and every path's
// first point is (u_x = 0, delta = 1e-5): the step there is a pure normal approach, with no
// tangential force in either model. A fresh Contact moved to that point starts from the same state.
TEST_F(TmdsimpyTest, PathsStartWithAPureNormalApproach) {
  for (const char* name : kPathNames) {
    const ReferencePath& path = reference_.paths.at(name);
    EXPECT_EQ(path.x_disp[0], 0.0) << name;
    EXPECT_EQ(path.x_force[0], 0.0) << name;
    EXPECT_EQ(path.normal_disp[0], 1e-5) << name;
    EXPECT_EQ(RunEngine(asperity_, path).tangential_force[0], 0.0) << name;
  }
}

// Both are Hertz: the difference is the rounding of the file's 13 significant digits, <= 5e-13
// relative per number, so <= 1.5 * 5e-13 (F_N ~ delta^1.5) + 5e-13.
TEST_F(TmdsimpyTest, NormalForceIsHertzInBoth) {
  for (const char* name : kPathNames) {
    const ReferencePath& path = reference_.paths.at(name);
    const EngineRun run = RunEngine(asperity_, path);
    double worst = 0;
    for (std::size_t k = 0; k < path.size(); ++k) {
      worst = std::max(worst, std::abs(path.normal_force[k] / run.normal_force[k] - 1));
    }
    std::printf("%-18s normal force: max |F_N(tmdsimpy)/F_N(exact) - 1| = %.2e\n", name, worst);
    EXPECT_LE(worst, 1.3e-12) << name;
  }
}

// The test that can fail for us: the engine on every point of the three paths against the
// closed forms (Mindlin-Deresiewicz at constant normal load, Cattaneo-Mindlin at the current
// state on the two others), to 1e-12 of mu F_N plus the bound of the data's own shortfall.
TEST_F(TmdsimpyTest, EngineMatchesTheClosedFormsOnAllThreePaths) {
  const HertzMindlin hm(asperity_);
  for (const char* name : kPathNames) {
    const ReferencePath& path = reference_.paths.at(name);
    const EngineRun run = RunEngine(asperity_, path);
    double bound = 0, worst = 0;
    const std::vector<double> closed = ClosedForm(hm, name, path, &bound);
    for (std::size_t k = 0; k < path.size(); ++k) {
      const double limit = hm.friction * hm.NormalForce(path.normal_disp[k]);
      const double error = std::abs(run.tangential_force[k] - closed[k]);
      worst = std::max(worst, error / limit);
      EXPECT_LE(error, 1e-12 * limit + bound) << name << " point " << k;
    }
    std::printf("%-18s engine vs closed form: max |dF_x|/(mu F_N) = %.2e (premise bound %.2e N)\n",
                name, worst, bound);
  }
}

// tmdsimpy against the exact engine, per point relative to mu F_N.
struct Deviation {
  double max = 0, rms = 0;
  std::size_t where = 0;
  double max_of_exact = 0;  // largest |dF_x|/|F_x exact| where |F_x| >= 0.1 mu F_N
  std::size_t where_of_exact = 0;
  // tmdsimpy's |F_x|/(mu F_N), lowest and highest, where both slip wholly: the exact contact is at
  // mu F_N and tmdsimpy's F_x repeats the previous point's.
  double gross_slip_min = 2, gross_slip_max = 0;
};

Deviation DeviationOf(const HertzMindlin& hm, const ReferencePath& path, const EngineRun& run) {
  Deviation d;
  double sum_squares = 0;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const double limit = hm.friction * run.normal_force[k];
    const double diff = path.x_force[k] - run.tangential_force[k];
    sum_squares += (diff / limit) * (diff / limit);
    if (std::abs(diff) / limit > std::abs(d.max)) {
      d.max = diff / limit;
      d.where = k;
    }
    if (std::abs(run.tangential_force[k]) >= 0.1 * limit &&
        std::abs(diff / run.tangential_force[k]) > std::abs(d.max_of_exact)) {
      d.max_of_exact = diff / run.tangential_force[k];
      d.where_of_exact = k;
    }
    if (k > 0 && std::abs(run.tangential_force[k]) >= limit * (1 - 1e-12) &&
        path.x_force[k] == path.x_force[k - 1]) {
      d.gross_slip_min = std::min(d.gross_slip_min, std::abs(path.x_force[k]) / limit);
      d.gross_slip_max = std::max(d.gross_slip_max, std::abs(path.x_force[k]) / limit);
    }
  }
  d.rms = std::sqrt(sum_squares / path.size());
  return d;
}

// tmdsimpy's F_x at gross slip over mu F_N if its force is the trapezoidal rule on `points` equally
// spaced normalised radii rho in [0, 1] (end weights halved) of the gross-slip traction: mu times
// the Hertz pressure 3 F_N/(2 pi a^2) sqrt(1 - rho^2) over the area 2 pi a^2 rho d rho, i.e. of
// 3 rho sqrt(1 - rho^2), whose integral is 1.
double TrapezoidalGrossSlipRatio(int points) {
  double sum = 0;
  for (int i = 0; i < points; ++i) {
    const double rho = static_cast<double>(i) / (points - 1);
    sum += (i == 0 || i == points - 1 ? 1.0 : 2.0) * 3 * rho * std::sqrt(1 - rho * rho);
  }
  return sum / (2.0 * (points - 1));
}

// The figures of docs/comparisons.md, with bands around them so that a change in either model
// shows: at constant normal load the sliders stay within 0.05-1.5 % of mu F_N; with decreasing
// normal load they lose 1-15 %, most at the end of the decrease; at gross slip they carry exactly
// what the trapezoidal rule on their radial points gives (0.99908 mu F_N), on every path.
TEST_F(TmdsimpyTest, TmdsimpyDeviationStaysWithinItsDocumentedBounds) {
  const HertzMindlin hm(asperity_);
  const double slip_ratio =
      TrapezoidalGrossSlipRatio(std::stoi(reference_.scalars.at("asp_num_quad_points")));
  struct Band {
    const char* name;
    double min_max, max_max;
  };
  std::printf("trapezoidal rule's gross-slip ratio: %.10f\n", slip_ratio);
  std::printf("%-18s %6s %14s %10s %24s %18s %12s\n", "path", "points", "max|dF|/muFN", "RMS",
              "where (k: delta, u_x)", "max|dF|/|F_x|", "slip ratio");
  for (const Band& band :
       {Band{"constant_normal", 0.0005, 0.015}, Band{"decreasing_normal", 0.01, 0.15},
        Band{"increasing_normal", 0.005, 0.05}}) {
    const ReferencePath& path = reference_.paths.at(band.name);
    const Deviation d = DeviationOf(hm, path, RunEngine(asperity_, path));
    std::printf("%-18s %6zu %13.3f%% %9.3f%% %4zu: %.3e, %.3e %11.2f%% (k %3zu) %12.10f\n",
                band.name, path.size(), 100 * d.max, 100 * d.rms, d.where,
                path.normal_disp[d.where], path.x_disp[d.where], 100 * d.max_of_exact,
                d.where_of_exact, d.gross_slip_min);
    EXPECT_GE(std::abs(d.max), band.min_max) << band.name;
    EXPECT_LE(std::abs(d.max), band.max_max) << band.name;
    EXPECT_NEAR(d.gross_slip_min, slip_ratio, 1e-9) << band.name;
    EXPECT_NEAR(d.gross_slip_max, slip_ratio, 1e-9) << band.name;
  }
  // The decreasing path's worst point is the last one of the normal decrease.
  const ReferencePath& decreasing = reference_.paths.at("decreasing_normal");
  const Deviation d = DeviationOf(hm, decreasing, RunEngine(asperity_, decreasing));
  std::size_t last_decrease = 0;
  for (std::size_t k = 1; k < decreasing.size(); ++k) {
    if (decreasing.normal_disp[k] < decreasing.normal_disp[k - 1]) last_decrease = k;
  }
  EXPECT_EQ(d.where, last_decrease);
}

}  // namespace
}  // namespace mdr
