// Scores an ANN-2D model (runtime/ann2d_network.h) on one labelled sequence: each window of
// each length is one event frame (ann_features.h) of that window's events, binned at the
// model's time step (and, for a model with ann_history, the frames of the windows just before
// it, newest first); P = the pixels with input events in the window whose logit is > 0 (the
// ANN says "moving" where events fell, as its loss is taught), G as for every model. Causal by
// construction: a window's prediction uses its own events and earlier ones only. Same WindowScorer,
// same windows, same skipped windows as score_sequence, so the tables compare one to one.
#pragma once

#include <cstdint>
#include <vector>

#include "core/eval/sequence_scorer.h"

namespace spikems {

// Windows start at the first event; the partial last one is dropped. opt.block_steps is
// unused. Throws Error for unlabelled events, a bad window length or a model that is not ANN-2D.
SequenceScore score_ann_sequence(const ModelSpec& model, const LabelledSequence& seq,
                                 const std::vector<int64_t>& windows_us,
                                 const SequenceScoreOptions& opt = {});

}  // namespace spikems
