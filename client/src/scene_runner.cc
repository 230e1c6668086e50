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
// Per-contact values per Apply call (1 MiB of doubles, well inside the default 4 MiB message).
constexpr std::uint64_t kMaxBatchValues = 1 << 17;
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
  Runner(ContactClient& client, const bridge::SceneDocument& document, const RunOptions& options)
      : client_(client), document_(document), options_(options) {}

  RpcResult<v1::RunReport> Run() {
    const Status valid = ValidateSceneFile(document_.file());
    if (!valid.ok())
      return InvalidArgument(document_.Error(valid.field(), valid.message()).ToString());
    if (grpc::Status options = CheckOptions(); !options.ok()) return options;
    auto session = client_.CreateSession(document_.file().scene());
    if (!session.ok()) return SceneError(session.status());
    report_.set_title(document_.file().title());
    report_.set_session(session->name());
    if (options_.contact_index) report_.set_contact_index(*options_.contact_index);
    report_.set_slip_histogram_bins(options_.slip_histogram_bins);
    report_.set_torsion(KindOf(document_.file().scene()) == SceneKind::kTorsion);
    state_ = session->state();
    const std::uint32_t limit = session->limits().max_steps_per_batch();
    batch_ = limit == 0 ? kMaxBatch : std::min<std::uint64_t>(limit, kMaxBatch);
    total_ = StepCount(document_.file());
    grpc::Status status = PrepareStepQuery();
    if (status.ok()) status = RunAll();
    if (!options_.keep_session) {
      const grpc::Status deleted = client_.DeleteSession(session->name());
      if (status.ok()) status = deleted;
    }
    if (!status.ok()) return status;
    return std::move(report_);
  }

 private:
  // The options against the scene's kind; their ranges are checked by the service.
  grpc::Status CheckOptions() const {
    if (IsInterface(KindOf(document_.file().scene()))) {
      if (options_.contact_index) return grpc::Status::OK;
      for (int k = 0; k < document_.file().path_size(); ++k) {
        if (!document_.file().path(k).has_hold()) continue;
        const std::string hold = "path[" + std::to_string(k) + "].hold";
        return InvalidArgument(document_
                                   .Error(hold,
                                          "records the profiles of one contact of the "
                                          "interface: give its --contact-index")
                                   .ToString());
      }
      return grpc::Status::OK;
    }
    if (options_.contact_index) {
      return InvalidArgument("--contact-index: needs an interface scene (scene.interface)");
    }
    if (options_.slip_histogram_bins > 0) {
      return InvalidArgument("--histogram-bins: needs an interface scene (scene.interface)");
    }
    return grpc::Status::OK;
  }

  // The query after every step: only the outputs printed. Sent once before the first step, so a
  // bad option fails before anything is applied.
  grpc::Status PrepareStepQuery() {
    step_query_.set_session(report_.session());
    auto* mask = step_query_.mutable_read_mask();
    if (NeedsInterfaceTotals(TableOutputs(document_.file()))) mask->add_paths("interface.totals");
    if (options_.slip_histogram_bins > 0) {
      mask->add_paths("interface.slip_histogram");
      step_query_.set_slip_histogram_bins(static_cast<std::int32_t>(options_.slip_histogram_bins));
    }
    if (options_.contact_index) {
      mask->add_paths("state");
      step_query_.set_contact_index(*options_.contact_index);
    }
    if (mask->paths().empty()) return grpc::Status::OK;
    auto probe = client_.Query(step_query_);
    if (probe.ok()) return grpc::Status::OK;
    auto [field, message] = ReadErrorDetails(probe.status());
    const std::string option = field == "contact_index"         ? "--contact-index"
                               : field == "slip_histogram_bins" ? "--histogram-bins"
                                                                : field;
    return {probe.status().error_code(), option + ": " + message};
  }

  bool QueriesEveryStep() const { return !step_query_.read_mask().paths().empty(); }

  // Steps per Apply: one when every step is followed by a query; a contact list's steps are
  // bounded by their per-contact values.
  std::uint64_t BatchSize(const std::vector<v1::Step>& steps) const {
    if (QueriesEveryStep()) return 1;
    std::uint64_t values = 0;  // the most of any step (a file's own steps may differ)
    for (const v1::Step& step : steps) {
      values = std::max<std::uint64_t>(
          values, step.contact_normal_values_size() + step.contact_tangential_values_size());
    }
    if (values == 0) return batch_;
    return std::clamp<std::uint64_t>(kMaxBatchValues / values, 1, batch_);
  }

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
    const v1::ContactState start = state_;
    const std::vector<v1::Step> steps =
        ExpandSegment(segment, state_, ContactCount(document_.file().scene()));
    const grpc::Status status = ApplyAll(steps, {k, 0, steps.size()});
    if (status.ok() && CycleCount(segment) > 0) AddCycleEnergies(k, segment, first_row, start);
    return status;
  }

  // Applies the steps in batches of at most batch_ and appends a row per step.
  grpc::Status ApplyAll(const std::vector<v1::Step>& steps, BatchOrigin origin) {
    FieldMask every_state;
    every_state.add_paths("state");
    const std::uint64_t batch_size = BatchSize(steps);
    for (std::uint64_t begin = 0; begin < steps.size(); begin += batch_size) {
      const std::uint64_t end = std::min<std::uint64_t>(begin + batch_size, steps.size());
      RepeatedPtrField<v1::Step> batch(steps.begin() + begin, steps.begin() + end);
      auto applied = client_.Apply(report_.session(), batch, every_state);
      origin.offset = begin;
      if (!applied.ok()) return StepError(applied.status(), origin);
      AppendRows(*applied, origin);
      state_ = applied->state();
      if (QueriesEveryStep()) {
        if (grpc::Status queried = AddStepOutputs(); !queried.ok()) return queried;
      }
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

  // The interface outputs of the last row (one step per batch when this is called).
  grpc::Status AddStepOutputs() {
    auto queried = client_.Query(step_query_);
    if (!queried.ok()) return queried.status();
    v1::RunReport::Row* row = report_.mutable_rows(report_.rows_size() - 1);
    const v1::InterfaceOutputs& outputs = queried->interface();
    if (outputs.has_totals()) *row->mutable_interface_totals() = outputs.totals();
    *row->mutable_slip_histogram() = outputs.slip_histogram();
    if (options_.contact_index) *row->mutable_contact() = queried->state();
    return grpc::Status::OK;
  }

  // The dissipated energy and the work of F_x and of M_z (trapezoidal rule) of every cycle.
  void AddCycleEnergies(int k, const v1::Segment& segment, std::size_t first_row,
                        const v1::ContactState& start) {
    const std::uint32_t quarter = segment.has_cycles()
                                      ? segment.cycles().steps_per_quarter()
                                      : segment.contact_cycles().steps_per_quarter();
    const std::uint64_t per_cycle = StepsPerCycle(quarter);
    const v1::ContactState* previous = &start;
    for (std::uint32_t c = 0; c < CycleCount(segment); ++c) {
      const double energy_before = previous->dissipated_energy();
      double work = 0;
      double twisting_work = 0;
      for (std::uint64_t j = 0; j < per_cycle; ++j) {
        const v1::ContactState& state = report_.rows(first_row + c * per_cycle + j).state();
        work += 0.5 * (previous->tangential_force() + state.tangential_force()) *
                (state.tangential_displacement() - previous->tangential_displacement());
        twisting_work += 0.5 * (previous->twisting_moment() + state.twisting_moment()) *
                         (state.twist() - previous->twist());
        previous = &state;
      }
      v1::RunReport::CycleEnergy* energy = report_.add_cycle_energies();
      energy->set_origin("path[" + std::to_string(k) + "]");
      energy->set_cycle(c + 1);
      energy->set_dissipated_energy(previous->dissipated_energy() - energy_before);
      energy->set_tangential_work(work);
      energy->set_twisting_work(twisting_work);
    }
  }

  grpc::Status Record(const v1::Hold& hold) {
    v1::RunReport::Record* record = report_.add_records();
    record->set_name(hold.record().empty() ? "record " + std::to_string(report_.records_size())
                                           : hold.record());
    record->set_step(report_.rows_size());
    v1::QueryRequest query;
    query.set_session(report_.session());
    if (options_.contact_index) query.set_contact_index(*options_.contact_index);
    auto recorded = RecordedState(query);
    if (!recorded.ok()) return recorded.status();
    *record->mutable_state() = *recorded;
    const std::uint32_t n = hold.samples() == 0 ? kDefaultSamples : hold.samples();
    for (std::uint32_t i = 0; i < n; ++i) {
      record->add_radii(recorded->contact_radius() * i / (n - 1));
    }
    *query.mutable_radii() = record->radii();
    if (KindOf(document_.file().scene()) == SceneKind::kTorsion) {
      query.mutable_read_mask()->add_paths("torsion.tractions");
      auto tractions = client_.Query(query);
      if (!tractions.ok()) return tractions.status();
      *record->mutable_torsion_tractions() = tractions->torsion().tractions();
      return grpc::Status::OK;
    }
    query.mutable_read_mask()->add_paths("springs");
    auto springs = client_.Query(query);
    if (!springs.ok()) return springs.status();
    *record->mutable_springs() = springs->springs();
    return RecordOptional(query, record);
  }

  // The state of the recorded contact: the run's for a single contact, else queried.
  RpcResult<v1::ContactState> RecordedState(v1::QueryRequest query) const {
    if (!query.has_contact_index()) return state_;
    query.mutable_read_mask()->add_paths("state");
    auto queried = client_.Query(query);
    if (!queried.ok()) return queried.status();
    return queried->state();
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
  const bridge::SceneDocument& document_;
  const RunOptions& options_;
  v1::RunReport report_;
  v1::ContactState state_;
  // The query after every step (empty read mask: none).
  v1::QueryRequest step_query_;
  std::uint64_t batch_ = kMaxBatch;
  std::uint64_t total_ = 0;
};

}  // namespace

RpcResult<v1::RunReport> RunScene(ContactClient& client, const bridge::SceneDocument& document,
                                  const RunOptions& options) {
  return Runner(client, document, options).Run();
}

}  // namespace mdr::client
