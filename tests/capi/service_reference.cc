// The service's answer that the C, Fortran and Python callers of libmdr_c must reproduce bit for
// bit. Runs the service's transport-independent operations (ContactOperations, what mdrd's
// handlers call), not the C library.
//
//   capi_service_reference generate SCENE_FILE OUT_DIR
//     writes OUT_DIR/scene.pb (the scene file's Scene, serialized), history.txt (the steps),
//     reference.txt (the expected output of a caller, tests/capi/README in docs/capi.md),
//     snapshot.pb (the session exported after kRestoreAt steps) and final.pb (after all).
//   capi_service_reference contact_list SCENE_FILE OUT_DIR
//     the same for a contact list (an interface session of 3 contacts): list_history.txt and
//     list_reference.txt.
//   capi_service_reference analysis SCENE_FILE OUT_DIR
//     records three noisy fretting loops of the scene's contact (the service's conversion, the
//     core's steps, seeded noise) and writes a request of every analysis, analysis_K.request.pb
//     (K: the mdr_analysis number), with the service's answer analysis_K.service.pb
//     (compute_seconds 0, deterministic serialization). For the Octave package's torsional
//     records (tests/matlab/torsion_analysis_caller.m) it also twists the scene's contact behind
//     a shaft and writes torsion_analysis_scene.json, torsion_analysis_samples.txt ("phi M" per
//     sample) and torsion_analysis_reference.txt, the service's figures as analysis_reference.txt
//     has them (each "C" line ending in the cycle's full-slip moment).
//   capi_service_reference compare_analysis OUT_DIR
//     parses the library's answers analysis_K.library.pb (written by c_analysis.c) and checks
//     that each, compute_seconds cleared, is the service's answer byte for byte.
//   capi_service_reference torsion SCENE_FILE OUT_DIR
//     the same for a torsional scene (scene.torsion): torsion_scene.pb, torsion_history.txt,
//     torsion_reference.txt, torsion_snapshot.pb (after kTorsionRestoreAt steps) and
//     torsion_final.pb.
//   capi_service_reference import OUT_DIR SNAPSHOT [EXPECTED]
//     imports a snapshot written by the library and checks that the service's export of it has
//     the state (contact or torsion), scene and step count of EXPECTED (default final.pb): a state
//     moves from the library to the service.
//
// Formats (one line each, values as the 16 upper-case hex digits of a double's bits):
//   history.txt:   NORMAL_CONTROL NORMAL_VALUE TANGENTIAL_CONTROL TANGENTIAL_VALUE
//                  (controls as the mdr.h enum numbers: 0..3 for each channel)
//   reference.txt: "S depth ux a F_N F_x W" after every step of the history, then again after
//                  every step from kRestoreAt on, continued from snapshot.pb; then of the final
//                  state "K k+ k-", "J count edge_weight" and count lines "W r_begin r_end weight",
//                  "T tau tau_error p p_error" at the radii a*k/8 for k = 0..7, "L count" and count
//                  lines "I r_begin r_end direction" (direction in decimal).
//   list_history.txt: NORMAL_CONTROL TANGENTIAL_CONTROL, then one normal and one tangential value
//                  per contact (0 for a held channel)
//   list_reference.txt: after every step "S" and per contact "depth ux F_N F_x W", then "T F_N F_x
//   W"
//                  of the interface's totals
//   torsion_history.txt: NORMAL_CONTROL NORMAL_VALUE TWIST_CONTROL TWIST_VALUE (mdr.h numbers)
//   torsion_reference.txt: "S depth a F_N phi M M_slip W dW mu_F_N steps pieces" after every step
//                  (dW: the step's dissipated energy; steps and pieces in decimal), as
//                  reference.txt from kTorsionRestoreAt on again; then of the final state
//                  "K k+ k-", "L count" and count lines "I r_begin r_end direction", "T tau
//                  route_difference" at the radii a*k/8 for k = 0..9, and "E stored_energy"
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "mdr/analysis/exact_loops.h"
#include "mdr/bridge/analysis_ops.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/scene_file.h"
#include "mdr/bridge/torsion_session.h"
#include "mdr/service/operations.h"

