#include "core/eval/energy.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <tuple>

#include "core/dataset/sequence.h"
#include "core/eval/metrics.h"
#include "core/eval/results.h"
#include "core/events/binning.h"
#include "core/events/io.h"
#include "core/model/model_scale.h"
#include "core/runtime/segmenter.h"
#include "core/util/atomic_file.h"
#include "core/util/error.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"
#include "core/util/text_format.h"

namespace spikems {

namespace fs = std::filesystem;

std::vector<LayerShape> layer_shapes(const ModelSpec& model, int height, int width) {
  if (height <= 0 || width <= 0)
    fail(model.name, "",
         "the input size " + std::to_string(width) + "x" + std::to_string(height) +
             " is not positive");
  std::vector<LayerShape> out;
  int h = height, w = width;
  // As the runtime: a model with skips on its fitted size (in_channels counts the skip's).
  if (model.has_skips()) {
    std::tie(h, w) = model.fitted_input_size(height, width);
    model.check_input_size(h, w, model.name);
  }
  for (size_t k = 0; k < model.layers.size(); ++k) {
    const LayerSpec& l = model.layers[k];
    LayerShape s;
    s.kind = l.kind;
    s.in_channels = l.in_channels;
    s.out_channels = l.out_channels;
    s.kernel = l.kernel;
    s.stride = l.stride;
    s.in_height = h;
    s.in_width = w;
    s.out_height = l.output_size(h);
    s.out_width = l.output_size(w);
    if (s.out_height <= 0 || s.out_width <= 0)
      fail(model.name, "layer " + std::to_string(k + 1),
           "no output for a " + std::to_string(h) + "x" + std::to_string(w) +
               " input: the network is too deep for the sensor");
    out.push_back(s);
    h = s.out_height;
    w = s.out_width;
  }
  return out;
}

uint64_t ann_macs(const LayerShape& s) {
  const uint64_t taps =
      uint64_t(s.kernel) * uint64_t(s.kernel) * uint64_t(s.in_channels) * uint64_t(s.out_channels);
  if (s.kind == LayerKind::ConvTranspose)
    return uint64_t(s.in_height) * uint64_t(s.in_width) * taps;
  return uint64_t(s.out_height) * uint64_t(s.out_width) * taps;
}

double EnergyReport::synops() const {
  double n = 0;
  for (const auto& l : layers) n += l.synops_per_sample;
  return n;
}
double EnergyReport::ann_macs() const {
  double n = 0;
  for (const auto& l : layers) n += double(l.ann_macs);
  return n;
}
double EnergyReport::snn_pj() const {
  return snn_energy_pj(synops());
}
double EnergyReport::ann_pj() const {
  return ann_energy_pj(ann_macs());
}
double EnergyReport::benefit() const {
  return snn_pj() > 0 ? ann_pj() / snn_pj() : 0;
}

void fill_layers(EnergyReport& r, const StreamingNetwork& net, const ModelSpec& model) {
  const auto shapes = layer_shapes(model, net.in_height(), net.in_width());
  const auto st = net.stats();
  if (r.layers.empty()) r.layers.resize(st.size());
  if (r.layers.size() != st.size() || shapes.size() != st.size())
    fail(model.name, "", "internal error: layer counts differ");
  for (size_t k = 0; k < st.size(); ++k) {
    LayerEnergy& l = r.layers[k];
    l.shape = shapes[k];
    l.neurons = st[k].neurons;
    l.in_spikes += st[k].in_spikes;
    l.out_spikes += st[k].out_spikes;
    l.synops += st[k].synops;
    l.ann_macs = ann_macs(shapes[k]);
    const LayerShape& sh = shapes[k];
    if (uint64_t(sh.out_channels) * uint64_t(sh.out_height) * uint64_t(sh.out_width) != l.neurons)
      fail(model.name, "layer " + std::to_string(k + 1),
           "internal error: the runtime's layer size differs from the model's shapes");
  }
}

void finish_report(EnergyReport& r) {
  r.samples = r.seconds / (r.window_ms * 1e-3);
  for (auto& l : r.layers) {
    const double neuron_steps = double(l.neurons) * double(r.steps);
    l.firing_rate = neuron_steps > 0 ? double(l.out_spikes) / neuron_steps : 0;
    l.synops_per_sample = r.samples > 0 ? double(l.synops) / r.samples : 0;
  }
}

namespace {

std::string kind_name(LayerKind k) {
  return k == LayerKind::ConvTranspose ? "convT" : "conv";
}

}  // namespace

EnergyReport measure_energy(const EnergyOptions& opt) {
  if (opt.window_us <= 0) fail("--window-ms", "", "a window length must be positive");
  if (opt.data.empty()) fail("spikems energy", "", "no data given (--data PATH)");
  ModelSpec model = load_model(opt.model_path);
  if (opt.iir) model = with_iir_neurons(std::move(model), opt.model_path);
  std::vector<std::pair<std::string, std::vector<std::string>>> sources;
  size_t total = 0;
  for (const auto& path : opt.data) {
    DatasetSource src;
    src.path = path;
    src.split = opt.split;
    sources.emplace_back(path, sequence_files(src));
    total += sources.back().second.size();
  }

  EnergyReport r;
  r.command_line = opt.command_line;
  r.date = utc_now_iso8601();
  r.model_path = opt.model_path;
  r.model_name = model.name;
  r.data = opt.data;
  r.split = opt.split;
  r.time_step_ms = model.time_step_ms;
  r.window_ms = double(opt.window_us) / 1000.0;
  r.max_seconds = opt.max_seconds;
  r.iir = opt.iir;
  const int64_t max_us = opt.max_seconds > 0 ? int64_t(opt.max_seconds * 1e6 + 0.5) : 0;
  ProgressBar bar("energy", total, "sequences", opt.progress);
  size_t done = 0;
  for (const auto& [path, files] : sources) {
    for (const auto& f : files) {
      if (interrupted()) break;
      bar.set_status(fs::path(f).filename().string());
      bar.update(done);
      const EventStream ev = read_events(f);
      if (!ev.sensor.known()) fail(f, "", "the sensor size is unknown");
      // The model runs at the resolution its training grid asks for (as segment and eval run
      // it), and the ANN's MACs are counted at that grid too.
      const int ds = nearest_downsample(model, ev.sensor.width, ev.sensor.height);
      BinningConfig geo;
      geo.downsample = ds;
      const auto [gh, gw] = binned_size(ev.sensor, geo);
      if (r.width == 0) {
        r.width = gw;
        r.height = gh;
        r.downsample = ds;
      } else if (gw != r.width || gh != r.height) {
        fail(f, "",
             "the network's grid " + std::to_string(gw) + "x" + std::to_string(gh) +
                 " differs from the first sequence's " + std::to_string(r.width) + "x" +
                 std::to_string(r.height) +
                 ": the ANN's MACs depend on the resolution, measure each size apart");
      }
      ++r.sequences;
      if (ev.empty()) continue;
      const int64_t t0 = ev.t_first();
      size_t n = ev.size();
      int64_t end = ev.t_last() + 1;
      if (max_us > 0 && ev.t_last() >= t0 + max_us) {
        n = ev.time_range(t0, t0 + max_us).second;
        end = t0 + max_us;
      }
      SegmenterOptions so;
      so.threads = opt.threads;
      so.block_steps = 16;
      so.label_tolerance_steps = 0;
      // The whole fitted size, as the ANN's MACs count it (the runtime skips the padding's
      // neurons; counting them keeps the ratio between equal networks).
      so.whole_network = true;
      so.downsample = ds;
      Segmenter seg(model, ev.sensor, so, f);
      constexpr size_t kChunk = 1 << 16;
      for (size_t b = 0; b < n && !interrupted(); b += kChunk) {
        seg.push(ev.slice_index(b, std::min(n, b + kChunk)));
        seg.labelled().clear();
      }
      if (interrupted()) {
        --r.sequences;
        break;
      }
      seg.finish();
      r.events += n;
      r.steps += uint64_t(seg.steps());
      r.seconds += double(end - t0) * 1e-6;
      fill_layers(r, seg.network(), model);
      bar.update(++done);
    }
    if (interrupted()) {
      r.interrupted = true;
      break;
    }
  }
  bar.set_status("");
  bar.finish();
  if (r.layers.empty() && !r.interrupted)
    fail("spikems energy", "", "the data holds no events: nothing to count");
  finish_report(r);
  return r;
}

nlohmann::ordered_json energy_json(const EnergyReport& r) {
  nlohmann::ordered_json j;
  j["format"] = "spikems-energy";
  j["version"] = 1;
  j["command"] = r.command_line;
  j["date"] = r.date;
  j["model"] = r.model_path;
  j["name"] = r.model_name;
  j["time_step_ms"] = r.time_step_ms;
  j["iir"] = r.iir;
  j["data"] = r.data;
  j["split"] = r.split;
  j["max_seconds"] =
      r.max_seconds > 0 ? nlohmann::ordered_json(r.max_seconds) : nlohmann::ordered_json(nullptr);
  j["interrupted"] = r.interrupted;
  j["sensor"] = {{"width", r.width}, {"height", r.height}};
  j["downsample"] = r.downsample;
  j["window_ms"] = r.window_ms;
  j["sequences"] = r.sequences;
  j["events"] = r.events;
  j["steps"] = r.steps;
  j["seconds"] = r.seconds;
  j["samples"] = r.samples;
  j["pj_per_accumulate"] = kPicojoulePerAccumulate;
  j["pj_per_mac"] = kPicojoulePerMac;
  j["convention"] = {
      {"sample", "one window of window_ms on the whole sensor; samples = seconds / window"},
      {"synops", "input spike x output neurons it reached (borders included), as counted"},
      {"ann_conv_macs", "output positions x C_out x C_in x k^2"},
      {"ann_convT_macs", "input positions x C_in x C_out x k^2"}};
  j["per_sample"] = {{"synops", r.synops()},
                     {"snn_energy_uj", r.snn_pj() * 1e-6},
                     {"ann_macs", r.ann_macs()},
                     {"ann_energy_uj", r.ann_pj() * 1e-6},
                     {"benefit", r.benefit()}};
  nlohmann::ordered_json layers = nlohmann::ordered_json::array();
  for (size_t k = 0; k < r.layers.size(); ++k) {
    const LayerEnergy& l = r.layers[k];
    nlohmann::ordered_json jl;
    jl["layer"] = k + 1;
    jl["kind"] = kind_name(l.shape.kind);
    jl["in"] = {l.shape.in_channels, l.shape.in_height, l.shape.in_width};
    jl["out"] = {l.shape.out_channels, l.shape.out_height, l.shape.out_width};
    jl["kernel"] = l.shape.kernel;
    jl["stride"] = l.shape.stride;
    jl["neurons"] = l.neurons;
    jl["in_spikes"] = l.in_spikes;
    jl["out_spikes"] = l.out_spikes;
    jl["firing_rate"] = l.firing_rate;
    jl["synops"] = l.synops;
    jl["synops_per_sample"] = l.synops_per_sample;
    jl["ann_macs_per_sample"] = l.ann_macs;
    layers.push_back(std::move(jl));
  }
  j["layers"] = std::move(layers);
  return j;
}

std::string energy_table(const EnergyReport& r) {
  std::string out;
  out +=
      "| model | SynOps per sample (x10^8) | energy SNN (uJ) | MACs ANN-2D (x10^8) | energy "
      "ANN-2D (uJ) | benefit (x) |\n";
  out += "|---|---|---|---|---|---|\n";
  out += "| " + r.model_name + " | " + fmt("%.4f", r.synops() * 1e-8) + " | " +
         fmt("%.2f", r.snn_pj() * 1e-6) + " | " + fmt("%.4f", r.ann_macs() * 1e-8) + " | " +
         fmt("%.2f", r.ann_pj() * 1e-6) + " | " + fmt("%.1f", r.benefit()) + " |\n";
  out += "| paper (SpikeMS, MOD / EV-IMO / EED) | 0.34-0.83 | | | | 58-144 |\n\n";
  out +=
      "| layer | kind | in (C×H×W) | out (C×H×W) | neurons | in spikes | out spikes | firing "
      "rate | SynOps / sample | ANN MACs / sample |\n";
  out += "|---|---|---|---|---|---|---|---|---|---|\n";
  for (size_t k = 0; k < r.layers.size(); ++k) {
    const LayerEnergy& l = r.layers[k];
    const LayerShape& s = l.shape;
    auto dims = [](int c, int h, int w) {
      return std::to_string(c) + "×" + std::to_string(h) + "×" + std::to_string(w);
    };
    out += "| " + std::to_string(k + 1) + " | " + kind_name(s.kind) + " | " +
           dims(s.in_channels, s.in_height, s.in_width) + " | " +
           dims(s.out_channels, s.out_height, s.out_width) + " | " + std::to_string(l.neurons) +
           " | " + std::to_string(l.in_spikes) + " | " + std::to_string(l.out_spikes) + " | " +
           fmt("%.5f", l.firing_rate) + " | " + fmt("%.0f", l.synops_per_sample) + " | " +
           std::to_string(l.ann_macs) + " |\n";
  }
  return out;
}

std::string energy_markdown(const EnergyReport& r) {
  std::string out = "# spikems energy\n\n";
  out += "- command: `" + r.command_line + "`\n";
  out += "- date: " + r.date + "\n";
  out += "- model: `" + r.model_path + "` (" + r.model_name + ", time step " +
         fmt("%g", r.time_step_ms) + " ms" + (r.iir ? ", FIR layers run as IIR" : "") + ")\n";
  out += "- data: " + std::to_string(r.sequences) + " sequences, " + std::to_string(r.events) +
         " events, " + fmt("%.3f", r.seconds) + " s, sensor " + std::to_string(r.width) + "x" +
         std::to_string(r.height) +
         (r.downsample > 1 ? " (downsampled " + std::to_string(r.downsample) + "x)" : "") +
         "; sample = " + fmt("%g", r.window_ms) + " ms on the whole sensor (" +
         fmt("%.1f", r.samples) + " samples)\n";
  if (r.interrupted) out += "- **interrupted**: the sequences finished before Ctrl-C only\n";
  out +=
      "\nSynOps as the runtime counts them (each input spike times the neurons it reached, "
      "borders included); ANN-2D = the same layers dense: conv MACs = output positions × "
      "C_out × C_in × k², transposed conv MACs = input positions × C_in × C_out × k²; 0.9 pJ "
      "per accumulate, 4.6 pJ per MAC. See docs/evaluation.md.\n\n";
  return out + energy_table(r);
}

void write_energy(const EnergyReport& r, const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) fail(dir, "", "cannot create the output folder: " + ec.message());
  write_file_atomic((fs::path(dir) / "results.json").string(), energy_json(r).dump(2) + "\n");
  write_file_atomic((fs::path(dir) / "results.md").string(), energy_markdown(r));
}

}  // namespace spikems
