// A rough steel interface under a bolt-like normal load and a fretting cycle, with the core's
// Interface (docs/interfaces.md): a few thousand exact Hertz asperities with Gaussian summit
// heights share one rigid motion. The total normal force is a target solved exactly; the tangential
// displacement then runs a triangle wave. Writes the hysteresis loop (CSV), the energy dissipated
// per cycle, and checks the energy balance: after the first cycle the loop's area (the work of F_x)
// equals the energy the contacts dissipate, to the trapezoidal rule's error.
//
//   mdr_rough_interface [--asperities N] [--normal-force F] [--cycles C] [--steps S] [--out DIR]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "mdr/core/interface.h"

namespace {

struct Options {
  std::size_t asperities = 3000;
  double normal_force = 5000;  // N: a M8 bolt's preload shared by a ~1 cm^2 joint patch
  int cycles = 3;
  int steps_per_cycle = 400;
  std::string out = ".";
};

Options Parse(int argc, char** argv) {
  Options options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const char* value = argv[i + 1];
    if (flag == "--asperities")
      options.asperities = std::strtoull(value, nullptr, 10);
    else if (flag == "--normal-force")
      options.normal_force = std::strtod(value, nullptr);
    else if (flag == "--cycles")
      options.cycles = std::atoi(value);
    else if (flag == "--steps")
      options.steps_per_cycle = std::atoi(value);
    else if (flag == "--out")
      options.out = value;
    else {
      std::fprintf(stderr, "unknown flag %s\n", flag.c_str());
      std::exit(2);
    }
  }
  return options;
}

void Check(const mdr::Status& status, const char* what) {
  if (status.ok()) return;
  std::fprintf(stderr, "%s: %s\n", what, status.ToString().c_str());
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = Parse(argc, argv);
  // Ground steel: summits of radius 0.1 mm, heights Gaussian with sigma = 1 um (seeded).
  mdr::PopulationSpec spec;
  spec.count = options.asperities;
  spec.height_scale = 1e-6;
  spec.radius = 1e-4;
  spec.seed = 2026;
  mdr::Result<mdr::Population> population = mdr::GeneratePopulation(spec);
  Check(population.status(), "population");
  mdr::Result<mdr::InterfaceConfig> config = mdr::HertzInterfaceConfig(
      *population, *mdr::ElasticPair(210e9, 0.3, 210e9, 0.3), /*friction=*/0.3);
  Check(config.status(), "interface config");
  mdr::Result<mdr::Interface> created = mdr::Interface::Create(std::move(config).value());
  Check(created.status(), "interface");
  mdr::Interface interface = std::move(created).value();

  // The bolt: the total normal force as an exact target.
  Check(interface.Apply({mdr::NormalControl::kForce, options.normal_force}), "normal load");
  const mdr::InterfaceTotals loaded = *interface.Totals();
  // Fretting at half the displacement that makes the whole interface slide.
  const double slide = 0.5 * loaded.friction_limit / loaded.tangential_stiffness.positive;
  std::printf(
      "%zu asperities, %zu in contact at F_N = %.6g N (approach %.4g um); "
      "amplitude %.4g um\n",
      interface.size(), loaded.in_contact, loaded.normal_force, interface.approach() * 1e6,
      slide * 1e6);

  std::ofstream loop(options.out + "/rough_interface_loop.csv");
  loop << "cycle,ux_m,fx_n,dissipated_j,partial_slip,gross_slip\n";
  std::ofstream per_cycle(options.out + "/rough_interface_energy.csv");
  per_cycle << "cycle,dissipated_j,loop_area_j,relative_difference\n";
  const int n = options.steps_per_cycle;
  double worst = 0;
  for (int cycle = 0; cycle < options.cycles; ++cycle) {
    const double energy_before = interface.Totals()->dissipated_energy;
    double area = 0, ux_prev = interface.tangential_displacement();
    double fx_prev = interface.Totals()->tangential_force;
    for (int k = 1; k <= n; ++k) {
      // 0 -> +A -> -A -> 0: a triangle wave starting at the centre.
      const double s = static_cast<double>(k) / n;
      const double ux = slide * (s < 0.25 ? 4 * s : s < 0.75 ? 2 - 4 * s : 4 * s - 4);
      Check(interface.Apply({mdr::NormalControl::kDepthIncrement, 0,
                             mdr::TangentialControl::kDisplacement, ux}),
            "fretting step");
      const mdr::InterfaceTotals totals = *interface.Totals();
      area += 0.5 * (totals.tangential_force + fx_prev) * (ux - ux_prev);
      loop << cycle << ',' << ux << ',' << totals.tangential_force << ','
           << totals.dissipated_energy << ',' << totals.partial_slip << ',' << totals.gross_slip
           << '\n';
      ux_prev = ux;
      fx_prev = totals.tangential_force;
    }
    const double dissipated = interface.Totals()->dissipated_energy - energy_before;
    const double difference = (area - dissipated) / dissipated;
    if (cycle > 0) worst = std::max(worst, std::abs(difference));
    per_cycle << cycle << ',' << dissipated << ',' << area << ',' << difference << '\n';
    std::printf("cycle %d: dissipated %.6e J, loop area %.6e J (%+.2e)\n", cycle, dissipated, area,
                difference);
  }
  // The trapezoidal rule on n steps per cycle: error ~ (amplitude / n)^2 curvature terms, well
  // below 1e-3 for n >= 100 on this loop.
  const double tolerance = 1e-3;
  std::printf(
      "energy balance after the first cycle: worst |area - dissipated| / dissipated = "
      "%.2e (tolerance %.0e)\n",
      worst, tolerance);
  return worst <= tolerance ? 0 : 1;
}
