#include "core/model/model_file.h"

#include <algorithm>
#include <cmath>

#include "core/model/safetensors.h"
#include "core/util/error.h"

namespace spikems {

int LayerSpec::output_size(int in) const {
  if (kind == LayerKind::Conv) return (in + 2 * padding - kernel) / stride + 1;
  return (in - 1) * stride - 2 * padding + kernel + output_padding;
}

std::pair<int, int> ModelSpec::output_size(int h, int w) const {
  for (const auto& l : layers) {
    h = l.output_size(h);
    w = l.output_size(w);
  }
  return {h, w};
}

bool ModelSpec::has_skips() const {
  return std::any_of(layers.begin(), layers.end(),
                     [](const LayerSpec& l) { return l.skip_from >= 0; });
}

namespace {
// Whether one spatial dimension of this size passes every layer and meets every skip.
bool dimension_fits(const std::vector<LayerSpec>& layers, int n) {
  std::vector<int> out;
  for (const auto& l : layers) {
    if (l.skip_from >= 0 && out[size_t(l.skip_from)] != n) return false;
    n = l.output_size(n);
    if (n <= 0) return false;
    out.push_back(n);
  }
  return true;
}
}  // namespace

std::pair<int, int> ModelSpec::fitted_input_size(int h, int w) const {
  auto fit = [&](int n) {
    for (int m = std::max(n, 1); m < n + 4096; ++m)
      if (dimension_fits(layers, m)) return m;
    return n;  // none: check_input_size says why
  };
  return {fit(h), fit(w)};
}

void ModelSpec::check_input_size(int h, int w, const std::string& src) const {
  std::vector<std::pair<int, int>> out;
  for (size_t k = 0; k < layers.size(); ++k) {
    const auto& l = layers[k];
    const std::string where = "layer " + std::to_string(k);
    if (l.skip_from >= 0 && out[size_t(l.skip_from)] != std::make_pair(h, w))
      fail(src, where,
           "its skip connection from layer " + std::to_string(l.skip_from) + " is " +
               std::to_string(out[size_t(l.skip_from)].second) + "x" +
               std::to_string(out[size_t(l.skip_from)].first) + " but its input is " +
               std::to_string(w) + "x" + std::to_string(h) +
               " for this input size; use a size that is a multiple of 2^levels");
    h = l.output_size(h);
    w = l.output_size(w);
    if (h <= 0 || w <= 0) fail(src, where, "the input is too small for this network");
    out.emplace_back(h, w);
  }
}

void ModelSpec::validate(const std::string& src) const {
  if (layers.empty()) fail(src, "", "model has no layers");
  // The runtime steps in whole microseconds (Segmenter): a step it would round is refused.
  if (!(time_step_ms >= 0.001) || time_step_ms > 1000 ||
      std::abs(time_step_ms * 1000 - std::round(time_step_ms * 1000)) > 1e-6)
    fail(src, "",
         "time step must be a whole number of microseconds from 0.001 to 1000 ms, not " +
             std::to_string(time_step_ms) + " ms");
  if (input_width < 0 || input_height < 0 || input_width > 65535 || input_height > 65535)
    fail(src, "", "input size out of range");
  if (train_width < 0 || train_height < 0 || train_width > 65535 || train_height > 65535 ||
      (train_width == 0) != (train_height == 0))
    fail(src, "",
         "train_width/train_height must both be 0 (not recorded) or both 1 to 65535, got " +
             std::to_string(train_width) + "x" + std::to_string(train_height));
  if (output_gate_steps < 0 || output_gate_steps > kMaxOutputGateSteps)
    fail(src, "",
         "output_gate_steps must be 0 (off) to " + std::to_string(kMaxOutputGateSteps) + ", got " +
             std::to_string(output_gate_steps));
  if (output_gate_steps > 0 && type != ModelType::SNN)
    fail(src, "", "an output gate is for spiking models (the ANN-2D's output is gated already)");
  if (ann_history < 0 || ann_history > kMaxAnnHistory)
    fail(src, "",
         "ann_history must be 0 to " + std::to_string(kMaxAnnHistory) + " past frames, got " +
             std::to_string(ann_history));
  if (ann_history > 0 && type != ModelType::ANN2D)
    fail(src, "", "ann_history is for ANN-2D models (a spiking network keeps its own state)");
  for (size_t k = 0; k < layers.size(); ++k) {
    const auto& l = layers[k];
    std::string where = "layer " + std::to_string(k);
    if (l.in_channels <= 0 || l.out_channels <= 0 || l.in_channels > 4096 || l.out_channels > 4096)
      fail(src, where, "channel counts out of range");
    if (l.skip_from != -1 && (l.skip_from < 0 || size_t(l.skip_from) + 1 >= k))
      fail(src, where,
           "skip_from must name an earlier layer other than the predecessor (0.." +
               std::to_string(int(k) - 2) + "), got " + std::to_string(l.skip_from));
    const int fed = k == 0 ? l.in_channels
                           : layers[k - 1].out_channels +
                                 (l.skip_from >= 0 ? layers[size_t(l.skip_from)].out_channels : 0);
    if (l.in_channels != fed)
      fail(src, where,
           "takes " + std::to_string(l.in_channels) + " channels but layer " +
               std::to_string(k - 1) + " gives " + std::to_string(layers[k - 1].out_channels) +
               (l.skip_from >= 0 ? " and its skip from layer " + std::to_string(l.skip_from) + " " +
                                       std::to_string(layers[size_t(l.skip_from)].out_channels)
                                 : std::string()));
    if (l.kernel <= 0 || l.kernel > 15 || l.stride <= 0 || l.stride > 8 || l.padding < 0 ||
        l.padding >= l.kernel || l.output_padding < 0 || l.output_padding >= l.stride)
      fail(src, where, "kernel, stride or padding out of range");
    if (int64_t(l.weight.size()) != l.weight_count())
      fail(src, where,
           "weight has " + std::to_string(l.weight.size()) + " values, expected " +
               std::to_string(l.weight_count()));
    const auto& n = l.neuron;
    if (type == ModelType::SNN &&
        (!(n.theta > 0) || !(n.tau_s > 0) || !(n.tau_r > 0) || !(n.scale_ref >= 0) ||
         !std::isfinite(n.theta) || !std::isfinite(n.tau_s) || !std::isfinite(n.tau_r)))
      fail(src, where, "neuron parameters must be positive and finite");
    if (type == ModelType::SNN && n.discretisation == Discretisation::FIR &&
        (l.srm_kernel.empty() || l.ref_kernel.empty()))
      fail(src, where, "FIR layer without sampled kernels");
    if (type == ModelType::SNN && n.srm_onset != layers.front().neuron.srm_onset)
      fail(src, where,
           "mixes srm_onset \"same_step\" and \"next_step\" layers; the runtime needs one for "
           "all");
    if (type == ModelType::SNN && n.srm_onset == SrmOnset::SameStep &&
        n.discretisation == Discretisation::FIR)
      fail(src, where,
           "srm_onset \"same_step\" needs IIR neurons (a FIR layer's stored kernel sets its own "
           "onset)");
    if (l.srm_kernel.size() > 100000 || l.ref_kernel.size() > 100000)
      fail(src, where, "kernel longer than 100000 steps");
    if (!l.delay.empty() && int(l.delay.size()) != l.out_channels)
      fail(src, where, "delay must have one value per output channel");
    for (float v : l.weight)
      if (!std::isfinite(v)) fail(src, where, "weight contains NaN or infinity");
    if (type == ModelType::ANN2D && int(l.bias.size()) != l.out_channels)
      fail(src, where, "an ANN-2D layer needs one bias per output channel");
    if (type == ModelType::SNN && !l.bias.empty()) fail(src, where, "a spiking layer has no bias");
    for (float v : l.bias)
      if (!std::isfinite(v)) fail(src, where, "bias contains NaN or infinity");
  }
  if (type == ModelType::ANN2D &&
      (layers.front().in_channels != ann_input_channels() || layers.back().out_channels != 1))
    fail(src, "",
         "an ANN-2D model with " + std::to_string(ann_history) + " past frames takes " +
             std::to_string(ann_input_channels()) +
             " input channels (4 per frame, ann_features.h) and gives 1 output channel; its "
             "first layer has " +
             std::to_string(layers.front().in_channels));
  if (input_width > 0 && input_height > 0) {
    // The sensor's size: a model with skips runs on it padded to the fitted size.
    const auto [h, w] = has_skips() ? fitted_input_size(input_height, input_width)
                                    : std::make_pair(input_height, input_width);
    check_input_size(h, w, src);
  }
}

std::vector<float> sample_srm_kernel(double tau, double ts) {
  std::vector<float> k;
  for (int i = 0;; ++i) {
    double t = i * ts;
    double v = (t / tau) * std::exp(1.0 - t / tau);
    if (std::fabs(v) < 0.01 && t > tau) break;
    k.push_back(float(v));
    if (i > 1000000) break;
  }
  return k;
}

std::vector<float> sample_refractory_kernel(const NeuronParams& n, double ts) {
  std::vector<float> k;
  double mult = -double(n.scale_ref) * double(n.theta);
  if (n.refractory == RefractoryShape::SpikeMS) {
    k.push_back(0.f);
    for (int j = 0;; ++j) {
      double v = mult * std::exp(-j * ts / double(n.tau_r));
      if (!(std::fabs(v) > 0.01)) break;
      k.push_back(float(v));
      if (j > 1000000) break;
    }
  } else {
    for (int i = 0;; ++i) {
      double t = i * ts, tau = n.tau_r;
      double v = mult * (t / tau) * std::exp(1.0 - t / tau);
      if (std::fabs(v) < 0.01 && t > tau) break;
      k.push_back(float(v));
      if (i > 1000000) break;
    }
  }
  return k;
}

void fill_fir_kernels(ModelSpec& spec) {
  for (auto& l : spec.layers) {
    if (l.neuron.discretisation != Discretisation::FIR) {
      l.srm_kernel.clear();
      l.ref_kernel.clear();
      continue;
    }
    l.srm_kernel = sample_srm_kernel(l.neuron.tau_s, spec.time_step_ms);
    l.ref_kernel = sample_refractory_kernel(l.neuron, spec.time_step_ms);
  }
}

bool has_sampled_kernels(const LayerSpec& l, double ts) {
  auto same = [](const std::vector<float>& a, const std::vector<float>& b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i)
      if (std::fabs(double(a[i]) - double(b[i])) > 1e-6 * std::max(1.0, std::fabs(double(b[i]))))
        return false;
    return true;
  };
  return same(l.srm_kernel, sample_srm_kernel(l.neuron.tau_s, ts)) &&
         same(l.ref_kernel, sample_refractory_kernel(l.neuron, ts));
}