namespace mdr::capi_testing {
namespace {

using service::ContactOperations;

constexpr int kRestoreAt = 100;
constexpr int kTorsionRestoreAt = 50;  // c_torsion.c's too
constexpr char kSessionId[] = "capi";
constexpr char kSessionName[] = "sessions/capi";

// One step of the history, with the mdr.h control numbers (0 holds; 1..3 for each channel).
struct HistoryStep {
  int normal_control;
  double normal_value;
  int tangential_control;
  double tangential_value;
};

// A Hertz fretting history that exercises every control: loading by normal force, fretting by
// displacement targets (partial slip), by tangential force, increments of both channels, and
// curved paths (normal and tangential force together).
std::vector<HistoryStep> History() {
  std::vector<HistoryStep> steps{{3, 100, 0, 0}};
  constexpr int kPerCycle = 40;
  for (int i = 1; i <= 3 * kPerCycle; ++i) {
    steps.push_back({0, 0, 1, 1e-6 * std::sin(2 * std::numbers::pi * i / kPerCycle)});
  }
  for (int i = 1; i <= 2 * kPerCycle; ++i) {
    steps.push_back({0, 0, 3, 15 * std::sin(2 * std::numbers::pi * i / kPerCycle)});
  }
  steps.push_back({3, 120, 3, 10});
  for (int i = 0; i < 10; ++i) steps.push_back({2, 1e-8, 2, -2e-8});
  steps.push_back({3, 100, 3, 15});
  steps.push_back({1, 3e-6, 2, 1e-7});
  return steps;
}

std::string Hex(double value) {
  std::uint64_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  char text[17];
  std::snprintf(text, sizeof text, "%016" PRIX64, bits);
  return text;
}

void SetNormal(const HistoryStep& s, v1::Step* step) {
  switch (s.normal_control) {
    case 1:
      step->set_depth(s.normal_value);
      break;
    case 2:
      step->set_depth_increment(s.normal_value);
      break;
    case 3:
      step->set_normal_force(s.normal_value);
      break;
    default:
      break;
  }
}

v1::Step ToProto(const HistoryStep& s) {
  v1::Step step;
  SetNormal(s, &step);
  switch (s.tangential_control) {
    case 1:
      step.set_displacement(s.tangential_value);
      break;
    case 2:
      step.set_displacement_increment(s.tangential_value);
      break;
    case 3:
      step.set_tangential_force(s.tangential_value);
      break;
    default:
      break;
  }
  return step;
}

bool Check(const Status& status, const char* what) {
  if (status.ok()) return true;
  std::cerr << what << ": " << status.ToString() << "\n";
  return false;
}

// Applies the steps one batch each (as a rig streams them) and appends their "S" lines.
bool ApplySteps(ContactOperations& ops, const std::vector<HistoryStep>& steps, std::size_t first,
                std::ostream& out) {
  for (std::size_t i = first; i < steps.size(); ++i) {
    v1::ApplyRequest request;
    request.set_session(kSessionName);
    *request.add_steps() = ToProto(steps[i]);
    request.mutable_step_mask()->add_paths("state");
    v1::ApplyResponse response;
    if (!Check(ops.Apply(
                   std::nullopt, request, [] { return OkStatus(); }, &response),
               "Apply")) {
      std::cerr << "at step " << i << "\n";
      return false;
    }
    const v1::ContactState& s = response.step_results(0).state();
    out << "S " << Hex(s.depth()) << ' ' << Hex(s.tangential_displacement()) << ' '
        << Hex(s.contact_radius()) << ' ' << Hex(s.normal_force()) << ' '
        << Hex(s.tangential_force()) << ' ' << Hex(s.dissipated_energy()) << '\n';
  }
  return true;
}

bool WriteFinals(ContactOperations& ops, std::ostream& out) {
  v1::QueryRequest state_request;
  state_request.set_session(kSessionName);
  v1::QueryResponse state;
  if (!Check(ops.Query(std::nullopt, state_request, &state), "Query state")) return false;
  v1::QueryRequest request;
  request.set_session(kSessionName);
  for (const char* path :
       {"tangential_stiffness", "jager_weights", "tractions", "pressure", "slip_intervals"}) {
    request.mutable_read_mask()->add_paths(path);
  }
  const double a = state.state().contact_radius();
  for (int k = 0; k < 8; ++k) request.add_radii(a * k / 8);
  v1::QueryResponse r;
  if (!Check(ops.Query(std::nullopt, request, &r), "Query")) return false;
  out << "K " << Hex(r.tangential_stiffness().positive()) << ' '
      << Hex(r.tangential_stiffness().negative()) << '\n';
  out << "J " << r.jager_weights().intervals_size() << ' ' << Hex(r.jager_weights().edge_weight())
      << '\n';
  for (const v1::WeightInterval& w : r.jager_weights().intervals()) {
    out << "W " << Hex(w.r_begin()) << ' ' << Hex(w.r_end()) << ' ' << Hex(w.weight()) << '\n';
  }
  for (int k = 0; k < 8; ++k) {
    out << "T " << Hex(r.tractions(k).value()) << ' ' << Hex(r.tractions(k).error_estimate()) << ' '
        << Hex(r.pressure(k).value()) << ' ' << Hex(r.pressure(k).error_estimate()) << '\n';
  }
  out << "L " << r.slip_intervals_size() << '\n';
  for (const v1::SlipInterval& s : r.slip_intervals()) {
    out << "I " << Hex(s.r_begin()) << ' ' << Hex(s.r_end()) << ' ' << s.direction() << '\n';
  }
  return true;
}

bool CreateSession(ContactOperations& ops, const v1::Scene& scene) {
  v1::CreateSessionRequest request;
  request.set_session_id(kSessionId);
  *request.mutable_session()->mutable_scene() = scene;
  v1::Session session;
  return Check(ops.CreateSession(std::nullopt, request, &session), "CreateSession");
}

bool Export(ContactOperations& ops, v1::SessionSnapshot* snapshot) {
  v1::ExportSessionRequest request;
  request.set_name(kSessionName);
  return Check(ops.ExportSession(std::nullopt, request, snapshot), "ExportSession");
}

bool Import(ContactOperations& ops, const v1::SessionSnapshot& snapshot) {
  v1::DeleteSessionRequest remove;
  remove.set_name(kSessionName);
  ops.DeleteSession(std::nullopt, remove).ok();  // absent when the session is new
  v1::ImportSessionRequest request;
  request.set_session_id(kSessionId);
  *request.mutable_snapshot() = snapshot;
  v1::Session session;
  return Check(ops.ImportSession(std::nullopt, request, &session), "ImportSession");
}

bool WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream file(path, std::ios::binary);
  file << bytes;
  return static_cast<bool>(file);
}

bool ReadMessage(const std::string& path, google::protobuf::Message* message) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream bytes;
  bytes << file.rdbuf();
  if (file && message->ParseFromString(bytes.str())) return true;
  std::cerr << path << ": not a readable " << message->GetTypeName() << "\n";
  return false;
}

