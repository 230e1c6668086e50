// mdrctl loops, fit and synthesize: from a rig's CSV or MATLAB files to a report (docs/analysis.md,
// "From a rig's CSV or MATLAB files to a report").
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <sstream>

#include "analysis_plot.h"
#include "analysis_report.h"
#include "campaign.h"
#include "commands.h"
#include "connection.h"
#include "json_writer.h"
#include "loop_sessions.h"
#include "mdr/analysis/identify.h"
#include "mdr/base/validate.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/scene_file.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/client/error_details.h"
#include "mdr/core/material.h"
#include "plot.h"
#include "report_format.h"
#include "rig_csv.h"

namespace mdrctl {
namespace {

namespace fs = std::filesystem;
using mdr::client::ContactClient;

// ---- shared ----

mdr::Status MakeDirectory(const std::string& dir, const std::string& option) {
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) return mdr::InvalidArgument(option, "cannot create " + dir + ": " + error.message());
  return mdr::OkStatus();
}

mdr::Status WriteText(const fs::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary);
  if (!(out << text) || !out.flush()) {
    return mdr::InvalidArgument(file.string(), "cannot write");
  }
  return mdr::OkStatus();
}

// A service error about one sample of this file restated at its line and column (MAT: element
// and variable).
mdr::Status SampleError(const grpc::Status& status, const RigData& csv, const CsvLayout& layout) {
  const mdr::client::ErrorDetails details = mdr::client::ReadErrorDetails(status);
  if (details.field.empty()) return mdr::InvalidArgument(csv.path, status.error_message());
  return LocateSampleError(details.field, details.description, csv, layout);
}

// The G_t a torsional scene twists with: scene.torsion.torsional_modulus, else its material's
// (the service's own conversion). Errors name the Scene's fields ("scene.elastic_pair...").
mdr::Result<double> TorsionalModulus(const mdr::v1::Scene& scene) {
  auto config = mdr::bridge::ToContactConfig(scene, std::numeric_limits<std::size_t>::max());
  if (!config.ok()) return config.status();
  auto torsion = mdr::bridge::ToTorsionalScene(scene, *config);
  if (!torsion.ok()) return torsion.status();
  return torsion->torsional_modulus;
}

// The scene's rig compliance for a record of `channel`: a tangential record's scene.rig, a
// torsional one's shaft (scene.torsion.rig_compliance, when not 0); nothing without.
std::optional<double> SceneRigCompliance(const mdr::v1::Scene& scene,
                                         mdr::analysis::LoopChannel channel) {
  if (channel == mdr::analysis::LoopChannel::kTorsional) {
    if (scene.has_torsion() && scene.torsion().rig_compliance() != 0) {
      return scene.torsion().rig_compliance();
    }
    return std::nullopt;
  }
  if (scene.has_rig()) return scene.rig().tangential_compliance();
  return std::nullopt;
}

mdr::v1::AnalyzeLoopsRequest AnalysisRequest(const RigData& csv,
                                             const mdr::v1::LoopAnalysisOptions& options,
                                             const mdr::v1::Scene* scene) {
  mdr::v1::AnalyzeLoopsRequest request;
  *request.mutable_samples() = csv.samples;
  *request.mutable_options() = options;
  if (scene != nullptr) *request.mutable_scene() = *scene;
  return request;
}

// The PNGs of a report, or why there are none (gnuplot missing or failing does not fail the
// report: the Markdown and the JSON are written either way).
template <typename Draw>
Plots DrawPlots(Draw draw) {
  Plots plots;
  if (!GnuplotInstalled()) {
    plots.skipped =
        "gnuplot is not installed (not found on PATH; apt-get install gnuplot-nox draws them)";
    return plots;
  }
  auto pngs = draw();
  if (pngs.ok()) {
    plots.pngs = *pngs;
  } else {
    plots.skipped = pngs.status().ToString();
  }
  return plots;
}

mdr::Status WriteReport(const std::string& dir, const std::string& markdown,
                        const std::string& json, const Plots& plots) {
  if (auto s = WriteText(fs::path(dir) / "report.md", markdown); !s.ok()) return s;
  if (auto s = WriteText(fs::path(dir) / "report.json", json); !s.ok()) return s;
  std::fprintf(stderr, "mdrctl: wrote %s/report.md, report.json", dir.c_str());
  if (plots.skipped.empty()) {
    std::fprintf(stderr, " and %zu plots\n", plots.pngs.size());
  } else {
    std::fprintf(stderr, "; plots skipped: %s\n", plots.skipped.c_str());
  }
  return mdr::OkStatus();
}

// ---- loops ----

// An AnalyzeLoops error in the command line's terms: a sample or column at its CSV line, an
// option by its flag, the scene at its file's line.
mdr::Status LoopsError(const grpc::Status& status, const RigData& csv, const CsvLayout& layout,
                       const mdr::bridge::SceneDocument* scene) {
  const mdr::client::ErrorDetails details = mdr::client::ReadErrorDetails(status);
  const std::string& field = details.field;
  if (field.starts_with("samples.")) return SampleError(status, csv, layout);
  if (field.starts_with("options.")) {
    std::string flag = "--" + field.substr(8);
    std::replace(flag.begin(), flag.end(), '_', '-');
    return mdr::InvalidArgument(flag, details.description);
  }
  if (field.starts_with("scene") && scene != nullptr) {
    return scene->Error(field, details.description);
  }
  return mdr::InvalidArgument("", status.error_message());
}

// The record's channel from the options: torsional when any torsional option is given, and then
// no tangential column or unit may be given (the error names it and the torsional option).
mdr::Result<mdr::analysis::LoopChannel> ChannelFromArgs(const LoopsArgs& args) {
  const std::pair<bool, const char*> torsional[] = {
      {args.twist_column.has_value(), "--twist-column"},
      {args.moment_column.has_value(), "--moment-column"},
      {args.twist_unit.has_value(), "--twist-unit"},
      {args.moment_unit.has_value(), "--moment-unit"}};
  const char* torsional_option = nullptr;
  for (const auto& [given, option] : torsional) {
    if (given && torsional_option == nullptr) torsional_option = option;
  }
  if (torsional_option == nullptr) return mdr::analysis::LoopChannel::kTangential;
  const std::pair<bool, const char*> tangential[] = {
      {args.displacement_column.has_value(), "--displacement-column"},
      {args.force_column.has_value(), "--force-column"},
      {args.displacement_unit.has_value(), "--displacement-unit"}};
  for (const auto& [given, option] : tangential) {
    if (!given) continue;
    return mdr::InvalidArgument(
        option, std::string("cannot be combined with ") + torsional_option +
                    ": a record is tangential (--displacement-column, --force-column, "
                    "--displacement-unit) or torsional (--twist-column, --moment-column, "
                    "--twist-unit, --moment-unit), not both");
  }
  return mdr::analysis::LoopChannel::kTorsional;
}

