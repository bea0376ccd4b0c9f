// A model's operating point: its output layer's firing threshold θ scaled by a factor, so that
// the same network labels fewer (factor > 1) or more (< 1) events moving. With a potential
// readout (docs/training.md: the output layer has no refractory) the output's potential does
// not depend on its own θ, so the events labelled moving at a higher factor are a subset of
// those at a lower one: sweeping the factor traces the network's precision-recall curve
// (`spikems eval --output-thresholds`), and `spikems segment --output-threshold` runs one point.
#pragma once

#include <string>
#include <vector>

#include "core/model/model_file.h"

namespace spikems {

// The model with its last layer's θ multiplied by `scale`; its refractory (−scale_ref·θ) scales
// with θ as for any threshold (a FIR layer's sampled kernel is sampled again, any other stored
// kernel multiplied by `scale`). Throws Error naming `source` for
// a scale that is not a finite number in (0, 100], or an ANN-2D model (its output is a logit
// compared with 0, not a threshold).
ModelSpec with_output_threshold(ModelSpec model, double scale, const std::string& source);

// Parses a comma-separated list of scales ("1,1.1,1.2"); throws Error naming `what` for an empty
// item, a non-number, a value outside (0, 100] or a repeated value.
std::vector<double> parse_threshold_scales(const std::string& list, const std::string& what);

}  // namespace spikems
