#include "core/model/model_summary.h"

#include <algorithm>
#include <vector>

#include "core/util/text_format.h"

namespace spikems {

namespace {

// A value of the free-form training metadata, or null when absent.
nlohmann::json at_path(const nlohmann::json& j, std::initializer_list<const char*> keys) {
  const nlohmann::json* p = &j;
  for (const char* k : keys) {
    if (!p->is_object() || !p->contains(k)) return nullptr;
    p = &(*p)[k];
  }
  return *p;
}

int shortest_path_steps(const ModelSpec& m) {
  std::vector<int> d(m.layers.size());
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const int skip = m.layers[k].skip_from;
    d[k] = 1 + (k == 0 ? 0 : std::min(d[k - 1], skip >= 0 ? d[size_t(skip)] : d[k - 1]));
  }
  return d.empty() ? 0 : d.back();
}

}  // namespace

nlohmann::json model_summary(const ModelSpec& m) {
  nlohmann::json j;
  j["name"] = m.name;
  j["type"] = m.type == ModelType::SNN ? "snn" : "ann2d";
  j["time_step_ms"] = m.time_step_ms;
  j["input_width"] = m.input_width;
  j["input_height"] = m.input_height;
  if (m.train_width > 0) j["train_grid"] = {m.train_width, m.train_height};
  int64_t weights = 0;
  nlohmann::json layers = nlohmann::json::array();
  for (const LayerSpec& l : m.layers) {
    weights += l.weight_count();
    nlohmann::json lj;
    lj["kind"] = l.kind == LayerKind::Conv ? "conv" : "conv_transpose";
    lj["in_channels"] = l.in_channels;
    lj["out_channels"] = l.out_channels;
    lj["stride"] = l.stride;
    if (l.skip_from >= 0) lj["skip_from"] = l.skip_from;
    if (m.type == ModelType::SNN) {
      lj["theta"] = l.neuron.theta;
      lj["tau_s_ms"] = l.neuron.tau_s;
      lj["discretisation"] = l.neuron.discretisation == Discretisation::IIR ? "iir" : "fir";
    }
    layers.push_back(std::move(lj));
  }
  j["weights"] = weights;
  j["layers"] = std::move(layers);
  if (m.type == ModelType::SNN) {
    // Each layer answers a step after its input: the longest path is every layer, the
    // shortest goes through the skips. SameStep neurons answer in the step itself.
    const bool same = m.layers.front().neuron.srm_onset == SrmOnset::SameStep;
    j["srm_onset"] = same ? "same_step" : "next_step";
    j["latency_steps"] = same ? 0 : int(m.layers.size());
    j["shortest_path_steps"] = same ? 0 : shortest_path_steps(m);
    j["output_theta"] = m.layers.back().neuron.theta;
    j["output_gate_ms"] = m.output_gate_steps * m.time_step_ms;
  } else {
    j["history_frames"] = m.ann_history;  // past frames beside the window's
  }
  const nlohmann::json c = at_path(m.training, {"calibration"});
  if (c.is_object()) {
    nlohmann::json cj;
    for (const char* k : {"factor", "output_threshold_scale", "output_gate_ms", "criterion",
                          "score", "data", "static_moving", "max_static_moving"})
      if (c.contains(k)) cj[k] = c[k];
    j["calibration"] = std::move(cj);
  }
  nlohmann::json tj;
  for (const char* k : {"steps", "wall_seconds"})
    if (m.training.is_object() && m.training.contains(k)) tj[k] = m.training[k];
  const nlohmann::json dev = at_path(m.training, {"hardware", "device"});
  if (!dev.is_null()) tj["device"] = dev;
  if (!tj.empty()) j["training"] = std::move(tj);
  return j;
}

std::string model_summary_text(const std::string& path, const ModelSpec& m) {
  const nlohmann::json j = model_summary(m);
  std::string out = path + "\n";
  auto line = [&](std::string key, const std::string& v) {
    key.resize(std::max<size_t>(14, key.size() + 1), ' ');  // values in one column
    out += "  " + key + v + "\n";
  };
  const bool snn = m.type == ModelType::SNN;
  line("model", "\"" + m.name + "\", " + (snn ? "spiking network" : "ANN-2D baseline") + ", " +
                    std::to_string(m.layers.size()) + " layers, " +
                    std::to_string(j["weights"].get<int64_t>()) + " weights");
  line("time step",
       fmt("%g ms", m.time_step_ms) +
           (!snn ? std::string()
            : j["srm_onset"] == "same_step"
                ? "; an input spike reaches the output in its own step (srm_onset same_step)"
                : "; an input spike reaches the output after " +
                      std::to_string(j["shortest_path_steps"].get<int>()) +
                      " (through the skips) to " + std::to_string(m.layers.size()) + " steps"));
  line("input", m.input_width > 0
                    ? std::to_string(m.input_width) + " x " + std::to_string(m.input_height)
                    : std::string("any sensor size"));
  if (m.train_width > 0)
    line("pixel scale", "trained on a " + std::to_string(m.train_width) + " x " +
                            std::to_string(m.train_height) +
                            " grid; larger sensors are downsampled to the nearest grid "
                            "(segment/eval --downsample auto)");
  std::string chain;
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const LayerSpec& l = m.layers[k];
    if (k) chain += ", ";
    chain += std::to_string(l.out_channels);
    if (l.skip_from >= 0) chain += "(+" + std::to_string(l.skip_from + 1) + ")";
  }
  line("channels", std::to_string(m.layers.front().in_channels) + " -> " + chain +
                       (m.has_skips() ? "  ((+k): skip from layer k)" : ""));
  if (snn) {
    line("output theta", fmt("%.4g", m.layers.back().neuron.theta));
    line("output gate", m.output_gate_steps > 0
                            ? fmt("%g ms", m.output_gate_steps * m.time_step_ms) + " (" +
                                  std::to_string(m.output_gate_steps) + " steps)"
                            : std::string("none"));
  }
  if (!snn)
    line("input frames", m.ann_history > 0
                             ? "the window's and the " + std::to_string(m.ann_history) +
                                   " windows of the same length before it, newest first"
                             : std::string("the window's only"));
  if (j.contains("calibration")) {
    const auto& c = j["calibration"];
    std::string v;
    if (c.contains("output_threshold_scale"))
      v += "θ x " + fmt("%g", c["output_threshold_scale"].get<double>());
    if (c.contains("criterion")) v += ", by " + c["criterion"].get<std::string>();
    if (c.contains("score")) v += fmt(" %.1f %%", c["score"].get<double>());
    if (c.contains("data") && c["data"].is_array() && !c["data"].empty())
      v += " on " + c["data"][0].get<std::string>();
    if (c.contains("static_moving") && c.contains("max_static_moving"))
      v += fmt(", static scenes %.1f %% called moving", c["static_moving"].get<double>()) +
           fmt(" (at most %g %%)", c["max_static_moving"].get<double>());
    line("calibration", v);
  }
  if (j.contains("training")) {
    const auto& t = j["training"];
    std::string v;
    if (t.contains("steps")) v += std::to_string(t["steps"].get<int64_t>()) + " steps";
    if (t.contains("wall_seconds"))
      v += (v.empty() ? "" : ", ") + fmt("%.0f s", t["wall_seconds"].get<double>());
    if (t.contains("device")) v += (v.empty() ? "" : ", ") + t["device"].get<std::string>();
    if (!v.empty()) line("training", v);
  }
  return out;
}

}  // namespace spikems