// A unit option's factor to SI, `fallback` when it is not given.
mdr::Status ReadUnit(Quantity quantity, const std::optional<std::string>& unit,
                     const char* fallback, const std::string& option, double* factor) {
  auto value = UnitFactor(quantity, unit.value_or(fallback), option);
  if (!value.ok()) return value.status();
  *factor = *value;
  return mdr::OkStatus();
}

mdr::Result<CsvLayout> LayoutFromArgs(const LoopsArgs& args) {
  auto channel = ChannelFromArgs(args);
  if (!channel.ok()) return channel.status();
  CsvLayout layout;
  layout.channel = *channel;
  layout.displacement_column = args.displacement_column.value_or(layout.displacement_column);
  layout.force_column = args.force_column.value_or(layout.force_column);
  layout.twist_column = args.twist_column.value_or(layout.twist_column);
  layout.moment_column = args.moment_column.value_or(layout.moment_column);
  layout.normal_force_column = args.normal_force_column;
  layout.time_column = args.time_column;
  layout.run_column = args.run_column;
  for (const mdr::Status& s :
       {ReadUnit(Quantity::kDisplacement, args.displacement_unit, "m", "--displacement-unit",
                 &layout.displacement_unit),
        ReadUnit(Quantity::kTwist, args.twist_unit, "rad", "--twist-unit", &layout.twist_unit),
        ReadUnit(Quantity::kMoment, args.moment_unit, "N m", "--moment-unit", &layout.moment_unit),
        ReadUnit(Quantity::kForce, args.force_unit, "N", "--force-unit", &layout.force_unit),
        ReadUnit(Quantity::kTime, args.time_unit, "s", "--time-unit", &layout.time_unit)}) {
    if (!s.ok()) return s;
  }
  return layout;
}

mdr::v1::LoopAnalysisOptions LoopsOptions(const LoopsArgs& args, const CsvLayout& layout,
                                          const mdr::v1::Scene* scene) {
  mdr::v1::LoopAnalysisOptions options;
  options.set_reversal_threshold(args.reversal_threshold);
  options.set_displacement_resolution(args.displacement_resolution);
  if (args.normal_force) options.set_normal_force(*args.normal_force);
  const std::optional<double> from_scene =
      scene != nullptr ? SceneRigCompliance(*scene, layout.channel) : std::nullopt;
  if (args.rig_compliance) {
    options.set_rig_compliance(*args.rig_compliance);
  } else if (from_scene) {
    options.set_rig_compliance(*from_scene);
  }
  return options;
}

// What mdrctl loops analyses: the file, or with --run-column each of its runs (or the --run).
mdr::Result<std::vector<RigData>> LoopsRuns(const LoopsArgs& args, const CsvLayout& layout,
                                            const RigData& file) {
  if (!args.run) return SplitRuns(file);
  auto run = SelectRun(file, layout, *args.run);
  if (!run.ok()) return run.status();
  return std::vector<RigData>{std::move(run).value()};
}

// The figures of one run (or the whole file), its errors at the file's lines.
mdr::Result<ReportSet> AnalyzeRun(Connection& connection, const LoopsArgs& args,
                                  const CsvLayout& layout,
                                  const mdr::v1::LoopAnalysisOptions& options,
                                  const mdr::bridge::SceneDocument* document, RigData run) {
  const mdr::v1::Scene* scene = document ? &document->file().scene() : nullptr;
  const mdr::v1::AnalyzeLoopsRequest request = AnalysisRequest(run, options, scene);
  auto analysis = connection.client().AnalyzeLoops(request);
  if (!analysis.ok()) {
    if (auto large = RequestTooLarge(analysis.status(), args.file, request.ByteSizeLong())) {
      return *large;
    }
    return LoopsError(analysis.status(), run, layout, document);
  }
  ReportSet set;
  set.label = fs::path(args.file).filename().string();
  set.csv = std::move(run);
  set.layout = layout;
  set.normal_force = options.has_normal_force() ? options.normal_force() : std::nan("");
  set.analysis = std::move(analysis).value();
  return set;
}

void PrintLoops(const LoopsArgs& args, const std::vector<ReportSet>& sets, Format format) {
  const ChannelLabels labels = LabelsOf(sets.front().layout.channel);
  if (args.run_column.empty()) {
    PrintLoopAnalysis(sets.front().analysis, labels, format, stdout);
    return;
  }
  std::vector<RunAnalysis> runs;
  for (const ReportSet& set : sets) {
    runs.push_back({*set.csv.run, set.csv.lines.size(), set.csv.lines.front(), set.csv.lines.back(),
                    &set.analysis});
  }
  PrintRunAnalyses(runs, labels, format, stdout);
}

// loop.png and cycles.png, or per run run1_loop.png, run1_cycles.png, ... in the file's order.
mdr::Result<std::vector<std::string>> WriteLoopsReportPlots(const LoopsReport& report,
                                                            const std::string& dir) {
  std::vector<std::string> pngs;
  for (std::size_t k = 0; k < report.sets.size(); ++k) {
    const ReportSet& set = report.sets[k];
    const std::string prefix = report.run_column.empty() ? "" : "run" + std::to_string(k + 1) + "_";
    const std::string title = set.label + (set.csv.run ? " run " + Printable(*set.csv.run) : "");
    const PlottedSet plotted{title,         &set.csv.samples,
                             &set.analysis, set.normal_force,
                             nullptr,       0,
                             nullptr,       LabelsOf(set.layout.channel)};
    auto written = WriteLoopsPlots(plotted, dir, prefix);
    if (!written.ok()) return written.status();
    pngs.insert(pngs.end(), written->begin(), written->end());
  }
  return pngs;
}

}  // namespace