int Generate(const std::string& scene_file, const std::string& dir) {
  Result<bridge::SceneDocument> document = bridge::SceneDocument::Load(scene_file);
  if (!Check(document.status(), "scene file")) return 1;
  const v1::Scene& scene = document->file().scene();
  const std::vector<HistoryStep> steps = History();
  std::ostringstream history;
  for (const HistoryStep& s : steps) {
    history << s.normal_control << ' ' << Hex(s.normal_value) << ' ' << s.tangential_control << ' '
            << Hex(s.tangential_value) << '\n';
  }
  ContactOperations ops(service::ServiceLimits{}, service::TestHooks{});
  std::ostringstream reference;
  v1::SessionSnapshot middle, final;
  if (!CreateSession(ops, scene)) return 1;
  const std::vector<HistoryStep> first(steps.begin(), steps.begin() + kRestoreAt);
  if (!ApplySteps(ops, first, 0, reference) || !Export(ops, &middle)) return 1;
  if (!ApplySteps(ops, steps, kRestoreAt, reference)) return 1;
  // The callers restore the middle snapshot and repeat the second part: the service's import of
  // it must give the same lines again.
  if (!Import(ops, middle) || !ApplySteps(ops, steps, kRestoreAt, reference)) return 1;
  if (!WriteFinals(ops, reference) || !Export(ops, &final)) return 1;
  const bool written = WriteFile(dir + "/scene.pb", scene.SerializeAsString()) &&
                       WriteFile(dir + "/history.txt", history.str()) &&
                       WriteFile(dir + "/reference.txt", reference.str()) &&
                       WriteFile(dir + "/snapshot.pb", middle.SerializeAsString()) &&
                       WriteFile(dir + "/final.pb", final.SerializeAsString());
  if (!written) std::cerr << "cannot write into " << dir << "\n";
  return written ? 0 : 1;
}

// ---- Torsion: the second channel of a HistoryStep is the twist (mdr_twist_control numbers) ----

// Loading by normal force; twist fretting by angle targets, increments and moment targets in
// partial slip; a load increase at fixed twist, a twist far into slip and load decreases after it
// (the exact state allows them: every piece on a bound is then clipped to the smaller one), an
// empty step, and twists after.
std::vector<HistoryStep> TorsionHistory() {
  std::vector<HistoryStep> steps{{3, 100, 0, 0}};
  constexpr int kPerCycle = 20;
  for (int i = 1; i <= 2 * kPerCycle; ++i) {
    steps.push_back({0, 0, 1, 3e-3 * std::sin(2 * std::numbers::pi * i / kPerCycle)});
  }
  for (int i = 0; i < 10; ++i) steps.push_back({0, 0, 2, i % 2 == 0 ? -4e-4 : 3e-4});
  for (int i = 1; i <= kPerCycle; ++i) {
    steps.push_back({0, 0, 3, 2e-3 * std::sin(2 * std::numbers::pi * i / kPerCycle)});
  }
  steps.push_back({3, 130, 0, 0});
  steps.push_back({0, 0, 2, 2e-2});
  steps.push_back({3, 90, 0, 0});
  steps.push_back({2, -1e-8, 0, 0});
  steps.push_back({0, 0, 0, 0});
  steps.push_back({0, 0, 2, -3e-3});
  steps.push_back({0, 0, 3, 1e-3});
  steps.push_back({1, 4.5e-6, 0, 0});
  steps.push_back({0, 0, 1, 0});
  return steps;
}

v1::Step ToTorsionProto(const HistoryStep& s) {
  v1::Step step;
  SetNormal(s, &step);
  switch (s.tangential_control) {
    case 1:
      step.set_twist(s.tangential_value);
      break;
    case 2:
      step.set_twist_increment(s.tangential_value);
      break;
    case 3:
      step.set_twisting_moment(s.tangential_value);
      break;
    default:
      break;
  }
  return step;
}

