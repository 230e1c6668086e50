// The most samples the analysis RPCs take (analysis.proto states them), in the base library so
// that mdrctl's rig file readers refuse a file at the bound the server would, before sending it.
#pragma once

#include <cstddef>

namespace mdr {

// AnalyzeLoopsRequest.samples: at most this many samples.
inline constexpr std::size_t kMaxAnalyzedSamples = 10'000'000;
// FitLoopsRequest.sets: at most this many samples in all.
inline constexpr std::size_t kMaxFittedSamples = 1'000'000;

}  // namespace mdr
