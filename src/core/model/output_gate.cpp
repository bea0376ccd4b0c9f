#include "core/model/output_gate.h"

#include <algorithm>
#include <cmath>

#include "core/util/error.h"
#include "core/util/number_list.h"

namespace spikems {

ModelSpec with_output_gate(ModelSpec model, int64_t gate_us, const std::string& source) {
  if (model.type != ModelType::SNN)
    fail(source, "",
         "an output gate applies to spiking models only: the ANN-2D's output is gated by "
         "construction");
  const int64_t step_us = std::llround(model.time_step_ms * 1000.0);
  const std::string ms = std::to_string(double(gate_us) / 1000.0);
  if (gate_us < 0) fail(source, "", "output gate of " + ms + " ms: give 0 (off) or more");
  if (step_us <= 0 || gate_us % step_us != 0)
    fail(source, "",
         "output gate of " + ms + " ms is not a whole number of the model's " +
             std::to_string(model.time_step_ms) + " ms steps");
  if (gate_us / step_us > kMaxOutputGateSteps)
    fail(source, "",
         "output gate of " + ms + " ms is longer than " + std::to_string(kMaxOutputGateSteps) +
             " steps");
  model.output_gate_steps = int(gate_us / step_us);
  return model;
}

std::vector<int64_t> parse_gate_list_ms(const std::string& list, const std::string& what) {
  std::vector<int64_t> out;
  for (const ListedNumber& n : parse_number_list(list, what, "durations in ms like 0,10,20")) {
    const double v = n.value;
    if (v < 0 || v > 100000)
      fail(what, "", "'" + n.text + "' ms is out of range: give 0 (off) to 100000 ms");
    const int64_t us = std::llround(v * 1000.0);
    if (std::abs(double(us) - v * 1000.0) > 1e-6 * std::max(1.0, v * 1000.0))
      fail(what, "", "'" + n.text + "' ms is finer than a microsecond");
    out.push_back(us);
  }
  return out;
}

}  // namespace spikems