int LoopsCommand(const Common& common, const LoopsArgs& args) {
  if (args.run && args.run_column.empty()) {
    return Fail(mdr::InvalidArgument("--run", "needs --run-column, the column of the runs' ids"));
  }
  auto layout = LayoutFromArgs(args);
  if (!layout.ok()) return Fail(layout.status());
  auto file = ReadRigFile(args.file, *layout);
  if (!file.ok()) return Fail(file.status());
  auto runs = LoopsRuns(args, *layout, *file);
  if (!runs.ok()) return Fail(runs.status());
  std::optional<mdr::bridge::SceneDocument> document;
  if (!args.scene.empty()) {
    auto loaded = mdr::bridge::SceneDocument::Load(args.scene);
    if (!loaded.ok()) return Fail(loaded.status());
    document = std::move(loaded).value();
  }
  if (!args.report_dir.empty()) {
    if (auto s = MakeDirectory(args.report_dir, "--report"); !s.ok()) return Fail(s);
  }
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status());
  const mdr::v1::LoopAnalysisOptions options =
      LoopsOptions(args, *layout, document ? &document->file().scene() : nullptr);
  LoopsReport report;
  report.label = fs::path(args.file).filename().string();
  report.run_column = args.run_column;
  report.options = options;
  report.scene_source = args.scene;
  for (RigData& run : *runs) {
    auto set = AnalyzeRun(**connection, args, *layout, options, document ? &*document : nullptr,
                          std::move(run));
    if (!set.ok()) return Fail(set.status());
    report.sets.push_back(std::move(set).value());
  }
  PrintLoops(args, report.sets, common.format);
  if (args.report_dir.empty()) return EXIT_SUCCESS;
  report.plots = DrawPlots([&] { return WriteLoopsReportPlots(report, args.report_dir); });
  const mdr::Status written =
      WriteReport(args.report_dir, LoopsMarkdown(report), LoopsJson(report), report.plots);
  return written.ok() ? EXIT_SUCCESS : Fail(written);
}

}  // namespace mdrctl

// ---- fit ----
namespace mdrctl {
namespace {

// The files of a campaign, each read once per layout: several sets may take runs of one file.
class CampaignFiles {
 public:
  mdr::Result<const RigData*> Read(const CampaignSet& set) {
    const std::string key = set.path + '\0' + LayoutKey(set.layout);
    auto found = files_.find(key);
    if (found == files_.end()) {
      auto read = ReadRigFile(set.path, set.layout);
      if (!read.ok()) return read.status();
      found = files_.emplace(key, std::move(read).value()).first;
    }
    return &found->second;
  }

