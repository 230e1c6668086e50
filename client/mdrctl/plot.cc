#include "plot.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace mdrctl {
namespace {

namespace fs = std::filesystem;
using mdr::v1::RunReport;

// A gnuplot single-quoted string.
std::string Quoted(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("''") : std::string(1, c);
  return quoted + "'";
}

std::string ShellQuoted(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

std::string Title(const RunReport& report, const std::string& what) {
  return Quoted(report.title().empty() ? what : report.title() + ": " + what);
}

void WriteSteps(const RunReport& report, const fs::path& file) {
  std::ofstream out(file);
  out.precision(12);
  out << "# step ux[m] F_x[N] F_N[N] delta[m] a[m] W[J] in_contact partial_slip gross_slip "
         "phi[rad] M[N_m]\n";
  for (const auto& row : report.rows()) {
    const auto& s = row.state();
    const auto& totals = row.interface_totals();
    out << row.step() << ' ' << s.tangential_displacement() << ' ' << s.tangential_force() << ' '
        << s.normal_force() << ' ' << s.depth() << ' ' << s.contact_radius() << ' '
        << s.dissipated_energy() << ' ' << totals.in_contact() << ' ' << totals.partial_slip()
        << ' ' << totals.gross_slip() << ' ' << s.twist() << ' ' << s.twisting_moment() << '\n';
  }
}

// One line per cycle: its number over the run, the dissipated energy and the work of F_x.
void WriteCycles(const RunReport& report, const fs::path& file) {
  std::ofstream out(file);
  out.precision(12);
  out << (report.torsion() ? "# cycle W[J] work_of_M[J] segment\n"
                           : "# cycle W[J] work_of_F_x[J] segment\n");
  for (int i = 0; i < report.cycle_energies_size(); ++i) {
    const auto& cycle = report.cycle_energies(i);
    out << i + 1 << ' ' << cycle.dissipated_energy() << ' '
        << (report.torsion() ? cycle.twisting_work() : cycle.tangential_work()) << ' '
        << cycle.origin() << '\n';
  }
}

// One gnuplot data block per record (separated by two blank lines: "index i").
void WriteRecords(const RunReport& report, const fs::path& file) {
  std::ofstream out(file);
  out.precision(12);
  for (const auto& record : report.records()) {
    if (report.torsion()) {
      out << "# " << record.name() << ": r[m] tau_phi[Pa] route_difference[Pa]\n";
      for (const auto& traction : record.torsion_tractions()) {
        out << traction.radius() << ' ' << traction.value() << ' ' << traction.route_difference()
            << '\n';
      }
      out << "\n\n";
      continue;
    }
    out << "# " << record.name() << ": x[m] u[m] w[m] tau[Pa]\n";
    for (int i = 0; i < record.radii_size(); ++i) {
      out << record.radii(i) << ' ' << record.springs().tangential_displacement(i) << ' '
          << record.springs().normal_displacement(i) << ' '
          << (i < record.tractions_size() ? record.tractions(i).value() : 0.0) << '\n';
    }
    out << "\n\n";
  }
}

// The Jäger weight F(r) of each record as a step function (two points per interval).
void WriteWeights(const RunReport& report, const fs::path& file) {
  std::ofstream out(file);
  out.precision(12);
  for (const auto& record : report.records()) {
    out << "# " << record.name() << ": r[m] F\n";
    for (const auto& interval : record.jager_weights().intervals()) {
      out << interval.r_begin() << ' ' << interval.weight() << '\n'
          << interval.r_end() << ' ' << interval.weight() << '\n';
    }
    out << "\n\n";
  }
}

// "plot" over every record's block of `data` for which `has` holds.
template <typename Has>
std::string PlotRecords(const RunReport& report, const fs::path& data, const std::string& using_,
                        Has has) {
  std::string plot;
  for (int i = 0; i < report.records_size(); ++i) {
    if (!has(report.records(i))) continue;
    plot += (plot.empty() ? "plot " : ", ") + Quoted(data.string()) + " index " +
            std::to_string(i) + " using " + using_ + " with lines lw 2 title " +
            Quoted(report.records(i).name());
  }
  return plot + "\n";
}

struct Script {
  std::ostringstream text;
  std::vector<std::string> pngs;

  void Begin(const fs::path& png, const std::string& title, const std::string& xlabel,
             const std::string& ylabel) {
    pngs.push_back(png.string());
    text << "set output " << Quoted(png.string()) << "\nset title " << title << "\nset xlabel "
         << Quoted(xlabel) << "\nset ylabel " << Quoted(ylabel) << "\n";
  }
};

void AddStepPlots(const RunReport& report, const fs::path& dir, Script* script) {
  const std::string steps = Quoted((dir / "steps.dat").string());
  if (report.torsion()) {  // the loop is M over phi; F_N and M over the path
    script->Begin(dir / "hysteresis.png", Title(report, "M over phi"), "phi [mrad]", "M [N mm]");
    script->text << "plot " << steps << " using ($11*1e3):($12*1e3) with lines lw 2 title 'M'\n";
    script->Begin(dir / "forces.png", Title(report, "normal force over the loading path"), "step",
                  "F_N [N]");
    script->text << "plot " << steps << " using 1:4 with lines lw 2 title 'F_N'\n";
    script->Begin(dir / "moment.png", Title(report, "twisting moment over the loading path"),
                  "step", "M [N mm]");
    script->text << "plot " << steps << " using 1:($12*1e3) with lines lw 2 title 'M'\n";
    return;
  }
  script->Begin(dir / "hysteresis.png", Title(report, "F_x over u_x"), "u_x [µm]", "F_x [N]");
  script->text << "plot " << steps << " using ($2*1e6):3 with lines lw 2 title 'F_x'\n";
  script->Begin(dir / "forces.png", Title(report, "forces over the loading path"), "step",
                "force [N]");
  script->text << "plot " << steps << " using 1:3 with lines lw 2 title 'F_x', " << steps
               << " using 1:4 with lines lw 2 title 'F_N'\n";
  const auto has_totals = [](const RunReport::Row& row) { return row.has_interface_totals(); };
  if (std::any_of(report.rows().begin(), report.rows().end(), has_totals)) {
    script->Begin(dir / "counts.png", Title(report, "contacts over the loading path"), "step",
                  "contacts");
    script->text << "plot " << steps << " using 1:8 with lines lw 2 title 'in contact', " << steps
                 << " using 1:9 with lines lw 2 title 'partial slip', " << steps
                 << " using 1:10 with lines lw 2 title 'gross slip'\n";
  }
}

// Bars of the energy dissipated per cycle, points of the work of F_x around the loop.
void AddCyclePlot(const RunReport& report, const fs::path& dir, Script* script) {
  if (report.cycle_energies().empty()) return;
  const std::string cycles = Quoted((dir / "cycles.dat").string());
  script->Begin(dir / "energy_per_cycle.png", Title(report, "energy per cycle"), "cycle",
                "energy [µJ]");
  script->text << "set yrange [0:*]\nset xtics 1\nset style fill solid 0.5\nset boxwidth 0.6\n"
               << "plot " << cycles << " using 1:($2*1e6) with boxes title 'dissipated', " << cycles
               << " using 1:($3*1e6) with points pt 7 ps 1.5 title "
               << (report.torsion() ? "'work of M'" : "'work of F_x'") << "\n"
               << "set autoscale y\nset xtics autofreq\n";
}

void AddRecordPlots(const RunReport& report, const fs::path& dir, Script* script) {
  if (report.records().empty()) return;
  const fs::path records = dir / "records.dat";
  if (report.torsion()) {
    script->Begin(dir / "tractions.png", Title(report, "circumferential traction"), "r [mm]",
                  "tau_{phi} [MPa]");
    script->text << PlotRecords(report, records, "($1*1e3):($2*1e-6)", [](auto&) { return true; });
    return;
  }
  script->Begin(dir / "profiles.png", Title(report, "spring displacements u(x)"), "x [mm]",
                "u [µm]");
  script->text << PlotRecords(report, records, "($1*1e3):($2*1e6)", [](auto&) { return true; });
  const auto has_tractions = [](const RunReport::Record& r) { return r.tractions_size() > 0; };
  if (std::any_of(report.records().begin(), report.records().end(), has_tractions)) {
    script->Begin(dir / "tractions.png", Title(report, "tangential traction"), "r [mm]",
                  "tau [MPa]");
    script->text << PlotRecords(report, records, "($1*1e3):($4*1e-6)", has_tractions);
  }
  const auto has_weights = [](const RunReport::Record& r) {
    return r.jager_weights().intervals_size() > 0;
  };
  if (std::any_of(report.records().begin(), report.records().end(), has_weights)) {
    script->Begin(dir / "weights.png", Title(report, "Jäger weight F(r)"), "r [mm]", "F");
    script->text << PlotRecords(report, dir / "weights.dat", "($1*1e3):2", has_weights);
  }
}

}  // namespace

bool GnuplotInstalled() {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path == nullptr ? "" : path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (!dir.empty() && ::access((fs::path(dir) / "gnuplot").c_str(), X_OK) == 0) return true;
  }
  return false;
}