ModelSpec with_iir_neurons(ModelSpec spec, const std::string& source) {
  for (size_t k = 0; k < spec.layers.size(); ++k) {
    LayerSpec& l = spec.layers[k];
    if (l.neuron.discretisation != Discretisation::FIR) continue;
    if (!has_sampled_kernels(l, spec.time_step_ms))
      fail(source, "layer " + std::to_string(k),
           "its FIR kernels are not the sampled kernels of its neuron parameters, so they have "
           "no exact IIR form; run the model as it is (without the IIR option)");
    l.neuron.discretisation = Discretisation::IIR;
    l.srm_kernel.clear();
    l.ref_kernel.clear();
  }
  return spec;
}

void check_widths(const std::vector<int>& widths, const std::string& where) {
  if (widths.empty() || widths.size() > 6)
    fail(where, "", "needs 1 to 6 encoder levels, got " + std::to_string(widths.size()));
  for (int w : widths)
    if (w < 1 || w > 1024)
      fail(where, "", "a level's channels must lie in 1..1024, got " + std::to_string(w));
}

ModelSpec spikems_architecture(bool padded, Discretisation d, const std::vector<int>& widths,
                               const std::vector<double>& tau_s, bool skips,
                               const std::vector<int>& skip_levels) {
  check_widths(widths, "architecture widths");
  if (!skip_levels.empty() && !skips)
    fail("architecture skip_levels", "", "skip levels need skip connections (skips = true)");
  for (size_t a = 0; a < skip_levels.size(); ++a) {
    const int v = skip_levels[a];
    if (v < 1 || v >= int(widths.size()))
      fail("architecture skip_levels", "",
           "each must lie in 1.." + std::to_string(int(widths.size()) - 1) +
               " (1 = the finest level; the bottleneck has none), got " + std::to_string(v));
    for (size_t b = 0; b < a; ++b)
      if (skip_levels[b] == v)
        fail("architecture skip_levels", "", "level " + std::to_string(v) + " is given twice");
  }
  if (skips && !padded)
    fail("architecture", "",
         "skip connections need the padded geometry (the unpadded one loses a pixel per level, "
         "so the sizes do not meet)");
  const bool per_layer = tau_s.size() == 2 * widths.size();
  if (!tau_s.empty() && tau_s.size() != widths.size() && !per_layer)
    fail("architecture tau_s", "",
         "needs one time constant per level (" + std::to_string(widths.size()) +
             ") or per layer (" + std::to_string(2 * widths.size()) + "), got " +
             std::to_string(tau_s.size()));
  for (double t : tau_s)
    if (!(t >= 0.1 && t <= 100)) fail("architecture tau_s", "", "each must lie in 0.1..100 ms");
  // The authors' neuron parameters per encoder level; the decoder mirrors the encoder's (its
  // first layer the bottleneck's, its last the input layer's).
  struct Neuron {
    float theta, ts, tr, rho;
  };
  const Neuron enc[] = {{0.22f, 2, 1, 0.20f}, {0.22f, 2, 1, 0.30f}, {0.24f, 4, 3, 0.30f}};
  const Neuron dec[] = {{0.22f, 2, 1, 0.22f}, {0.22f, 2, 1, 0.25f}, {0.24f, 4, 3, 0.25f}};
  const int n = int(widths.size());
  struct Row {
    LayerKind k;
    int ci, co;
    Neuron nr;
    int skip = -1;
  };
  auto level = [&](const Neuron* table, int i) {
    Neuron nr = table[std::min(i, 2)];
    if (!tau_s.empty() && !per_layer) nr.ts = float(tau_s[size_t(i)]);
    return nr;
  };
  std::vector<Row> rows;
  for (int i = 0; i < n; ++i)
    rows.push_back(
        {LayerKind::Conv, i == 0 ? 2 : widths[size_t(i - 1)], widths[size_t(i)], level(enc, i)});
  // Decoder level i works at encoder level i's output resolution: with skips, level i's
  // spikes join it (all but the bottleneck's own level).
  for (int i = n - 1; i >= 0; --i) {
    const bool skip = skips && i < n - 1 &&
                      (skip_levels.empty() || std::find(skip_levels.begin(), skip_levels.end(),
                                                        i + 1) != skip_levels.end());
    rows.push_back({LayerKind::ConvTranspose, widths[size_t(i)] * (skip ? 2 : 1),
                    i == 0 ? 2 : widths[size_t(i - 1)], level(dec, i), skip ? i : -1});
  }
  if (per_layer)
    for (size_t k = 0; k < rows.size(); ++k) rows[k].nr.ts = float(tau_s[k]);
  ModelSpec s;
  s.name = padded ? "spikems-padded" : "spikems";
  for (const auto& r : rows) {
    LayerSpec l;
    l.kind = r.k;
    l.in_channels = r.ci;
    l.out_channels = r.co;
    l.padding = padded ? 1 : 0;
    l.output_padding = (padded && r.k == LayerKind::ConvTranspose) ? 1 : 0;
    l.skip_from = r.skip;
    l.neuron.theta = r.nr.theta;
    l.neuron.tau_s = r.nr.ts;
    l.neuron.tau_r = r.nr.tr;
    l.neuron.scale_rho = r.nr.rho;
    l.neuron.discretisation = d;
    l.weight.assign(size_t(l.weight_count()), 0.f);
    s.layers.push_back(std::move(l));
  }
  fill_fir_kernels(s);
  return s;
}