 private:
  static std::string LayoutKey(const CsvLayout& layout) {
    std::string key;
    key += IsTorsional(layout) ? "torsional" : "tangential";
    key += '\0';
    for (const std::string* name :
         {&layout.displacement_column, &layout.force_column, &layout.twist_column,
          &layout.moment_column, &layout.normal_force_column, &layout.time_column,
          &layout.run_column}) {
      key += *name + '\0';
    }
    for (double unit : {layout.displacement_unit, layout.force_unit, layout.time_unit,
                        layout.twist_unit, layout.moment_unit}) {
      char text[32];  // the shortest text that reads back as the same factor
      key.append(text, std::to_chars(text, text + sizeof text, unit).ptr);
      key += '\0';
    }
    return key;
  }
  std::map<std::string, RigData> files_;
};

// A set's samples: its file, or with a run column the set's run (a file of one run needs none).
mdr::Result<RigData> SetSamples(const Campaign& campaign, std::size_t index, CampaignFiles* files) {
  const CampaignSet& set = campaign.sets[index];
  auto file = files->Read(set);
  if (!file.ok()) return file.status();
  const RigData& data = **file;
  if (set.layout.run_column.empty()) return data;
  const std::string field = mdr::Indexed("sets", index);
  if (set.run) {
    auto run = SelectRun(data, set.layout, *set.run);
    if (run.ok()) return run;
    return mdr::InvalidArgument(
        run.status().field(),
        run.status().message() + " (" + campaign.lines.Where(field + ".run") + ")");
  }
  if (data.runs.size() == 1) return SplitRuns(data).front();
  return campaign.lines.Error(field, "its file " + set.path + " holds " +
                                         std::to_string(data.runs.size()) + " runs in column " +
                                         Printable(set.layout.run_column) + " (" +
                                         RunIds(data.runs) + "): choose one with run: ID");
}

double MeanOf(const google::protobuf::RepeatedField<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? std::nan("") : sum / values.size();
}

mdr::Result<std::vector<ReportSet>> ReadSets(const Campaign& campaign) {
  std::vector<ReportSet> sets;
  CampaignFiles files;
  for (std::size_t i = 0; i < campaign.sets.size(); ++i) {
    const CampaignSet& set = campaign.sets[i];
    auto csv = SetSamples(campaign, i, &files);
    if (!csv.ok()) return csv.status();
    ReportSet& read = sets.emplace_back();
    read.label = set.file + (csv->run ? " run " + Printable(*csv->run) : "");
    read.csv = std::move(csv).value();
    read.layout = set.layout;
    read.declared_normal_force = set.normal_force;
    read.normal_force = set.normal_force.value_or(MeanOf(read.csv.samples.normal_force()));
  }
  return sets;
}

// A service error about the campaign: at the CSV's line and column for a sample, else at the
// campaign's line of the field (the request's fields carry the campaign's names).
mdr::Status CampaignError(const grpc::Status& status, const Campaign& campaign,
                          const std::vector<ReportSet>& sets, int set = -1) {
  const mdr::client::ErrorDetails details = mdr::client::ReadErrorDetails(status);
  std::string field = details.field;
  if (set >= 0 && !field.empty() && !field.starts_with("scene")) {
    field = mdr::Indexed("sets", static_cast<std::size_t>(set)) + "." + field;
  }
  if (field.empty()) return mdr::InvalidArgument(campaign.path, status.error_message());
  const std::string prefix = "sets[";
  if (field.starts_with(prefix)) {
    const std::size_t close = field.find(']');
    const std::size_t i = std::stoul(field.substr(prefix.size(), close - prefix.size()));
    const std::string rest = field.substr(std::min(field.size(), close + 2));
    if (i < sets.size() && rest.starts_with("samples.")) {
      return LocateSampleError(rest, details.description, sets[i].csv, sets[i].layout);
    }
    if (i < sets.size() && rest != "normal_force" && !rest.empty()) {
      return mdr::InvalidArgument(sets[i].csv.path, rest + ": " + details.description);
    }
  }
  return campaign.lines.Error(field, details.description);
}

mdr::v1::LoopAnalysisOptions SetOptions(const Campaign& campaign, const ReportSet& set,
                                        const mdr::v1::Scene& scene) {
  mdr::v1::LoopAnalysisOptions options;
  options.set_reversal_threshold(campaign.reversal_threshold);
  options.set_displacement_resolution(campaign.displacement_resolution);
  options.set_normal_force(set.normal_force);
  if (const std::optional<double> c = SceneRigCompliance(scene, campaign.channel)) {
    options.set_rig_compliance(*c);
  }
  return options;
}

// Every set's cycles, classified against `scene` (with its rig's compliance for the contact
// figures).
mdr::Status AnalyzeSets(ContactClient& client, const Campaign& campaign,
                        const mdr::v1::Scene& scene, std::vector<ReportSet>* sets) {
  for (std::size_t i = 0; i < sets->size(); ++i) {
    ReportSet& set = (*sets)[i];
    const mdr::v1::AnalyzeLoopsRequest request =
        AnalysisRequest(set.csv, SetOptions(campaign, set, scene), &scene);
    auto analysis = client.AnalyzeLoops(request);
    if (!analysis.ok()) {
      if (auto large = RequestTooLarge(analysis.status(), set.csv.path, request.ByteSizeLong())) {
        return *large;
      }
      return CampaignError(analysis.status(), campaign, *sets, static_cast<int>(i));
    }
    set.analysis = std::move(analysis).value();
  }
  return mdr::OkStatus();
}

mdr::v1::FitLoopsRequest FitRequest(const Campaign& campaign, const std::vector<ReportSet>& sets,
                                    bool with_samples) {
  mdr::v1::FitLoopsRequest request;
  *request.mutable_scene() = campaign.scene;
  for (const ReportSet& set : sets) {
    auto* loop_set = request.add_sets();
    if (set.declared_normal_force) loop_set->set_normal_force(*set.declared_normal_force);
    if (!with_samples) continue;
    // Every column the campaign names: the measured normal force is replayed, the time carries
    // the drift and the inertia.
    *loop_set->mutable_samples() = set.csv.samples;
  }
  for (const auto& free : campaign.free) *request.add_free() = free;
  *request.mutable_nuisances() = campaign.nuisances;
  if (campaign.displacement_noise) request.set_displacement_noise(*campaign.displacement_noise);
  if (campaign.force_noise) request.set_force_noise(*campaign.force_noise);
  request.set_include_models(with_samples);
  if (campaign.burn_in_reversals) request.set_burn_in_reversals(*campaign.burn_in_reversals);
  request.set_reversal_threshold(campaign.reversal_threshold);
  request.set_max_iterations(campaign.max_iterations);
  return request;
}

void PrintProgress(const mdr::v1::FitLoopsRequest& request, const ChannelLabels& labels,
                   const mdr::v1::FitProgress& progress) {
  std::string values;
  for (int k = 0; k < progress.values_size() && k < request.free_size(); ++k) {
    values += std::string(k ? ", " : "") + FitParameterName(request.free(k).parameter()) + " " +
              FormatValue(progress.values(k));
  }
  std::fprintf(stderr, "mdrctl: fit iteration %d: residual RMS %s %s (%s)\n", progress.iteration(),
               FormatValue(progress.residual_rms()).c_str(), labels.force_unit.c_str(),
               values.c_str());
}

// The model contact's forces (moments) replayed through a session of the fitted scene. A
// torsional set's session twists the contact itself (sessions hold no shaft): to the model's
// actuator twist less the shaft's C M, at the set's constant normal force.
mdr::client::RpcResult<std::vector<double>> ReplayModel(ContactClient& client,
                                                        const mdr::v1::Scene& fitted,
                                                        const mdr::v1::SetModel& model,
                                                        const mdr::v1::SetFit& set_fit) {
  const std::vector<double> path(model.actuator_path().begin(), model.actuator_path().end());
  if (fitted.has_torsion()) {
    const double compliance = fitted.torsion().rig_compliance();
    std::vector<double> twists(path.size());
    for (std::size_t k = 0; k < path.size(); ++k) {
      twists[k] = path[k] - compliance * model.contact_force(static_cast<int>(k));
    }
    const double load =
        model.normal_force().empty() ? set_fit.normal_force() : model.normal_force(0);
    return ReplayTwists(client, fitted, load, twists);
  }
  std::vector<double> normal;
  if (set_fit.normal_force_measured())
    normal.assign(model.normal_force().begin(), model.normal_force().end());
  return ReplayForces(client, fitted, set_fit.normal_force(), normal, path);
}

// Each set's model as the fit returned it (FitResult.models): the forces the sensor should have
// read, and the residual RMS over the counted samples, per set and over every set. The model
// contact's forces are checked against a session of the fitted scene replayed along the model's
// own actuator path and normal force (the largest difference is reported): the loops in the
// report are the exact engine's.
mdr::Status ReplaySets(ContactClient& client, const mdr::v1::FitResult& fit, FitReport* report) {
  double sum = 0;
  std::size_t count = 0;
  if (fit.models_size() != static_cast<int>(report->sets.size()) ||
      fit.sets_size() != static_cast<int>(report->sets.size())) {
    return mdr::Internal(report->campaign->path, "the fit returned no model of every set");
  }
  report->replay_difference = 0;
  for (std::size_t i = 0; i < report->sets.size(); ++i) {
    ReportSet& set = report->sets[i];
    const mdr::v1::SetModel& model = fit.models(static_cast<int>(i));
    const mdr::v1::SetFit& set_fit = fit.sets(static_cast<int>(i));
    auto replayed = ReplayModel(client, fit.fitted_scene(), model, set_fit);
    if (!replayed.ok()) {
      return mdr::Internal(set.csv.path, "the replay of the fitted scene failed: " +
                                             replayed.status().error_message());
    }
    for (std::size_t k = 0; k < replayed->size(); ++k) {
      report->replay_difference =
          std::max(report->replay_difference,
                   std::abs((*replayed)[k] - model.contact_force(static_cast<int>(k))));
    }
    set.model.assign(model.predicted_force().begin(), model.predicted_force().end());
    set.first_counted = set_fit.first_residual();
    const auto& measured = LoopForces(set.csv.samples);
    double set_sum = 0;
    for (std::size_t k = set.first_counted; k < set.model.size(); ++k) {
      const double r = measured[static_cast<int>(k)] - set.model[k];
      set_sum += r * r;
    }
    const std::size_t set_count = set.model.size() - set.first_counted;
    set.replay_rms = set_count > 0 ? std::sqrt(set_sum / static_cast<double>(set_count)) : 0;
    sum += set_sum;
    count += set_count;
  }
  report->replay_rms = count > 0 ? std::sqrt(sum / static_cast<double>(count)) : 0;
  report->replay_residuals = count;
  return mdr::OkStatus();
}

mdr::v1::FrettingMapRequest MapRequest(const Campaign& campaign, const std::vector<ReportSet>& sets,
                                       const mdr::v1::Scene& fitted) {
  mdr::v1::FrettingMapRequest request;
  *request.mutable_scene() = fitted;
  std::vector<double> loads = campaign.map_normal_forces;
  if (loads.empty()) {
    const std::set<double> distinct = [&] {
      std::set<double> s;
      for (const ReportSet& set : sets) s.insert(set.normal_force);
      return s;
    }();
    loads.assign(distinct.begin(), distinct.end());
  }
  request.mutable_normal_forces()->Add(loads.begin(), loads.end());
  const std::vector<double> amplitudes = campaign.map_relative_amplitudes.empty()
                                             ? DefaultMapAmplitudes()
                                             : campaign.map_relative_amplitudes;
  request.mutable_relative_amplitudes()->Add(amplitudes.begin(), amplitudes.end());
  return request;
}

std::vector<PlottedSet> PlottedSets(const std::vector<ReportSet>& sets,
                                    const mdr::v1::FitResult& fit) {
  std::vector<PlottedSet> plotted;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const ReportSet& set = sets[i];
    plotted.push_back(
        {set.label, &set.csv.samples, &set.analysis, set.normal_force, &set.model,
         set.first_counted,
         i < static_cast<std::size_t>(fit.sets_size()) ? &fit.sets(static_cast<int>(i)) : nullptr,
         LabelsOf(set.layout.channel)});
  }
  return plotted;
}

// A torsional campaign's fitted G_t (the scene's, or its material's) and why it has no map: the
// service draws none of a torsional scene.
mdr::Status FittedTorsion(const Campaign& campaign, const mdr::v1::Scene& fitted,
                          FitReport* report) {
  auto modulus = TorsionalModulus(fitted);
  if (!modulus.ok())
    return campaign.lines.Error(modulus.status().field(), modulus.status().message());
  report->fitted_torsional_modulus = *modulus;
  report->map_skipped =
      "A torsional campaign has no fretting map: a twisted contact of a smooth profile never "
      "slides as a whole at a finite twist, so it has no onset of gross slip to map (FrettingMap "
      "refuses scene.torsion); its cycles are classified against the full-slip moment instead.";
  return mdr::OkStatus();
}

// Fit, analysis with the fitted scene, replay and map: everything of the report but the plots.
mdr::Status RunCampaign(ContactClient& client, FitReport* report) {
  const Campaign& campaign = *report->campaign;
  // The campaign's own scene first: bad data fail here, before the fit.
  if (auto s = AnalyzeSets(client, campaign, campaign.scene, &report->sets); !s.ok()) return s;
  const mdr::v1::FitLoopsRequest request = FitRequest(campaign, report->sets, true);
  const ChannelLabels labels = LabelsOf(campaign.channel);
  auto fit = client.FitLoops(request, [&](const mdr::v1::FitProgress& progress) {
    PrintProgress(request, labels, progress);
  });
  if (!fit.ok()) {
    if (auto large =
            RequestTooLarge(fit.status(), "the fit of " + campaign.path, request.ByteSizeLong())) {
      return *large;
    }
    return CampaignError(fit.status(), campaign, report->sets);
  }
  report->fit = std::move(fit).value();
  report->request = FitRequest(campaign, report->sets, false);
  const mdr::v1::Scene& fitted = report->fit.fitted_scene();
  if (auto s = AnalyzeSets(client, campaign, fitted, &report->sets); !s.ok()) return s;
  if (auto s = ReplaySets(client, report->fit, report); !s.ok()) return s;
  if (fitted.has_torsion()) return FittedTorsion(campaign, fitted, report);
  report->map_request = MapRequest(campaign, report->sets, fitted);
  auto map = client.FrettingMap(report->map_request);
  if (!map.ok()) return CampaignError(map.status(), campaign, report->sets);
  report->map = std::move(map).value();
  return mdr::OkStatus();
}

}  // namespace

