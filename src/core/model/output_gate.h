// A model's output gate (ModelSpec::output_gate_steps) set from a duration, and lists of them
// for `spikems calibrate --gates` and `spikems eval --output-gates`. The gate keeps an output
// spike only where its pixel had an input event in the last K steps (docs/model-format.md,
// "Output gate"): it changes no weight, so any trained model can be scored with several.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/model/model_file.h"

namespace spikems {

// The model with output_gate_steps = gate_us / its time step (0 = off). Throws Error naming
// `source` for a negative duration, one that is not a whole number of steps, one beyond
// kMaxOutputGateSteps steps, or an ANN-2D model (gated by construction).
ModelSpec with_output_gate(ModelSpec model, int64_t gate_us, const std::string& source);

// Parses a comma-separated list of durations in ms ("0,10,20"; 0 = off; up to µs precision)
// into µs; throws Error naming `what` for an empty item, a non-number, a negative value, one
// above 100 s or a repeated value.
std::vector<int64_t> parse_gate_list_ms(const std::string& list, const std::string& what);

}  // namespace spikems
