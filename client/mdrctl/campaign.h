// The YAML files of `mdrctl fit` (a campaign: the scene, the rig's CSV files and what to fit) and
// of `mdrctl synthesize` (a synthetic campaign's truth, loads, amplitudes and noise). Their
// schemas are documented at the top of examples/rig_campaign/spec.yaml, in the campaign.yaml that
// synthesize writes, and in docs/analysis.md. Unknown keys are errors (a typo would otherwise
// silently take a default); every error is "field: message (file:line)".
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/v1/analysis.pb.h"
#include "mdr/v1/scene.pb.h"
#include "rig_csv.h"

namespace mdrctl {

// "friction", "effective_modulus", "profile_scale", "rig_compliance", "displacement_offset",
// "torsional_modulus".
const char* FitParameterName(mdr::v1::FitParameter parameter);

// Field path -> the 1-based line of its key in a YAML file.
class FieldLines {
 public:
  FieldLines() = default;
  explicit FieldLines(std::string file) : file_(std::move(file)) {}
  void Record(const std::string& field, int line) { lines_.emplace(field, line); }
  // "file:line" of `field` or of its nearest enclosing field with a line; "file" if none.
  std::string Where(const std::string& field) const;
  // "field: message (file:line)".
  mdr::Status Error(const std::string& field, const std::string& message) const;
  const std::string& file() const { return file_; }

 private:
  std::string file_;
  std::map<std::string, int> lines_;
};

struct CampaignSet {
  std::string file;  // as written in the campaign
  std::string path;  // resolved against the campaign's directory
  // N: required unless the set has a normal-force column (then replayed as measured and this,
  // if given, checked against it).
  std::optional<double> normal_force;
  CsvLayout layout;
  // The run of a file of several (its id in layout.run_column); unset: the file's only run.
  std::optional<std::string> run;
};

struct Campaign {
  std::string path;
  std::string title;
  mdr::v1::Scene scene;
  // Torsional when the scene has torsion: every set is then read as a torsional record (its
  // twist and twisting-moment columns) and the fit is torsional.
  mdr::analysis::LoopChannel channel = mdr::analysis::LoopChannel::kTangential;
  std::string scene_source;  // the scene file's path, or "inline"
  std::vector<CampaignSet> sets;
  std::vector<mdr::v1::FitLoopsRequest::FreeParameter> free;
  mdr::v1::FitLoopsRequest::Nuisances nuisances;
  std::optional<double> displacement_noise, force_noise;  // the sensors', when known
  std::optional<int> burn_in_reversals;
  double reversal_threshold = 0;          // m; 0: automatic
  int max_iterations = 0;                 // 0: the service's default
  double displacement_resolution = 0;     // m, for the regimes
  std::vector<double> map_normal_forces;  // empty: the sets' loads
  std::vector<double> map_relative_amplitudes;
  // Synthetic campaigns: the values the data were generated with, by parameter name.
  std::map<std::string, double> truth;
  FieldLines lines;
};

mdr::Result<Campaign> LoadCampaign(const std::string& path);

// The relative amplitudes of the fretting map when the campaign gives none.
std::vector<double> DefaultMapAmplitudes();

// A synthetic campaign's spec. A truth with torsion makes torsional runs: the amplitudes are the
// contact's twist amplitudes (rad), the noise is the twist's (rad) and the moment's (N m).
struct SynthesisSpec {
  std::string path;
  std::string title;
  mdr::v1::Scene truth;
  std::vector<double> normal_forces;  // N
  // The actuator's displacement amplitudes, m; torsional: the contact's twist amplitudes, rad.
  std::vector<double> amplitudes;
  int cycles = 0;
  int samples_per_cycle = 0;
  double sampling_rate = 0;  // Hz: t = i / sampling_rate
  std::uint64_t seed = 1;
  double displacement_noise = 0;    // standard deviation, m (rad)
  double force_noise = 0;           // standard deviation, N (N m)
  double force_noise_relative = 0;  // standard deviation over the run's noise-free Q* (M*)
  // Copied into the campaign (the fit section of the spec).
  std::vector<mdr::v1::FitLoopsRequest::FreeParameter> free;
  mdr::v1::FitLoopsRequest::Nuisances nuisances;
  std::optional<double> fit_displacement_noise, fit_force_noise;
  std::optional<int> burn_in_reversals;
  double reversal_threshold = 0;
  int max_iterations = 0;
  std::vector<double> map_relative_amplitudes;
  FieldLines lines;
};

mdr::Result<SynthesisSpec> LoadSynthesisSpec(const std::string& path);

}  // namespace mdrctl
