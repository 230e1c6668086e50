// mdrctl: runs a scene file (JSON of mdr.v1.SceneFile) against mdrd, or against a server it
// starts in-process when no --server is given, and prints one table row per step.
#include <google/protobuf/util/json_util.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "mdr/client/contact_client.h"
#include "mdr/service/server.h"
#include "mdr/v1/scene_file.pb.h"

namespace {

using mdr::v1::ContactState;
using mdr::v1::SceneFile;

struct Column {
  const char* header;
  double (*value)(const ContactState&);
};

Column ColumnFor(SceneFile::Output output) {
  switch (output) {
    case SceneFile::DEPTH:
      return {"delta [m]", [](const ContactState& s) { return s.depth(); }};
    case SceneFile::TANGENTIAL_DISPLACEMENT:
      return {"ux [m]", [](const ContactState& s) { return s.tangential_displacement(); }};
    case SceneFile::NORMAL_FORCE:
      return {"F_N [N]", [](const ContactState& s) { return s.normal_force(); }};
    case SceneFile::TANGENTIAL_FORCE:
      return {"F_x [N]", [](const ContactState& s) { return s.tangential_force(); }};
    case SceneFile::CONTACT_RADIUS:
      return {"a [m]", [](const ContactState& s) { return s.contact_radius(); }};
    case SceneFile::DISSIPATED_ENERGY:
      return {"W [J]", [](const ContactState& s) { return s.dissipated_energy(); }};
    case SceneFile::FRICTION_LIMIT:
      return {"mu*F_N [N]", [](const ContactState& s) { return s.friction_limit(); }};
    default:
      return {nullptr, nullptr};
  }
}

mdr::Result<std::vector<Column>> ColumnsFor(const SceneFile& file) {
  if (file.outputs().empty()) {
    return std::vector<Column>{
        ColumnFor(SceneFile::DEPTH), ColumnFor(SceneFile::TANGENTIAL_DISPLACEMENT),
        ColumnFor(SceneFile::NORMAL_FORCE), ColumnFor(SceneFile::TANGENTIAL_FORCE),
        ColumnFor(SceneFile::CONTACT_RADIUS)};
  }
  std::vector<Column> columns;
  for (int i = 0; i < file.outputs_size(); ++i) {
    Column column = ColumnFor(file.outputs(i));
    if (column.header == nullptr) {
      return mdr::InvalidArgument("outputs[" + std::to_string(i) + "]",
                                  "must be one of DEPTH, TANGENTIAL_DISPLACEMENT, NORMAL_FORCE, "
                                  "TANGENTIAL_FORCE, CONTACT_RADIUS, DISSIPATED_ENERGY, "
                                  "FRICTION_LIMIT");
    }
    columns.push_back(column);
  }
  return columns;
}

mdr::Result<SceneFile> ReadSceneFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return mdr::InvalidArgument(path, "cannot open the scene file");
  std::stringstream json;
  json << in.rdbuf();
  SceneFile file;
  const auto status = google::protobuf::util::JsonStringToMessage(json.str(), &file);
  if (!status.ok()) {
    return mdr::InvalidArgument(path, "not a valid scene file: " + std::string(status.message()));
  }
  if (file.steps().empty()) return mdr::InvalidArgument("steps", "must contain at least one step");
  return file;
}

// The server reports CreateSession fields from the request ("session.scene.friction"); the scene
// file holds the scene at "scene".
std::string InSceneFileTerms(const std::string& server_message) {
  const std::string request_prefix = "session.";
  if (server_message.starts_with(request_prefix + "scene")) {
    return server_message.substr(request_prefix.size());
  }
  return server_message;
}

void PrintRow(const std::string& first, const std::vector<std::string>& cells) {
  std::printf("%5s", first.c_str());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const bool last = i + 1 == cells.size();
    std::printf(last ? "  %s" : "  %-18s", cells[i].c_str());
  }
  std::printf("\n");
}

void PrintTable(const std::vector<Column>& columns, const mdr::v1::ApplyResponse& response) {
  std::vector<std::string> headers;
  for (const Column& column : columns) headers.push_back(column.header);
  PrintRow("step", headers);
  for (int i = 0; i < response.step_results_size(); ++i) {
    std::vector<std::string> cells;
    for (const Column& column : columns) {
      char cell[32];
      std::snprintf(cell, sizeof cell, "%.10g", column.value(response.step_results(i).state()));
      cells.push_back(cell);
    }
    PrintRow(std::to_string(i + 1), cells);
  }
}

int Fail(const std::string& message) {
  std::fprintf(stderr, "mdrctl: %s\n", message.c_str());
  return EXIT_FAILURE;
}

int RunScene(mdr::client::ContactClient& client, const SceneFile& file,
             const std::vector<Column>& columns) {
  auto session = client.CreateSession(file.scene());
  if (!session.ok()) return Fail(InSceneFileTerms(session.status().error_message()));
  google::protobuf::FieldMask every_state;
  every_state.add_paths("state");
  auto applied = client.Apply(session->name(), file.steps(), every_state);
  // The session is this run's scratch space: remove it whether or not the steps succeeded.
  const grpc::Status deleted = client.DeleteSession(session->name());
  if (!applied.ok()) return Fail(applied.status().error_message());
  PrintTable(columns, *applied);
  if (!deleted.ok()) return Fail(deleted.error_message());
  return EXIT_SUCCESS;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mdrctl: client of the mdr contact service"};
  app.require_subcommand(1);
  CLI::App* run = app.add_subcommand("run", "Apply a scene file's steps and print the states");
  std::string scene_path;
  std::string server_address;
  double timeout_seconds = 60;
  run->add_option("scene", scene_path, "Scene file (JSON of mdr.v1.SceneFile)")->required();
  run->add_option("--server", server_address,
                  "mdrd address host:port; without it an in-process server is used");
  run->add_option("--timeout", timeout_seconds, "Deadline of each call in seconds")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  // The embedded server's session log would interleave with the table; errors still show.
  spdlog::set_level(spdlog::level::warn);

  auto file = ReadSceneFile(scene_path);
  if (!file.ok()) return Fail(file.status().ToString());
  auto columns = ColumnsFor(*file);
  if (!columns.ok()) return Fail(columns.status().ToString());

  std::unique_ptr<mdr::service::ContactServer> embedded;
  std::shared_ptr<grpc::Channel> channel;
  if (server_address.empty()) {
    auto started = mdr::service::ContactServer::Start({});
    if (!started.ok()) return Fail(started.status().ToString());
    embedded = std::move(started).value();
    channel = embedded->InProcessChannel();
  } else {
    channel = grpc::CreateChannel(server_address, grpc::InsecureChannelCredentials());
  }
  const auto timeout = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::duration<double>(timeout_seconds));
  mdr::client::ContactClient client(channel, timeout);
  return RunScene(client, *file, *columns);
}