bool ApplyTorsionSteps(ContactOperations& ops, const std::vector<HistoryStep>& steps,
                       std::size_t first, std::size_t last, std::ostream& out) {
  for (std::size_t i = first; i < last; ++i) {
    v1::ApplyRequest request;
    request.set_session(kSessionName);
    *request.add_steps() = ToTorsionProto(steps[i]);
    request.mutable_step_mask()->add_paths("state");
    request.mutable_step_mask()->add_paths("dissipated_energy");
    v1::ApplyResponse response;
    if (!Check(ops.Apply(
                   std::nullopt, request, [] { return OkStatus(); }, &response),
               "Apply")) {
      std::cerr << "at torsional step " << i << "\n";
      return false;
    }
    const v1::StepResult& r = response.step_results(0);
    const v1::ContactState& s = r.state();
    out << "S " << Hex(s.depth()) << ' ' << Hex(s.contact_radius()) << ' ' << Hex(s.normal_force())
        << ' ' << Hex(s.twist()) << ' ' << Hex(s.twisting_moment()) << ' '
        << Hex(s.full_slip_moment()) << ' ' << Hex(s.dissipated_energy()) << ' '
        << Hex(r.dissipated_energy()) << ' ' << Hex(s.friction_limit()) << ' ' << s.applied_steps()
        << ' ' << s.memory_vertices() << '\n';
  }
  return true;
}

bool WriteTorsionFinals(ContactOperations& ops, std::ostream& out) {
  v1::QueryRequest state_request;
  state_request.set_session(kSessionName);
  v1::QueryResponse state;
  if (!Check(ops.Query(std::nullopt, state_request, &state), "Query state")) return false;
  v1::QueryRequest request;
  request.set_session(kSessionName);
  for (const char* path : {"torsion.stiffness", "torsion.slip_intervals", "torsion.tractions",
                           "torsion.stored_energy"}) {
    request.mutable_read_mask()->add_paths(path);
  }
  const double a = state.state().contact_radius();
  for (int k = 0; k < 10; ++k) request.add_radii(a * k / 8);  // two beyond the contact
  v1::QueryResponse r;
  if (!Check(ops.Query(std::nullopt, request, &r), "Query torsion")) return false;
  const v1::TorsionOutputs& t = r.torsion();
  out << "K " << Hex(t.stiffness_positive()) << ' ' << Hex(t.stiffness_negative()) << '\n';
  out << "L " << t.slip_intervals_size() << '\n';
  for (const v1::SlipInterval& i : t.slip_intervals()) {
    out << "I " << Hex(i.r_begin()) << ' ' << Hex(i.r_end()) << ' ' << i.direction() << '\n';
  }
  for (const v1::TorsionTraction& traction : t.tractions()) {
    out << "T " << Hex(traction.value()) << ' ' << Hex(traction.route_difference()) << '\n';
  }
  out << "E " << Hex(t.stored_energy()) << '\n';
  return true;
}

int GenerateTorsion(const std::string& scene_file, const std::string& dir) {
  Result<bridge::SceneDocument> document = bridge::SceneDocument::Load(scene_file);
  if (!Check(document.status(), "scene file")) return 1;
  const v1::Scene& scene = document->file().scene();
  const std::vector<HistoryStep> steps = TorsionHistory();
  std::ostringstream history;
  for (const HistoryStep& s : steps) {
    history << s.normal_control << ' ' << Hex(s.normal_value) << ' ' << s.tangential_control << ' '
            << Hex(s.tangential_value) << '\n';
  }
  ContactOperations ops(service::ServiceLimits{}, service::TestHooks{});
  std::ostringstream reference;
  v1::SessionSnapshot middle, final;
  if (!CreateSession(ops, scene)) return 1;
  if (!ApplyTorsionSteps(ops, steps, 0, kTorsionRestoreAt, reference) || !Export(ops, &middle)) {
    return 1;
  }
  if (!ApplyTorsionSteps(ops, steps, kTorsionRestoreAt, steps.size(), reference)) return 1;
  // The caller restores the middle snapshot and repeats the rest, as the service's import does.
  if (!Import(ops, middle) ||
      !ApplyTorsionSteps(ops, steps, kTorsionRestoreAt, steps.size(), reference)) {
    return 1;
  }
  if (!WriteTorsionFinals(ops, reference) || !Export(ops, &final)) return 1;
  const bool written = WriteFile(dir + "/torsion_scene.pb", scene.SerializeAsString()) &&
                       WriteFile(dir + "/torsion_history.txt", history.str()) &&
                       WriteFile(dir + "/torsion_reference.txt", reference.str()) &&
                       WriteFile(dir + "/torsion_snapshot.pb", middle.SerializeAsString()) &&
                       WriteFile(dir + "/torsion_final.pb", final.SerializeAsString());
  if (!written) std::cerr << "cannot write into " << dir << "\n";
  return written ? 0 : 1;
}