ModelSpec ann2d_architecture(const std::vector<int>& widths, bool skips,
                             const std::vector<int>& skip_levels, int history) {
  if (history < 0 || history > kMaxAnnHistory)
    throw Error("ANN-2D: history must be 0 to " + std::to_string(kMaxAnnHistory) +
                " past frames, got " + std::to_string(history));
  ModelSpec s = spikems_architecture(true, Discretisation::IIR, widths, {}, skips, skip_levels);
  s.name = "ann2d";
  s.type = ModelType::ANN2D;
  s.ann_history = history;
  s.layers.front().in_channels = s.ann_input_channels();
  s.layers.back().out_channels = 1;
  for (auto& l : s.layers) {
    l.weight.assign(size_t(l.weight_count()), 0.f);
    l.bias.assign(size_t(l.out_channels), 0.f);
  }
  return s;
}

namespace {

const char* kind_name(LayerKind k) {
  return k == LayerKind::Conv ? "conv" : "conv_transpose";
}

template <typename E>
E parse_enum(const nlohmann::json& j, const char* key,
             std::initializer_list<std::pair<const char*, E>> opts, E def, const std::string& src,
             const std::string& where) {
  if (!j.contains(key)) return def;
  std::string v = j[key].get<std::string>();
  for (auto& [n, e] : opts)
    if (v == n) return e;
  fail(src, where, std::string("unknown value '") + v + "' for " + key);
}

}  // namespace

