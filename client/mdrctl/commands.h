// The subcommands of mdrctl, one <Name>Command function each (the suffix tells them from the
// client's methods Apply, Query, Transform ...). Each returns the process exit code and reports
// errors on stderr as "mdrctl: field: message".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "report_format.h"

namespace mdrctl {

// Options every subcommand shares.
struct Common {
  // mdrd address; empty: an in-process server that lives as long as the command.
  std::string server;
  double timeout_seconds = 60;
  Format format = Format::kTable;
  bool tls = false;
  std::string root_certificates_file;
  std::string client_certificate_file;
  std::string client_key_file;
  std::string token;
};

struct RunArgs {
  std::string scene;
  std::string plot_dir;
  bool keep_session = false;
  // Interface scenes: one contact's state per step (and its profiles at holds); the slip
  // histogram per step in this many bins (0: none).
  std::optional<std::uint64_t> contact_index;
  std::uint32_t histogram_bins = 0;
};
int RunCommand(const Common& common, const RunArgs& args);

int SessionCreateCommand(const Common& common, const std::string& scene, const std::string& id);
int SessionGetCommand(const Common& common, const std::string& name);
int SessionListCommand(const Common& common);
int SessionDeleteCommand(const Common& common, const std::string& name);

struct ApplyArgs {
  std::string session;
  // Steps as YAML/JSON mappings, e.g. "{normal_force: 100}".
  std::vector<std::string> steps;
  std::string request_id;
  // One StreamApply message per step instead of one batch.
  bool stream = false;
};
int ApplyCommand(const Common& common, const ApplyArgs& args);

struct QueryArgs {
  std::string session;
  std::vector<std::string> read_mask;
  std::vector<double> radii;
  // Interface sessions: the contact of the ordinary paths; the bins of interface.slip_histogram.
  std::optional<std::uint64_t> contact_index;
  std::int32_t histogram_bins = 0;
};
int QueryCommand(const Common& common, const QueryArgs& args);

// The snapshot as JSON, to `output` or stdout when empty.
int ExportCommand(const Common& common, const std::string& name, const std::string& output);
int ImportCommand(const Common& common, const std::string& snapshot_file, const std::string& id);
// A TransformRequest in YAML or JSON.
int TransformCommand(const Common& common, const std::string& request_file);

// mdrctl loops FILE.csv: the figures of every cycle of a rig's CSV file (AnalyzeLoops), of each
// run of a file of several. A record is tangential, or torsional when any torsional option
// (twist_column, moment_column, twist_unit, moment_unit) is given; a tangential column or unit
// given with one is refused. Unset columns and units take their channel's defaults.
struct LoopsArgs {
  std::string file;
  std::optional<std::string> displacement_column;  // default "displacement"
  std::optional<std::string> force_column;         // default "tangential_force"
  std::optional<std::string> twist_column;         // default "twist"
  std::optional<std::string> moment_column;        // default "twisting_moment"
  std::string normal_force_column;                 // optional
  std::string time_column;                         // optional
  std::string run_column;                          // optional: each sample's run id
  std::optional<std::string> run;                  // only this run (needs run_column)
  std::optional<std::string> displacement_unit;    // default m
  std::optional<std::string> twist_unit;           // default rad
  std::optional<std::string> moment_unit;          // default "N m"
  std::string force_unit = "N";  // the tangential and the normal force's (torsional: the normal's)
  std::string time_unit = "s";
  std::optional<double> normal_force;  // N, when the file has no normal force column
  // m/N (torsional: rad/(N m)); unset: the scene's rig (scene.torsion.rig_compliance), if any.
  std::optional<double> rig_compliance;
  double reversal_threshold = 0;       // m (rad); 0: automatic
  double displacement_resolution = 0;  // m (rad), for the regimes
  std::string scene;                   // scene file whose scene classifies the regimes
  std::string report_dir;
};
int LoopsCommand(const Common& common, const LoopsArgs& args);

// mdrctl fit CAMPAIGN.yaml: analyses, fit, replay and fretting map of a campaign.
struct FitArgs {
  std::string campaign;
  std::string report_dir;
};
int FitCommand(const Common& common, const FitArgs& args);

// mdrctl synthesize SPEC.yaml --out DIR: a synthetic campaign made with the engine.
struct SynthesizeArgs {
  std::string spec;
  std::string out_dir;
};
int SynthesizeCommand(const Common& common, const SynthesizeArgs& args);

}  // namespace mdrctl
