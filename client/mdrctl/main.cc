// mdrctl: the command-line client of the mdr contact service. `run SCENE` applies a scene file's
// loading path (YAML or JSON of mdr.v1.SceneFile) and prints one row per step; the other
// subcommands wrap one RPC each. Without --server an in-process server is used.
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

  for (CLI::App* command :
       {run, create, get, list, remove, apply, query, exporter, importer, transform}) {
    AddCommonOptions(command, &common);
  }
  // The embedded server's session log would interleave with the output; errors still show.
  spdlog::set_level(spdlog::level::warn);
  CLI11_PARSE(app, argc, argv);
  return exit_code;
}
