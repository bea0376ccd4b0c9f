#include "train/trainer/trainer.h"

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <sstream>
#include <thread>

#include "core/eval/evaluation.h"
#include "core/model/model_file.h"
#include "core/model/output_gate.h"
#include "core/model/time_step.h"
#include "core/util/atomic_file.h"
#include "core/util/error.h"
#include "core/util/host_info.h"
#include "core/util/interrupt.h"
#include "core/util/progress.h"
#include "core/viz/svg_plot.h"
#include "spikems/version.h"
#include "train/loss/ann_loss.h"
#include "train/loss/spikems_loss.h"
#include "train/loss/synops_loss.h"
#include "train/network/ann2d_network.h"
#include "train/neuron/kernel_choice.h"
#include "train/neuron/neuron_cuda_torch.h"
#include "train/threads.h"
#include "train/trainer/batch_tensors.h"
#include "train/trainer/checkpoint.h"
#include "train/trainer/distributed.h"
#include "train/trainer/weight_init.h"

namespace spikems::train {

namespace fs = std::filesystem;

namespace {

ModelSpec initial_spec(const TrainConfig& c) {
  ModelSpec spec;
  if (c.init == "data" && c.type == "ann2d")
    return ann2d_architecture(c.channels, c.skips, c.skip_levels, c.history);
  if (c.init != "data") {
    spec = load_model(c.init);  // fine-tuning: geometry and neurons from the file
    const double ts = double(c.sample.step_us) / 1000.0;
    if (!same_time_step(spec.time_step_ms, ts)) {
      // Setting the step alone would change every neuron's per-step decay: a 2 ms model at
      // 5 ms steps falls silent. Say which of the two meanings is wanted.
      if (c.init_time_constants.empty()) {
        char why[320];
        std::snprintf(why, sizeof why,
                      " was trained with %g ms steps and sample.step_ms is %g: set "
                      "model.init_time_constants = \"steps\" (each step behaves as before, time "
                      "constants scaled) or \"ms\" (time constants kept in ms), or "
                      "sample.step_ms = %g",
                      spec.time_step_ms, ts, spec.time_step_ms);
        fail("model.init", "", c.init + why);
      }
      spec =
          with_time_step(std::move(spec), ts,
                         parse_time_constants(c.init_time_constants, "model.init_time_constants"),
                         "model.init_time_constants (" + c.init + ")");
    }
  } else {
    spec = spikems_architecture(c.padded,
                                c.neurons == "iir" ? Discretisation::IIR : Discretisation::FIR,
                                c.channels, c.tau_s, c.skips, c.skip_levels);
    for (auto& l : spec.layers)
      l.neuron.surrogate = c.surrogate == "slayer" ? SurrogateForm::Slayer : SurrogateForm::SpikeMS;
    // Encoder layer k is level k; the decoder mirrors it (layer 2n-1-k is level k).
    const size_t n = c.channels.size();
    for (size_t k = 0; k < spec.layers.size() && !c.tau_r.empty(); ++k)
      spec.layers[k].neuron.tau_r =
          float(c.tau_r.size() == 2 * n ? c.tau_r[k] : c.tau_r[k < n ? k : 2 * n - 1 - k]);
  }
  if (c.tau_rho > 0)
    for (auto& l : spec.layers) l.neuron.tau_rho = float(c.tau_rho);
  if (!c.srm_onset.empty() && spec.type == ModelType::SNN) {
    // A file's weights keep their meaning only roughly: each layer now answers a step earlier,
    // so the paths through the skips meet at other relative delays (train on).
    for (auto& l : spec.layers)
      l.neuron.srm_onset = c.srm_onset == "same_step" ? SrmOnset::SameStep : SrmOnset::NextStep;
    spec.validate("model.srm_onset");
  }
  return spec;
}

double lr_at(const TrainConfig& c, int64_t step) {
  if (step < c.warmup_steps) return c.lr * double(step + 1) / double(c.warmup_steps);
  const double s = double(step - c.warmup_steps);
  if (c.schedule == "constant") return c.lr;
  if (c.schedule == "step") return c.lr * std::pow(c.step_gamma, std::floor(s / c.step_every));
  const double span = std::max(1.0, double(c.steps - c.warmup_steps));
  return c.min_lr +
         0.5 * (c.lr - c.min_lr) * (1 + std::cos(std::numbers::pi * std::min(1.0, s / span)));
}

LossOptions loss_options(const TrainConfig& c, double ts) {
  LossOptions o;
  o.projection = c.projection == "sigmoid" ? LossOptions::Projection::Sigmoid
                                           : LossOptions::Projection::Exponential;
  o.alpha = c.alpha;
  o.beta = c.beta;
  o.kappa = c.kappa;
  o.lambda = c.lambda;
  o.ts = ts;
  o.all_pixels = c.all_pixels;
  o.pos_weight = c.pos_weight;
  o.balanced = c.balanced;
  o.gate_events = c.gate_events;
  o.potential_readout = c.readout == "potential";
  return o;
}

struct StepOutput {
  torch::Tensor total, bce, spike, iou, activity, distill;
  torch::Tensor attention;  // loss.attention_weight's term (unweighted)
  torch::Tensor feature;    // loss.feature_weight's term (unweighted)
  torch::Tensor offevent;   // loss.offevent_weight's term (unweighted)
  // The distillation's floor: the teacher's own mean binary entropy over the pixels with
  // events, what `distill` would be for a student that matched it exactly.
  torch::Tensor distill_floor;
  // Its ceiling: the best constant student's score, the binary entropy of the teacher's mean.
  torch::Tensor distill_const;
  std::vector<double> rates;
  // Synaptic operations per input event over the window, the mean over samples (0: no input);
  // loss.synops_weight's penalty is in `activity`.
  double synops_per_event = 0;
  torch::Tensor out_window, fg_window, in_window;
};

// teacher_group: the teacher's time step in this run's steps (1, or a whole multiple).
StepOutput forward_loss(SpikeMSNetwork& net, Ann2dNetwork teacher, int64_t teacher_group,
                        const SynopsCounter& synops, const BatchTensors& bt, const TrainConfig& c,
                        const LossOptions& lo, double ts) {
  const int64_t T = bt.input.size(0), H = bt.input.size(3), W = bt.input.size(4);
  const int64_t w0 = bt.warmup_steps, tw = T - w0;
  // Truncated: the layers come back as their window steps only (lw0 = 0).
  const bool truncate = !c.warmup_backprop && w0 > 0;
  torch::Tensor u;  // the output layer's potential (model.readout = "potential")
  torch::Tensor* readout = lo.potential_readout ? &u : nullptr;
  std::vector<torch::Tensor> layers = truncate ? net->forward_all_truncated(bt.input, w0, readout)
                                               : net->forward_all(bt.input, readout);
  const int64_t lw0 = truncate ? 0 : w0;
  StepOutput o;
  torch::Tensor out = align_to_input(layers.back(), H, W).narrow(0, lw0, tw);
  // What the task's terms score: the spikes, or the potential they come from.
  const torch::Tensor scored = readout ? align_to_input(u, H, W).narrow(0, lw0, tw) : out;
  torch::Tensor in = bt.input.narrow(0, w0, tw), fg = bt.fg.narrow(0, w0, tw);
  const auto zero = torch::zeros({}, out.options());
  const bool use_bce = c.loss == "bce" || c.loss == "both";
  const bool use_spike = c.loss == "spike" || c.loss == "both";
  const double iou_w = c.loss == "iou" ? 1.0 : c.iou_weight;
  o.bce = use_bce ? bce_loss(scored, in, fg, lo) : zero;
  o.spike = use_spike ? van_rossum_loss(out, foreground_target(in, fg), lo) : zero;
  o.iou = iou_w > 0 ? soft_iou_loss(scored, in, fg, lo) : zero;
  o.offevent = c.offevent_weight > 0 ? offevent_loss(scored, in, fg, lo) : zero;
  o.activity = zero;
  for (size_t k = 0; k < layers.size(); ++k) {
    // Over the window only: in the warm-up the deep layers are still filling up (each adds
    // a few ms of latency), and a mean over it would understate their steady-state rates.
    const torch::Tensor rate = layers[k].narrow(0, lw0, tw).mean() * ts;
    o.rates.push_back(rate.item<double>());
    if (c.activity_weight > 0) o.activity = o.activity + c.activity_weight * rate;
    // Per-layer lists, when given, have one entry per hidden layer (checked at start-up).
    const bool hidden = k + 1 < layers.size();
    const double floor = !hidden                 ? c.output_floor
                         : c.rate_floors.empty() ? c.rate_floor
                                                 : c.rate_floors[k];
    if (c.floor_weight > 0 && floor > 0)
      o.activity = o.activity + c.floor_weight * torch::relu(1 - rate / floor).pow(2);
    const double ceiling = !hidden                   ? 0.0
                           : c.rate_ceilings.empty() ? c.rate_ceiling
                                                     : c.rate_ceilings[k];
    if (c.floor_weight > 0 && ceiling > 0)
      o.activity = o.activity + c.floor_weight * torch::relu(rate / ceiling - 1).pow(2);
  }
  {
    // SynOps per input event, per sample: the runtime's work for what the camera gave. A sample
    // without input events counts its operations as if it had one.
    const torch::Tensor events = in.sum(std::vector<int64_t>{0, 2, 3, 4}) * ts;
    std::vector<torch::Tensor> window;
    for (const auto& l : layers) window.push_back(l.narrow(0, lw0, tw));
    const auto sope = [&] { return synops.per_sample(in, window, ts) / events.clamp_min(1); };
    // The penalty counts what loss.synops_source_weights says; the log, every operation.
    const bool weighted = !c.synops_source_weights.empty();
    if (c.synops_weight > 0) {
      const torch::Tensor v =
          synops.per_sample(in, window, ts, c.synops_source_weights) / events.clamp_min(1);
      o.activity = o.activity + synops_penalty(v, c.synops_weight, c.synops_budget);
      if (!weighted) o.synops_per_event = v.detach().mean().item<double>();
    }
    if (c.synops_weight == 0 || weighted) {
      torch::NoGradGuard ng;
      o.synops_per_event = sope().mean().item<double>();
    }
  }
  o.distill = o.attention = o.feature = zero;
  o.distill_floor = o.distill_const = zero;
  if (teacher) {      // set only when c.uses_teacher()
    torch::Tensor q;  // the teacher's probability per pixel, [B, H, W]
    std::vector<torch::Tensor> t_hidden;
    {
      torch::NoGradGuard ng;
      const torch::Tensor feat =
          ann_feature_tensor(bt.input, w0, ts, teacher_group, teacher->history());
      std::vector<torch::Tensor> t_layers = teacher->forward_all(feat);
      q = torch::sigmoid(align_to_input(t_layers.back(), H, W).squeeze(1));
      t_layers.pop_back();
      t_hidden = std::move(t_layers);
    }
    // Samples without a moving event: the teacher's q, their labels, or no distillation.
    const DistillTargets dt = static_distill_targets(q, in, fg, c.teacher_static);
    q = dt.q;
    if (c.teacher_weight > 0) o.distill = distill_loss(scored, in, q, lo, dt.sample_weight);
    o.distill_floor = teacher_entropy(in, q);
    o.distill_const = teacher_mean_entropy(in, q);
    if (c.attention_weight > 0 || c.feature_weight > 0) {
      // Each hidden layer's firing rate over the window (spikes are 1/Ts: rate = mean x Ts).
      std::vector<torch::Tensor> s_hidden;
      for (size_t k = 0; k + 1 < layers.size(); ++k)
        s_hidden.push_back(layers[k].narrow(0, lw0, tw).mean(0) * ts);
      if (c.attention_weight > 0) o.attention = attention_transfer_loss(s_hidden, t_hidden);
      if (c.feature_weight > 0) o.feature = feature_transfer_loss(s_hidden, t_hidden);
    }
  }
  o.total = o.bce + lo.lambda * o.spike + iou_w * o.iou + o.activity +
            c.teacher_weight * o.distill + c.attention_weight * o.attention +
            c.feature_weight * o.feature + c.offevent_weight * o.offevent;
  o.out_window = out;
  o.fg_window = fg;
  o.in_window = in;
  return o;
}

// The ANN-2D baseline on the event frame of the window and, with model.history, the frames just
// before it (taken from the warm-up; otherwise the warm-up is not shown to it).
// "rates" are the shares of non-zero ReLU outputs (the output layer: of positive logits).
StepOutput ann_forward_loss(Ann2dNetwork& net, const BatchTensors& bt, const TrainConfig& c,
                            double ts) {
  const int64_t w0 = bt.warmup_steps, tw = bt.input.size(0) - w0;
  const torch::Tensor feat = ann_feature_tensor(bt.input, w0, ts, 1, net->history());
  const std::vector<torch::Tensor> layers = net->forward_all(feat);
  const torch::Tensor logits = align_to_input(layers.back(), feat.size(2), feat.size(3));
  const torch::Tensor had = (feat.narrow(1, 0, 2).sum(1) > 0).to(torch::kFloat);
  StepOutput o;
  o.fg_window = bt.fg.narrow(0, w0, tw);
  const torch::Tensor fg = (o.fg_window.sum(0) > 0).to(torch::kFloat);
  const double iou_w = c.loss == "iou" ? 1.0 : c.iou_weight;
  const AnnLoss l = ann_loss(logits, had, fg, c.balanced, iou_w);
  const auto zero = torch::zeros({}, logits.options());
  o.bce = c.loss == "iou" ? zero : l.bce;
  o.iou = l.iou;
  o.spike = o.activity = o.distill = o.distill_floor = o.distill_const = o.attention = o.feature =
      o.offevent = zero;
  o.total = o.bce + iou_w * o.iou;
  for (const auto& a : layers)
    o.rates.push_back((a.detach() > 0).to(torch::kFloat).mean().item<double>());
  o.out_window =
      ((logits.detach().squeeze(1) > 0).to(torch::kFloat) * had).unsqueeze(0).unsqueeze(2);
  return o;
}

// The network being trained: the spiking SpikeMS network or the ANN-2D baseline.
struct TrainNet {
  SpikeMSNetwork snn{nullptr};
  Ann2dNetwork ann{nullptr};
  Ann2dNetwork teacher{nullptr};          // loss.teacher: fixed, not trained, not saved
  int64_t teacher_group = 1;              // the teacher's step in this run's steps
  std::unique_ptr<SynopsCounter> synops;  // the SNN's
  torch::nn::Module& module() {
    return snn ? static_cast<torch::nn::Module&>(*snn) : static_cast<torch::nn::Module&>(*ann);
  }
  ModelSpec to_spec() const { return snn ? snn->to_spec() : ann->to_spec(); }
  size_t size() const { return snn ? snn->size() : ann->size(); }
  StepOutput step(const BatchTensors& bt, const TrainConfig& c, const LossOptions& lo, double ts) {
    return snn ? forward_loss(snn, teacher, teacher_group, *synops, bt, c, lo, ts)
               : ann_forward_loss(ann, bt, c, ts);
  }
};

nlohmann::json rates_json(const std::vector<double>& r) {
  nlohmann::json a = nlohmann::json::array();
  for (double v : r) a.push_back(std::round(v * 1e6) / 1e6);
  return a;
}

struct Curves {
  std::vector<double> step, loss, val_step, val_iou, val_det, full_step, full_iou;
  std::vector<double> static_step, static_moving;
  void add(const nlohmann::json& j) {
    if (j.value("kind", "") == "train") {
      step.push_back(j["step"].get<double>());
      loss.push_back(j["loss"].get<double>());
    } else if (j.value("kind", "") == "val") {
      val_step.push_back(j["step"].get<double>());
      val_iou.push_back(j["iou"].get<double>());
      val_det.push_back(j["detection_rate"].get<double>());
      if (j.contains("full_iou")) {
        full_step.push_back(j["step"].get<double>());
        full_iou.push_back(j["full_iou"].get<double>());
      }
      if (j.contains("static_moving")) {
        static_step.push_back(j["step"].get<double>());
        static_moving.push_back(j["static_moving"].get<double>());
      }
    }
  }
  void write(const std::string& path) const {
    if (step.empty()) return;
    PlotOptions po;
    po.title = "Training loss";
    po.x_label = "step";
    po.y_label = "loss";
    po.height = 300;
    std::string svg = svg_line_plot({{"train loss", step, loss, {}, ""}}, po);
    std::string all = svg;
    if (!val_step.empty()) {
      PlotOptions pv = po;
      pv.title = "Validation";
      pv.y_label = "%";
      pv.y_min = 0;
      pv.y_max = 100;
      std::vector<PlotSeries> series;
      series.push_back({"IoU (crops)", val_step, val_iou, {}, ""});
      series.push_back({"detection rate", val_step, val_det, {}, ""});
      if (!full_step.empty()) series.push_back({"IoU (whole sensor)", full_step, full_iou, {}, ""});
      if (!static_step.empty())
        series.push_back({"static scenes called moving", static_step, static_moving, {}, ""});
      all = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"640\" height=\"700\">" +
            std::string("<g>") + svg + "</g><g transform=\"translate(0,320)\">" +
            svg_line_plot(series, pv) + "</g></svg>";
    }
    write_svg(path, all);
  }
};

// The whole text of a gzipped file (zlib's gz reader); throws Error naming it when unreadable.
std::string read_gzip(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) fail(path, "", "cannot open the gzipped log");
  std::string out;
  char buf[1 << 16];
  int n;
  while ((n = gzread(f, buf, sizeof buf)) > 0) out.append(buf, size_t(n));
  const bool bad = n < 0;
  gzclose(f);
  if (bad) fail(path, "", "the gzipped log is damaged (gunzip it by hand, then --resume)");
  return out;
}

// Keeps the log's lines up to `step` (a resume repeats the steps after its checkpoint). A log
// kept gzipped (log.jsonl.gz, as the repository keeps long logs) is unpacked into log.jsonl
// first, so that the resumed run continues the whole log and its curves.
Curves trim_log(const std::string& path, int64_t step) {
  Curves cv;
  std::error_code ec;
  const std::string gz = path + ".gz";
  std::stringstream in;
  if (!fs::exists(path) && fs::exists(gz)) {
    in << read_gzip(gz);
  } else {
    std::ifstream f(path);
    in << f.rdbuf();
  }
  std::string line, kept;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(line);
    } catch (...) {
      continue;  // a line cut by a kill
    }
    if (j.value("step", int64_t(0)) > step) continue;
    cv.add(j);
    kept += line + "\n";
  }
  write_file_atomic(path, kept);
  if (fs::exists(gz)) fs::remove(gz, ec);  // its lines are in `path` now
  return cv;
}