// A contact list's history: per-contact targets and increments of both channels, force targets
// of both channels together (a curved path per contact) included.
struct ListStep {
  int normal_control, tangential_control;
  std::vector<double> normal, tangential;
};

std::vector<ListStep> ListHistory() {
  std::vector<ListStep> steps{{1, 0, {3.5e-6, 2e-6, 1e-6}, {0, 0, 0}}};
  for (int k = 1; k <= 40; ++k) {
    const double s = std::sin(2 * std::numbers::pi * k / 20);
    steps.push_back({0, 1, {0, 0, 0}, {8e-7 * s, 4e-7 * s, 1e-7 * s}});
  }
  steps.push_back({3, 3, {100, 50, 20}, {10, -5, 2}});
  for (int k = 0; k < 5; ++k) steps.push_back({2, 2, {1e-8, -1e-8, 2e-8}, {-3e-8, 1e-8, 0}});
  return steps;
}

int GenerateContactList(const std::string& scene_file, const std::string& dir) {
  Result<bridge::SceneDocument> document = bridge::SceneDocument::Load(scene_file);
  if (!Check(document.status(), "scene file")) return 1;
  ContactOperations ops(service::ServiceLimits{}, service::TestHooks{});
  if (!CreateSession(ops, document->file().scene())) return 1;
  std::ostringstream history, reference;
  for (const ListStep& step : ListHistory()) {
    history << step.normal_control << ' ' << step.tangential_control;
    for (double v : step.normal) history << ' ' << Hex(v);
    for (double v : step.tangential) history << ' ' << Hex(v);
    history << '\n';
    v1::ApplyRequest request;
    request.set_session(kSessionName);
    v1::Step* proto = request.add_steps();
    *proto = ToProto({step.normal_control, 0, step.tangential_control, 0});
    if (step.normal_control != 0)
      proto->mutable_contact_normal_values()->Add(step.normal.begin(), step.normal.end());
    if (step.tangential_control != 0) {
      proto->mutable_contact_tangential_values()->Add(step.tangential.begin(),
                                                      step.tangential.end());
    }
    v1::ApplyResponse response;
    if (!Check(ops.Apply(
                   std::nullopt, request, [] { return OkStatus(); }, &response),
               "Apply")) {
      return 1;
    }
    reference << 'S';
    for (std::uint64_t i = 0; i < step.normal.size(); ++i) {
      v1::QueryRequest query;
      query.set_session(kSessionName);
      query.set_contact_index(i);
      v1::QueryResponse answer;
      if (!Check(ops.Query(std::nullopt, query, &answer), "Query")) return 1;
      const v1::ContactState& c = answer.state();
      reference << ' ' << Hex(c.depth()) << ' ' << Hex(c.tangential_displacement()) << ' '
                << Hex(c.normal_force()) << ' ' << Hex(c.tangential_force()) << ' '
                << Hex(c.dissipated_energy());
    }
    const v1::ContactState& t = response.state();
    reference << "\nT " << Hex(t.normal_force()) << ' ' << Hex(t.tangential_force()) << ' '
              << Hex(t.dissipated_energy()) << '\n';
  }
  const bool written = WriteFile(dir + "/list_history.txt", history.str()) &&
                       WriteFile(dir + "/list_reference.txt", reference.str());
  if (!written) std::cerr << "cannot write into " << dir << "\n";
  return written ? 0 : 1;
}

int CheckImport(const std::string& dir, const std::string& snapshot_path,
                const std::string& expected_name) {
  v1::SessionSnapshot library, expected;
  if (!ReadMessage(snapshot_path, &library) || !ReadMessage(dir + "/" + expected_name, &expected)) {
    return 1;
  }
  ContactOperations ops(service::ServiceLimits{}, service::TestHooks{});
  v1::SessionSnapshot exported;
  if (!Import(ops, library) || !Export(ops, &exported)) return 1;
  using google::protobuf::util::MessageDifferencer;
  std::string difference;
  MessageDifferencer differencer;
  differencer.ReportDifferencesToString(&difference);
  bool same = differencer.Compare(exported.contact(), expected.contact());
  same = differencer.Compare(exported.torsion(), expected.torsion()) && same;
  same = differencer.Compare(exported.scene(), expected.scene()) && same;
  if (exported.applied_steps() != expected.applied_steps()) {
    difference += "applied_steps " + std::to_string(exported.applied_steps()) +
                  " != " + std::to_string(expected.applied_steps()) + "\n";
    same = false;
  }
  if (!same) std::cerr << "the library's state differs from the service's:\n" << difference;
  return same ? 0 : 1;
}

// The analyses the library offers, by their mdr_analysis numbers (mdr.h).
constexpr int kAnalyzeLoops = 1, kFitLoops = 2, kFrettingMap = 3, kBackbone = 4;

std::string AnalysisPath(const std::string& dir, int k, const char* what) {
  return dir + "/analysis_" + std::to_string(k) + "." + what + ".pb";
}

