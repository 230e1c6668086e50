#include "mdr/client/scene_runner.h"

#include <algorithm>
#include <regex>
#include <string>
#include <vector>

#include "mdr/client/error_details.h"
#include "mdr/client/loading_path.h"

namespace mdr::client {
namespace {

using google::protobuf::FieldMask;
using google::protobuf::RepeatedPtrField;

constexpr std::uint64_t kMaxBatch = 1000;  // steps per Apply call (progress granularity)
constexpr std::uint32_t kDefaultSamples = 101;

grpc::Status InvalidArgument(const std::string& message) {
  return {grpc::StatusCode::INVALID_ARGUMENT, message};
}

// Where a batch of steps comes from: file.steps at `offset`, or path[segment] (step offset + i
// of total).
struct BatchOrigin {
  int segment = -1;  // -1: file.steps
  std::uint64_t offset = 0;
  std::uint64_t total = 0;
};

class Runner {
 public:
  Runner(ContactClient& client, const SceneDocument& document, const RunOptions& options)
      : client_(client), document_(document), options_(options) {}

  RpcResult<v1::RunReport> Run() {
    const Status valid = ValidateSceneFile(document_.file());
    if (!valid.ok())
      return InvalidArgument(document_.Error(valid.field(), valid.message()).ToString());
    auto session = client_.CreateSession(document_.file().scene());
    if (!session.ok()) return SceneError(session.status());
    report_.set_title(document_.file().title());
    report_.set_session(session->name());
    state_ = session->state();
    const std::uint32_t limit = session->limits().max_steps_per_batch();
    batch_ = limit == 0 ? kMaxBatch : std::min<std::uint64_t>(limit, kMaxBatch);
    total_ = StepCount(document_.file());
    grpc::Status status = RunAll();
    if (!options_.keep_session) {
      const grpc::Status deleted = client_.DeleteSession(session->name());
      if (status.ok()) status = deleted;
    }
    if (!status.ok()) return status;
    return std::move(report_);
  }

 private:
  grpc::Status RunAll() {
    const auto& file = document_.file();
    const std::vector<v1::Step> steps(file.steps().begin(), file.steps().end());
    grpc::Status status = ApplyAll(steps, {-1, 0, steps.size()});
    for (int k = 0; status.ok() && k < file.path_size(); ++k) status = RunSegment(k);
    return status;
  }

  grpc::Status RunSegment(int k) {
    const v1::Segment& segment = document_.file().path(k);
    if (segment.has_hold()) return Record(segment.hold());
    const std::size_t first_row = report_.rows_size();
    const double start_energy = state_.dissipated_energy();
    const std::vector<v1::Step> steps = ExpandSegment(segment, state_);
    const grpc::Status status = ApplyAll(steps, {k, 0, steps.size()});
    if (status.ok() && segment.has_cycles())
      AddCycleEnergies(k, segment.cycles(), first_row, start_energy);
    return status;
  }

  // Applies the steps in batches of at most batch_ and appends a row per step.
  grpc::Status ApplyAll(const std::vector<v1::Step>& steps, BatchOrigin origin) {
    FieldMask every_state;
    every_state.add_paths("state");
    for (std::uint64_t begin = 0; begin < steps.size(); begin += batch_) {
      const std::uint64_t end = std::min<std::uint64_t>(begin + batch_, steps.size());
      RepeatedPtrField<v1::Step> batch(steps.begin() + begin, steps.begin() + end);
      auto applied = client_.Apply(report_.session(), batch, every_state);
      origin.offset = begin;
      if (!applied.ok()) return StepError(applied.status(), origin);
      AppendRows(*applied, origin);
      state_ = applied->state();
      if (options_.progress) options_.progress(report_.rows_size(), total_);
    }
    return grpc::Status::OK;
  }

  void AppendRows(const v1::ApplyResponse& applied, const BatchOrigin& origin) {
    for (int i = 0; i < applied.step_results_size(); ++i) {
      v1::RunReport::Row* row = report_.add_rows();
      row->set_step(report_.rows_size());
      row->set_origin(origin.segment < 0 ? "steps[" + std::to_string(origin.offset + i) + "]"
                                         : "path[" + std::to_string(origin.segment) + "]");
      *row->mutable_state() = applied.step_results(i).state();
    }
  }