nlohmann::json spec_to_json(const ModelSpec& s) {
  nlohmann::json j;
  j["name"] = s.name;
  if (s.type == ModelType::ANN2D) j["type"] = "ann2d";
  j["time_step_ms"] = s.time_step_ms;
  j["input_width"] = s.input_width;
  j["input_height"] = s.input_height;
  // Written only when recorded, so that older files rewrite byte for byte.
  if (s.train_width != 0) {
    j["train_width"] = s.train_width;
    j["train_height"] = s.train_height;
  }
  if (s.output_gate_steps != 0) j["output_gate_steps"] = s.output_gate_steps;
  if (s.ann_history != 0) j["ann_history"] = s.ann_history;
  j["training"] = s.training;
  j["layers"] = nlohmann::json::array();
  for (const auto& l : s.layers) {
    const auto& n = l.neuron;
    nlohmann::json lj = {{"kind", kind_name(l.kind)},
                         {"in_channels", l.in_channels},
                         {"out_channels", l.out_channels},
                         {"kernel", l.kernel},
                         {"stride", l.stride},
                         {"padding", l.padding},
                         {"output_padding", l.output_padding},
                         {"has_delay", !l.delay.empty()}};
    if (l.skip_from >= 0) lj["skip_from"] = l.skip_from;
    if (s.type == ModelType::SNN)
      lj["neuron"] = {
          {"theta", n.theta},
          {"tau_s", n.tau_s},
          {"tau_r", n.tau_r},
          {"scale_ref", n.scale_ref},
          {"tau_rho", n.tau_rho},
          {"scale_rho", n.scale_rho},
          {"refractory", n.refractory == RefractoryShape::SpikeMS ? "spikems" : "slayer"},
          {"discretisation", n.discretisation == Discretisation::FIR ? "fir" : "iir"},
          {"surrogate", n.surrogate == SurrogateForm::SpikeMS ? "spikems" : "slayer"}};
    // Written only when not SLAYER's, so that older files rewrite byte for byte.
    if (s.type == ModelType::SNN && n.srm_onset == SrmOnset::SameStep)
      lj["neuron"]["srm_onset"] = "same_step";
    j["layers"].push_back(std::move(lj));
  }
  return j;
}