std::string Deterministic(const google::protobuf::Message& message) {
  std::string bytes;
  google::protobuf::io::StringOutputStream stream(&bytes);
  google::protobuf::io::CodedOutputStream coded(&stream);
  coded.SetSerializationDeterministic(true);
  message.SerializeToCodedStream(&coded);
  coded.Trim();
  return bytes;
}

// Three fretting cycles at F_N = 100 N, 100 samples a cycle, with a rig's noise: 5 nm on the
// displacement, 0.05 N on the force (a fixed seed).
Result<v1::LoopSamples> RecordLoops(const v1::Scene& scene) {
  Result<ContactConfig> config = bridge::ToContactConfig(scene, 65536);
  if (!config.ok()) return config.status();
  Result<Contact> contact = Contact::Create(std::move(config).value());
  if (!contact.ok()) return contact.status();
  if (Status s = contact->Apply({.normal = NormalControl::kForce, .normal_value = 100}); !s.ok()) {
    return s;
  }
  std::mt19937_64 random(47);
  std::normal_distribution<double> noise(0, 1);
  v1::LoopSamples samples;
  for (int i = 0; i <= 300; ++i) {
    const double ux = 1e-6 * std::sin(2 * std::numbers::pi * i / 100);
    const Step step{
        .normal_value = 0, .tangential = TangentialControl::kDisplacement, .tangential_value = ux};
    if (Status s = contact->Apply(step); !s.ok()) return s;
    samples.add_displacement(contact->tangential_displacement() + 5e-9 * noise(random));
    samples.add_tangential_force(contact->tangential_force() + 0.05 * noise(random));
  }
  return samples;
}

// A torsional record: the scene's contact (with scene.torsion) pressed to 100 N and twisted
// behind its shaft through three triangles of 6 mrad, 120 samples each, with 2 urad on the twist
// and 20 uN m on the moment of seeded noise.
Result<v1::LoopSamples> RecordTorsion(const v1::Scene& scene) {
  Result<ContactConfig> config = bridge::ToContactConfig(scene, 65536);
  if (!config.ok()) return config.status();
  Result<analysis::TorsionalScene> torsion = bridge::ToTorsionalScene(scene, *config);
  if (!torsion.ok()) return torsion.status();
  Result<TorsionalContact> contact = analysis::PressTorsionalContact(*torsion, 100);
  if (!contact.ok()) return contact.status();
  std::mt19937_64 random(49);
  std::normal_distribution<double> noise(0, 1);
  v1::LoopSamples samples;
  for (int k = 0; k <= 360; ++k) {
    const double phase = static_cast<double>(k % 120) / 120;
    const double wave = phase < 0.25 ? 4 * phase : phase < 0.75 ? 2 - 4 * phase : 4 * phase - 4;
    if (Status s = contact->TwistThroughCompliance(6e-3 * wave, torsion->rig_compliance); !s.ok()) {
      return s;
    }
    samples.add_twist(6e-3 * wave + 2e-6 * noise(random));
    samples.add_twisting_moment(contact->memory().Moment() + 2e-5 * noise(random));
  }
  return samples;
}

// A message as proto3 JSON with the proto's field names, for the Octave callers.
bool WriteJson(const google::protobuf::Message& message, const std::string& path) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  return google::protobuf::util::MessageToJsonString(message, &json, options).ok() &&
         WriteFile(path, json);
}

// The figures an Octave caller prints, in hex: "C Q* Ed delta_0 A B k_sec REGIME" per cycle (a
// torsional record's M*, phi_0, ... and its full-slip moment last), "E value se lower upper
// verdict" per estimate and "B k_sec damping" per backbone loop.
std::string AnalysisFigures(const v1::AnalyzeLoopsResponse& loops, const v1::FitResult& fit,
                            const v1::BackboneResponse& backbone, bool torsional) {
  std::string figures;
  for (const v1::CycleFigures& c : loops.cycles()) {
    figures += "C " + Hex(c.force_amplitude()) + " " + Hex(c.dissipated_energy()) + " " +
               Hex(c.half_opening()) + " " + Hex(c.energy_ratio()) + " " + Hex(c.sliding_ratio()) +
               " " + Hex(c.secant_stiffness()) + " " + v1::Regime_Name(c.regime()) +
               (torsional ? " " + Hex(c.full_slip_moment()) : "") + "\n";
  }
  for (const v1::ParameterEstimate& e : fit.estimates()) {
    figures += "E " + Hex(e.value()) + " " + Hex(e.standard_error()) + " " + Hex(e.lower_95()) +
               " " + Hex(e.upper_95()) + (e.identified() ? " identified" : " not_identified") +
               "\n";
  }
  for (const v1::LoopFigures& l : backbone.loops()) {
    figures += "B " + Hex(l.secant_stiffness()) + " " + Hex(l.damping_ratio()) + "\n";
  }
  return figures;
}