int FitCommand(const Common& common, const FitArgs& args) {
  auto campaign = LoadCampaign(args.campaign);
  if (!campaign.ok()) return Fail(campaign.status());
  if (!args.report_dir.empty()) {
    if (auto s = MakeDirectory(args.report_dir, "--report"); !s.ok()) return Fail(s);
  }
  FitReport report;
  report.campaign = &*campaign;
  auto sets = ReadSets(*campaign);
  if (!sets.ok()) return Fail(sets.status());
  report.sets = std::move(sets).value();
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status());
  if (auto s = RunCampaign((*connection)->client(), &report); !s.ok()) return Fail(s);
  PrintFitResult(report.fit, LabelsOf(campaign->channel), common.format, stdout);
  if (args.report_dir.empty()) return EXIT_SUCCESS;
  report.plots = DrawPlots([&] {
    return WriteFitPlots(PlottedSets(report.sets, report.fit),
                         report.map_skipped.empty() ? &report.map : nullptr, args.report_dir);
  });
  const mdr::Status written =
      WriteReport(args.report_dir, FitMarkdown(report), FitJson(report), report.plots);
  return written.ok() ? EXIT_SUCCESS : Fail(written);
}

}  // namespace mdrctl

// ---- synthesize ----
namespace mdrctl {
namespace {

// Standard normal numbers by Box-Muller over std::mt19937_64, whose output the standard fixes:
// the same seed gives the same numbers with every standard library (std::normal_distribution's
// algorithm is left to the implementation).
class Gaussian {
 public:
  explicit Gaussian(std::uint64_t seed) : engine_(seed) {}
  double Next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double radius = std::sqrt(-2 * std::log(Uniform()));
    const double angle = 2 * std::numbers::pi * Uniform();
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }

