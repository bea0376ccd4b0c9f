#include "train/trainer/train_config.h"

#include <toml++/toml.h>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "core/model/model_file.h"
#include "core/util/error.h"
#include "train/trainer/toml_json.h"

namespace spikems::train {

nlohmann::json toml_to_json(const toml::node& n) {
  if (auto t = n.as_table()) {
    nlohmann::json j = nlohmann::json::object();
    for (auto& [k, v] : *t) j[std::string(k.str())] = toml_to_json(v);
    return j;
  }
  if (auto a = n.as_array()) {
    nlohmann::json j = nlohmann::json::array();
    for (auto& v : *a) j.push_back(toml_to_json(v));
    return j;
  }
  if (auto v = n.as_string()) return v->get();
  if (auto v = n.as_integer()) return v->get();
  if (auto v = n.as_floating_point()) return v->get();
  if (auto v = n.as_boolean()) return v->get();
  return nullptr;  // dates and times: no key takes them; the type check names the key
}

namespace {

// "section.key=value": the value in TOML syntax ("0.5", "true", "[1, 2]", "\"x\""); a bare
// word that is not valid TOML is taken as a string (so --set model.neurons=fir works).
void apply_override(nlohmann::json& j, const std::string& kv, const std::string& source) {
  const auto eq = kv.find('=');
  const auto dot = kv.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq)
    fail(source, "--set " + kv, "expected section.key=value, e.g. optim.lr=0.001");
  const std::string section = kv.substr(0, dot), key = kv.substr(dot + 1, eq - dot - 1);
  const std::string value = kv.substr(eq + 1);
  nlohmann::json v;
  try {
    toml::table t = toml::parse("v = " + value);
    v = toml_to_json(*t.get("v"));
  } catch (const toml::parse_error&) {
    v = value;
  }
  j[section][key] = v;
}

class Binder {
 public:
  Binder(const nlohmann::json& j, std::string source) : j_(j), source_(std::move(source)) {
    if (!j_.is_object()) fail(source_, "", "the configuration must be a table");
  }
  template <typename T>
  void bind(const char* section, const char* key, T& value) {
    used_.insert(std::string(section) + "." + key);
    const nlohmann::json* v = find(section, key);
    if (v) {
      try {
        if constexpr (std::is_same_v<T, bool>) {
          if (!v->is_boolean()) throw std::invalid_argument("a boolean");
        } else if constexpr (std::is_integral_v<T>) {
          if (!v->is_number_integer()) throw std::invalid_argument("an integer");
        } else if constexpr (std::is_floating_point_v<T>) {
          if (!v->is_number()) throw std::invalid_argument("a number");
        } else if constexpr (std::is_same_v<T, std::string>) {
          if (!v->is_string()) throw std::invalid_argument("a string");
        }
        value = v->get<T>();
      } catch (const std::exception& e) {
        fail(source_, std::string(section) + "." + key,
             std::string("wrong type: expected ") + e.what() + ", got " + v->dump());
      }
    }
    out_[section][key] = value;
  }
  void bind_list(const char* section, const char* key, std::vector<double>& value) {
    used_.insert(std::string(section) + "." + key);
    const nlohmann::json* v = find(section, key);
    if (v) {
      if (!v->is_array()) bad(section, key, "expected a list of numbers");
      value.clear();
      for (const auto& x : *v) {
        if (!x.is_number()) bad(section, key, "expected a list of numbers");
        value.push_back(x.get<double>());
      }
    }
    out_[section][key] = value;
  }
  void bind_sources(const char* section, const char* key, std::vector<DatasetSource>& value,
                    const char* default_split) {
    used_.insert(std::string(section) + "." + key);
    const nlohmann::json* v = find(section, key);
    if (v) {
      if (!v->is_array()) bad(section, key, "expected a list of {path, split, weight} tables");
      value.clear();
      for (const auto& d : *v) {
        DatasetSource s;
        s.split = default_split;
        if (d.is_string()) {
          s.path = d.get<std::string>();
        } else if (d.is_object()) {
          for (auto& [k, x] : d.items()) {
            if (k == "path" && x.is_string())
              s.path = x.get<std::string>();
            else if (k == "split" && x.is_string())
              s.split = x.get<std::string>();
            else if (k == "weight" && x.is_number())
              s.weight = x.get<double>();
            else if (k == "mask_dilation" && x.is_number_integer())
              s.mask_dilation = x.get<int>();
            else
              bad(section, key,
                  "entry key \"" + k +
                      "\" unknown or of the wrong type (path, "
                      "split, weight, mask_dilation)");
          }
        } else {
          bad(section, key, "expected a list of {path, split, weight} tables");
        }
        if (s.path.empty()) bad(section, key, "an entry has no path");
        if (!(s.weight > 0)) bad(section, key, "weights must be positive");
        value.push_back(s);
      }
    }
    nlohmann::json a = nlohmann::json::array();
    for (const auto& s : value)
      a.push_back({{"path", s.path},
                   {"split", s.split},
                   {"weight", s.weight},
                   {"mask_dilation", s.mask_dilation}});
    out_[section][key] = a;
  }
  // Every key of the input must have been bound.
  void check_unknown() const {
    for (auto& [sec, t] : j_.items()) {
      if (!t.is_object())
        fail(source_, sec,
             "unknown key (sections: model, data, sample, loss, "
             "optim, run; see docs/training.md)");
      for (auto& [k, v] : t.items())
        if (!used_.count(sec + "." + k))
          fail(source_, sec + "." + k, "unknown key (see docs/training.md for every key)");
    }
  }
  [[noreturn]] void bad(const std::string& section, const std::string& key,
                        const std::string& why) const {
    fail(source_, section + "." + key, why);
  }
  const nlohmann::json& resolved() const { return out_; }

