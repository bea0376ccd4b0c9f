#include "core/model/output_threshold.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/util/error.h"
#include "core/util/number_list.h"

namespace spikems {

namespace {

void check_scale(double scale, const std::string& where) {
  if (!std::isfinite(scale) || scale <= 0 || scale > 100) {
    char b[64];
    std::snprintf(b, sizeof b, "%g", scale);
    fail(where, "",
         std::string("output threshold scale ") + b +
             " is out of range: give a factor in (0, 100], e.g. 1.2");
  }
}

}  // namespace

ModelSpec with_output_threshold(ModelSpec model, double scale, const std::string& source) {
  check_scale(scale, source);
  if (model.type != ModelType::SNN)
    fail(source, "",
         "an output threshold applies to spiking models only: an ANN-2D's output is a logit "
         "compared with 0");
  if (model.layers.empty()) fail(source, "", "the model has no layers");
  LayerSpec& out = model.layers.back();
  // A FIR layer keeps the refractory kernel its neuron samples (whose length follows θ, so that
  // the model keeps its exact IIR form); other stored kernels scale, both shapes being
  // proportional to θ. IIR layers compute theirs from θ.
  const bool sampled = out.neuron.discretisation == Discretisation::FIR &&
                       has_sampled_kernels(out, model.time_step_ms);
  out.neuron.theta = float(double(out.neuron.theta) * scale);
  if (sampled)
    out.ref_kernel = sample_refractory_kernel(out.neuron, model.time_step_ms);
  else
    for (float& v : out.ref_kernel) v = float(double(v) * scale);
  return model;
}

std::vector<double> parse_threshold_scales(const std::string& list, const std::string& what) {
  std::vector<double> out;
  for (const ListedNumber& n : parse_number_list(list, what, "factors like 1,1.1,1.2")) {
    check_scale(n.value, what);
    out.push_back(n.value);
  }
  return out;
}

}  // namespace spikems
