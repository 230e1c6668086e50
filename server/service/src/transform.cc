#include "mdr/service/transform.h"

#include <string>
#include <utility>
#include <vector>

#include "mdr/bridge/conversion.h"
#include "mdr/bridge/outputs.h"
#include "mdr/core/jager.h"
#include "mdr/core/memory.h"
#include "mdr/core/sampled_weight.h"
#include "mdr/core/traction.h"

namespace mdr::service {

using bridge::CheckRadiiCount;
using bridge::Output;
using bridge::OutputSelection;
using bridge::RadialSampling;
using bridge::ToContactConfig;
using bridge::ToCoreTerms;
using bridge::ToProtoMemory;
using bridge::ToProtoRadialValues;
using bridge::ToProtoSampledWeight;
using bridge::ToRadialSampling;
namespace {

// AnalyzeSampledDisplacement names its inputs "x[i]", "u[i]", "options.tolerance",
// "options.max_plateaus" and mu*kappa "mu_kappa"; these are the request's paths.
Status ToSamplesStatus(const Status& status) {
  const std::string& field = status.field();
  if (field == "mu_kappa") return Status(status.code(), "scene.friction", status.message());
  const std::string options_prefix = "options.";
  const std::string relative =
      field.starts_with(options_prefix) ? field.substr(options_prefix.size()) : field;
  return Status(status.code(), relative.empty() ? "samples" : "samples." + relative,
                status.message());
}

Result<PiecewiseLinearMemory> SuperpositionMemory(
    const v1::CattaneoMindlinSuperposition& superposition, const ContactConfig& config) {
  Result<std::vector<CattaneoMindlinTerm>> terms = ToCoreTerms(superposition, *config.profile);
  if (!terms.ok()) return terms.status().WithFieldPrefix("superposition");
  Result<PiecewiseLinearMemory> memory =
      MemoryFromTerms(*terms, superposition.depth(), config.friction * config.material.kappa());
  if (!memory.ok()) return memory.status().WithFieldPrefix("superposition");
  return memory;
}

// The samples joined linearly in z = g(x), as one term per cell of non-zero rise: their Jäger
// weight is the sampled F (u constant inside x_0, u_N taken as 0).
std::vector<CattaneoMindlinTerm> CellTerms(const std::vector<double>& x, const Profile& profile,
                                           const SampledWeight& sampled) {
  std::vector<CattaneoMindlinTerm> terms;
  std::size_t cell = 0;
  for (std::size_t j = 0; j + 1 < x.size() && cell < sampled.weights.size(); ++j) {
    if (!(profile.Rise(x[j + 1], x[j]) > 0)) continue;  // no weight where g is constant
    terms.push_back(
        {sampled.weights[cell++], x[j + 1], x[j], profile.G(x[j + 1]), profile.G(x[j])});
  }
  return terms;
}

Result<PiecewiseLinearMemory> SampledMemory(const v1::SampledDisplacement& samples,
                                            const ContactConfig& config,
                                            v1::SampledWeight* sampled_weight) {
  const std::vector<double> x(samples.x().begin(), samples.x().end());
  const std::vector<double> u(samples.u().begin(), samples.u().end());
  SampledWeightOptions options;
  if (samples.has_tolerance()) options.tolerance = samples.tolerance();
  if (samples.has_max_plateaus()) options.max_plateaus = samples.max_plateaus();
  const double mu_kappa = config.friction * config.material.kappa();
  const Profile& profile = *config.profile;
  Result<SampledWeight> sampled = AnalyzeSampledDisplacement(x, u, profile, mu_kappa, options);
  if (!sampled.ok()) return ToSamplesStatus(sampled.status());
  ToProtoSampledWeight(*sampled, sampled_weight);
  const std::vector<CattaneoMindlinTerm> terms =
      sampled->kind == WeightKind::kStepFunction ? sampled->terms : CellTerms(x, profile, *sampled);
  Result<PiecewiseLinearMemory> memory = MemoryFromTerms(terms, profile.G(x.back()), mu_kappa);
  // The samples themselves break the Coulomb bound (|F| > 1 somewhere).
  if (!memory.ok()) return Status(memory.status().code(), "samples.u", memory.status().message());
  return memory;
}

// The memory the request's input defines (the sampled weight too, for samples).
Result<PiecewiseLinearMemory> InputMemory(const v1::TransformRequest& request,
                                          const ContactConfig& config,
                                          v1::TransformResponse* response) {
  switch (request.input_case()) {
    case v1::TransformRequest::kSuperposition:
      return SuperpositionMemory(request.superposition(), config);
    case v1::TransformRequest::kSamples:
      return SampledMemory(request.samples(), config, response->mutable_sampled_weight());
    case v1::TransformRequest::INPUT_NOT_SET:
      break;
  }
  return InvalidArgument(
      "input", "required: set superposition (terms to memory) or samples (u(x) to weights)");
}

// The sizes of the request, before any work: the terms or samples (the work grows with their
// product with the memory) and the radii (their tractions must fit in the response).
Status CheckRequestSize(const v1::TransformRequest& request, int max_message_bytes) {
  if (request.superposition().terms_size() > kMaxTransformTerms) {
    return ResourceExhausted("superposition.terms",
                             std::to_string(request.superposition().terms_size()) +
                                 " terms exceed the limit of " +
                                 std::to_string(kMaxTransformTerms));
  }
  if (request.samples().x_size() > kMaxTransformSamples) {
    return ResourceExhausted("samples.x", std::to_string(request.samples().x_size()) +
                                              " samples exceed the limit of " +
                                              std::to_string(kMaxTransformSamples));
  }
  OutputSelection tractions;
  tractions.add(Output::kTractions);
  return CheckRadiiCount(request.radii_size(), tractions, max_message_bytes);
}

}  // namespace

Status RunTransform(const v1::TransformRequest& request, const ServiceLimits& limits,
                    v1::TransformResponse* response) {
  if (Status s = CheckRequestSize(request, limits.max_message_bytes); !s.ok()) return s;
  if (request.scene().has_interface()) {
    return InvalidArgument("scene.interface",
                           "must be unset: Transform works on one contact's memory (query an "
                           "interface's contact with QueryRequest.contact_index instead)");
  }
  Result<ContactConfig> config = ToContactConfig(request.scene(), limits.max_memory_vertices);
  if (!config.ok()) return config.status();
  Result<RadialSampling> sampling = ToRadialSampling(request.radii(), request.traction_route());
  if (!sampling.ok()) return sampling.status();
  Result<PiecewiseLinearMemory> memory = InputMemory(request, *config, response);
  if (!memory.ok()) return memory.status();
  ToProtoMemory(*memory, response->mutable_memory());

  v1::ErrorEstimate* estimate = response->mutable_error_estimate();
  estimate->set_profile_tolerance(config->profile->ToleranceEstimate());
  if (!sampling->radii.empty()) {
    Result<std::vector<RadialValue>> tractions = ComputeTangentialTraction(
        *memory, *config->profile, config->material, sampling->radii, sampling->traction_options);
    if (!tractions.ok()) return tractions.status();
    estimate->set_traction_error(ToProtoRadialValues(*tractions, response->mutable_tractions()));
  }
  return OkStatus();
}

}  // namespace mdr::service