ModelSpec spec_from_json(const nlohmann::json& j, const std::string& src) {
  ModelSpec s;
  // Fields of a number type must hold one: nlohmann converts 0.5 and true to an int, and true to
  // a float, without a word, so "stride": 0.5 would load as a stride of 0.
  auto typed = [&](const nlohmann::json& o, std::initializer_list<const char*> keys, bool integer,
                   const std::string& where) {
    if (!o.is_object()) fail(src, where, "not a JSON object");
    for (const char* key : keys)
      if (o.contains(key) && !(integer ? o[key].is_number_integer() : o[key].is_number()))
        fail(src, where,
             std::string("'") + key + "' must be " + (integer ? "an integer" : "a number") +
                 ", not " + o[key].dump());
  };
  typed(j,
        {"input_width", "input_height", "train_width", "train_height", "output_gate_steps",
         "ann_history"},
        true, "model spec");
  typed(j, {"time_step_ms"}, false, "model spec");
  try {
    s.name = j.value("name", "spikems");
    s.type =
        parse_enum<ModelType>(j, "type", {{"snn", ModelType::SNN}, {"ann2d", ModelType::ANN2D}},
                              ModelType::SNN, src, "model spec");
    s.time_step_ms = j.at("time_step_ms").get<double>();
    s.input_width = j.value("input_width", 0);
    s.input_height = j.value("input_height", 0);
    s.train_width = j.value("train_width", 0);
    s.train_height = j.value("train_height", 0);
    s.output_gate_steps = j.value("output_gate_steps", 0);
    s.ann_history = j.value("ann_history", 0);
    if (j.contains("training")) s.training = j["training"];
    for (size_t k = 0; k < j.at("layers").size(); ++k) {
      const auto& lj = j["layers"][k];
      std::string where = "layer " + std::to_string(k);
      typed(lj,
            {"in_channels", "out_channels", "kernel", "stride", "padding", "output_padding",
             "skip_from"},
            true, where);
      if (lj.contains("neuron"))
        typed(lj["neuron"], {"theta", "tau_s", "tau_r", "scale_ref", "tau_rho", "scale_rho"}, false,
              where + " neuron");
      LayerSpec l;
      l.kind = parse_enum<LayerKind>(
          lj, "kind", {{"conv", LayerKind::Conv}, {"conv_transpose", LayerKind::ConvTranspose}},
          LayerKind::Conv, src, where);
      l.in_channels = lj.at("in_channels");
      l.out_channels = lj.at("out_channels");
      l.kernel = lj.value("kernel", 3);
      l.stride = lj.value("stride", 2);
      l.padding = lj.value("padding", 0);
      l.output_padding = lj.value("output_padding", 0);
      l.skip_from = lj.value("skip_from", -1);
      // ANN-2D layers have no neuron; they keep the (unused) defaults.
      const auto& nj =
          s.type == ModelType::ANN2D && !lj.contains("neuron")
              ? nlohmann::json::object({{"theta", 0.22}, {"tau_s", 2.0}, {"tau_r", 1.0}})
              : lj.at("neuron");
      auto& n = l.neuron;
      n.theta = nj.at("theta");
      n.tau_s = nj.at("tau_s");
      n.tau_r = nj.at("tau_r");
      n.scale_ref = nj.value("scale_ref", 2.f);
      n.tau_rho = nj.value("tau_rho", 0.3f);
      n.scale_rho = nj.value("scale_rho", 1.f);
      n.refractory = parse_enum<RefractoryShape>(
          nj, "refractory",
          {{"spikems", RefractoryShape::SpikeMS}, {"slayer", RefractoryShape::Slayer}},
          RefractoryShape::SpikeMS, src, where);
      n.discretisation = parse_enum<Discretisation>(
          nj, "discretisation", {{"fir", Discretisation::FIR}, {"iir", Discretisation::IIR}},
          Discretisation::FIR, src, where);
      n.surrogate = parse_enum<SurrogateForm>(
          nj, "surrogate", {{"spikems", SurrogateForm::SpikeMS}, {"slayer", SurrogateForm::Slayer}},
          SurrogateForm::SpikeMS, src, where);
      n.srm_onset = parse_enum<SrmOnset>(
          nj, "srm_onset", {{"next_step", SrmOnset::NextStep}, {"same_step", SrmOnset::SameStep}},
          SrmOnset::NextStep, src, where);
      s.layers.push_back(std::move(l));
    }
  } catch (const nlohmann::json::exception& e) {
    fail(src, "model spec", std::string("malformed: ") + e.what());
  }
  return s;
}

