#include "analysis_plot.h"

#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "plot.h"
#include "rig_csv.h"

namespace mdrctl {
namespace {

namespace fs = std::filesystem;
using mdr::v1::AnalyzeLoopsResponse;
using mdr::v1::CycleFigures;

// A directory for the data files and the script, removed with this object.
class TemporaryDirectory {
 public:
  TemporaryDirectory() {
    std::string pattern = (fs::temp_directory_path() / "mdrctl-plot-XXXXXX").string();
    if (::mkdtemp(pattern.data()) != nullptr) path_ = pattern;
  }
  ~TemporaryDirectory() {
    std::error_code ignored;
    if (!path_.empty()) fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::ofstream DataFile(const fs::path& file) {
  std::ofstream out(file);
  out.precision(12);
  return out;
}

// The regime as a number for the scripts: 0 unknown, 1 sticking, 2 partial slip, 3 gross slip.
int RegimeCode(mdr::v1::Regime regime) { return static_cast<int>(regime); }

// How the position axis is drawn: u in µm (the data's metres times 1e6), phi in rad.
struct PositionAxis {
  std::string scale;  // gnuplot's factor on the data's SI values
  std::string label;  // the axis' label without what it measures
};
PositionAxis AxisOf(const ChannelLabels& labels) {
  if (labels.torsional) return {"1", labels.position + " [" + labels.position_unit + "]"};
  return {"1e6", labels.position + " [µm]"};
}

// "($1*1e6)": column `column` of the data in the axis' unit.
std::string Scaled(const PositionAxis& axis, int column) {
  return "($" + std::to_string(column) + "*" + axis.scale + ")";
}

std::string ForceAxis(const ChannelLabels& labels) {
  return labels.force + " [" + labels.force_unit + "]";
}

// u [m] (phi [rad]), F_x [N] (M [N m]), the number of the cycle the sample belongs to (0: outside
// complete cycles).
void WriteLoop(const PlottedSet& set, const fs::path& file) {
  std::ofstream out = DataFile(file);
  out << "# " << set.labels.position << "[" << set.labels.position_unit << "] " << set.labels.force
      << "[" << set.labels.force_unit << "] cycle\n";
  const auto& positions = LoopPositions(*set.samples);
  const auto& forces = LoopForces(*set.samples);
  const auto& cycles = set.analysis->cycles();
  int cycle = 0;
  for (int i = 0; i < positions.size(); ++i) {
    while (cycle < cycles.size() && static_cast<std::uint64_t>(i) > cycles[cycle].last_sample()) {
      ++cycle;
    }
    const bool inside =
        cycle < cycles.size() && static_cast<std::uint64_t>(i) >= cycles[cycle].first_sample();
    out << positions[i] << ' ' << forces[i] << ' ' << (inside ? cycle + 1 : 0) << '\n';
  }
}

// One block per set: the figures of each cycle (a torsional record's in rad and N m, its
// full-slip moment last).
void WriteCycles(const std::vector<PlottedSet>& sets, const fs::path& file) {
  std::ofstream out = DataFile(file);
  for (const PlottedSet& set : sets) {
    out << "# " << set.label
        << ": cycle Q*[N] P[N] Q*/P Ed[J] delta_0[m] C A B A_c B_c C_onset delta*[m] M_slip[N m]\n";
    for (int i = 0; i < set.analysis->cycles_size(); ++i) {
      const CycleFigures& c = set.analysis->cycles(i);
      const double nan = std::nan("");
      out << i + 1 << ' ' << c.force_amplitude() << ' ' << c.normal_force() << ' '
          << c.force_amplitude() / c.normal_force() << ' ' << c.dissipated_energy() << ' '
          << c.half_opening() << ' ' << c.system_free_ratio() << ' ' << c.energy_ratio() << ' '
          << c.sliding_ratio() << ' ' << (c.has_contact() ? c.contact().energy_ratio() : nan) << ' '
          << (c.has_contact() ? c.contact().sliding_ratio() : nan) << ' '
          << (c.regime() != mdr::v1::REGIME_UNSPECIFIED ? c.onset_system_free_ratio() : nan) << ' '
          << c.displacement_amplitude() << ' '
          << (set.labels.torsional && c.regime() != mdr::v1::REGIME_UNSPECIFIED
                  ? c.full_slip_moment()
                  : nan)
          << '\n';
    }
    out << "\n\n";
  }
}

struct Script {
  std::ostringstream text;
  std::vector<std::string> pngs;
  const fs::path dir;

  explicit Script(fs::path out_dir) : dir(std::move(out_dir)) {
    text << "set terminal pngcairo size 1000,700 noenhanced font ',11'\nset grid\n"
         << "set datafile missing 'nan'\n";
  }
  void Output(const std::string& png) {
    pngs.push_back(png);
    text << "set output " << GnuplotQuoted((dir / png).string()) << "\n";
  }
  void Labels(const std::string& title, const std::string& xlabel, const std::string& ylabel) {
    text << "set title " << GnuplotQuoted(title) << "\nset xlabel " << GnuplotQuoted(xlabel)
         << "\nset ylabel " << GnuplotQuoted(ylabel) << "\n";
  }
};

std::string Q(const fs::path& file) { return GnuplotQuoted(file.string()); }

std::string FormatNumberShort(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", value);
  return text;
}

// One curve of a plot command: "<source> using <columns> with <style> title <title>".
struct Series {
  std::string source;  // a quoted file name and "index i" if any
  std::string columns;
  std::string style;
  std::string title;
};

std::string Plot(const std::vector<Series>& series) {
  std::string plot;
  for (const Series& s : series) {
    plot += (plot.empty() ? "plot " : ", ") + s.source + " using " + s.columns + " with " +
            s.style + " title " + GnuplotQuoted(s.title);
  }
  return plot + "\n";
}

// One curve per set's block of `data`, coloured by set (dash type `dash`).
std::vector<Series> PerSet(const std::vector<PlottedSet>& sets, const fs::path& data,
                           const std::string& columns, const std::string& what, int dash = 1) {
  std::vector<Series> series;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    series.push_back(
        {Q(data) + " index " + std::to_string(i), columns,
         "linespoints lw 2 pt 7 ps 0.6 dt " + std::to_string(dash) + " lc " + std::to_string(i + 1),
         sets.size() == 1 ? what : sets[i].label + " " + what});
  }
  return series;
}

std::vector<Series> Joined(std::vector<Series> a, const std::vector<Series>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

bool AllHaveLoads(const std::vector<PlottedSet>& sets) {
  for (const PlottedSet& set : sets) {
    for (const CycleFigures& c : set.analysis->cycles()) {
      if (!(c.normal_force() > 0)) return false;
    }
  }
  return true;
}

bool AnyContact(const std::vector<PlottedSet>& sets) {
  for (const PlottedSet& set : sets) {
    for (const CycleFigures& c : set.analysis->cycles()) {
      if (c.has_contact()) return true;
    }
  }
  return false;
}

bool AnyRegime(const std::vector<PlottedSet>& sets) {
  for (const PlottedSet& set : sets) {
    for (const CycleFigures& c : set.analysis->cycles()) {
      if (c.regime() != mdr::v1::REGIME_UNSPECIFIED) return true;
    }
  }
  return false;
}

// The first panel of cycles.png: Q*/P with loads (a tangential record), else Q* (a torsional
// record's M*, with the full-slip moment where a scene classified the cycles).
void AddAmplitudePanel(const std::vector<PlottedSet>& sets, const fs::path& data, Script* script) {
  const ChannelLabels& labels = sets.front().labels;
  if (!labels.torsional && AllHaveLoads(sets)) {
    script->text << "set ylabel 'Q*/P (contact)'\n" << Plot(PerSet(sets, data, "1:4", "Q*/P"));
    return;
  }
  std::vector<Series> series = PerSet(sets, data, "1:2", labels.amplitude);
  if (labels.torsional && AnyRegime(sets)) {
    series = Joined(series, PerSet(sets, data, "1:14", "M_slip", 2));
  }
  script->text << "set ylabel "
               << GnuplotQuoted(labels.amplitude + " [" + labels.force_unit + "] (contact)") << "\n"
               << Plot(series);
}

// Q* (or Q*/P), Ed, A and B (and the contact's A), C (and the onset's) per cycle.
void AddCyclePlots(const std::vector<PlottedSet>& sets, const fs::path& data,
                   const std::string& png, Script* script) {
  script->Output(png);
  int cycles = 0;
  for (const PlottedSet& set : sets) cycles = std::max(cycles, set.analysis->cycles_size());
  script->text << "set multiplot layout 2,2 title 'figures per cycle'\nset key bottom right "
                  "font ',9'\nset xlabel 'cycle'\nunset title\n"
               << (cycles <= 20 ? "set xtics 1\n" : "");  // a tic per cycle while legible
  AddAmplitudePanel(sets, data, script);
  script->text << "set ylabel 'Ed [µJ] (contact)'\n"
               << Plot(PerSet(sets, data, "1:($5*1e6)", "Ed"));
  std::vector<Series> ratios = Joined(PerSet(sets, data, "1:8", "A (contact+rig)"),
                                      PerSet(sets, data, "1:9", "B (contact+rig)", 2));
  if (AnyContact(sets)) ratios = Joined(ratios, PerSet(sets, data, "1:10", "A_c (contact)", 3));
  script->text << "set ylabel 'A, B'\n" << Plot(ratios);
  std::vector<Series> c = PerSet(sets, data, "1:7", "C");
  if (AnyRegime(sets) && !sets.front().labels.torsional) {
    c = Joined(c, PerSet(sets, data, "1:12", "onset C", 2));
  }
  script->text << "set ylabel 'C (contact)'\n"
               << Plot(c) << "unset multiplot\nset xtics autofreq\nset key default\n";
}

// One block per set: u [m], measured F_x, model F_x [N] (phi [rad], M [N m]), counted (1) or
// burn-in (0).
void WriteFitLoops(const std::vector<PlottedSet>& sets, const fs::path& file) {
  std::ofstream out = DataFile(file);
  for (const PlottedSet& set : sets) {
    const auto& positions = LoopPositions(*set.samples);
    const auto& forces = LoopForces(*set.samples);
    out << "# " << set.label << ": position, measured force, model force, counted\n";
    for (int i = 0; i < positions.size(); ++i) {
      out << positions[i] << ' ' << forces[i] << ' ' << (*set.model)[i] << ' '
          << (static_cast<std::size_t>(i) >= set.first_counted) << '\n';
    }
    out << "\n\n";
  }
}

// One block per set: the sample index and the residual over the counted samples.
void WriteResiduals(const std::vector<PlottedSet>& sets, const fs::path& file) {
  std::ofstream out = DataFile(file);
  for (const PlottedSet& set : sets) {
    const auto& forces = LoopForces(*set.samples);
    out << "# " << set.label << ": counted sample, measured - model force\n";
    for (int i = static_cast<int>(set.first_counted); i < forces.size(); ++i) {
      out << i << ' ' << forces[i] - (*set.model)[i] << '\n';
    }
    out << "\n\n";
  }
}

// map.dat: one block per load, the map's loops (actuator amplitude, Q*/P, regime, P); onset.dat:
// one line per load; measured.dat: one line per measured cycle (delta*, Q*/P, regime, P).
void WriteMap(const std::vector<PlottedSet>& sets, const mdr::v1::FrettingMapResponse& map,
              const fs::path& dir) {
  std::ofstream loops = DataFile(dir / "map.dat");
  std::ofstream onsets = DataFile(dir / "onset.dat");
  for (const auto& load : map.loads()) {
    const double p = load.onset().normal_force();
    loops << "# P = " << p << " N: actuator amplitude[m] Q*/P regime P[N]\n";
    for (int i = 0; i < load.loops_size(); ++i) {
      loops << load.loops(i).actuator_amplitude() << ' ' << load.loops(i).force_amplitude() / p
            << ' ' << RegimeCode(load.regimes(i)) << ' ' << p << '\n';
    }
    loops << "\n\n";
    onsets << load.onset().actuator_amplitude() << ' ' << load.onset().force_amplitude() / p << ' '
           << p << '\n';
  }
  std::ofstream measured = DataFile(dir / "measured.dat");
  measured << "# delta*[m] Q*/P regime P[N] colour (the map's line of that load)\n";
  for (const PlottedSet& set : sets) {
    int colour = 0;
    for (int l = 0; l < map.loads_size(); ++l) {
      if (map.loads(l).onset().normal_force() == set.normal_force) colour = l + 1;
    }
    for (const CycleFigures& c : set.analysis->cycles()) {
      measured << c.displacement_amplitude() << ' ' << c.force_amplitude() / set.normal_force << ' '
               << RegimeCode(c.regime()) << ' ' << set.normal_force << ' ' << colour << '\n';
    }
  }
}

void AddFitLoopsPlot(const std::vector<PlottedSet>& sets, const fs::path& data, Script* script) {
  const ChannelLabels& labels = sets.front().labels;
  const PositionAxis axis = AxisOf(labels);
  const std::string x = Scaled(axis, 1);
  const int columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(sets.size()))));
  const int rows = static_cast<int>((sets.size() + columns - 1) / columns);
  script->text << "set terminal pngcairo size " << 420 * columns + 80 << "," << 340 * rows + 60
               << " noenhanced font ',10'\n";
  script->Output("loops.png");
  script->text << "set multiplot layout " << rows << "," << columns
               << " title 'measured (grey) and fitted (red) loops'\nset key top left font ',8'\n"
               << "set xlabel " << GnuplotQuoted(axis.label) << "\nset ylabel "
               << GnuplotQuoted(ForceAxis(labels))
               << "\n"
               // Twists in rad take many digits: turned, the tics of a narrow panel stay apart.
               << (labels.torsional ? "set xtics rotate by 30 right\n" : "");
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const std::string block = Q(data) + " index " + std::to_string(i);
    script->text << "set title " << GnuplotQuoted(sets[i].label) << "\n"
                 << Plot({{block, x + ":2", "points pt 7 ps 0.3 lc rgb '#999999'", "measured"},
                          {block, x + ":($4>0?1/0:$3)", "lines lw 1 dt 2 lc rgb '#f0a0a0'",
                           "fitted, burn-in"},
                          {block, x + ":($4>0?$3:1/0)", "lines lw 1.5 lc rgb '#d62728'",
                           "fitted, counted"}});
  }
  script->text << "unset multiplot\nset xtics norotate\n"
               << "set terminal pngcairo size 1000,700 noenhanced font ',11'\n";
}

