// The coverage study of FitLoops (issue #47; docs/analysis.md, "Coverage measured"): seeded
// replicates of a synthetic campaign (tests/fixtures/identify_campaigns.h) with the sensor effects
// asked for, fitted; per parameter how often the 95 % interval holds the truth, the mean and
// spread of (estimate - truth) / standard error; how often the verdicts say misfit or identified;
// the time per fit. A program, not a test:
//   build/release/tests/analysis/mdr_identify_study --displacement-noise 5e-9 --replicates 100
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "fixtures/identify_campaigns.h"

namespace mdr {
namespace {

using analysis::FitOptions;
using analysis::FitResult;
using analysis::Nuisance;
namespace campaigns = identify_campaigns;

struct Tally {
  int covered = 0, count = 0;
  double sum_z = 0, sum_z2 = 0;
  void Add(double value, double truth, double se, double lo, double hi) {
    covered += lo <= truth && truth <= hi;
    const double z = (value - truth) / se;
    if (std::isfinite(z)) sum_z += z, sum_z2 += z * z;
    ++count;
  }
  void Print(const char* name) const {
    const double mean = sum_z / count;
    std::printf("  %-28s covered %3d/%-3d  mean z %+6.2f  sd z %5.2f\n", name, covered, count, mean,
                std::sqrt(std::max(0.0, sum_z2 / count - mean * mean)));
  }
};

int Main(int argc, char** argv) {
  CLI::App app{"FitLoops coverage study"};
  int replicates = 20, threads = 1, cycles = 3, per_cycle = 200, burn_in = 2;
  double u_noise = 5e-9, f_noise = 0.1, n_noise = 0.1, variation = 0, force_offset = 0;
  double displacement_offset = 0, drift = 0, mass = 0, frequency = 1, declared = 0;
  std::string truth_profile = "sphere", waveform = "sine", dump;
  bool fit_offsets = false, fit_drift = false, fit_mass = false, column = false, given = false;
  std::uint64_t seed = 1;
  app.add_option("--replicates", replicates);
  app.add_option("--threads", threads);
  app.add_option("--burn-in", burn_in);
  app.add_option("--cycles", cycles);
  app.add_option("--samples-per-cycle", per_cycle);
  app.add_option("--frequency", frequency);
  app.add_option("--displacement-noise", u_noise);
  app.add_option("--force-noise", f_noise);
  app.add_option("--normal-noise", n_noise);
  app.add_option("--normal-variation", variation);
  app.add_option("--force-offset", force_offset);
  app.add_option("--displacement-offset", displacement_offset);
  app.add_option("--drift", drift);
  app.add_option("--mass", mass);
  app.add_option("--declared-normal-force", declared);
  app.add_option("--truth", truth_profile, "sphere or cone (fitted as a sphere)");
  app.add_option("--waveform", waveform, "sine or triangle");
  app.add_option("--seed", seed);
  std::vector<double> loads, amplitudes;
  app.add_option("--loads", loads, "N (default 20 60 150)");
  app.add_option("--amplitudes", amplitudes, "m (default 1e-6 3e-6 8e-6)");
  app.add_option("--dump", dump, "CSV of the first replicate's samples and model");
  app.add_flag("--fit-offsets", fit_offsets);
  app.add_flag("--fit-drift", fit_drift);
  app.add_flag("--fit-mass", fit_mass);
  app.add_flag("--normal-column", column);
  app.add_flag("--given-noise", given, "weigh with the generator's noise instead of estimating it");
  bool torsion = false;
  app.add_flag("--torsion", torsion,
               "the torsional campaign (identify_campaigns.h): mu, G_t and the shaft's compliance "
               "from (twist, moment) loops; the noises in rad and N m, amplitudes in rad");
  CLI11_PARSE(app, argc, argv);

  const ContactConfig truth =
      campaigns::SteelOnTitanium(truth_profile == "cone" ? *MakeCone(0.02) : ProfilePtr{});
  const rig_simulator::TorsionalRig torsional_truth =
      campaigns::TorsionalSteel(truth_profile == "cone" ? *MakeCone(0.2) : ProfilePtr{});
  const ContactConfig start = torsion ? campaigns::TorsionalStart() : campaigns::SteelOnTitanium();
  campaigns::Spec spec = torsion ? campaigns::TorsionalSpec() : campaigns::Spec{};
  if (!torsion) {  // the torsional spec keeps its own cycles, samples and waveform
    spec.cycles = cycles;
    spec.samples_per_cycle = per_cycle;
    spec.waveform = waveform == "triangle" ? rig_simulator::Waveform::kTriangle
                                           : rig_simulator::Waveform::kSine;
  }
  if (!loads.empty()) spec.loads = loads;
  if (!amplitudes.empty()) spec.amplitudes = amplitudes;
  spec.frequency = frequency;
  spec.displacement_noise = u_noise;
  spec.force_noise = f_noise;
  spec.normal_noise = n_noise;
  spec.normal_variation = variation;
  spec.record_normal_force = column || variation != 0;
  spec.force_offset = force_offset;
  spec.displacement_offset = displacement_offset;
  spec.displacement_drift = drift;
  spec.mass = mass;
  spec.declared_normal_force = declared;
  FitOptions options = torsion ? campaigns::TorsionalThreeFree() : campaigns::ThreeFree();
  options.threads = threads;
  options.burn_in_reversals = burn_in;
  if (given) {
    options.displacement_noise = std::max(u_noise, 1e-15);
    options.force_noise = f_noise;
  }
  options.nuisances.force_offset = fit_offsets;
  options.nuisances.displacement_drift = fit_drift;
  options.nuisances.moving_mass = fit_mass;
  const double values[] = {
      torsion ? torsional_truth.friction : truth.friction,
      torsion ? torsional_truth.torsional_modulus : truth.material.e_star,
      torsion ? torsional_truth.compliance : truth.rig.tangential};
  Tally tally[3];
  std::map<std::string, Tally> nuisance_tally;
  int misfits = 0, identified = 0, failed = 0, mismatches = 0;
  double seconds = 0, chi2 = 0;
  for (int replicate = 0; replicate < replicates; ++replicate) {
    spec.seed = seed + static_cast<std::uint64_t>(replicate);
    std::vector<rig_simulator::Record> records;
    const std::vector<analysis::LoopSet> sets =
        torsion ? campaigns::MakeTorsional(torsional_truth, spec, &records)
                : campaigns::Make(truth, spec, &records);
    const auto began = std::chrono::steady_clock::now();
    options.keep_models = replicate == 0 && !dump.empty();
    Result<FitResult> fit = analysis::FitLoops(start, sets, options);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
    if (!fit.ok()) {
      std::printf("replicate %d: %s\n", replicate, fit.status().ToString().c_str());
      ++failed;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const auto& e = fit->estimates[k];
      tally[k].Add(e.value, values[k], e.standard_error, e.lower_95, e.upper_95);
    }
    for (const analysis::NuisanceEstimate& e : fit->nuisances) {
      double true_value = 0;
      switch (e.nuisance) {
        case Nuisance::kForceOffset:
          true_value = force_offset;
          break;
        case Nuisance::kDisplacementOffset:
          true_value = *e.set % 2 == 0 ? displacement_offset : -displacement_offset;
          break;
        case Nuisance::kDisplacementDrift:
          true_value = drift;
          break;
        case Nuisance::kMovingMass:
          true_value = mass;
          break;
      }
      if (replicate == 0) {
        std::printf("  %s set %d: %.6g +- %.3g (truth %.6g)%s\n",
                    analysis::NuisanceName(e.nuisance), e.set ? static_cast<int>(*e.set) : -1,
                    e.value, e.standard_error, true_value, e.identified ? "" : " undetermined");
      }
      if (!e.identified) continue;
      if (std::abs((e.value - true_value) / e.standard_error) > 5) {
        std::printf("  outlier replicate %d %s set %d: %.6g +- %.3g (truth %.6g)\n", replicate,
                    analysis::NuisanceName(e.nuisance), e.set ? static_cast<int>(*e.set) : -1,
                    e.value, e.standard_error, true_value);
      }
      nuisance_tally[analysis::NuisanceName(e.nuisance)].Add(e.value, true_value, e.standard_error,
                                                             e.lower_95, e.upper_95);
    }
    for (std::size_t s = 0; s < fit->sets.size(); ++s) {
      const analysis::SetFit& f = fit->sets[s];
      if (replicate > 0 && (f.reduced_chi_square > 1.25 || f.misfit)) {
        std::printf("  replicate %d set %zu: chi2 %.3f structure p %.2g shift %.3g%s\n", replicate,
                    s, f.reduced_chi_square, f.structure_p_value, f.turning_point_shift_rms,
                    f.misfit ? " MISFIT" : "");
      }
    }
    bool misfit = false, mismatch = false;
    for (const analysis::SetFit& s : fit->sets) {
      misfit = misfit || s.misfit;
      mismatch = mismatch || s.load_mismatch;
    }
    misfits += misfit;
    mismatches += mismatch;
    identified += fit->identified;
    chi2 += fit->reduced_chi_square;
    if (options.keep_models) {
      std::FILE* out = std::fopen(dump.c_str(), "w");
      std::fprintf(out, "set,i,u,f,true_u,true_f,path,contact,predicted\n");
      for (std::size_t s = 0; s < sets.size(); ++s) {
        const analysis::SetModel& m = fit->models[s];
        for (std::size_t i = 0; i < m.actuator_path.size(); ++i) {
          std::fprintf(out, "%zu,%zu,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g\n", s, i,
                       sets[s].samples.displacement[i], sets[s].samples.tangential_force[i],
                       records[s].true_displacement[i], records[s].true_force[i],
                       m.actuator_path[i], m.contact_force[i], m.predicted_force[i]);
        }
      }
      std::fclose(out);
    }
    if (replicate == 0) {
      for (std::size_t s = 0; s < fit->sets.size(); ++s) {
        const analysis::SetFit& f = fit->sets[s];
        std::printf(
            "  set %zu: noise u %.3g (true %.3g) F %.3g; chi2 %.3f ac %+.3f structure %.1f/%d p "
            "%.2g tp %zu shift %.3g%s\n",
            s, f.displacement_noise, u_noise, f.force_noise, f.reduced_chi_square,
            f.autocorrelation, f.structure_statistic, f.structure_bins, f.structure_p_value,
            f.turning_points, f.turning_point_shift_rms, f.misfit ? " MISFIT" : "");
      }
      std::printf("  iterations %d, parameters %zu, residuals %zu, converged %d\n", fit->iterations,
                  fit->parameters, fit->residuals, fit->converged);
      for (int k = 0; k < 3; ++k) {
        const auto& e = fit->estimates[k];
        std::printf("  %s %.10g (truth %.10g, relative error %.2e, se %.2e)\n",
                    analysis::ParameterName(e.parameter), e.value, values[k],
                    e.value / values[k] - 1, e.standard_error / std::abs(values[k]));
      }
    }
  }
  std::printf("u noise %.3g %s, F noise %.3g %s, %d replicates (%d failed): %.3f s per fit\n",
              u_noise, torsion ? "rad" : "m", f_noise, torsion ? "N m" : "N", replicates, failed,
              seconds / replicates);
  for (int k = 0; k < 3; ++k) tally[k].Print(analysis::ParameterName(options.free[k].parameter));
  for (const auto& [name, t] : nuisance_tally) t.Print(name.c_str());
  std::printf("  misfit %d, load mismatch %d, identified %d, mean reduced chi-square %.3f\n",
              misfits, mismatches, identified, chi2 / replicates);
  return 0;
}

}  // namespace
}  // namespace mdr

int main(int argc, char** argv) { return mdr::Main(argc, argv); }