ModelSpec load_model(const std::string& path) {
  return model_from_safetensors(read_safetensors(path), path);
}

ModelSpec model_from_safetensors(const SafeTensors& st, const std::string& path) {
  auto fmt = st.metadata.find("format");
  if (fmt == st.metadata.end() || fmt->second != "spikems-model")
    fail(path, "",
         "not a spikems model file (metadata 'format' is not 'spikems-model'); "
         "import other weights with `spikems import-slayer`");
  auto ver = st.metadata.find("version");
  if (ver == st.metadata.end() || ver->second != std::to_string(kModelFormatVersion))
    fail(path, "",
         "model file version " + (ver == st.metadata.end() ? std::string("?") : ver->second) +
             " is not supported (this spikems reads version " +
             std::to_string(kModelFormatVersion) + ")");
  auto spec = st.metadata.find("spec");
  if (spec == st.metadata.end())
    fail(path, "", "metadata 'spec' (the network's layers) is missing");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(spec->second);
  } catch (const std::exception& e) {
    fail(path, "metadata 'spec'", std::string("not valid JSON: ") + e.what());
  }
  ModelSpec s = spec_from_json(j, path);
  auto take = [&](const std::string& name, std::vector<int64_t> shape, bool required) {
    auto it = st.tensors.find(name);
    if (it == st.tensors.end()) {
      if (required) fail(path, "", "tensor '" + name + "' is missing");
      return std::vector<float>{};
    }
    if (it->second.dtype != "F32") fail(path, "", "tensor '" + name + "' is not F32");
    if (!shape.empty() && it->second.shape != shape) {
      std::string want, got;
      for (auto d : shape) want += (want.empty() ? "" : "x") + std::to_string(d);
      for (auto d : it->second.shape) got += (got.empty() ? "" : "x") + std::to_string(d);
      fail(path, "", "tensor '" + name + "' has shape " + got + ", expected " + want);
    }
    return it->second.f32;
  };
  for (size_t k = 0; k < s.layers.size(); ++k) {
    auto& l = s.layers[k];
    std::string p = "layers." + std::to_string(k) + ".";
    std::vector<int64_t> wshape =
        l.kind == LayerKind::Conv
            ? std::vector<int64_t>{l.out_channels, l.in_channels, l.kernel, l.kernel}
            : std::vector<int64_t>{l.in_channels, l.out_channels, l.kernel, l.kernel};
    l.weight = take(p + "weight", wshape, true);
    const bool fir = s.type == ModelType::SNN && l.neuron.discretisation == Discretisation::FIR;
    l.srm_kernel = take(p + "srm_kernel", {}, fir);
    l.ref_kernel = take(p + "ref_kernel", {}, fir);
    l.delay = take(p + "delay", {l.out_channels}, false);
    l.bias = take(p + "bias", {l.out_channels}, s.type == ModelType::ANN2D);
  }
  s.validate(path);
  return s;
}