 private:
  // Uniform in (0, 1): the top 53 bits, offset by half a step so that 0 never occurs.
  double Uniform() { return (static_cast<double>(engine_() >> 11) + 0.5) * 0x1.0p-53; }
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0;
};

// Shortest text that reads back as the same double.
std::string Shortest(double value) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, value).ptr;
  return std::string(text, end);
}

std::string Csv(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", value);
  return text;
}

mdr::Result<double> EffectiveModulus(const mdr::v1::Scene& scene) {
  if (scene.has_rigid_on_half_space()) {
    const auto& m = scene.rigid_on_half_space();
    auto material = mdr::RigidOnHalfSpace(m.shear_modulus(), m.poisson_ratio());
    if (!material.ok()) return material.status().WithFieldPrefix("truth.rigid_on_half_space");
    return material->e_star;
  }
  const auto& m = scene.elastic_pair();
  auto material = mdr::ElasticPair(m.youngs_modulus_1(), m.poisson_ratio_1(), m.youngs_modulus_2(),
                                   m.poisson_ratio_2());
  if (!material.ok()) return material.status().WithFieldPrefix("truth.elastic_pair");
  return material->e_star;
}

// The truth's value of every fit parameter the scene defines.
mdr::Result<std::map<std::string, double>> TruthValues(const mdr::v1::Scene& scene) {
  std::map<std::string, double> truth;
  truth["friction"] = scene.friction();
  auto e_star = EffectiveModulus(scene);
  if (!e_star.ok()) return e_star.status();
  truth["effective_modulus"] = *e_star;
  truth["rig_compliance"] = scene.rig().tangential_compliance();
  truth["displacement_offset"] = 0;
  if (scene.has_sphere()) truth["profile_scale"] = scene.sphere().radius();
  if (scene.has_power_law()) truth["profile_scale"] = scene.power_law().coefficient();
  if (scene.has_torsion()) {
    auto modulus = TorsionalModulus(scene);
    if (!modulus.ok()) return modulus.status().WithFieldPrefix("truth");
    truth["torsional_modulus"] = *modulus;
    truth["rig_compliance"] = scene.torsion().rig_compliance();
  }
  return truth;
}

// The truth with every free parameter at its initial value: the campaign's starting scene, so
// that nothing of the truth leaks into the fit.
mdr::Result<mdr::v1::Scene> StartingScene(const SynthesisSpec& spec,
                                          const std::map<std::string, double>& truth) {
  mdr::v1::Scene scene = spec.truth;
  for (std::size_t k = 0; k < spec.free.size(); ++k) {
    const auto& free = spec.free[k];
    const std::string field = mdr::Indexed("fit.free", k);
    if (free.parameter() == mdr::v1::FIT_PARAMETER_DISPLACEMENT_OFFSET) continue;
    if (!free.has_initial()) {
      return spec.lines.Error(field,
                              "needs an initial value in a synthesis spec (the fit would "
                              "otherwise start at the truth)");
    }
    const double initial = free.initial();
    switch (free.parameter()) {
      case mdr::v1::FIT_PARAMETER_FRICTION:
        scene.set_friction(initial);
        break;
      case mdr::v1::FIT_PARAMETER_RIG_COMPLIANCE:
        if (scene.has_torsion()) {
          scene.mutable_torsion()->set_rig_compliance(initial);
        } else {
          scene.mutable_rig()->set_tangential_compliance(initial);
        }
        break;
      case mdr::v1::FIT_PARAMETER_TORSIONAL_MODULUS:
        scene.mutable_torsion()->set_torsional_modulus(initial);
        break;
      case mdr::v1::FIT_PARAMETER_EFFECTIVE_MODULUS: {
        const double factor = initial / truth.at("effective_modulus");
        if (scene.has_rigid_on_half_space()) {
          auto* m = scene.mutable_rigid_on_half_space();
          m->set_shear_modulus(m->shear_modulus() * factor);
        } else {
          auto* m = scene.mutable_elastic_pair();
          m->set_youngs_modulus_1(m->youngs_modulus_1() * factor);
          m->set_youngs_modulus_2(m->youngs_modulus_2() * factor);
        }
        break;
      }
      case mdr::v1::FIT_PARAMETER_PROFILE_SCALE:
        if (scene.has_sphere()) {
          scene.mutable_sphere()->set_radius(initial);
        } else if (scene.has_power_law()) {
          scene.mutable_power_law()->set_coefficient(initial);
        } else {
          return spec.lines.Error(field + ".parameter",
                                  "profile_scale needs a sphere or a power law in the truth");
        }
        break;
      default:
        break;
    }
  }
  return scene;
}

std::string TruthText(const std::map<std::string, double>& truth) {
  const bool torsional = truth.contains("torsional_modulus");
  std::string text = "friction " + Shortest(truth.at("friction")) + ", effective_modulus " +
                     Shortest(truth.at("effective_modulus")) + " Pa";
  if (torsional) text += ", torsional_modulus " + Shortest(truth.at("torsional_modulus")) + " Pa";
  text += ", rig_compliance " + Shortest(truth.at("rig_compliance")) +
          (torsional ? " rad/(N m)" : " m/N");
  if (truth.contains("profile_scale")) {
    text += ", profile_scale " + Shortest(truth.at("profile_scale"));
  }
  return text;
}

// "p100N_u4um.csv"; a torsional run's "p100N_phi4.8mrad.csv".
std::string RunFileName(double normal_force, double amplitude, bool torsional) {
  char name[96];
  if (torsional) {
    std::snprintf(name, sizeof name, "p%gN_phi%gmrad.csv", normal_force, amplitude * 1e3);
  } else {
    std::snprintf(name, sizeof name, "p%gN_u%gum.csv", normal_force, amplitude * 1e6);
  }
  return name;
}

struct SynthesizedRun {
  std::string file;
  double normal_force, amplitude;
};