  void AddCycleEnergies(int k, const v1::Cycles& cycles, std::size_t first_row,
                        double start_energy) {
    const std::uint64_t per_cycle = StepsPerCycle(cycles);
    double before = start_energy;
    for (std::uint32_t c = 0; c < cycles.count(); ++c) {
      const double after =
          report_.rows(first_row + (c + 1) * per_cycle - 1).state().dissipated_energy();
      v1::RunReport::CycleEnergy* energy = report_.add_cycle_energies();
      energy->set_origin("path[" + std::to_string(k) + "]");
      energy->set_cycle(c + 1);
      energy->set_dissipated_energy(after - before);
      before = after;
    }
  }

  grpc::Status Record(const v1::Hold& hold) {
    v1::RunReport::Record* record = report_.add_records();
    record->set_name(hold.record().empty() ? "record " + std::to_string(report_.records_size())
                                           : hold.record());
    record->set_step(report_.rows_size());
    *record->mutable_state() = state_;
    const std::uint32_t n = hold.samples() == 0 ? kDefaultSamples : hold.samples();
    for (std::uint32_t i = 0; i < n; ++i) {
      record->add_radii(state_.contact_radius() * i / (n - 1));
    }
    v1::QueryRequest query;
    query.set_session(report_.session());
    *query.mutable_radii() = record->radii();
    query.mutable_read_mask()->add_paths("springs");
    auto springs = client_.Query(query);
    if (!springs.ok()) return springs.status();
    *record->mutable_springs() = springs->springs();
    return RecordOptional(query, record);
  }

  // Tractions and Jäger weights where the scene has them; a refusal is noted, not an error.
  grpc::Status RecordOptional(v1::QueryRequest query, v1::RunReport::Record* record) {
    for (const char* output : {"tractions", "jager_weights"}) {
      query.mutable_read_mask()->clear_paths();
      query.mutable_read_mask()->add_paths(output);
      auto queried = client_.Query(query);
      if (queried.ok()) {
        if (queried->tractions_size() > 0) *record->mutable_tractions() = queried->tractions();
        if (queried->has_jager_weights()) {
          *record->mutable_jager_weights() = queried->jager_weights();
        }
      } else if (queried.status().error_code() == grpc::StatusCode::FAILED_PRECONDITION ||
                 queried.status().error_code() == grpc::StatusCode::INVALID_ARGUMENT) {
        record->add_unavailable(std::string(output) + ": " + queried.status().error_message());
      } else {
        return queried.status();
      }
    }
    return grpc::Status::OK;
  }

  // A CreateSession error in the file's terms: the request's "session.scene..." is "scene...".
  grpc::Status SceneError(const grpc::Status& status) const {
    auto [field, message] = ReadErrorDetails(status);
    if (field.starts_with("session.")) field = field.substr(std::string("session.").size());
    if (field.empty()) return status;
    return {status.error_code(), document_.Error(field, message).ToString()};
  }

  // An Apply error in the file's terms: "steps[i]" of the batch is a step of the file or of a
  // segment.
  grpc::Status StepError(const grpc::Status& status, const BatchOrigin& origin) const {
    static const std::regex kStep(R"(^steps\[([0-9]+)\]\.?(.*)$)");
    auto [field, message] = ReadErrorDetails(status);
    std::smatch match;
    if (!std::regex_match(field, match, kStep)) return status;
    const std::uint64_t index = origin.offset + std::stoull(match[1]);
    const std::string channel = match[2];
    if (origin.segment < 0) {
      const std::string file_field =
          "steps[" + std::to_string(index) + "]" + (channel.empty() ? "" : "." + channel);
      return {status.error_code(), document_.Error(file_field, message).ToString()};
    }
    const std::string segment = "path[" + std::to_string(origin.segment) + "]";
    const std::string text = segment + " (step " + std::to_string(index + 1) + " of " +
                             std::to_string(origin.total) +
                             "): " + (channel.empty() ? "" : channel + ": ") + message + " (" +
                             document_.Where(segment) + ")";
    return {status.error_code(), text};
  }

  ContactClient& client_;
  const SceneDocument& document_;
  const RunOptions& options_;
  v1::RunReport report_;
  v1::ContactState state_;
  std::uint64_t batch_ = kMaxBatch;
  std::uint64_t total_ = 0;
};

}  // namespace

RpcResult<v1::RunReport> RunScene(ContactClient& client, const SceneDocument& document,
                                  const RunOptions& options) {
  return Runner(client, document, options).Run();
}

}  // namespace mdr::client