// A panel per set: its residuals against its sample index, the force sensor's noise band and its
// adequacy verdict in the title.
void AddResidualsPlot(const std::vector<PlottedSet>& sets, const fs::path& data, Script* script) {
  const ChannelLabels& labels = sets.front().labels;
  const int columns = sets.size() > 4 ? 3 : sets.size() > 1 ? 2 : 1;
  const int rows = static_cast<int>((sets.size() + columns - 1) / columns);
  script->text << "set terminal pngcairo size " << 420 * columns << "," << 300 * rows
               << " noenhanced font ',10'\n";
  script->Output("residuals.png");
  script->text << "set multiplot layout " << rows << "," << columns << " title "
               << GnuplotQuoted("residuals of the fit, " + labels.force +
                                " measured - fitted, per set")
               << "\nset key top left font ',8'\nset xlabel 'sample'\nset ylabel "
               << GnuplotQuoted("residual [" + labels.force_unit + "]") << "\n";
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const PlottedSet& set = sets[i];
    std::string title = set.label;
    std::vector<Series> series{{Q(data) + " index " + std::to_string(i), "1:2",
                                "points pt 7 ps 0.3 lc " + std::to_string(i % 8 + 1), "residual"}};
    if (set.fit) {
      char verdict[160];
      std::snprintf(verdict, sizeof verdict, ": chi2 %.3g, structure p %.2g%s",
                    set.fit->reduced_chi_square(), set.fit->structure_p_value(),
                    set.fit->misfit() ? ", MISFIT" : "");
      title += verdict;
      const std::string band = std::to_string(2 * set.fit->force_noise());
      series.push_back({series.front().source, "1:(" + band + ")",
                        "lines lw 1 dt 2 lc rgb '#555555'", "+-2 " + labels.force_word + " noise"});
      series.push_back(
          {series.front().source, "1:(-" + band + ")", "lines lw 1 dt 2 lc rgb '#555555'", ""});
    }
    script->text << "set title " << GnuplotQuoted(title) << "\n" << Plot(series);
  }
  script->text << "unset multiplot\nset terminal pngcairo size 1000,700 noenhanced font ',11'\n"
               << "set key default\n";
}