// The run's comment lines after the "# SYNTHETIC" one: its load, path and sampling.
std::string RunComment(const SynthesisSpec& spec, const SynthesizedRun& run) {
  std::ostringstream out;
  out << "# run: normal_force " << Shortest(run.normal_force) << " N, ";
  if (spec.truth.has_torsion()) {
    out << "contact twist amplitude " << Shortest(run.amplitude)
        << " rad, phi_c = PHI sin(2 pi f t); the twist recorded is the actuator's, phi_c + C M "
           "behind the shaft's compliance C, ";
  } else {
    out << "actuator amplitude " << Shortest(run.amplitude) << " m, u = U sin(2 pi f t), ";
  }
  out << spec.cycles << " cycles of " << spec.samples_per_cycle << " samples at "
      << Shortest(spec.sampling_rate) << " Hz\n";
  return out.str();
}

// The run with noise, as a CSV file (time, displacement, tangential_force in s, m, N; a
// torsional run's time, twist, twisting_moment in s, rad, N m).
mdr::Status WriteRunCsv(const SynthesisSpec& spec, const std::string& truth_text,
                        const SynthesizedRun& run, const RecordedRun& recorded, Gaussian* noise,
                        const fs::path& file) {
  const auto [lo, hi] = std::minmax_element(recorded.force.begin(), recorded.force.end());
  const double force_sd = spec.force_noise + spec.force_noise_relative * 0.5 * (*hi - *lo);
  const CsvLayout names;
  const bool torsional = spec.truth.has_torsion();
  const std::string& position = torsional ? names.twist_column : names.displacement_column;
  const std::string& force = torsional ? names.moment_column : names.force_column;
  std::ostringstream out;
  out << "# SYNTHETIC: generated by mdrctl synthesize, truth: " << truth_text << "\n"
      << RunComment(spec, run) << "# noise: Gaussian (Box-Muller over mt19937_64, seed "
      << spec.seed << "), sd " << Shortest(spec.displacement_noise) << (torsional ? " rad" : " m")
      << " on " << position << ", " << Csv(force_sd) << (torsional ? " N m" : " N") << " on "
      << force << "\n"
      << "time," << position << "," << force << "\n";
  for (std::size_t i = 0; i < recorded.displacement.size(); ++i) {
    const double u = recorded.displacement[i] + spec.displacement_noise * noise->Next();
    const double f = recorded.force[i] + force_sd * noise->Next();
    out << Csv(static_cast<double>(i) / spec.sampling_rate) << ',' << Csv(u) << ',' << Csv(f)
        << '\n';
  }
  return WriteText(file, out.str());
}

// A scene as a YAML node in block style (from its proto3 JSON).
YAML::Node SceneNode(const mdr::v1::Scene& scene) {
  std::function<void(YAML::Node)> block = [&](YAML::Node node) {
    node.SetStyle(YAML::EmitterStyle::Block);
    if (node.IsMap()) {
      for (auto entry : node) block(entry.second);
    } else if (node.IsSequence()) {
      for (auto item : node) block(item);
    }
  };
  YAML::Node node = YAML::Load(ProtoJson(scene, false, JsonFields::kSet));
  block(node);
  return node;
}

void EmitFree(const SynthesisSpec& spec, YAML::Emitter* out) {
  *out << YAML::Key << "free" << YAML::Value << YAML::BeginSeq;
  for (const auto& free : spec.free) {
    *out << YAML::Flow << YAML::BeginMap << YAML::Key << "parameter" << YAML::Value
         << FitParameterName(free.parameter());
    if (free.has_initial())
      *out << YAML::Key << "initial" << YAML::Value << Shortest(free.initial());
    *out << YAML::Key << "lower" << YAML::Value << Shortest(free.lower()) << YAML::Key << "upper"
         << YAML::Value << Shortest(free.upper()) << YAML::EndMap;
  }
  *out << YAML::EndSeq;
}

// The campaign format, at the top of every campaign synthesize writes.
constexpr char kCampaignSchema[] =
    R"(  mdrctl fit campaign.yaml [--report DIR]