// The torsional record's analyses by the service for the Octave caller: the loops classified
// against the full-slip moment at 100 N, a fit of mu and G_t (and the shaft), the backbone by
// the actuator's twist.
int GenerateTorsionalAnalysis(const v1::Scene& tangential, const std::string& dir) {
  v1::Scene scene = tangential;
  scene.clear_rig();
  scene.mutable_torsion()->set_rig_compliance(0.5);
  Result<v1::LoopSamples> samples = RecordTorsion(scene);
  if (!Check(samples.status(), "recording the torsional loops")) return 1;
  const service::ServiceLimits limits;
  const Interrupt never;
  v1::AnalyzeLoopsRequest loops;
  *loops.mutable_samples() = *samples;
  *loops.mutable_scene() = scene;
  loops.mutable_options()->set_normal_force(100);
  loops.mutable_options()->set_rig_compliance(0.5);
  v1::FitLoopsRequest fit;
  *fit.mutable_scene() = scene;
  fit.mutable_scene()->set_friction(0.25);
  v1::FitLoopsRequest::LoopSet* set = fit.add_sets();
  *set->mutable_samples() = *samples;
  set->set_normal_force(100);
  for (const auto& [parameter, initial, lower, upper] :
       {std::tuple{v1::FIT_PARAMETER_FRICTION, 0.25, 0.05, 0.9},
        std::tuple{v1::FIT_PARAMETER_TORSIONAL_MODULUS, 3e10, 1e9, 1e12}}) {
    v1::FitLoopsRequest::FreeParameter* free = fit.add_free();
    free->set_parameter(parameter);
    free->set_initial(initial);
    free->set_lower(lower);
    free->set_upper(upper);
  }
  v1::BackboneRequest backbone;
  *backbone.mutable_scene() = scene;
  backbone.set_normal_force(100);
  backbone.set_kind(v1::BackboneRequest::AMPLITUDE_KIND_ACTUATOR_DISPLACEMENT);
  for (double phi : {1e-4, 2e-3, 6e-3}) backbone.add_amplitudes(phi);
  v1::AnalyzeLoopsResponse loops_answer;
  v1::FitResult fit_answer;
  v1::BackboneResponse backbone_answer;
  if (!Check(bridge::RunAnalyzeLoops(loops, limits.max_memory_vertices, never, &loops_answer),
             "torsional loops") ||
      !Check(
          bridge::RunFitLoops(
              fit, limits.max_memory_vertices, never, [](const v1::FitProgress&) {}, &fit_answer),
          "torsional fit") ||
      !Check(bridge::RunBackbone(backbone, limits.max_memory_vertices, never, &backbone_answer),
             "torsional backbone")) {
    return 1;
  }
  std::string sample_lines;
  for (int i = 0; i < samples->twist_size(); ++i) {
    sample_lines += Hex(samples->twist(i)) + " " + Hex(samples->twisting_moment(i)) + "\n";
  }
  const bool written = WriteJson(scene, dir + "/torsion_analysis_scene.json") &&
                       WriteFile(dir + "/torsion_analysis_samples.txt", sample_lines) &&
                       WriteFile(dir + "/torsion_analysis_reference.txt",
                                 AnalysisFigures(loops_answer, fit_answer, backbone_answer, true));
  return written ? 0 : 1;
}

template <typename Request, typename Response, typename Run>
bool WriteAnalysis(const std::string& dir, int k, const Request& request, Run run) {
  Response response;
  if (!Check(run(request, &response), "analysis")) return false;
  response.set_compute_seconds(0);
  return WriteFile(AnalysisPath(dir, k, "request"), request.SerializeAsString()) &&
         WriteFile(AnalysisPath(dir, k, "service"), Deterministic(response));
}

