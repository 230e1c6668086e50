#include "commands.h"

#include <google/protobuf/util/json_util.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>

#include "connection.h"
#include "mdr/bridge/scene_file.h"
#include "mdr/client/contact_client.h"
#include "mdr/client/loading_path.h"
#include "mdr/client/scene_runner.h"
#include "plot.h"

namespace mdrctl {
namespace {

using mdr::client::ContactClient;

// "abc" -> "sessions/abc"; full names pass.
std::string SessionName(const std::string& name) {
  return name.find('/') == std::string::npos ? "sessions/" + name : name;
}

// A bar on stderr, drawn only for long runs when stdout and stderr are terminals.
class ProgressBar {
 public:
  explicit ProgressBar(std::uint64_t total)
      : enabled_(total >= kLongRun && ::isatty(STDOUT_FILENO) && ::isatty(STDERR_FILENO)) {}
  ~ProgressBar() {
    if (drawn_) std::fprintf(stderr, "\r%*s\r", kWidth + 32, "");
  }
  void Update(std::uint64_t done, std::uint64_t total) {
    if (!enabled_ || total == 0) return;
    const int filled = static_cast<int>(kWidth * done / total);
    std::fprintf(stderr, "\r[%s%*s] %3d%% %llu/%llu steps", std::string(filled, '#').c_str(),
                 kWidth - filled, "", static_cast<int>(100 * done / total),
                 static_cast<unsigned long long>(done), static_cast<unsigned long long>(total));
    std::fflush(stderr);
    drawn_ = true;
  }

