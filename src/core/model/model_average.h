// The uniform average of several snapshots of one network (stochastic weight averaging, as
// Izmailov et al. 2018 average the snapshots of one run): weights, axonal delays and biases are
// averaged element by element; everything else must be identical. Snapshots of one run a few
// hundred steps apart can differ in their output scale (the share of a real static poster
// called moving swung 5-10x between snapshots 250 steps apart; docs/results.md); an average
// smooths such drift as the trainer's running average (optim.ema_decay) does, over a window of
// saved snapshots chosen after the run. (Late snapshots of one run, at a low learning rate,
// average to what each scores: poster 18.0 % against 18.3-18.5 % for three snapshots.)
#pragma once

#include <string>
#include <vector>

#include "core/model/model_file.h"

namespace spikems {

// The average of `models` (at least two; sources[i] names models[i] in errors and in the
// record). Throws Error naming the second source and the layer and field when the models are
// not snapshots of one architecture with the same neurons, thresholds, kernels and output gate
// (a calibrated snapshot differs in its output θ: average uncalibrated snapshots, then
// calibrate). The result keeps the first model's name and training record without its
// calibration (an average needs its own) and adds training.averaged_from: [{source, steps}].
ModelSpec average_models(const std::vector<ModelSpec>& models,
                         const std::vector<std::string>& sources);

}  // namespace spikems
