// The analysis RPCs (AnalyzeLoops, FitLoops, FrettingMap, Backbone; contract in
// analysis.proto and contact_service.proto): proto <-> mdr_analysis, no session and no gRPC here.
// Their sizes are checked before any work; errors name the request fields.
#pragma once

#include <cstddef>
#include <functional>

#include "mdr/base/sample_limits.h"  // kMaxAnalyzedSamples, kMaxFittedSamples
#include "mdr/base/status.h"
#include "mdr/core/interrupt.h"
#include "mdr/v1/analysis.pb.h"

namespace mdr::bridge {

// Bounds on the work one call may ask for (analysis.proto states them; the samples' bounds are
// mdr_base's, which mdrctl's file readers share).
inline constexpr int kMaxLoopSets = 64;
inline constexpr int kMaxFitIterations = 1000;
inline constexpr int kMaxMapForces = 100;
inline constexpr int kMaxMapAmplitudes = 200;
inline constexpr int kMaxBackboneAmplitudes = 1000;

// Each fills everything but compute_seconds. max_memory_vertices bounds the scene's memory as a
// session's (ToContactConfig).
Status RunAnalyzeLoops(const v1::AnalyzeLoopsRequest& request, std::size_t max_memory_vertices,
                       const Interrupt& interrupt, v1::AnalyzeLoopsResponse* response);
// progress is called after every iteration (on the calling thread).
Status RunFitLoops(const v1::FitLoopsRequest& request, std::size_t max_memory_vertices,
                   const Interrupt& interrupt,
                   const std::function<void(const v1::FitProgress&)>& progress,
                   v1::FitResult* result);
Status RunFrettingMap(const v1::FrettingMapRequest& request, std::size_t max_memory_vertices,
                      const Interrupt& interrupt, v1::FrettingMapResponse* response);
Status RunBackbone(const v1::BackboneRequest& request, std::size_t max_memory_vertices,
                   const Interrupt& interrupt, v1::BackboneResponse* response);

}  // namespace mdr::bridge
