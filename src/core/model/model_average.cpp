#include "core/model/model_average.h"

#include <cstdio>

#include "core/util/error.h"

namespace spikems {

namespace {

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

// Throws unless `a` (the first model) and `b` agree on `what`.
template <typename T>
void same(const T& a, const T& b, const std::string& source, const std::string& where,
          const std::string& what) {
  if (!(a == b))
    fail(source, where,
         what +
             " differs from the first model's: only snapshots of one network with the same "
             "settings can be averaged (average uncalibrated snapshots, then run `spikems "
             "calibrate` on the average)");
}

void same_num(double a, double b, const std::string& source, const std::string& where,
              const std::string& what) {
  if (a != b)
    fail(source, where,
         what + " is " + num(b) + ", the first model's " + num(a) +
             ": only snapshots of one network with the same settings can be averaged (a "
             "calibrated model has its own output threshold: average uncalibrated snapshots, "
             "then run `spikems calibrate` on the average)");
}

void check_compatible(const ModelSpec& a, const ModelSpec& b, const std::string& source) {
  same(a.type, b.type, source, "", "the model type");
  same_num(a.time_step_ms, b.time_step_ms, source, "", "the time step (ms)");
  same_num(a.input_width, b.input_width, source, "", "the input width");
  same_num(a.input_height, b.input_height, source, "", "the input height");
  same_num(a.train_width, b.train_width, source, "", "the training grid's width");
  same_num(a.train_height, b.train_height, source, "", "the training grid's height");
  same_num(a.output_gate_steps, b.output_gate_steps, source, "", "the output gate (steps)");
  same_num(a.ann_history, b.ann_history, source, "", "the frame history");
  same_num(double(a.layers.size()), double(b.layers.size()), source, "", "the layer count");
  for (size_t k = 0; k < a.layers.size(); ++k) {
    const LayerSpec &x = a.layers[k], &y = b.layers[k];
    const std::string at = "layer " + std::to_string(k + 1);
    same(x.kind, y.kind, source, at, "the layer kind");
    same_num(x.in_channels, y.in_channels, source, at, "the input channel count");
    same_num(x.out_channels, y.out_channels, source, at, "the output channel count");
    same_num(x.kernel, y.kernel, source, at, "the kernel size");
    same_num(x.stride, y.stride, source, at, "the stride");
    same_num(x.padding, y.padding, source, at, "the padding");
    same_num(x.output_padding, y.output_padding, source, at, "the output padding");
    same_num(x.skip_from, y.skip_from, source, at, "the skip connection");
    const NeuronParams &n = x.neuron, &m = y.neuron;
    same_num(n.theta, m.theta, source, at, "the threshold θ");
    same_num(n.tau_s, m.tau_s, source, at, "tau_s");
    same_num(n.tau_r, m.tau_r, source, at, "tau_r");
    same_num(n.scale_ref, m.scale_ref, source, at, "scale_ref");
    same_num(n.tau_rho, m.tau_rho, source, at, "tau_rho");
    same_num(n.scale_rho, m.scale_rho, source, at, "scale_rho");
    same(n.refractory, m.refractory, source, at, "the refractory shape");
    same(n.discretisation, m.discretisation, source, at, "the neuron discretisation");
    same(n.surrogate, m.surrogate, source, at, "the surrogate form");
    same(x.srm_kernel, y.srm_kernel, source, at, "the sampled spike-response kernel");
    same(x.ref_kernel, y.ref_kernel, source, at, "the sampled refractory kernel");
    same_num(double(x.weight.size()), double(y.weight.size()), source, at, "the weight count");
    same_num(double(x.delay.size()), double(y.delay.size()), source, at, "the delay count");
    same_num(double(x.bias.size()), double(y.bias.size()), source, at, "the bias count");
  }
}

// out[i] = mean over models of field(model)[i], summed in double.
template <typename Field>
std::vector<float> mean_of(const std::vector<ModelSpec>& models, size_t layer, Field field) {
  const size_t n = field(models[0].layers[layer]).size();
  std::vector<double> sum(n, 0.0);
  for (const ModelSpec& m : models) {
    const std::vector<float>& v = field(m.layers[layer]);
    for (size_t i = 0; i < n; ++i) sum[i] += v[i];
  }
  std::vector<float> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = float(sum[i] / double(models.size()));
  return out;
}

}  // namespace

ModelSpec average_models(const std::vector<ModelSpec>& models,
                         const std::vector<std::string>& sources) {
  if (models.size() < 2 || sources.size() != models.size())
    fail(sources.empty() ? std::string("average") : sources[0], "",
         "give at least two models to average (snapshots of one training run)");
  for (size_t i = 1; i < models.size(); ++i) check_compatible(models[0], models[i], sources[i]);
  ModelSpec out = models[0];
  for (size_t k = 0; k < out.layers.size(); ++k) {
    out.layers[k].weight = mean_of(
        models, k, [](const LayerSpec& l) -> auto& { return l.weight; });
    out.layers[k].delay = mean_of(
        models, k, [](const LayerSpec& l) -> auto& { return l.delay; });
    out.layers[k].bias = mean_of(
        models, k, [](const LayerSpec& l) -> auto& { return l.bias; });
  }
  if (!out.training.is_object()) out.training = nlohmann::json::object();
  out.training.erase("calibration");
  nlohmann::json from = nlohmann::json::array();
  for (size_t i = 0; i < models.size(); ++i) {
    nlohmann::json e = {{"source", sources[i]}};
    const nlohmann::json& t = models[i].training;
    if (t.is_object() && t.contains("steps")) e["steps"] = t["steps"];
    from.push_back(std::move(e));
  }
  out.training["averaged_from"] = std::move(from);
  out.validate(sources[0]);
  return out;
}

}  // namespace spikems