void AddMapPlots(const mdr::v1::FrettingMapResponse& map, const fs::path& dir, Script* script) {
  script->Output("fretting_map.png");
  script->Labels("fretting map of the fitted scene: Q*/P against the actuator amplitude",
                 "actuator amplitude delta* [µm] (contact+rig)", "Q*/P");
  std::vector<Series> series;
  for (int l = 0; l < map.loads_size(); ++l) {
    series.push_back({Q(dir / "map.dat") + " index " + std::to_string(l), "($1*1e6):2",
                      "linespoints lw 1.5 pt 6 ps 0.8 lc " + std::to_string(l + 1),
                      "map, P = " + FormatNumberShort(map.loads(l).onset().normal_force()) + " N"});
  }
  series.push_back({Q(dir / "onset.dat"), "($1*1e6):2", "points pt 5 ps 1.6 lc rgb 'black'",
                    "onset of gross slip"});
  series.push_back({Q(dir / "measured.dat"), "($1*1e6):2:5", "points pt 9 ps 1.6 lc variable",
                    "measured cycles (coloured by load)"});
  script->text << "set key bottom right\nset logscale x\n" << Plot(series);

  script->Output("fretting_regimes.png");
  script->Labels("regimes: normal force against actuator amplitude",
                 "actuator amplitude delta* [µm] (contact+rig)", "normal force P [N]");
  const std::string m = Q(dir / "map.dat"), c = Q(dir / "measured.dat");
  script->text << Plot({{Q(dir / "onset.dat"), "($1*1e6):3", "linespoints lw 2 pt 5 lc rgb 'black'",
                         "boundary (onset of gross slip)"},
                        {m, "($1*1e6):($3==2?$4:1/0)", "points pt 6 ps 1 lc rgb '#2ca02c'",
                         "map: partial slip"},
                        {m, "($1*1e6):($3==3?$4:1/0)", "points pt 6 ps 1 lc rgb '#d62728'",
                         "map: gross slip"},
                        {c, "($1*1e6):($3==1?$4:1/0)", "points pt 9 ps 1.8 lc rgb '#1f77b4'",
                         "measured: sticking"},
                        {c, "($1*1e6):($3==2?$4:1/0)", "points pt 9 ps 1.8 lc rgb '#2ca02c'",
                         "measured: partial slip"},
                        {c, "($1*1e6):($3==3?$4:1/0)", "points pt 9 ps 1.8 lc rgb '#d62728'",
                         "measured: gross slip"}})
               << "unset logscale x\nset key default\n";
}

}  // namespace

