// The "every event moving" baseline (`spikems eval --baseline all-events`): P = every pixel with
// an input event in the window, i.e. a segmenter that cannot tell motion apart and passes all
// events through. A model must beat it to be said to segment moving objects (docs/results.md).
// Scored by the same WindowScorer as the models, so the numbers compare one to one.
#pragma once

#include <cstdint>
#include <vector>

#include "core/eval/sequence_scorer.h"

namespace spikems {

inline constexpr const char* kAllEventsBaseline = "all-events";

// Windows start at the first event; the partial last one is dropped (as score_sequence).
// opt.threads and opt.block_steps are unused. Throws Error for unlabelled events or a window
// length that is not positive.
SequenceScore score_all_events(const LabelledSequence& seq, const std::vector<int64_t>& windows_us,
                               const SequenceScoreOptions& opt = {});

}  // namespace spikems