void save_model(const std::string& path, const ModelSpec& s) {
  s.validate(path);
  SafeTensors st;
  st.metadata["format"] = "spikems-model";
  st.metadata["version"] = std::to_string(kModelFormatVersion);
  st.metadata["spec"] = spec_to_json(s).dump();
  for (size_t k = 0; k < s.layers.size(); ++k) {
    const auto& l = s.layers[k];
    std::string p = "layers." + std::to_string(k) + ".";
    StTensor w;
    w.shape = l.kind == LayerKind::Conv
                  ? std::vector<int64_t>{l.out_channels, l.in_channels, l.kernel, l.kernel}
                  : std::vector<int64_t>{l.in_channels, l.out_channels, l.kernel, l.kernel};
    w.f32 = l.weight;
    st.tensors[p + "weight"] = w;
    if (!l.srm_kernel.empty())
      st.tensors[p + "srm_kernel"] =
          StTensor{"F32", {int64_t(l.srm_kernel.size())}, l.srm_kernel, {}};
    if (!l.ref_kernel.empty())
      st.tensors[p + "ref_kernel"] =
          StTensor{"F32", {int64_t(l.ref_kernel.size())}, l.ref_kernel, {}};
    if (!l.delay.empty())
      st.tensors[p + "delay"] = StTensor{"F32", {int64_t(l.delay.size())}, l.delay, {}};
    if (!l.bias.empty())
      st.tensors[p + "bias"] = StTensor{"F32", {int64_t(l.bias.size())}, l.bias, {}};
  }
  write_safetensors(path, st);
}

}  // namespace spikems