mdr::Result<std::vector<std::string>> WriteFitPlots(const std::vector<PlottedSet>& sets,
                                                    const mdr::v1::FrettingMapResponse* map,
                                                    const std::string& dir) {
  TemporaryDirectory temporary;
  if (temporary.path().empty()) return mdr::Internal("--report", "cannot create a temporary dir");
  const fs::path& data = temporary.path();
  WriteFitLoops(sets, data / "loops.dat");
  WriteResiduals(sets, data / "residuals.dat");
  Script script(fs::absolute(dir));
  AddFitLoopsPlot(sets, data / "loops.dat", &script);
  AddResidualsPlot(sets, data / "residuals.dat", &script);
  if (map != nullptr) {
    WriteMap(sets, *map, data);
    AddMapPlots(*map, data, &script);
  }
  const fs::path script_file = data / "plots.gp";
  std::ofstream(script_file) << script.text.str();
  if (mdr::Status s = RunGnuplot(script_file.string(), "--report"); !s.ok()) return s;
  return script.pngs;
}

mdr::Result<std::vector<std::string>> WriteLoopsPlots(const PlottedSet& set, const std::string& dir,
                                                      const std::string& prefix) {
  TemporaryDirectory temporary;
  if (temporary.path().empty()) return mdr::Internal("--report", "cannot create a temporary dir");
  const fs::path out = fs::absolute(dir);
  WriteLoop(set, temporary.path() / "loop.dat");
  WriteCycles({set}, temporary.path() / "cycles.dat");
  Script script(out);
  script.Output(prefix + "loop.png");
  const PositionAxis axis = AxisOf(set.labels);
  const std::string x = Scaled(axis, 1);
  script.Labels(
      set.label + ": " + set.labels.force + " over " + set.labels.position + ", coloured by cycle",
      axis.label + " (contact+rig)", ForceAxis(set.labels));
  const int cycles = std::max(set.analysis->cycles_size(), 1);
  script.text << "set key top left\nset cbrange [0.5:" << cycles + 0.5 << "]\nset cblabel 'cycle'\n"
              << "set palette rgb 33,13,10\nplot " << Q(temporary.path() / "loop.dat") << " using "
              << x << ":2 with lines lc rgb '#bbbbbb' title 'outside complete cycles', "
              << Q(temporary.path() / "loop.dat") << " using " << x
              << ":($3>0?$2:1/0):3 with lines lw 1.5 lc palette title 'cycles'\n"
              << "unset colorbox\n";
  AddCyclePlots({set}, temporary.path() / "cycles.dat", prefix + "cycles.png", &script);
  const fs::path script_file = temporary.path() / "plots.gp";
  std::ofstream(script_file) << script.text.str();
  if (mdr::Status s = RunGnuplot(script_file.string(), "--report"); !s.ok()) return s;
  return script.pngs;
}

}  // namespace mdrctl
