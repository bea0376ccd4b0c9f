#include "core/model/time_step.h"

#include <algorithm>
#include <cmath>

#include "core/util/error.h"
#include "core/util/text_format.h"

namespace spikems {

TimeConstants parse_time_constants(const std::string& text, const std::string& what) {
  if (text == "steps") return TimeConstants::Steps;
  if (text == "ms") return TimeConstants::Ms;
  fail(what, "",
       "'" + text +
           "': give \"steps\" (each step's dynamics kept, time constants scaled) or \"ms\" (time "
           "constants kept in milliseconds)");
}

bool same_time_step(double a_ms, double b_ms) {
  return std::abs(a_ms - b_ms) <= 1e-9 * std::max(std::abs(a_ms), std::abs(b_ms));
}

ModelSpec with_time_step(ModelSpec model, double step_ms, TimeConstants keep,
                         const std::string& source) {
  if (!(std::isfinite(step_ms) && step_ms > 0))
    fail(source, "", "time step of " + fmt("%g", step_ms) + " ms: must be positive");
  if (same_time_step(model.time_step_ms, step_ms)) return model;
  if (model.type != ModelType::SNN)
    fail(source, "",
         "an ANN-2D model's time step is its frame: train or run it at its own " +
             fmt("%g", model.time_step_ms) + " ms");
  const double old_ms = model.time_step_ms, ratio = step_ms / old_ms;
  if (keep == TimeConstants::Steps) {
    // Every kernel is a function of (time / tau) sampled at multiples of the step, so scaling
    // tau with the step leaves each sample, and FIR kernels, delays and gate counts, unchanged.
    for (LayerSpec& l : model.layers) {
      l.neuron.tau_s = float(double(l.neuron.tau_s) * ratio);
      l.neuron.tau_r = float(double(l.neuron.tau_r) * ratio);
    }
  } else {
    for (size_t k = 0; k < model.layers.size(); ++k) {
      const LayerSpec& l = model.layers[k];
      const std::string why = "layer " + std::to_string(k + 1) + " ";
      if (l.neuron.discretisation == Discretisation::FIR)
        fail(source, "",
             why + "has FIR kernels sampled at " + fmt("%g", old_ms) +
                 " ms steps: keep the steps' dynamics (\"steps\") or convert it to IIR first");
      if (!l.delay.empty())
        fail(source, "",
             why + "has delays counted in " + fmt("%g", old_ms) +
                 " ms steps: keep the steps' dynamics (\"steps\")");
    }
    if (model.output_gate_steps > 0) {
      const double steps = double(model.output_gate_steps) / ratio;
      if (std::abs(steps - std::round(steps)) > 1e-9)
        fail(source, "",
             "the output gate of " + fmt("%g", double(model.output_gate_steps) * old_ms) +
                 " ms is not a whole number of " + fmt("%g", step_ms) +
                 " ms steps: set another gate too");
      model.output_gate_steps = int(std::llround(steps));
    }
  }
  model.time_step_ms = step_ms;
  return model;
}

}  // namespace spikems