 private:
  const nlohmann::json* find(const char* section, const char* key) const {
    auto s = j_.find(section);
    if (s == j_.end() || !s->is_object()) return nullptr;
    auto k = s->find(key);
    return k == s->end() ? nullptr : &*k;
  }
  const nlohmann::json& j_;
  std::string source_;
  std::set<std::string> used_;
  nlohmann::json out_ = nlohmann::json::object();
};

void one_of(const Binder& b, const char* sec, const char* key, const std::string& v,
            std::initializer_list<const char*> allowed) {
  std::string list;
  for (const char* a : allowed) {
    if (v == a) return;
    list += std::string(list.empty() ? "" : ", ") + a;
  }
  b.bad(sec, key, "\"" + v + "\" is not one of " + list);
}

void positive(const Binder& b, const char* sec, const char* key, double v) {
  if (!(v > 0)) b.bad(sec, key, "must be positive");
}

}  // namespace

TrainConfig train_config_from_json(nlohmann::json j, const std::string& source,
                                   const std::vector<std::string>& overrides) {
  for (const auto& o : overrides) apply_override(j, o, source);
  TrainConfig c;
  Binder b(j, source);
  b.bind("model", "type", c.type);
  b.bind("model", "padded", c.padded);
  b.bind("model", "neurons", c.neurons);
  b.bind("model", "surrogate", c.surrogate);
  b.bind("model", "backward", c.backward);
  b.bind("model", "delays", c.delays);
  b.bind("model", "init", c.init);
  std::vector<double> widths(c.channels.begin(), c.channels.end());
  b.bind_list("model", "channels", widths);
  c.channels.clear();
  for (double w : widths) {
    if (w != std::floor(w) || w < 1 || w > 1024)
      b.bad("model", "channels", "each level's channels must be a whole number in 1..1024");
    c.channels.push_back(int(w));
  }
  if (c.channels.empty() || c.channels.size() > 6)
    b.bad("model", "channels", "needs 1 to 6 encoder levels (the paper: [16, 32, 64])");
  b.bind_list("model", "tau_s", c.tau_s);
  b.bind_list("model", "tau_r", c.tau_r);
  b.bind("model", "skips", c.skips);
  b.bind("model", "readout", c.readout);
  b.bind("model", "output_gate_ms", c.output_gate_ms);
  if (c.skips && c.type == "snn" && !c.padded)
    b.bad("model", "skips", "skip connections need padded = true");
  std::vector<double> levels(c.skip_levels.begin(), c.skip_levels.end());
  b.bind_list("model", "skip_levels", levels);
  c.skip_levels.clear();
  for (double v : levels) {
    if (v != std::floor(v) || v < 1 || v >= double(c.channels.size()))
      b.bad("model", "skip_levels",
            "each must be a whole level in 1.." + std::to_string(int(c.channels.size()) - 1) +
                " (1 = the finest; the bottleneck has none)");
    if (std::find(c.skip_levels.begin(), c.skip_levels.end(), int(v)) != c.skip_levels.end())
      b.bad("model", "skip_levels", "a level is given twice");
    c.skip_levels.push_back(int(v));
  }
  if (!c.skip_levels.empty() && !c.skips) b.bad("model", "skip_levels", "needs model.skips = true");
  double history = c.history;
  b.bind("model", "history", history);
  if (history != std::floor(history) || history < 0 || history > kMaxAnnHistory)
    b.bad("model", "history",
          "must be a whole number of past frames in 0.." + std::to_string(kMaxAnnHistory));
  c.history = int(history);
  if (c.history > 0 && c.type != "ann2d")
    b.bad("model", "history", "is for model.type = \"ann2d\" (a spiking network keeps state)");
  b.bind("model", "tau_rho", c.tau_rho);
  if (c.tau_rho != 0 && !(c.tau_rho >= 0.01 && c.tau_rho <= 100))
    b.bad("model", "tau_rho", "must lie in 0.01..100 (or 0: the model's own)");
  if (!c.tau_s.empty() && c.tau_s.size() != c.channels.size() &&
      c.tau_s.size() != 2 * c.channels.size())
    b.bad("model", "tau_s",
          "needs one time constant per level of model.channels (" +
              std::to_string(c.channels.size()) + ") or per layer (" +
              std::to_string(2 * c.channels.size()) + "), or [] for the paper's");
  for (double t : c.tau_s)
    if (!(t >= 0.1 && t <= 100)) b.bad("model", "tau_s", "each must lie in 0.1..100 ms");
  if (!c.tau_r.empty() && c.tau_r.size() != c.channels.size() &&
      c.tau_r.size() != 2 * c.channels.size())
    b.bad("model", "tau_r",
          "needs one time constant per level of model.channels (" +
              std::to_string(c.channels.size()) + ") or per layer (" +
              std::to_string(2 * c.channels.size()) + "), or [] for the paper's");
  for (double t : c.tau_r)
    if (!(t >= 0.1 && t <= 100)) b.bad("model", "tau_r", "each must lie in 0.1..100 ms");
  c.init_rates.assign(2 * c.channels.size(), 0.03);
  c.init_rates.back() = 0.02;
  b.bind_list("model", "init_rates", c.init_rates);
  b.bind("model", "init_ann", c.init_ann);
  b.bind("model", "init_time_constants", c.init_time_constants);
  b.bind("model", "srm_onset", c.srm_onset);
  b.bind_sources("data", "train", c.train, "train");
  b.bind_sources("data", "val", c.val, "val");
  b.bind_sources("data", "val_static", c.val_static, "all");
  if (!c.val_static.empty() && c.val.empty())
    b.bad("data", "val_static", "needs data.val too (it is scored at each validation)");
  SampleOptions& s = c.sample;
  double window_ms = double(s.window_us) / 1000, warmup_ms = double(s.warmup_us) / 1000,
         step_ms = double(s.step_us) / 1000;
  b.bind("sample", "window_ms", window_ms);
  b.bind("sample", "warmup_ms", warmup_ms);
  b.bind("sample", "step_ms", step_ms);
  b.bind("sample", "crop", s.crop);
  b.bind("sample", "centred_fraction", s.centred_fraction);
  b.bind("sample", "jitter", s.jitter);
  b.bind("sample", "min_fg_pixels", s.min_fg_pixels);
  b.bind("sample", "max_bg_fg_ratio", s.max_bg_fg_ratio);
  b.bind("sample", "flip_x", s.flip_x);
  b.bind("sample", "flip_y", s.flip_y);
  b.bind("sample", "polarity_swap", s.polarity_swap);
  b.bind("sample", "drop_max", s.drop_max);
  b.bind("sample", "threshold_jitter", s.threshold_jitter);
  b.bind("sample", "noise_hz_max", s.noise_hz_max);
  b.bind("sample", "speed_max", s.speed_max);
  b.bind("loss", "kind", c.loss);
  b.bind("loss", "lambda", c.lambda);
  b.bind("loss", "iou_weight", c.iou_weight);
  b.bind("loss", "teacher", c.teacher);
  b.bind("loss", "teacher_weight", c.teacher_weight);
  b.bind("loss", "teacher_static", c.teacher_static);
  b.bind("loss", "attention_weight", c.attention_weight);
  b.bind("loss", "feature_weight", c.feature_weight);
  b.bind("loss", "offevent_weight", c.offevent_weight);
  b.bind("loss", "projection", c.projection);
  b.bind("loss", "alpha", c.alpha);
  b.bind("loss", "beta", c.beta);
  b.bind("loss", "kappa", c.kappa);
  b.bind("loss", "all_pixels", c.all_pixels);
  b.bind("loss", "pos_weight", c.pos_weight);
  b.bind("loss", "balanced", c.balanced);
  b.bind("loss", "activity_weight", c.activity_weight);
  b.bind("loss", "rate_floor", c.rate_floor);
  b.bind("loss", "floor_weight", c.floor_weight);
  b.bind("loss", "output_floor", c.output_floor);
  b.bind("loss", "rate_ceiling", c.rate_ceiling);
  b.bind_list("loss", "rate_ceilings", c.rate_ceilings);
  b.bind("loss", "synops_weight", c.synops_weight);
  b.bind("loss", "synops_budget", c.synops_budget);
  b.bind_list("loss", "synops_source_weights", c.synops_source_weights);
  b.bind_list("loss", "rate_floors", c.rate_floors);
  b.bind("optim", "lr", c.lr);
  b.bind("optim", "min_lr", c.min_lr);
  b.bind("optim", "weight_decay", c.weight_decay);
  b.bind("optim", "amsgrad", c.amsgrad);
  b.bind("optim", "schedule", c.schedule);
  b.bind("optim", "warmup_steps", c.warmup_steps);
  b.bind("optim", "step_every", c.step_every);
  b.bind("optim", "step_gamma", c.step_gamma);
  b.bind("optim", "batch", c.batch);
  b.bind("optim", "steps", c.steps);
  b.bind("optim", "clip", c.clip);
  b.bind("optim", "ema_decay", c.ema_decay);
  b.bind("optim", "warmup_backprop", c.warmup_backprop);
  int64_t seed = int64_t(c.seed);
  b.bind("run", "seed", seed);
  c.seed = uint64_t(seed);
  b.bind("run", "threads", c.threads);
  b.bind("run", "device", c.device);
  b.bind("run", "neuron_kernels", c.neuron_kernels);
  b.bind("run", "kernels", c.kernels);
  b.bind("run", "log_every", c.log_every);
  b.bind("run", "val_every", c.val_every);
  b.bind("run", "checkpoint_every", c.checkpoint_every);
  b.bind("run", "val_samples", c.val_samples);
  b.bind("run", "prefetch", c.prefetch);
  b.bind("run", "loader_threads", c.loader_threads);
  b.bind("run", "val_full_s", c.val_full_s);
  b.bind("run", "val_full_window_ms", c.val_full_window_ms);
  b.bind("run", "gate_events", c.gate_events);
  b.bind("run", "keep_val_models", c.keep_val_models);
  b.check_unknown();

  one_of(b, "model", "type", c.type, {"snn", "ann2d"});
  one_of(b, "model", "neurons", c.neurons, {"iir", "fir"});
  one_of(b, "model", "surrogate", c.surrogate, {"spikems", "slayer"});
  one_of(b, "model", "backward", c.backward, {"slayer", "exact"});
  if (c.init_rates.size() != 2 * c.channels.size())
    b.bad("model", "init_rates",
          "needs one rate per layer (" + std::to_string(2 * c.channels.size()) + ")");
  if (!c.init_ann.empty() && (c.init != "data" || c.type != "snn"))
    b.bad("model", "init_ann",
          "starts a spiking network's data initialisation: needs model.init = \"data\" and "
          "model.type = \"snn\"");
  if (!c.init_time_constants.empty()) {
    one_of(b, "model", "init_time_constants", c.init_time_constants, {"steps", "ms"});
    if (c.init == "data")
      b.bad("model", "init_time_constants", "applies to a model.init file: model.init is \"data\"");
  }
  if (!c.srm_onset.empty()) {
    one_of(b, "model", "srm_onset", c.srm_onset, {"next_step", "same_step"});
    if (c.srm_onset == "same_step" && c.init == "data" && c.neurons == "fir")
      b.bad("model", "srm_onset", "\"same_step\" needs model.neurons = \"iir\"");
  }
  for (double r : c.init_rates)
    if (!(r > 0 && r < 1)) b.bad("model", "init_rates", "rates must lie in (0, 1)");
  if (c.train.empty()) b.bad("data", "train", "no training data: give at least one dataset");
  positive(b, "sample", "step_ms", step_ms);
  positive(b, "sample", "window_ms", window_ms);
  if (warmup_ms < 0) b.bad("sample", "warmup_ms", "must not be negative");
  s.step_us = int64_t(std::llround(step_ms * 1000));
  s.window_us = int64_t(std::llround(window_ms * 1000));
  if (c.output_gate_ms != 0) {
    if (!(c.output_gate_ms > 0 && c.output_gate_ms <= 100000))
      b.bad("model", "output_gate_ms", "must be 0 (none) or a duration in (0, 100000] ms");
    else if (c.type != "snn")
      b.bad("model", "output_gate_ms",
            "an output gate is for spiking models (model.type = \"snn\")");
    else if (s.step_us > 0 && std::llround(c.output_gate_ms * 1000) % s.step_us != 0)
      b.bad("model", "output_gate_ms", "must be a whole number of sample.step_ms");
  }
  s.warmup_us = int64_t(std::llround(warmup_ms * 1000));
  if (s.crop < 0 || (s.crop > 0 && s.crop < 16))
    b.bad("sample", "crop", "0 (whole sensor) or >= 16");
  if (s.centred_fraction < 0 || s.centred_fraction > 1)
    b.bad("sample", "centred_fraction", "must lie in [0, 1]");
  for (auto [k, v] : {std::pair{"flip_x", s.flip_x},
                      {"flip_y", s.flip_y},
                      {"polarity_swap", s.polarity_swap},
                      {"drop_max", s.drop_max}})
    if (v < 0 || v > 1) b.bad("sample", k, "must lie in [0, 1]");
  if (s.threshold_jitter < 0) b.bad("sample", "threshold_jitter", "must not be negative");
  if (s.noise_hz_max < 0) b.bad("sample", "noise_hz_max", "must not be negative");
  if (!(s.speed_max >= 1 && s.speed_max <= 8))
    b.bad("sample", "speed_max", "must be in [1, 8] (1: no playback-speed augmentation)");
  one_of(b, "loss", "kind", c.loss, {"bce", "spike", "both", "iou"});
  one_of(b, "model", "readout", c.readout, {"spikes", "potential"});
  if (c.readout == "potential" && c.type != "snn")
    b.bad("model", "readout", "a readout potential needs a spiking model (model.type = \"snn\")");
  if (c.readout == "potential" && (c.loss == "spike" || c.loss == "both"))
    b.bad(
        "loss", "kind",
        "L_spike compares spike trains: with model.readout = \"potential\" use \"bce\" or \"iou\"");
  if (c.readout == "potential" && c.delays)
    b.bad("model", "readout",
          "the potential readout scores the output layer's undelayed potential: model.delays "
          "must be false");
  if (c.readout == "potential" && c.projection != "sigmoid")
    b.bad("loss", "projection", "model.readout = \"potential\" needs \"sigmoid\"");
  if (c.type == "ann2d" && (c.loss == "spike" || c.loss == "both"))
    b.bad("loss", "kind", "the ANN-2D baseline has no output spikes: use \"bce\" or \"iou\"");
  if (c.iou_weight < 0) b.bad("loss", "iou_weight", "must not be negative");
  if (!(c.teacher_weight >= 0)) b.bad("loss", "teacher_weight", "must not be negative");
  if (c.teacher_weight > 0 && c.teacher.empty())
    b.bad("loss", "teacher", "needs an ANN-2D model file when loss.teacher_weight > 0");
  if (c.teacher_weight > 0 && c.type == "ann2d")
    b.bad("loss", "teacher_weight", "distils into the spiking network: model.type = \"snn\"");
  if (!(c.attention_weight >= 0)) b.bad("loss", "attention_weight", "must not be negative");
  if (c.attention_weight > 0 && c.teacher.empty())
    b.bad("loss", "teacher", "needs an ANN-2D model file when loss.attention_weight > 0");
  if (c.attention_weight > 0 && c.type == "ann2d")
    b.bad("loss", "attention_weight", "transfers into the spiking network: model.type = \"snn\"");
  if (!(c.feature_weight >= 0)) b.bad("loss", "feature_weight", "must not be negative");
  if (c.feature_weight > 0 && c.teacher.empty())
    b.bad("loss", "teacher", "needs an ANN-2D model file when loss.feature_weight > 0");
  if (c.feature_weight > 0 && c.type == "ann2d")
    b.bad("loss", "feature_weight", "transfers into the spiking network: model.type = \"snn\"");
  if (!(c.offevent_weight >= 0)) b.bad("loss", "offevent_weight", "must not be negative");
  if (c.offevent_weight > 0 && c.projection != "sigmoid")
    b.bad("loss", "offevent_weight", "needs loss.projection = \"sigmoid\"");
  if (c.offevent_weight > 0 && c.type == "ann2d")
    b.bad("loss", "offevent_weight", "applies to the spiking network: model.type = \"snn\"");
  one_of(b, "loss", "projection", c.projection, {"sigmoid", "exponential"});
  one_of(b, "loss", "teacher_static", c.teacher_static, {"teacher", "skip", "labels"});
  if (c.teacher_static != "teacher" && !(c.teacher_weight > 0))
    b.bad("loss", "teacher_static", "changes the distillation: needs loss.teacher_weight > 0");
  if (c.lambda < 0) b.bad("loss", "lambda", "must not be negative");
  if (c.activity_weight < 0) b.bad("loss", "activity_weight", "must not be negative");
  if (!(c.synops_weight >= 0)) b.bad("loss", "synops_weight", "must not be negative");
  if (c.synops_weight > 0 && c.type == "ann2d")
    b.bad("loss", "synops_weight", "applies to the spiking network: model.type = \"snn\"");
  if (!(c.synops_budget >= 0))
    b.bad("loss", "synops_budget", "must not be negative (0: a linear penalty)");
  if (!c.synops_source_weights.empty() &&
      c.synops_source_weights.size() != 2 * c.channels.size() + 1)
    b.bad("loss", "synops_source_weights",
          "needs one weight for the input and one per layer (" +
              std::to_string(2 * c.channels.size() + 1) + ")");
  for (double w : c.synops_source_weights)
    if (!(w >= 0 && std::isfinite(w)))
      b.bad("loss", "synops_source_weights", "each must be a finite number, not negative");
  if (c.rate_floor < 0 || c.rate_floor >= 1) b.bad("loss", "rate_floor", "must lie in [0, 1)");
  if (c.floor_weight < 0) b.bad("loss", "floor_weight", "must not be negative");
  if (c.rate_ceiling < 0 || c.rate_ceiling > 1) b.bad("loss", "rate_ceiling", "must lie in [0, 1]");
  if (c.rate_ceiling > 0 && c.rate_ceiling <= c.rate_floor)
    b.bad("loss", "rate_ceiling", "must be above loss.rate_floor (or 0: off)");
  if (!c.rate_ceilings.empty() && c.rate_ceilings.size() + 1 != 2 * c.channels.size())
    b.bad("loss", "rate_ceilings",
          "needs one ceiling per hidden layer (" + std::to_string(2 * c.channels.size() - 1) + ")");
  if (!c.rate_floors.empty() && c.rate_floors.size() + 1 != 2 * c.channels.size())
    b.bad("loss", "rate_floors",
          "needs one floor per hidden layer (" + std::to_string(2 * c.channels.size() - 1) + ")");
  for (size_t k = 0; k < c.rate_floors.size(); ++k) {
    const double f = c.rate_floors[k];
    const double ceil =
        c.rate_ceilings.size() == c.rate_floors.size() ? c.rate_ceilings[k] : c.rate_ceiling;
    if (!(f >= 0 && f < 1) || (ceil > 0 && f >= ceil))
      b.bad("loss", "rate_floors", "each must lie in [0, 1) and below its layer's ceiling");
  }
  for (double r : c.rate_ceilings)
    if (!(r == 0 || (r > c.rate_floor && r <= 1)))
      b.bad("loss", "rate_ceilings",
            "each must lie above loss.rate_floor and at most 1 (or 0: off)");
  if (c.output_floor < 0 || c.output_floor >= 1)
    b.bad("loss", "output_floor", "must lie in [0, 1)");
  positive(b, "loss", "pos_weight", c.pos_weight);
  positive(b, "optim", "lr", c.lr);
  one_of(b, "optim", "schedule", c.schedule, {"cosine", "step", "constant"});
  if (c.batch < 1) b.bad("optim", "batch", "must be at least 1");
  if (c.steps < 1) b.bad("optim", "steps", "must be at least 1");
  if (!(c.ema_decay >= 0 && c.ema_decay < 1))
    b.bad("optim", "ema_decay", "must be in [0, 1) (0: no weight averaging; 0.999 is usual)");
  if (c.warmup_steps < 0) b.bad("optim", "warmup_steps", "must not be negative");
  if (c.step_every < 1) b.bad("optim", "step_every", "must be at least 1");
  if (!c.warmup_backprop && c.delays)
    b.bad("optim", "warmup_backprop",
          "false needs model.delays = false (a delayed spike may cross into the window)");
  one_of(b, "run", "device", c.device, {"cpu", "cuda"});
  one_of(b, "run", "neuron_kernels", c.neuron_kernels, {"fused", "ops"});
  one_of(b, "run", "kernels", c.kernels, {"auto", "sparse", "dense"});
  if (c.threads < 0) b.bad("run", "threads", "must not be negative");
  if (c.loader_threads < 0) b.bad("run", "loader_threads", "must not be negative");
  for (auto [k, v] : {std::pair{"log_every", c.log_every},
                      {"val_every", c.val_every},
                      {"checkpoint_every", c.checkpoint_every},
                      {"prefetch", c.prefetch}})
    if (v < 1) b.bad("run", k, "must be at least 1");
  if (c.val_samples < 0) b.bad("run", "val_samples", "must not be negative");
  if (!(c.val_full_s >= 0)) b.bad("run", "val_full_s", "must not be negative");
  if (!(c.val_full_window_ms > 0)) b.bad("run", "val_full_window_ms", "must be positive");
  if ((c.val_full_s > 0 || !c.val_static.empty()) &&  // both score windows of this length
      std::llround(c.val_full_window_ms * 1000) % std::llround(step_ms * 1000) != 0)
    b.bad("run", "val_full_window_ms", "must be a multiple of sample.step_ms");
  c.source = b.resolved();
  return c;
}

TrainConfig load_train_config(const std::string& path, const std::vector<std::string>& overrides) {
  if (path.size() > 5 && path.compare(path.size() - 5, 5, ".json") == 0) {  // a run's config.json
    std::ifstream in(path);
    if (!in) fail(path, "", "cannot open the file");
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(in);
    } catch (const std::exception& e) {
      fail(path, "", std::string("not valid JSON: ") + e.what());
    }
    return train_config_from_json(j, path, overrides);
  }
  toml::table t;
  try {
    t = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    std::ostringstream pos;
    pos << "line " << e.source().begin.line << ", column " << e.source().begin.column;
    fail(path, pos.str(), std::string(e.description()));
  }
  return train_config_from_json(toml_to_json(t), path, overrides);
}

}  // namespace spikems::train
