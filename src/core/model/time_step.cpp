#include "core/model/time_step.h"

#include <cmath>

#include "core/util/error.h"

namespace spikems {

TimeConstants parse_time_constants(const std::string& text, const std::string& what) {
  if (text == "steps") return TimeConstants::Steps;
  if (text == "ms") return TimeConstants::Ms;
  fail(what, "",
       "'" + text +
           "': give \"steps\" (each step's dynamics kept, time constants scaled) or \"ms\" (time "
           "constants kept in milliseconds)");
}

ModelSpec with_time_step(ModelSpec model, double step_ms, TimeConstants keep,
                         const std::string& source) {
  if (!(std::isfinite(step_ms) && step_ms > 0))
    fail(source, "", "time step of " + std::to_string(step_ms) + " ms: must be positive");
  if (model.type != ModelType::SNN)
    fail(source, "",
         "an ANN-2D model's time step is its frame: train or run it at its own " +
             std::to_string(model.time_step_ms) + " ms");
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
             why + "has FIR kernels sampled at " + std::to_string(old_ms) +
                 " ms steps: keep the steps' dynamics (\"steps\") or convert it to IIR first");
      if (!l.delay.empty())
        fail(source, "",
             why + "has delays counted in " + std::to_string(old_ms) +
                 " ms steps: keep the steps' dynamics (\"steps\")");
    }
    if (model.output_gate_steps > 0) {
      const double steps = double(model.output_gate_steps) / ratio;
      if (std::abs(steps - std::round(steps)) > 1e-9)
        fail(source, "",
             "the output gate of " + std::to_string(double(model.output_gate_steps) * old_ms) +
                 " ms is not a whole number of " + std::to_string(step_ms) +
                 " ms steps: set another gate too");
      model.output_gate_steps = int(std::llround(steps));
    }
  }
  model.time_step_ms = step_ms;
  return model;
}

}  // namespace spikems
