// A model moved to another time step, for fine-tuning at coarser (or finer) steps and for
// running a model at another step. Two meanings, both useful, neither safe to guess:
// - Steps: each step behaves as before; every time constant (tau_s, tau_r) is scaled by the
//   ratio of the steps, so the weights see the same per-step dynamics with more time (and
//   events) in each step. A trained model keeps its output; the runtime then runs 1/ratio as
//   many steps (docs/evaluation.md, "Coarser time steps").
// - Ms: the time constants stay in milliseconds (the neurons' physical dynamics); each step's
//   decay changes, so a trained network's potentials change (a 2 ms model at 5 ms steps falls
//   silent). The output gate keeps its duration.
#pragma once

#include <string>

#include "core/model/model_file.h"

namespace spikems {

enum class TimeConstants { Steps, Ms };

// Parses "steps" or "ms"; throws Error naming `what` otherwise.
TimeConstants parse_time_constants(const std::string& text, const std::string& what);

// Whether two steps are the same (within 1e-9 relative: steps are read from text and ms).
bool same_time_step(double a_ms, double b_ms);

// `model` with time_step_ms = step_ms, its neurons moved as `keep` says; at its own step (any
// model, any `keep`) the model unchanged. Throws Error naming `source` for a step that is not
// positive and finite, an ANN-2D model at another step (its step is its frame),
// and, with Ms, FIR kernels (sampled at the old step), delays (counted in old steps) or an output
// gate that is not a whole number of the new steps.
ModelSpec with_time_step(ModelSpec model, double step_ms, TimeConstants keep,
                         const std::string& source);

}  // namespace spikems
