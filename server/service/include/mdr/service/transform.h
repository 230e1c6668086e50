// Transform: the stateless conversion between the Jäger picture (Cattaneo-Mindlin terms, sampled
// spring displacements) and the MDR memory, with the tractions of the result (contract in
// contact_service.proto). No session and no gRPC here; errors name the request fields.
#pragma once

#include <cstddef>

#include "mdr/base/status.h"
#include "mdr/service/limits.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

// Most terms of a superposition and samples of a sampled u(x): the memory is built term by term,
// so the work grows with their product. contact_service.proto states both (CattaneoMindlin-
// Superposition.terms, SampledDisplacement.x); keep them equal.
inline constexpr int kMaxTransformTerms = 10000;
inline constexpr int kMaxTransformSamples = 10000;

// Fills everything but compute_seconds. The sizes of the request (terms, samples, radii against
// the response's size) are checked before any work; the scene is validated like a session's,
// against the server's max_memory_vertices.
Status RunTransform(const v1::TransformRequest& request, const ServiceLimits& limits,
                    v1::TransformResponse* response);

}  // namespace mdr::service