int GenerateAnalysis(const std::string& scene_file, const std::string& dir) {
  Result<bridge::SceneDocument> document = bridge::SceneDocument::Load(scene_file);
  if (!Check(document.status(), "scene file")) return 1;
  const v1::Scene& scene = document->file().scene();
  Result<v1::LoopSamples> samples = RecordLoops(scene);
  if (!Check(samples.status(), "recording the loops")) return 1;
  const service::ServiceLimits limits;
  const Interrupt never;

  v1::AnalyzeLoopsRequest loops;
  *loops.mutable_samples() = *samples;
  *loops.mutable_scene() = scene;
  loops.mutable_options()->set_normal_force(100);
  v1::FitLoopsRequest fit;
  *fit.mutable_scene() = scene;
  v1::FitLoopsRequest::LoopSet* set = fit.add_sets();
  *set->mutable_samples() = *samples;
  set->set_normal_force(100);
  v1::FitLoopsRequest::FreeParameter* free = fit.add_free();
  free->set_parameter(v1::FIT_PARAMETER_FRICTION);
  free->set_initial(0.25);
  free->set_lower(0.05);
  free->set_upper(0.9);
  v1::FrettingMapRequest map;
  *map.mutable_scene() = scene;
  for (double f : {50.0, 100.0}) map.add_normal_forces(f);
  for (double a : {0.3, 1.0, 3.0}) map.add_relative_amplitudes(a);
  v1::BackboneRequest backbone;
  *backbone.mutable_scene() = scene;
  backbone.set_normal_force(100);
  backbone.set_kind(v1::BackboneRequest::AMPLITUDE_KIND_FORCE);
  for (double q : {5.0, 15.0, 25.0}) backbone.add_amplitudes(q);

  // For the MATLAB/Octave package (tests/matlab/analysis_caller.m): the scene as JSON, the
  // samples in hex, and the service's figures in hex.
  if (!WriteJson(scene, dir + "/analysis_scene.json")) return 1;
  std::string sample_lines;
  for (int i = 0; i < samples->displacement_size(); ++i) {
    sample_lines += Hex(samples->displacement(i)) + " " + Hex(samples->tangential_force(i)) + "\n";
  }
  if (!WriteFile(dir + "/analysis_samples.txt", sample_lines)) return 1;
  const bool written =
      WriteAnalysis<v1::AnalyzeLoopsRequest, v1::AnalyzeLoopsResponse>(
          dir, kAnalyzeLoops, loops,
          [&](const auto& r, auto* out) {
            return bridge::RunAnalyzeLoops(r, limits.max_memory_vertices, never, out);
          }) &&
      WriteAnalysis<v1::FitLoopsRequest, v1::FitResult>(dir, kFitLoops, fit,
                                                        [&](const auto& r, auto* out) {
                                                          return bridge::RunFitLoops(
                                                              r, limits.max_memory_vertices, never,
                                                              [](const v1::FitProgress&) {}, out);
                                                        }) &&
      WriteAnalysis<v1::FrettingMapRequest, v1::FrettingMapResponse>(
          dir, kFrettingMap, map,
          [&](const auto& r, auto* out) {
            return bridge::RunFrettingMap(r, limits.max_memory_vertices, never, out);
          }) &&
      WriteAnalysis<v1::BackboneRequest, v1::BackboneResponse>(
          dir, kBackbone, backbone, [&](const auto& r, auto* out) {
            return bridge::RunBackbone(r, limits.max_memory_vertices, never, out);
          });
  if (!written) return 1;
  // The figures the Octave caller prints, from the service's answers.
  v1::AnalyzeLoopsResponse loops_answer;
  v1::FitResult fit_answer;
  v1::BackboneResponse backbone_answer;
  if (!ReadMessage(AnalysisPath(dir, kAnalyzeLoops, "service"), &loops_answer) ||
      !ReadMessage(AnalysisPath(dir, kFitLoops, "service"), &fit_answer) ||
      !ReadMessage(AnalysisPath(dir, kBackbone, "service"), &backbone_answer)) {
    return 1;
  }
  if (!WriteFile(dir + "/analysis_reference.txt",
                 AnalysisFigures(loops_answer, fit_answer, backbone_answer, false))) {
    return 1;
  }
  return GenerateTorsionalAnalysis(scene, dir);
}

template <typename Response>
bool SameAnswer(const std::string& dir, int k) {
  Response library, service;
  if (!ReadMessage(AnalysisPath(dir, k, "library"), &library) ||
      !ReadMessage(AnalysisPath(dir, k, "service"), &service)) {
    return false;
  }
  if (!(library.compute_seconds() > 0)) {
    std::cerr << "analysis " << k << ": the library's compute_seconds is not filled\n";
    return false;
  }
  library.set_compute_seconds(0);
  if (Deterministic(library) == Deterministic(service)) return true;
  std::cerr << "analysis " << k << ": the library's answer differs from the service's\n";
  return false;
}

int CompareAnalysis(const std::string& dir) {
  const bool same = SameAnswer<v1::AnalyzeLoopsResponse>(dir, kAnalyzeLoops) &
                    SameAnswer<v1::FitResult>(dir, kFitLoops) &
                    SameAnswer<v1::FrettingMapResponse>(dir, kFrettingMap) &
                    SameAnswer<v1::BackboneResponse>(dir, kBackbone);
  return same ? 0 : 1;
}

}  // namespace
}  // namespace mdr::capi_testing

int main(int argc, char** argv) {
  using namespace mdr::capi_testing;
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "generate" && argc == 4) return Generate(argv[2], argv[3]);
  if (mode == "import" && (argc == 4 || argc == 5)) {
    return CheckImport(argv[2], argv[3], argc == 5 ? argv[4] : "final.pb");
  }
  if (mode == "contact_list" && argc == 4) return GenerateContactList(argv[2], argv[3]);
  if (mode == "torsion" && argc == 4) return GenerateTorsion(argv[2], argv[3]);
  if (mode == "analysis" && argc == 4) return GenerateAnalysis(argv[2], argv[3]);
  if (mode == "compare_analysis" && argc == 3) return CompareAnalysis(argv[2]);
  std::cerr << "usage: " << argv[0]
            << " generate SCENE_FILE OUT_DIR | contact_list SCENE_FILE OUT_DIR | torsion "
               "SCENE_FILE OUT_DIR | import OUT_DIR SNAPSHOT [EXPECTED] | analysis SCENE_FILE "
               "OUT_DIR | compare_analysis OUT_DIR\n";
  return 2;
}