Campaign schema (docs/analysis.md, "From a rig's CSV files to a report"):
  title: text of the report's heading (optional)
  scene: a scene file's path (relative to this file; its `scene` is read) or an inline
    mdr.v1.Scene: the starting point of the fit; the free parameters start at `initial`
  columns: {displacement, tangential_force, normal_force, time, run}: header names in the CSV
    files (defaults: displacement, tangential_force; normal_force, time and run: none); run:
    the column of each row's run id, in files of several runs. A scene with torsion reads
    torsional records: {twist, twisting_moment, ...} (defaults twist, twisting_moment)
  units: {displacement: m|mm|um|nm, force: N|kN|mN, time: s|ms|us} (defaults m, N, s); a
    torsional campaign's {twist: rad|mrad|urad|deg, moment: N m|N mm|mN m, force (the normal
    force's), time}
  sets: [{file, normal_force (N)?, run?, columns?, units?}]: one run, a whole CSV file or
    its run `run` (its id in the run column); normal_force is required without a normal_force
    column (with one, the column is replayed and normal_force checked against it); columns and
    units override the defaults above for that file
  free: [{parameter, initial?, lower, upper}]: parameter is friction, effective_modulus,
    profile_scale, rig_compliance, displacement_offset or (torsional) torsional_modulus (SI
    units, a torsional campaign's compliance in rad/(N m), offset in rad; bounds exclusive)
  nuisances: {force_offset, displacement_drift, moving_mass}: true fits a force offset and a
    drift per set, a moving mass for all (needs time); each set's displacement offset and its
    turning points are fitted always
  displacement_noise, force_noise: the sensors' noise in m and N where known (default:
    estimated from each set)
  burn_in_reversals: residuals count from this reversal of each set on (default 2; 0 counts
    the virgin loading)
  reversal_threshold: hysteresis of the reversal detection in m (default 0: automatic)
  max_iterations: of the fit, 0 to 1000 (default 0: the service's 200)
  displacement_resolution: m; narrower loops are classified as sticking, C as nan (default 0)
  fretting_map: {normal_forces (default: the sets' loads), relative_amplitudes}
  truth: {parameter: value}: only for synthetic data, the values they were made with
Here the scene is the truth with every free parameter at its initial value, and `truth`
holds the values the data were generated with, which the report compares the estimates to.)";

std::string CampaignYaml(const SynthesisSpec& spec, const mdr::v1::Scene& starting,
                         const std::vector<SynthesizedRun>& runs,
                         const std::map<std::string, double>& truth) {
  YAML::Emitter out;
  out << YAML::Comment("A synthetic campaign written by `mdrctl synthesize " +
                       fs::path(spec.path).filename().string() + "`; fit it with\n" +
                       kCampaignSchema)
      << YAML::Newline << YAML::BeginMap;
  if (!spec.title.empty()) out << YAML::Key << "title" << YAML::Value << spec.title;
  out << YAML::Key << "scene" << YAML::Value << SceneNode(starting);
  const CsvLayout names;
  if (spec.truth.has_torsion()) {
    out << YAML::Key << "columns" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
        << "twist" << YAML::Value << names.twist_column << YAML::Key << "twisting_moment"
        << YAML::Value << names.moment_column << YAML::Key << "time" << YAML::Value << "time"
        << YAML::EndMap;
    out << YAML::Key << "units" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
        << "twist" << YAML::Value << "rad" << YAML::Key << "moment" << YAML::Value << "N m"
        << YAML::Key << "time" << YAML::Value << "s" << YAML::EndMap;
  } else {
    out << YAML::Key << "columns" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
        << "displacement" << YAML::Value << names.displacement_column << YAML::Key
        << "tangential_force" << YAML::Value << names.force_column << YAML::Key << "time"
        << YAML::Value << "time" << YAML::EndMap;
    out << YAML::Key << "units" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
        << "displacement" << YAML::Value << "m" << YAML::Key << "force" << YAML::Value << "N"
        << YAML::Key << "time" << YAML::Value << "s" << YAML::EndMap;
  }
  out << YAML::Key << "sets" << YAML::Value << YAML::BeginSeq;
  for (const SynthesizedRun& run : runs) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "file" << YAML::Value << run.file
        << YAML::Key << "normal_force" << YAML::Value << Shortest(run.normal_force) << YAML::EndMap;
  }
  out << YAML::EndSeq;
  EmitFree(spec, &out);
  const auto& nuisances = spec.nuisances;
  if (nuisances.force_offset() || nuisances.displacement_drift() || nuisances.moving_mass()) {
    out << YAML::Key << "nuisances" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [name, on] : {std::pair{"force_offset", nuisances.force_offset()},
                                   std::pair{"displacement_drift", nuisances.displacement_drift()},
                                   std::pair{"moving_mass", nuisances.moving_mass()}}) {
      if (on) out << YAML::Key << name << YAML::Value << true;
    }
    out << YAML::EndMap;
  }
  if (spec.fit_displacement_noise) {
    out << YAML::Key << "displacement_noise" << YAML::Value
        << Shortest(*spec.fit_displacement_noise);
  }
  if (spec.fit_force_noise) {
    out << YAML::Key << "force_noise" << YAML::Value << Shortest(*spec.fit_force_noise);
  }
  if (spec.burn_in_reversals) {
    out << YAML::Key << "burn_in_reversals" << YAML::Value << *spec.burn_in_reversals;
  }
  out << YAML::Key << "reversal_threshold" << YAML::Value << Shortest(spec.reversal_threshold);
  out << YAML::Key << "max_iterations" << YAML::Value << spec.max_iterations;
  if (!spec.map_relative_amplitudes.empty()) {
    out << YAML::Key << "fretting_map" << YAML::Value << YAML::BeginMap << YAML::Key
        << "relative_amplitudes" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (double a : spec.map_relative_amplitudes) out << Shortest(a);
    out << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::Key << "truth" << YAML::Value << YAML::BeginMap;
  for (const auto& [name, value] : truth)
    out << YAML::Key << name << YAML::Value << Shortest(value);
  out << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace

int SynthesizeCommand(const Common& common, const SynthesizeArgs& args) {
  auto spec = LoadSynthesisSpec(args.spec);
  if (!spec.ok()) return Fail(spec.status());
  auto truth = TruthValues(spec->truth);
  if (!truth.ok()) return Fail(spec->lines.Error(truth.status().field(), truth.status().message()));
  auto starting = StartingScene(*spec, *truth);
  if (!starting.ok()) return Fail(starting.status());
  if (auto s = MakeDirectory(args.out_dir, "--out"); !s.ok()) return Fail(s);
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status());
  const std::string truth_text = TruthText(*truth);
  Gaussian noise(spec->seed);
  std::vector<SynthesizedRun> runs;
  const bool torsional = spec->truth.has_torsion();
  for (double normal_force : spec->normal_forces) {
    for (double amplitude : spec->amplitudes) {
      const SynthesizedRun run{RunFileName(normal_force, amplitude, torsional), normal_force,
                               amplitude};
      auto& client = (*connection)->client();
      auto recorded = torsional ? RecordSineTwistRun(client, spec->truth, normal_force, amplitude,
                                                     spec->cycles, spec->samples_per_cycle)
                                : RecordSineRun(client, spec->truth, normal_force, amplitude,
                                                spec->cycles, spec->samples_per_cycle);
      if (!recorded.ok()) {
        return Fail(spec->lines.Error(
            "truth", "the run at normal_force " + Shortest(normal_force) + " N, amplitude " +
                         Shortest(amplitude) + (torsional ? " rad" : " m") +
                         " failed: " + recorded.status().error_message()));
      }
      const fs::path file = fs::path(args.out_dir) / run.file;
      if (auto s = WriteRunCsv(*spec, truth_text, run, *recorded, &noise, file); !s.ok()) {
        return Fail(s);
      }
      std::fprintf(stderr, "mdrctl: wrote %s (%zu samples)\n", file.c_str(),
                   recorded->displacement.size());
      runs.push_back(run);
    }
  }
  const fs::path campaign = fs::path(args.out_dir) / "campaign.yaml";
  if (auto s = WriteText(campaign, CampaignYaml(*spec, *starting, runs, *truth)); !s.ok()) {
    return Fail(s);
  }
  std::fprintf(stderr, "mdrctl: wrote %s\n", campaign.c_str());
  return EXIT_SUCCESS;
}

}  // namespace mdrctl