std::string percent(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}

}  // namespace

TrainConfig load_run_config(const std::string& out_dir, const std::vector<std::string>& overrides) {
  const std::string path = (fs::path(out_dir) / "config.json").string();
  if (!fs::exists(path))
    fail(path, "", "no such file: is " + out_dir + " a `spikems train` run folder?");
  return load_train_config(path, overrides);
}

namespace {

// Hidden switches for the dead-rank and hung-rank tests (SPIKEMS_TEST_DIE_AT_STEP,
// SPIKEMS_TEST_HANG_AT_STEP): this process exits as a crash would (no cleanup, no message to
// the others) or stops answering, after completing step N.
int64_t test_switch(const char* name) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoll(v) : -1;
}

TrainResult run_training_impl(const TrainConfig& c, const TrainRunOptions& ro,
                              std::unique_ptr<Distributed>& dist_ptr) {
  const auto t_start = std::chrono::steady_clock::now();
  const fs::path dir(ro.out_dir);
  const std::string ckpt_path = (dir / "checkpoint.pt").string();
  const DistOptions& dopt = ro.dist;
  const int world = dopt.world_size;
  const bool root = dopt.rank == 0;  // rank 0 alone writes the run folder
  if (world > 1) {
    if (c.batch % world != 0)
      fail("optim.batch", "",
           std::to_string(c.batch) + " is not divisible by the world size " +
               std::to_string(world) + ": each rank makes an equal share of every batch");
    if (c.device == "cuda")
      fail("run.device", "",
           "data-parallel training runs on CPUs (Gloo); with --device cuda use world size 1");
  }
  if (ro.resume && !fs::exists(ckpt_path))
    fail(ckpt_path, "",
         "no checkpoint to resume from (has the run written one yet?" +
             std::string(world > 1 ? " Every rank reads it: is the folder shared?)" : ")"));
  if (root && !ro.resume && fs::exists(ckpt_path))
    fail(ro.out_dir, "", "holds a run already: continue it with --resume, or choose another --out");
  if (root) fs::create_directories(dir);
  if (c.device == "cuda" && !torch::cuda::is_available())
    fail("run.device", "", "cuda asked for, but this LibTorch has no CUDA device");
  const torch::Device device(c.device == "cuda" ? torch::kCUDA : torch::kCPU);
  set_neuron_kernels(parse_neuron_kernels(c.neuron_kernels));
  const int threads = set_torch_threads(c.threads);  // the BLAS pool: one thread (threads.h)
  torch::manual_seed(c.seed);
  install_interrupt_flag();

  // Model files named by the config, read before the data (minutes): a missing or bad one is
  // reported at once, naming its key. Their fit to the network is checked below.
  auto read_model = [](const char* key, const std::string& path) {
    try {
      return load_model(path);
    } catch (const std::exception& e) {
      fail(key, "", e.what());
    }
  };
  if (!ro.resume && c.init != "data") read_model("model.init", c.init);
  const ModelSpec teacher_spec =
      c.uses_teacher() ? read_model("loss.teacher", c.teacher) : ModelSpec{};
  const ModelSpec init_ann_spec =
      !ro.resume && !c.init_ann.empty() ? read_model("model.init_ann", c.init_ann) : ModelSpec{};

  // Data: everything in memory (a 2 s simulated sequence is ~100 MB).
  std::vector<LabelledSequence> train_seqs, val_seqs;
  std::vector<double> weights;
  for (const auto& src : c.train) {
    auto s = load_sequences(src, ro.progress);
    for (auto& q : s) {
      weights.push_back(src.weight / double(s.size()));
      train_seqs.push_back(std::move(q));
    }
  }
  for (const auto& src : c.val) {
    auto s = load_sequences(src, ro.progress);
    for (auto& q : s) val_seqs.push_back(std::move(q));
  }
  std::vector<const LabelledSequence*> train_ptr, val_ptr;
  for (auto& s : train_seqs) train_ptr.push_back(&s);
  for (auto& s : val_seqs) val_ptr.push_back(&s);
  // The pixel scale the model learns (ModelSpec::train_width/height): the training data's
  // sensor when every training sequence has the same one; the runtime downsamples larger
  // sensors towards it (model_scale.h). Mixed sizes record none.
  SensorSize train_grid = train_seqs.empty() ? SensorSize{} : train_seqs.front().events.sensor;
  for (const auto& s : train_seqs)
    if (s.events.sensor.width != train_grid.width || s.events.sensor.height != train_grid.height)
      train_grid = SensorSize{};
  const double ts = double(c.sample.step_us) / 1000.0;
  // The rendezvous after loading the data, so that ranks loading at different speeds do not
  // spend the timeout.
  dist_ptr = std::make_unique<Distributed>(dopt);
  Distributed& dist = *dist_ptr;

  ModelSpec spec = initial_spec(c);
  spec.time_step_ms = ts;
  if (c.output_gate_ms > 0)
    spec = with_output_gate(std::move(spec), std::llround(c.output_gate_ms * 1000),
                            "model.output_gate_ms");
  if (c.readout == "potential" && spec.type == ModelType::SNN) {
    // No refractory at the output: it spikes at every step its potential is at or above
    // theta, the runtime's labels are then "u >= theta", the loss's p > 1/2.
    LayerSpec& last = spec.layers.back();
    last.neuron.scale_ref = 0;
    if (last.neuron.discretisation == Discretisation::FIR)
      last.ref_kernel = sample_refractory_kernel(last.neuron, ts);
  }
  const SpikeGradient grad = c.backward == "exact" ? SpikeGradient::Exact : SpikeGradient::Slayer;
  TrainNet net;
  // Past frames come from the warm-up: it must hold them whole (the ANN's own, or a teacher's).
  auto check_history = [&](int history, const std::string& who) {
    if (int64_t(history) * c.sample.window_us > c.sample.warmup_us) {
      char why[256];
      std::snprintf(why, sizeof why,
                    "%s sees %d past frames of the %g ms window: sample.warmup_ms must be at "
                    "least %g",
                    who.c_str(), history, double(c.sample.window_us) / 1000.0,
                    double(history) * double(c.sample.window_us) / 1000.0);
      fail("sample.warmup_ms", "", why);
    }
  };
  if (spec.type == ModelType::ANN2D) {
    check_history(spec.ann_history, "the ANN-2D");
    net.ann = Ann2dNetwork(spec);
  } else {
    net.snn = SpikeMSNetwork(spec, grad);
    net.synops = std::make_unique<SynopsCounter>(spec);
    if (!c.synops_source_weights.empty() && c.synops_source_weights.size() != net.synops->sources())
      fail("loss.synops_source_weights", "",
           "gives " + std::to_string(c.synops_source_weights.size()) +
               " weights, the network has " + std::to_string(net.synops->sources()) +
               " sources (the input and " + std::to_string(net.synops->sources() - 1) + " layers)");
    net.snn->set_kernels(parse_kernel_path(c.kernels));
    if (c.delays)
      for (size_t k = 0; k < net.size(); ++k) net.snn->layer(k)->enable_delay(true);
  }
  if (!c.rate_floors.empty() && c.rate_floors.size() + 1 != net.size())
    fail("loss.rate_floors", "",
         "gives " + std::to_string(c.rate_floors.size()) + " floors, the network has " +
             std::to_string(net.size() - 1) + " hidden layers");
  if (!c.rate_ceilings.empty() && c.rate_ceilings.size() + 1 != net.size())
    fail("loss.rate_ceilings", "",
         "gives " + std::to_string(c.rate_ceilings.size()) + " ceilings, the network has " +
             std::to_string(net.size() - 1) + " hidden layers");
  if (c.uses_teacher()) {
    const ModelSpec& t = teacher_spec;
    if (t.type != ModelType::ANN2D)
      fail("loss.teacher", "", c.teacher + " is not an ANN-2D model: the teacher must be one");
    if (c.attention_weight > 0 && t.layers.size() != net.size())
      fail("loss.attention_weight", "",
           c.teacher + " has " + std::to_string(t.layers.size()) + " layers, the network " +
               std::to_string(net.size()) +
               ": attention transfer pairs layers one to one (the same model.channels)");
    if (c.feature_weight > 0) {
      // Channel by channel: every hidden layer's output channels must match the teacher's.
      bool same = t.layers.size() == spec.layers.size();
      for (size_t k = 0; same && k + 1 < spec.layers.size(); ++k)
        same = t.layers[k].out_channels == spec.layers[k].out_channels;
      if (!same)
        fail("loss.feature_weight", "",
             c.teacher +
                 ": feature transfer pairs layers and channels one to one; the teacher's "
                 "hidden layers must have the network's channels (the same model.channels)");
    }
    // A teacher trained with coarser steps sees the window re-binned at its own step (exact:
    // ann_feature_tensor's group), so one that discriminates on a single 10 ms frame, and
    // transfers to real cameras best, can teach a student running at 1 or 2 ms.
    const double ratio = t.time_step_ms / ts;
    const int64_t group = std::llround(ratio), window_steps = c.sample.window_us / c.sample.step_us;
    if (group < 1 || std::abs(ratio - double(group)) > 1e-6 || window_steps % group != 0) {
      char why[256];
      std::snprintf(why, sizeof why,
                    " was trained with %g ms steps, this run's sample.step_ms is %g and its "
                    "window %g ms: the teacher's step must be a whole multiple of the run's "
                    "that divides the window",
                    t.time_step_ms, ts, double(c.sample.window_us) / 1000.0);
      fail("loss.teacher", "", c.teacher + why);
    }
    check_history(t.ann_history, "the teacher " + c.teacher);
    net.teacher_group = group;
    net.teacher = Ann2dNetwork(t);
    net.teacher->eval();
    net.teacher->to(device);
  }
  torch::optim::Adam opt(
      net.module().parameters(),
      torch::optim::AdamOptions(c.lr).amsgrad(c.amsgrad).weight_decay(c.weight_decay));
  CheckpointState st;
  const std::string log_path = (dir / "log.jsonl").string();
  Curves curves;
  // The run's config.json always holds the configuration in force (a resume's --set too).
  if (root) write_file_atomic((dir / "config.json").string(), c.source.dump(2) + "\n");
  if (ro.resume) {  // every rank reads the same checkpoint (model and Adam state)
    st = load_checkpoint(ckpt_path, net.module(), opt);
    if (root) curves = trim_log(log_path, st.step);
  } else if (root) {
    write_file_atomic(log_path, "");
    if (c.init == "data" && net.snn) {
      Batch b = BatchLoader::make(train_ptr, weights, c.sample, std::max(4, c.batch), c.seed, -1);
      // On the training device: ~19 forwards per layer of a whole batch took ~2.5 minutes of a
      // GPU run's start on its CPU (whole frames, six levels); the weights come back for the
      // data-parallel broadcast below. The random draws stay on the CPU, the same everywhere.
      net.module().to(device);
      BatchTensors bt = to_tensors(b.samples, ts, device);
      std::vector<torch::Tensor> directions;
      if (!c.init_ann.empty())
        directions = ann_weight_directions(init_ann_spec, spec, "model.init_ann: " + c.init_ann);
      auto r = init_weights_from_data(net.snn, bt.input, c.init_rates, ts, c.seed, directions);
      net.module().to(torch::kCPU);
      if (ro.progress) {
        std::fprintf(stderr, "init: layer firing rates");
        for (double v : r) std::fprintf(stderr, " %.4f", v);
        std::fprintf(stderr, "\n");
      }
    }
  }
  // The others wait for rank 0's initialisation at the store (it may outlast the timeout on
  // large crops), then take its weights.
  dist.root_done("init");
  dist.wait_for_root("init");
  dist.broadcast_module(net.module());  // rank 0's initial (or resumed) weights everywhere
  net.module().to(device);
  // Weight averaging (optim.ema_decay): every rank applies the same averaged gradients, so
  // every rank's average is the same; a resume continues the checkpoint's average.
  std::vector<torch::Tensor> params = net.module().parameters();
  if (c.ema_decay > 0) {
    torch::NoGradGuard ng;
    if (st.ema.empty()) {
      for (const auto& p : params) st.ema.push_back(p.detach().clone());
      st.ema_updates = 0;
    } else {
      if (st.ema.size() != params.size())
        fail(ckpt_path, "", "its averaged weights do not fit this network");
      for (size_t k = 0; k < params.size(); ++k) {
        if (!st.ema[k].sizes().equals(params[k].sizes()))
          fail(ckpt_path, "", "its averaged weights do not fit this network");
        st.ema[k] = st.ema[k].to(params[k].options());
      }
    }
  } else {
    st.ema.clear();  // a resume with averaging turned off drops it
  }
  // Runs fn with the averaged weights in the network (validation, saved models), then puts the
  // trained weights back; without averaging, just fn.
  auto with_average = [&](auto&& fn) {
    if (st.ema.empty()) return fn();
    torch::NoGradGuard ng;
    std::vector<torch::Tensor> trained;
    for (size_t k = 0; k < params.size(); ++k) {
      trained.push_back(params[k].detach().clone());
      params[k].copy_(st.ema[k]);
    }
    fn();
    for (size_t k = 0; k < params.size(); ++k) params[k].copy_(trained[k]);
  };
  std::ofstream log;
  if (root) log.open(log_path, std::ios::app);
  auto log_line = [&](const nlohmann::json& j) {
    if (!root) return;
    log << j.dump() << "\n";
    log.flush();
    curves.add(j);
  };
  nlohmann::json start_line = {
      {"kind", "run"},      {"step", st.step},    {"event", ro.resume ? "resume" : "start"},
      {"threads", threads}, {"device", c.device}, {"command", ro.command}};
  if (world > 1) start_line["world_size"] = world;
  start_line["blas_threads"] = blas_threads();  // 1 (threads.h), or 0: a BLAS without a pool
  log_line(start_line);

  // Validation runs on rank 0 alone; the others wait for it (Distributed::wait_for_root).
  const bool has_val = !val_ptr.empty() && c.val_samples > 0;
  const std::vector<Sample> val =
      !has_val || !root ? std::vector<Sample>{}
                        : validation_samples(val_ptr, c.sample, c.val_samples, c.seed);
  LossOptions lo = loss_options(c, ts);
  if (net.snn) lo.readout_theta = spec.layers.back().neuron.theta;

  auto save_model_file = [&](const std::string& path) {
    ModelSpec m = net.to_spec();
    m.name = dir.filename().string();
    if (train_grid.known()) {
      m.train_width = train_grid.width;
      m.train_height = train_grid.height;
    }
    m.training = {{"config", c.source},
                  {"steps", st.step},
                  {"wall_seconds", st.wall_seconds},
                  {"best_val_iou", st.best_val_iou},
                  {"best_step", st.best_step},
                  {"hardware",
                   {{"cpu", cpu_name()},
                    {"threads", threads},
                    {"device", c.device == "cuda" ? "cuda: " + cuda_device_name() : c.device},
                    {"neuron_kernels", c.neuron_kernels}}},
                  {"command", ro.command},
                  {"trainer", "spikems train " SPIKEMS_VERSION}};
    save_model(path, m);
  };
  auto validate = [&]() -> nlohmann::json {
    torch::NoGradGuard ng;
    WindowScores ws;
    double loss = 0, sope = 0;
    std::vector<double> rates(net.size(), 0.0);
    int batches = 0;
    for (size_t i = 0; i < val.size(); i += size_t(c.batch)) {
      std::vector<Sample> part(val.begin() + i,
                               val.begin() + std::min(val.size(), i + size_t(c.batch)));
      BatchTensors bt = to_tensors(part, ts, device);
      StepOutput o = net.step(bt, c, lo, ts);
      for (const auto& m :
           window_counts(o.out_window, o.fg_window, c.gate_events ? o.in_window : torch::Tensor()))
        ws.add(m);
      loss += o.total.item<double>();
      sope += o.synops_per_event;
      for (size_t k = 0; k < rates.size(); ++k) rates[k] += o.rates[k];
      ++batches;
    }
    for (double& r : rates) r /= std::max(1, batches);
    nlohmann::json v = {{"kind", "val"},
                        {"step", st.step},
                        {"loss", loss / std::max(1, batches)},
                        {"iou", 100 * ws.mean_iou()},
                        {"iou_std", 100 * ws.std_iou()},
                        {"detection_rate", 100 * ws.detection_rate()},
                        {"windows", ws.windows()},
                        {"skipped", ws.skipped()},
                        {"rates", rates_json(rates)}};
    if (net.snn) v["synops_per_event"] = std::round(10 * sope / std::max(1, batches)) / 10;
    return v;
  };
  // Whole-sensor validation through the core evaluation (the numbers `spikems eval` prints),
  // one source at a time because each names its own split; windows pooled over sources.
  const bool full_val = c.val_full_s > 0 && !c.val.empty();
  const bool static_val = !c.val_static.empty();
  // One source as `spikems eval` scores it (static_scene: every event background).
  auto eval_source = [&](const std::string& mp, const DatasetSource& src, bool static_scene) {
    EvalOptions eo;
    eo.model_path = mp;
    eo.data = {src.path};
    eo.split = src.split;
    eo.windows_us = {int64_t(std::llround(c.val_full_window_ms * 1000))};
    eo.threads = threads;
    eo.max_seconds = c.val_full_s;
    eo.gate_events = c.gate_events;
    eo.static_scene = static_scene;
    const auto r = evaluate(eo);
    // Ctrl-C stops the evaluation too, leaving no rows: say so rather than index nothing.
    if (r.models.empty() || r.models[0].datasets.empty() || r.models[0].datasets[0].windows.empty())
      fail(dir.string(), "step " + std::to_string(st.step),
           "whole-sensor validation interrupted; the last checkpoint (step " +
               std::to_string(
                   std::max<int64_t>(0, (st.step - 1) - (st.step - 1) % c.checkpoint_every)) +
               ") is kept: continue with spikems train --resume " + dir.string());
    return WindowSummary(r.models[0].datasets[0].windows[0]);
  };
  auto validate_full = [&](nlohmann::json& v) {
    if (!full_val && !static_val) return;
    const std::string mp = (dir / "val_model.safetensors").string();
    save_model_file(mp);
    if (full_val) {
      double iou_sum = 0, det_sum = 0;
      size_t windows = 0;
      // Event counts say whether the net tells moving objects from camera motion (precision above
      // the share of moving events) or merely fires where there are events; IoU alone hides that.
      EventCounts events;
      // Size bands (results.h), pooled over the sources like the whole row.
      std::vector<BandSummary> bands;
      for (const auto& src : c.val) {
        const WindowSummary w = eval_source(mp, src, false);
        iou_sum += w.iou_mean * double(w.windows);
        det_sum += w.detection_rate * double(w.windows);
        windows += w.windows;
        if (w.has_events) events += w.events;
        if (bands.empty()) {
          bands = w.bands;
          for (BandSummary& b : bands) b.iou_mean *= double(b.windows);  // sums until the end
        } else if (bands.size() == w.bands.size()) {
          for (size_t b = 0; b < bands.size(); ++b) {
            bands[b].iou_mean += w.bands[b].iou_mean * double(w.bands[b].windows);
            bands[b].windows += w.bands[b].windows;
          }
        }
      }
      v["full_iou"] = windows ? iou_sum / double(windows) : 0.0;
      v["full_detection_rate"] = windows ? det_sum / double(windows) : 0.0;
      v["full_windows"] = windows;
      v["full_event_precision"] = 100 * events.precision();
      v["full_event_base_rate"] =
          events.total() ? 100 * double(events.tp + events.fn) / double(events.total()) : 0.0;
      v["full_moving"] = 100 * events.moving_share();
      v["full_iou_bands"] = nlohmann::json::array();
      for (const BandSummary& b : bands)
        v["full_iou_bands"].push_back(
            {{"share_min_pct", b.lo_pct},
             {"share_max_pct", b.hi_pct},
             {"windows", b.windows},
             {"iou_mean",
              b.windows ? nlohmann::json(b.iou_mean / double(b.windows)) : nlohmann::json()}});
    }
    if (static_val) {  // every event background: what is called moving is a false positive
      EventCounts calls;
      for (const auto& src : c.val_static) {
        const WindowSummary w = eval_source(mp, src, true);
        if (w.has_events) calls += w.events;
      }
      v["static_moving"] = 100 * calls.moving_share();
      v["static_events"] = calls.total();
    }
    std::error_code ec;
    fs::remove(mp, ec);
  };
  // The score that picks best.safetensors.
  auto val_score = [&](const nlohmann::json& v) {
    return full_val ? v["full_iou"].get<double>() : v["iou"].get<double>();
  };
  auto checkpoint = [&]() {
    save_checkpoint(ckpt_path, net.module(), opt, st);  // the trained weights and the average
    with_average([&] { save_model_file((dir / "model.safetensors").string()); });
  };

  if (!ro.resume && has_val) {  // the untrained network's score
    if (root) {
      nlohmann::json v = validate();  // step 0: the average is the weights themselves
      validate_full(v);
      log_line(v);
    }
    dist.root_done("val/0");
    dist.wait_for_root("val/0");
  }
  // Rank r makes samples [r B/W, (r+1) B/W) of every global batch of B samples. Sample
  // making keeps a GPU busy only with many threads; on the CPU its cores train.
  const int local_batch = c.batch / world;
  const int loader_threads =
      c.loader_threads > 0
          ? c.loader_threads
          : (device.is_cuda() ? std::clamp(int(std::thread::hardware_concurrency()) - 2, 1, 12)
                              : 1);
  BatchLoader loader(train_ptr, weights, c.sample, local_batch, c.seed, st.step,
                     std::max(c.prefetch, 2 * loader_threads), loader_threads,
                     dopt.rank * local_batch);
  ProgressBar bar("train", uint64_t(c.steps) * uint64_t(c.batch), "samples", ro.progress && root);
  bar.update(uint64_t(st.step) * uint64_t(c.batch));
  TrainResult res;
  double ema_loss = -1, ema_iou = -1;
  WindowScores train_ws;
  double sum_loss = 0, sum_bce = 0, sum_spike = 0, sum_soft_iou = 0, sum_act = 0, sum_distill = 0;
  double sum_distill_floor = 0, sum_distill_const = 0, sum_attention = 0, sum_feature = 0;
  double sum_offevent = 0, sum_sope = 0;
  double sum_comm = 0;  // seconds in collectives, waiting for the slowest rank included
  std::vector<double> sum_rates(net.size(), 0.0);
  std::vector<double> sum_grad;  // per parameter tensor, summed over the log interval
  int in_sum = 0;
  auto seg_start = std::chrono::steady_clock::now();
  const double wall_before = st.wall_seconds;
  res.wall_seconds = st.wall_seconds;  // time of the last log line (samples/s between lines)
  const int64_t die_at = test_switch("SPIKEMS_TEST_DIE_AT_STEP");
  const int64_t hang_at = test_switch("SPIKEMS_TEST_HANG_AT_STEP");
  const size_t n_rates = net.size();
  bool stop = false;  // Ctrl-C on any rank: every rank stops after the same step
  // The time limit counts from the start (data loading included) and lets at least one step
  // run, so every call makes progress; in a data-parallel run it travels with the Ctrl-C flag.
  int64_t steps_here = 0;
  bool time_up = false;
  auto out_of_time = [&] {
    if (ro.time_limit_s > 0 && steps_here > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() >=
            ro.time_limit_s)
      time_up = true;
    return time_up;
  };
  while (st.step < c.steps && !stop) {
    if (world == 1 && (interrupted() || out_of_time())) break;
    dist.set_step(st.step + 1);
    Batch b = loader.next();
    BatchTensors bt = to_tensors(b.samples, ts, device);
    const double lr = lr_at(c, st.step);
    for (auto& g : opt.param_groups()) static_cast<torch::optim::AdamOptions&>(g.options()).lr(lr);
    opt.zero_grad();
    StepOutput o = net.step(bt, c, lo, ts);
    // This rank's numbers for the log, gathered from every rank before the backward pass so
    // that a non-finite loss anywhere stops every rank before any weight changes:
    // [loss terms x11, SynOps per event, rates, interrupted, then (intersection, predicted,
    // truth) per window].
    std::vector<double> mine = {
        o.total.item<double>(),         o.bce.item<double>(),           o.spike.item<double>(),
        o.iou.item<double>(),           o.activity.item<double>(),      o.distill.item<double>(),
        o.distill_floor.item<double>(), o.distill_const.item<double>(), o.attention.item<double>(),
        o.feature.item<double>(),       o.offevent.item<double>(),      o.synops_per_event};
    mine.insert(mine.end(), o.rates.begin(), o.rates.end());
    mine.push_back(world > 1 && (interrupted() || out_of_time()) ? 1.0 : 0.0);
    for (const auto& m :
         window_counts(o.out_window, o.fg_window, c.gate_events ? o.in_window : torch::Tensor()))
      mine.insert(mine.end(), {double(m.intersection), double(m.predicted), double(m.truth)});
    auto t_comm = std::chrono::steady_clock::now();
    const std::vector<double> all = dist.all_gather(mine);
    double comm_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_comm).count();
    constexpr size_t kTerms = 12;
    const size_t per_rank = mine.size(), head = kTerms + n_rates;
    // Each rank's loss is the mean over its share; the run's loss is the mean over the ranks
    // (the same number a single process computes for losses that are means over samples).
    std::vector<double> terms(head, 0.0);
    std::vector<MaskCounts> counts;
    for (int r = 0; r < world; ++r) {
      const double* p = all.data() + size_t(r) * per_rank;
      for (size_t k = 0; k < head; ++k) terms[k] += p[k] / world;
      stop = stop || p[head] != 0;
      for (size_t k = head + 1; k + 2 < per_rank; k += 3)
        counts.push_back({uint64_t(p[k]), uint64_t(p[k + 1]), uint64_t(p[k + 2])});
    }
    const double loss = terms[0];
    if (!std::isfinite(loss))
      fail(ro.out_dir, "step " + std::to_string(st.step + 1),
           "the loss is " + std::string(std::isnan(loss) ? "NaN" : "infinite") +
               "; stopped. The last good checkpoint (step " +
               std::to_string(
                   std::max<int64_t>(0, (st.step - 1) - (st.step - 1) % c.checkpoint_every)) +
               ") is kept: lower optim.lr or raise optim.clip, "
               "then --resume");
    o.total.backward();
    t_comm = std::chrono::steady_clock::now();
    dist.average_gradients(net.module());  // before clipping: the clip sees the global gradient
    comm_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_comm).count();
    sum_comm += comm_s;
    {  // per-parameter gradient norms before clipping (the log's grad_norms: which layers learn)
      torch::NoGradGuard ng;
      std::vector<torch::Tensor> norms;
      for (const auto& p : net.module().parameters())
        norms.push_back(p.grad().defined() ? p.grad().norm() : torch::zeros({}, p.options()));
      // One transfer for all of them: a per-tensor item() would sync a GPU once per layer.
      const torch::Tensor n = torch::stack(norms).to(torch::kCPU, torch::kDouble);
      if (sum_grad.size() != norms.size()) sum_grad.assign(norms.size(), 0.0);
      for (size_t k = 0; k < norms.size(); ++k) sum_grad[k] += n[int64_t(k)].item<double>();
    }
    if (c.clip > 0) torch::nn::utils::clip_grad_norm_(net.module().parameters(), c.clip);
    opt.step();
    if (!st.ema.empty()) {
      torch::NoGradGuard ng;
      const double n = double(st.ema_updates);
      const double d = std::min(c.ema_decay, (1 + n) / (10 + n));
      for (size_t k = 0; k < params.size(); ++k) st.ema[k].mul_(d).add_(params[k].detach(), 1 - d);
      ++st.ema_updates;
    }
    ++st.step;
    ++steps_here;
    if (st.step == die_at) std::_Exit(3);
    if (st.step == hang_at) {  // silent for 2 x timeout + 2 s, then gone (no stray process)
      std::this_thread::sleep_for(std::chrono::duration<double>(2 * dopt.timeout_s + 2));
      std::_Exit(4);
    }
    WindowScores ws;  // this batch (progress bar); train_ws: since the last log line
    for (const auto& m : counts) {
      ws.add(m);
      train_ws.add(m);
    }
    ema_loss = ema_loss < 0 ? loss : 0.95 * ema_loss + 0.05 * loss;
    if (ws.windows()) ema_iou = ema_iou < 0 ? ws.mean_iou() : 0.95 * ema_iou + 0.05 * ws.mean_iou();
    sum_loss += loss;
    sum_bce += terms[1];
    sum_spike += terms[2];
    sum_soft_iou += terms[3];
    sum_act += terms[4];
    sum_distill += terms[5];
    sum_distill_floor += terms[6];
    sum_distill_const += terms[7];
    sum_attention += terms[8];
    sum_feature += terms[9];
    sum_offevent += terms[10];
    sum_sope += terms[11];
    for (size_t k = 0; k < sum_rates.size(); ++k) sum_rates[k] += terms[kTerms + k];
    ++in_sum;
    st.wall_seconds =
        wall_before +
        std::chrono::duration<double>(std::chrono::steady_clock::now() - seg_start).count();
    char status[160];
    std::snprintf(status, sizeof status, "step %lld loss %.4f IoU %.1f%%", (long long)st.step,
                  ema_loss, 100 * std::max(0.0, ema_iou));
    bar.set_status(status);
    bar.update(uint64_t(st.step) * uint64_t(c.batch));
    if (st.step % c.log_every == 0 || st.step == c.steps) {
      std::vector<double> r = sum_rates, g = sum_grad;
      for (double& v : r) v /= in_sum;
      nlohmann::json grads = nlohmann::json::array();
      for (double v : g) grads.push_back(v / in_sum);
      nlohmann::json line = {
          {"kind", "train"},
          {"step", st.step},
          {"loss", sum_loss / in_sum},
          {"bce", sum_bce / in_sum},
          {"spike", sum_spike / in_sum},
          {"soft_iou_loss", sum_soft_iou / in_sum},
          {"activity", sum_act / in_sum},
          {"iou", 100 * train_ws.mean_iou()},
          {"detection_rate", 100 * train_ws.detection_rate()},
          {"lr", lr},
          {"rates", rates_json(r)},
          {"grad_norms", grads},
          {"samples_per_s",
           double(in_sum * c.batch) / std::max(1e-9, st.wall_seconds - res.wall_seconds)},
          {"wall_s", st.wall_seconds}};
      if (world > 1) line["comm_ms"] = std::round(1e4 * sum_comm / in_sum) / 10;
      if (c.uses_teacher()) {
        line["distill"] = sum_distill / in_sum;
        line["distill_floor"] = sum_distill_floor / in_sum;
        line["distill_const"] = sum_distill_const / in_sum;
      }
      if (c.attention_weight > 0) line["attention"] = sum_attention / in_sum;
      if (c.feature_weight > 0) line["feature"] = sum_feature / in_sum;
      if (c.offevent_weight > 0) line["offevent"] = sum_offevent / in_sum;
      if (net.snn) line["synops_per_event"] = std::round(10 * sum_sope / in_sum) / 10;
      log_line(line);
      res.wall_seconds = st.wall_seconds;
      sum_loss = sum_bce = sum_spike = sum_soft_iou = sum_act = sum_distill = sum_comm = 0;
      sum_distill_floor = sum_distill_const = sum_attention = sum_feature = sum_offevent = 0;
      sum_sope = 0;
      std::fill(sum_rates.begin(), sum_rates.end(), 0.0);
      std::fill(sum_grad.begin(), sum_grad.end(), 0.0);
      in_sum = 0;
      train_ws = WindowScores();
    }
    if (has_val && (st.step % c.val_every == 0 || st.step == c.steps)) {
      if (root)
        with_average([&] {
          nlohmann::json v = validate();
          validate_full(v);
          log_line(v);
          if (val_score(v) > st.best_val_iou) {
            st.best_val_iou = val_score(v);
            st.best_step = st.step;
            save_model_file((dir / "best.safetensors").string());
          }
          if (c.keep_val_models)
            save_model_file(
                (dir / ("val-step" + std::to_string(st.step) + ".safetensors")).string());
          curves.write((dir / "curves.svg").string());
          if (ro.progress) {
            const std::string whole =
                full_val ? ", whole sensor " + percent(v["full_iou"].get<double>()) +
                               " %, event precision " +
                               percent(v["full_event_precision"].get<double>()) + " % (base " +
                               percent(v["full_event_base_rate"].get<double>()) + " %)"
                         : "";
            const std::string still = static_val ? ", static scenes " +
                                                       percent(v["static_moving"].get<double>()) +
                                                       " % called moving"
                                                 : "";
            std::fprintf(
                stderr, "%sval step %lld: IoU %s %%%s%s (best %s at %lld), detection %s %%\n",
                isatty(2) ? "\n" : "", (long long)st.step, percent(v["iou"].get<double>()).c_str(),
                whole.c_str(), still.c_str(), percent(st.best_val_iou).c_str(),
                (long long)st.best_step, percent(v["detection_rate"].get<double>()).c_str());
          }
        });
      const std::string key = "val/" + std::to_string(st.step);
      dist.root_done(key);
      dist.wait_for_root(key);
    }
    if (root && (st.step % c.checkpoint_every == 0 || st.step == c.steps)) checkpoint();
  }
  bar.finish();
  if (root) {
    if (st.step % c.checkpoint_every != 0 && st.step != c.steps) checkpoint();  // interrupted
    curves.write((dir / "curves.svg").string());
  }
  const bool finished = st.step >= c.steps;
  log_line({{"kind", "run"},
            {"step", st.step},
            {"event", finished  ? "done"
                      : time_up ? "time_limit"
                                : "interrupted"},
            {"wall_s", st.wall_seconds}});
  res.steps = st.step;
  res.time_limit_reached = !finished && time_up;
  res.best_val_iou = st.best_val_iou;
  res.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return res;
}

}  // namespace

TrainResult run_training(const TrainConfig& c, const TrainRunOptions& ro) {
  std::unique_ptr<Distributed> dist;
  try {
    return run_training_impl(c, ro, dist);
  } catch (const std::exception& e) {
    if (dist) dist->report_failure(e.what());  // the other ranks' messages name this one
    throw;
  }
}

}  // namespace spikems::train