 private:
  static constexpr std::uint64_t kLongRun = 2000;
  static constexpr int kWidth = 40;
  bool enabled_;
  bool drawn_ = false;
};

int PrintPlots(const mdr::v1::RunReport& report, const std::string& dir) {
  auto pngs = WritePlots(report, dir);
  if (!pngs.ok()) return Fail(pngs.status().ToString());
  for (const std::string& png : *pngs) std::fprintf(stderr, "mdrctl: wrote %s\n", png.c_str());
  return EXIT_SUCCESS;
}

}  // namespace

int RunCommand(const Common& common, const RunArgs& args) {
  if (!args.plot_dir.empty()) {
    const mdr::Status gnuplot = CheckGnuplot();
    if (!gnuplot.ok()) return Fail(gnuplot.ToString());
  }
  auto document = mdr::bridge::SceneDocument::Load(args.scene);
  if (!document.ok()) return Fail(document.status().ToString());
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  ProgressBar progress(mdr::client::StepCount(document->file()));
  mdr::client::RunOptions options;
  options.keep_session = args.keep_session;
  options.contact_index = args.contact_index;
  options.slip_histogram_bins = args.histogram_bins;
  options.progress = [&](std::uint64_t done, std::uint64_t total) { progress.Update(done, total); };
  auto report = mdr::client::RunScene((*connection)->client(), *document, options);
  if (!report.ok()) return Fail(report.status());
  PrintReport(*report, document->file(), common.format, stdout);
  if (args.keep_session) std::fprintf(stderr, "mdrctl: kept %s\n", report->session().c_str());
  return args.plot_dir.empty() ? EXIT_SUCCESS : PrintPlots(*report, args.plot_dir);
}

int SessionCreateCommand(const Common& common, const std::string& scene, const std::string& id) {
  auto document = mdr::bridge::SceneDocument::Load(scene);
  if (!document.ok()) return Fail(document.status().ToString());
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  auto session = (*connection)->client().CreateSession(document->file().scene(), id);
  if (!session.ok()) return Fail(session.status());
  PrintMessage(*session, common.format, stdout);
  return EXIT_SUCCESS;
}

int SessionGetCommand(const Common& common, const std::string& name) {
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  auto session = (*connection)->client().GetSession(SessionName(name));
  if (!session.ok()) return Fail(session.status());
  PrintMessage(*session, common.format, stdout);
  return EXIT_SUCCESS;
}

int SessionListCommand(const Common& common) {
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  auto sessions = (*connection)->client().ListAllSessions();
  if (!sessions.ok()) return Fail(sessions.status());
  PrintSessions(*sessions, common.format, stdout);
  return EXIT_SUCCESS;
}

int SessionDeleteCommand(const Common& common, const std::string& name) {
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  const grpc::Status deleted = (*connection)->client().DeleteSession(SessionName(name));
  if (!deleted.ok()) return Fail(deleted);
  std::printf("deleted %s\n", SessionName(name).c_str());
  return EXIT_SUCCESS;
}

int ApplyCommand(const Common& common, const ApplyArgs& args) {
  mdr::v1::ApplyRequest request;
  request.set_session(SessionName(args.session));
  request.set_request_id(args.request_id);
  request.mutable_step_mask()->add_paths("state");
  for (std::size_t i = 0; i < args.steps.size(); ++i) {
    const mdr::Status parsed = mdr::bridge::ParseYamlMessage(args.steps[i], request.add_steps());
    if (!parsed.ok()) {
      return Fail(parsed.WithFieldPrefix("steps[" + std::to_string(i) + "]").ToString());
    }
  }
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  ContactClient& client = (*connection)->client();
  // The table's columns are the scene's (a torsional session prints its twist and moment).
  mdr::v1::Scene scene;
  if (common.format != Format::kJson) {
    auto session = client.GetSession(request.session());
    if (!session.ok()) return Fail(session.status());
    scene = session->scene();
  }
  if (!args.stream) {
    auto applied = client.Apply(request);
    if (!applied.ok()) return Fail(applied.status());
    PrintApplyResponse(*applied, scene, common.format, stdout);
    return EXIT_SUCCESS;
  }
  // One message per step; the results are joined as if they were one batch.
  std::vector<mdr::v1::ApplyRequest> messages;
  for (int i = 0; i < request.steps_size(); ++i) {
    mdr::v1::ApplyRequest& message = messages.emplace_back(request);
    message.clear_steps();
    *message.add_steps() = request.steps(i);
    if (!request.request_id().empty())
      message.set_request_id(request.request_id() + "-" + std::to_string(i));
  }
  auto responses = client.StreamApply(messages);
  if (!responses.ok()) return Fail(responses.status());
  mdr::v1::ApplyResponse joined;
  for (std::size_t i = 0; i < responses->size(); ++i) {
    const auto& response = (*responses)[i];
    if (response.status().code() != 0) {
      return Fail("message " + std::to_string(i) + ": " + response.status().message());
    }
    *joined.mutable_state() = response.result().state();
    for (const auto& result : response.result().step_results()) *joined.add_step_results() = result;
  }
  PrintApplyResponse(joined, scene, common.format, stdout);
  return EXIT_SUCCESS;
}

int QueryCommand(const Common& common, const QueryArgs& args) {
  mdr::v1::QueryRequest request;
  request.set_session(SessionName(args.session));
  for (const std::string& path : args.read_mask) request.mutable_read_mask()->add_paths(path);
  request.mutable_radii()->Add(args.radii.begin(), args.radii.end());
  if (args.contact_index) request.set_contact_index(*args.contact_index);
  request.set_slip_histogram_bins(args.histogram_bins);
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  auto queried = (*connection)->client().Query(request);
  if (!queried.ok()) return Fail(queried.status());
  PrintMessage(*queried, common.format, stdout);
  return EXIT_SUCCESS;
}

int ExportCommand(const Common& common, const std::string& name, const std::string& output) {
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  auto snapshot = (*connection)->client().ExportSession(SessionName(name));
  if (!snapshot.ok()) return Fail(snapshot.status());
  if (output.empty()) {
    std::fputs(ToJson(*snapshot).c_str(), stdout);
    return EXIT_SUCCESS;
  }
  std::ofstream out(output);
  if (!(out << ToJson(*snapshot))) return Fail(output + ": cannot write");
  return EXIT_SUCCESS;
}

int ImportCommand(const Common& common, const std::string& snapshot_file, const std::string& id) {
  auto json = ReadFile(snapshot_file);
  if (!json.ok()) return Fail(json.status().ToString());
  mdr::v1::SessionSnapshot snapshot;
  const auto parsed = google::protobuf::util::JsonStringToMessage(*json, &snapshot);
  if (!parsed.ok()) return Fail(snapshot_file + ": " + std::string(parsed.message()));
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  auto session = (*connection)->client().ImportSession(snapshot, id);
  if (!session.ok()) return Fail(session.status());
  PrintMessage(*session, common.format, stdout);
  return EXIT_SUCCESS;
}

int TransformCommand(const Common& common, const std::string& request_file) {
  auto text = ReadFile(request_file);
  if (!text.ok()) return Fail(text.status().ToString());
  mdr::v1::TransformRequest request;
  const mdr::Status parsed = mdr::bridge::ParseYamlMessage(*text, &request);
  if (!parsed.ok()) return Fail(request_file + ": " + parsed.ToString());
  auto connection = Connection::Open(common);
  if (!connection.ok()) return Fail(connection.status().ToString());
  auto transformed = (*connection)->client().Transform(request);
  if (!transformed.ok()) return Fail(transformed.status());
  PrintMessage(*transformed, common.format, stdout);
  return EXIT_SUCCESS;
}

}  // namespace mdrctl