std::string GnuplotQuoted(const std::string& text) { return Quoted(text); }

mdr::Status RunGnuplot(const std::string& script_file, const std::string& option) {
  const std::string command = "gnuplot " + ShellQuoted(script_file);
  if (std::system(command.c_str()) != 0) {
    return mdr::FailedPrecondition(option, "gnuplot failed on " + script_file);
  }
  return mdr::OkStatus();
}

mdr::Status CheckGnuplot() {
  if (GnuplotInstalled()) return mdr::OkStatus();
  return mdr::FailedPrecondition("--plot",
                                 "gnuplot is not installed (not found on PATH); install it, e.g. "
                                 "apt-get install gnuplot-nox, or run without --plot");
}

mdr::Result<std::vector<std::string>> WritePlots(const RunReport& report, const std::string& dir) {
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) return mdr::InvalidArgument("--plot", "cannot create " + dir + ": " + error.message());
  const fs::path root = fs::absolute(dir);
  WriteSteps(report, root / "steps.dat");
  WriteRecords(report, root / "records.dat");
  WriteWeights(report, root / "weights.dat");
  WriteCycles(report, root / "cycles.dat");
  Script script;
  script.text << "set terminal pngcairo size 900,600 enhanced font ',11'\nset grid\n"
              << "set key top left\n";
  AddStepPlots(report, root, &script);
  AddCyclePlot(report, root, &script);
  AddRecordPlots(report, root, &script);
  const fs::path script_file = root / "plots.gp";
  std::ofstream(script_file) << script.text.str();
  if (mdr::Status s = RunGnuplot(script_file.string(), "--plot"); !s.ok()) return s;
  return script.pngs;
}

}  // namespace mdrctl
