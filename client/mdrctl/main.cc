// mdrctl: the command-line client of the mdr contact service. `run SCENE` applies a scene file's
// loading path (YAML or JSON of mdr.v1.SceneFile) and prints one row per step; `loops`, `fit`
// and `synthesize` take a rig's CSV (or MATLAB) files to a report; the other subcommands wrap one
// RPC each. Without --server an in-process server is used.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>

#include "commands.h"

namespace {

using mdrctl::Common;

void AddCommonOptions(CLI::App* app, Common* common) {
  app->add_option("--server", common->server,
                  "mdrd address host:port; without it an in-process server is used (its "
                  "sessions live as long as the command)")
      ->envname("MDR_SERVER");
  app->add_option("--timeout", common->timeout_seconds, "Deadline of each call in seconds")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app->add_option_function<std::string>(
         "--format",
         [common](const std::string& name) {
           common->format = name == "csv"    ? mdrctl::Format::kCsv
                            : name == "json" ? mdrctl::Format::kJson
                                             : mdrctl::Format::kTable;
         },
         "Output: table (default), csv or json")
      ->check(CLI::IsMember({"table", "csv", "json"}));
  app->add_flag("--tls", common->tls, "Connect with TLS (implied by --ca, --cert, --key)");
  app->add_option("--ca", common->root_certificates_file, "PEM file of the root certificates");
  app->add_option("--cert", common->client_certificate_file, "PEM client certificate (mTLS)");
  app->add_option("--key", common->client_key_file, "PEM private key of --cert");
  app->add_option("--token", common->token, "Bearer token sent on every call (needs TLS)")
      ->envname("MDR_TOKEN");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mdrctl: client of the mdr contact service"};
  app.require_subcommand(1);
  Common common;
  int exit_code = EXIT_SUCCESS;

  CLI::App* run = app.add_subcommand("run", "Run a scene file and print the state after each step");
  mdrctl::RunArgs run_args;
  run->add_option("scene", run_args.scene, "Scene file (YAML or JSON of mdr.v1.SceneFile)")
      ->required();
  run->add_option("--plot", run_args.plot_dir, "Write PNG plots (gnuplot) into this directory");
  run->add_flag("--keep", run_args.keep_session, "Keep the session (with --server)");
  run->add_option_function<std::uint64_t>(
      "--contact-index", [&run_args](std::uint64_t index) { run_args.contact_index = index; },
      "Interface scenes: print this contact's state after every step (and record its profiles "
      "at holds)");
  run->add_option("--histogram-bins", run_args.histogram_bins,
                  "Interface scenes: print the slip histogram after every step in this many bins");
  run->callback([&] { exit_code = mdrctl::RunCommand(common, run_args); });

  CLI::App* session = app.add_subcommand("session", "Create, get, list or delete sessions");
  session->require_subcommand(1);
  std::string scene_file;
  std::string session_id;
  std::string name;
  CLI::App* create = session->add_subcommand("create", "Create a session for a scene file's scene");
  create->add_option("scene", scene_file, "Scene file (YAML or JSON)")->required();
  create->add_option("--id", session_id, "Session id ([a-z0-9-], starting with a letter)");
  create->callback(
      [&] { exit_code = mdrctl::SessionCreateCommand(common, scene_file, session_id); });
  CLI::App* get = session->add_subcommand("get", "Show a session");
  get->add_option("name", name, "sessions/ID or ID")->required();
  get->callback([&] { exit_code = mdrctl::SessionGetCommand(common, name); });
  CLI::App* list = session->add_subcommand("list", "List every session");
  list->callback([&] { exit_code = mdrctl::SessionListCommand(common); });
  CLI::App* remove = session->add_subcommand("delete", "Delete a session");
  remove->add_option("name", name, "sessions/ID or ID")->required();
  remove->callback([&] { exit_code = mdrctl::SessionDeleteCommand(common, name); });

  CLI::App* apply = app.add_subcommand("apply", "Apply steps to a session as one atomic batch");
  mdrctl::ApplyArgs apply_args;
  apply->add_option("session", apply_args.session, "sessions/ID or ID")->required();
  apply->add_option("steps", apply_args.steps, "Steps as YAML/JSON, e.g. '{normal_force: 100}'")
      ->required();
  apply->add_option("--request-id", apply_args.request_id, "Makes a retry safe");
  apply->add_flag("--stream", apply_args.stream, "One StreamApply message per step");
  apply->callback([&] { exit_code = mdrctl::ApplyCommand(common, apply_args); });

  CLI::App* query = app.add_subcommand("query", "Read a session's outputs");
  mdrctl::QueryArgs query_args;
  query->add_option("session", query_args.session, "sessions/ID or ID")->required();
  query
      ->add_option("--mask", query_args.read_mask,
                   "Outputs, e.g. state,energy,springs,tractions,interface.totals (default: "
                   "state)")
      ->delimiter(',');
  query->add_option("--radii", query_args.radii, "Radii in m for springs and tractions")
      ->delimiter(',');
  query->add_option_function<std::uint64_t>(
      "--contact-index", [&query_args](std::uint64_t index) { query_args.contact_index = index; },
      "Interface sessions: the contact whose state, springs, tractions ... are read");
  query->add_option("--histogram-bins", query_args.histogram_bins,
                    "Interface sessions: bins of interface.slip_histogram");
  query->callback([&] { exit_code = mdrctl::QueryCommand(common, query_args); });

  CLI::App* exporter = app.add_subcommand("export", "Print a session's snapshot (JSON)");
  std::string output;
  exporter->add_option("session", name, "sessions/ID or ID")->required();
  exporter->add_option("-o,--output", output, "Write to this file instead of stdout");
  exporter->callback([&] { exit_code = mdrctl::ExportCommand(common, name, output); });

  CLI::App* importer = app.add_subcommand("import", "Create a session from a snapshot file");
  std::string snapshot_file;
  importer->add_option("snapshot", snapshot_file, "JSON from export")->required();
  importer->add_option("--id", session_id, "Session id");
  importer->callback([&] { exit_code = mdrctl::ImportCommand(common, snapshot_file, session_id); });

  CLI::App* transform =
      app.add_subcommand("transform", "Convert between the MDR and the Jäger picture");
  std::string request_file;
  transform->add_option("request", request_file, "TransformRequest in YAML or JSON")->required();
  transform->callback([&] { exit_code = mdrctl::TransformCommand(common, request_file); });

  CLI::App* loops = app.add_subcommand(
      "loops", "Analyse a rig's CSV or MATLAB file: the figures of every cycle (AnalyzeLoops)");
  mdrctl::LoopsArgs loops_args;
  loops
      ->add_option("file", loops_args.file,
                   "CSV file with a header line, or MATLAB file (*.mat) whose variables are the "
                   "columns")
      ->required();
  // An optional's setter: options given explicitly are told from defaults (a tangential column
  // beside a torsional one is refused).
  const auto set = [](std::optional<std::string>* target) {
    return [target](const std::string& value) { *target = value; };
  };
  loops->add_option_function<std::string>(
      "--displacement-column", set(&loops_args.displacement_column),
      "Header name (MAT file: variable name) of the displacement (default: displacement)");
  loops->add_option_function<std::string>(
      "--force-column", set(&loops_args.force_column),
      "Header name (MAT: variable) of the tangential force (default: tangential_force)");
  loops->add_option_function<std::string>(
      "--twist-column", set(&loops_args.twist_column),
      "Header name (MAT: variable) of the twist of a torsional record (default: twist); any "
      "torsional option makes the record torsional: twist and twisting moment instead of "
      "displacement and tangential force");
  loops->add_option_function<std::string>(
      "--moment-column", set(&loops_args.moment_column),
      "Header name (MAT: variable) of the twisting moment of a torsional record (default: "
      "twisting_moment)");
  loops->add_option("--normal-force-column", loops_args.normal_force_column,
                    "Header name (MAT: variable) of the normal force (optional)");
  loops->add_option("--time-column", loops_args.time_column,
                    "Header name (MAT: variable) of the time (optional)");
  loops->add_option("--run-column", loops_args.run_column,
                    "Header name (MAT: variable) of each sample's run id, for a file of several "
                    "runs: each run is analysed on its own, in the file's order");
  loops->add_option_function<std::string>(
      "--run", [&loops_args](const std::string& id) { loops_args.run = id; },
      "Analyse only this run of the --run-column (its id as the file writes it)");
  loops->add_option_function<std::string>("--displacement-unit", set(&loops_args.displacement_unit),
                                          "m, mm, um or nm (default: m)");
  loops->add_option_function<std::string>("--twist-unit", set(&loops_args.twist_unit),
                                          "A torsional record's twist: rad, mrad, urad or deg "
                                          "(default: rad)");
  loops->add_option_function<std::string>("--moment-unit", set(&loops_args.moment_unit),
                                          "A torsional record's twisting moment: 'N m', 'N mm' or "
                                          "'mN m' (default: N m)");
  loops
      ->add_option("--force-unit", loops_args.force_unit,
                   "N, kN or mN: the tangential and the normal force's (a torsional record: the "
                   "normal force's)")
      ->capture_default_str();
  loops->add_option("--time-unit", loops_args.time_unit, "s, ms or us")->capture_default_str();
  loops->add_option_function<double>(
      "--normal-force", [&loops_args](double p) { loops_args.normal_force = p; },
      "Normal force in N when the file has no normal force column");
  loops->add_option_function<double>(
      "--rig-compliance", [&loops_args](double c) { loops_args.rig_compliance = c; },
      "The rig's tangential compliance in m/N (a torsional record: the shaft's torsional "
      "compliance in rad/(N m)): the contact's own figures too (default: the --scene's rig, or "
      "its torsion.rig_compliance)");
  loops->add_option("--reversal-threshold", loops_args.reversal_threshold,
                    "Hysteresis of the reversal detection in m, a torsional record's in rad (0: 5 "
                    "% of the typical stroke)");
  loops->add_option("--displacement-resolution", loops_args.displacement_resolution,
                    "The sensor's resolution in m (torsional: rad): narrower loops count as "
                    "sticking, their C and mu_e as nan");
  loops->add_option("--scene", loops_args.scene,
                    "Scene file (YAML/JSON) whose scene classifies each cycle's regime (a "
                    "torsional record's scene has torsion: its full-slip moment)");
  loops->add_option("--report", loops_args.report_dir,
                    "Write report.md, report.json and PNG plots into this directory");
  loops->callback([&] { exit_code = mdrctl::LoopsCommand(common, loops_args); });

  CLI::App* fit = app.add_subcommand(
      "fit", "Fit a scene to a campaign of rig CSV or MATLAB files, replay it and map its regimes");
  mdrctl::FitArgs fit_args;
  fit->add_option("campaign", fit_args.campaign, "Campaign file (YAML)")->required();
  fit->add_option("--report", fit_args.report_dir,
                  "Write report.md, report.json and PNG plots into this directory");
  fit->callback([&] { exit_code = mdrctl::FitCommand(common, fit_args); });

  CLI::App* synthesize = app.add_subcommand(
      "synthesize", "Generate a synthetic campaign (CSV files and campaign.yaml) with the engine");
  mdrctl::SynthesizeArgs synthesize_args;
  synthesize->add_option("spec", synthesize_args.spec, "Synthesis spec (YAML)")->required();
  synthesize->add_option("--out", synthesize_args.out_dir, "Directory for the files")->required();
  synthesize->callback([&] { exit_code = mdrctl::SynthesizeCommand(common, synthesize_args); });

  for (CLI::App* command : {run, create, get, list, remove, apply, query, exporter, importer,
                            transform, loops, fit, synthesize}) {
    AddCommonOptions(command, &common);
  }
  // The embedded server's session log would interleave with the output; errors still show.
  spdlog::set_level(spdlog::level::warn);
  CLI11_PARSE(app, argc, argv);
  return exit_code;
}
