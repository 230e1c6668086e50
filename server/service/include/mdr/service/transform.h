// Transform: the stateless conversion between the Jäger picture (Cattaneo-Mindlin terms, sampled
// spring displacements) and the MDR memory, with the tractions of the result (contract in
// contact_service.proto). No session and no gRPC here; errors name the request fields.
#pragma once

#include <cstddef>

#include "mdr/core/status.h"
#include "mdr/v1/contact_service.pb.h"

namespace mdr::service {

// Most terms of a superposition and samples of a sampled u(x): the memory is built term by term,
// so the work grows with their product.
inline constexpr int kMaxTransformTerms = 10000;
inline constexpr int kMaxTransformSamples = 10000;

// Fills everything but compute_seconds. max_memory_vertices is the server's limit, as for
// sessions (the scene is validated like a session's).
Status RunTransform(const v1::TransformRequest& request, std::size_t max_memory_vertices,
                    v1::TransformResponse* response);

}  // namespace mdr::service
