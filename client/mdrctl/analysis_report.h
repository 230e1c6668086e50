// The reports of `mdrctl loops --report` and `mdrctl fit --report`: report.md for people (every
// number labelled with what it measures, the verdicts in words) and report.json with the same
// content in machine form (the service's messages as proto3 JSON, timings cleared to 0 so that a
// re-run reproduces the file).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "campaign.h"
#include "mdr/v1/analysis.pb.h"
#include "rig_csv.h"

namespace mdrctl {

// One CSV file (or one run of a file of several: csv.run) and what was computed from it; a
// torsional record's (layout.channel) forces are moments, its displacements twists.
struct ReportSet {
  std::string label;  // the file as given (and its run)
  RigData csv;
  CsvLayout layout;
  // N; NaN when unknown (mdrctl loops without a load). mdrctl fit: the declared one, else the
  // mean of the normal-force column.
  double normal_force = 0;
  std::optional<double> declared_normal_force;  // mdrctl fit: as the campaign gives it
  mdr::v1::AnalyzeLoopsResponse analysis;
  // mdrctl fit: the force (moment) the fitted model says the sensor should have read at each
  // sample, the first sample the fit counts and the RMS of measured minus model from it on.
  std::vector<double> model;
  std::size_t first_counted = 0;
  double replay_rms = 0;
};

struct Plots {
  std::vector<std::string> pngs;  // file names in the report directory
  std::string skipped;            // why there are none ("" when drawn)
};

struct LoopsReport {
  std::string label;  // the file's name
  // One set, or with a run column one per run analysed, in the file's order (their csv.run).
  std::vector<ReportSet> sets;
  std::string run_column;  // "" without
  mdr::v1::LoopAnalysisOptions options;
  std::string scene_source;  // the --scene file, "" without
  Plots plots;
};

struct FitReport {
  const Campaign* campaign = nullptr;
  std::vector<ReportSet> sets;
  mdr::v1::FitLoopsRequest request;  // without the samples
  mdr::v1::FitResult fit;
  double replay_rms = 0;  // over every set's counted samples
  std::size_t replay_residuals = 0;
  // N (N m): the largest difference between the model contact's forces (moments) and a session
  // of the fitted scene replayed along the model's path.
  double replay_difference = 0;
  mdr::v1::FrettingMapRequest map_request;
  mdr::v1::FrettingMapResponse map;
  // Why there is no fretting map ("" when there is one): a torsional campaign has none.
  std::string map_skipped;
  // A torsional campaign: the fitted scene's G_t in Pa (scene.torsion.torsional_modulus, else
  // its material's), which the fit replayed.
  double fitted_torsional_modulus = 0;
  Plots plots;
};

std::string LoopsMarkdown(const LoopsReport& report);
std::string LoopsJson(const LoopsReport& report);
std::string FitMarkdown(const FitReport& report);
std::string FitJson(const FitReport& report);

}  // namespace mdrctl
