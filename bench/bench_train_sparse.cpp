// Sparse against dense synapse kernels (train/synapse/sparse_conv.h) in one process, on the
// same batch: one full training step (forward, the trainer's loss, backward, gradient clip,
// Adam) of the SpikeMS network at 128x128, batch 8, T = 40 steps (10 ms window + the default
// config's 30 ms warm-up), with the shipped model's weights (its real firing rates) and with
// weights initialised on the same batch to a range of firing rates. Prints each layer's input
// density, the step times of the dense, sparse and auto paths and their ratios. Then (--layers) the
// crossover density of each layer alone (psp + synapse, forward + backward), from which
// `run.kernels = "auto"` takes its rule.
//
// Run from the repository root (figures: docs/performance.md):
//   build/bench_train_sparse [--data data/mod2-train] [--model models/spikems-default.safetensors]
//                            [--reps 3] [--threads 0] [--layers]
// Without a dataset folder the input is random spikes at 2 % density (said in the output).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/dataset/batch_loader.h"
#include "core/dataset/sequence.h"
#include "core/model/model_file.h"
#include "core/util/host_memory.h"
#include "train/loss/spikems_loss.h"
#include "train/network/spikems_network.h"
#include "train/neuron/psp.h"
#include "train/synapse/sparse_conv.h"
#include "train/threads.h"
#include "train/trainer/batch_tensors.h"
#include "train/trainer/train_config.h"
#include "train/trainer/weight_init.h"

namespace {

using namespace spikems;
using namespace spikems::train;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string config = "configs/train/default.toml", model = "models/spikems-default.safetensors",
              data = "data/mod2-train";
  int reps = 3, threads = 0, crop = 128, batch = 8;
  std::vector<double> rates = {0.01, 0.03, 0.06, 0.12, 0.25};
  bool layers = false, flush_denormal = false, system_malloc = false;
};

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// User + system CPU seconds of the process so far (less sensitive than wall time to other
// programs sharing the cores).
double cpu_seconds() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  return double(r.ru_utime.tv_sec + r.ru_stime.tv_sec) +
         1e-6 * double(r.ru_utime.tv_usec + r.ru_stime.tv_usec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The trainer's step (trainer.cpp forward_loss with the default config's loss terms).
double train_step(SpikeMSNetwork& net, torch::optim::Adam& opt, const BatchTensors& bt,
                  const TrainConfig& c, double ts) {
  const int64_t T = bt.input.size(0), H = bt.input.size(3), W = bt.input.size(4);
  const int64_t w0 = bt.warmup_steps, tw = T - w0;
  LossOptions lo;
  lo.alpha = c.alpha;
  lo.beta = c.beta;
  lo.ts = ts;
  lo.all_pixels = c.all_pixels;
  lo.balanced = c.balanced;
  opt.zero_grad();
  std::vector<torch::Tensor> layers = net->forward_all(bt.input);
  torch::Tensor out = align_to_input(layers.back(), H, W).narrow(0, w0, tw);
  torch::Tensor in = bt.input.narrow(0, w0, tw), fg = bt.fg.narrow(0, w0, tw);
  torch::Tensor loss = bce_loss(out, in, fg, lo) + c.iou_weight * soft_iou_loss(out, in, fg, lo);
  for (auto& l : layers) loss = loss + c.activity_weight * l.narrow(0, w0, tw).mean() * ts;
  loss.backward();
  torch::nn::utils::clip_grad_norm_(net->parameters(), c.clip);
  opt.step();
  return loss.item<double>();
}

// Input density of every layer (the fraction of nonzero entries its synapse sees).
std::vector<double> layer_input_densities(const ModelSpec& spec, const torch::Tensor& x) {
  torch::NoGradGuard ng;
  SpikeMSNetwork net(spec);
  std::vector<double> d{nonzero_density(x)};
  auto all = net->forward_all(x);
  for (size_t k = 0; k + 1 < all.size(); ++k) d.push_back(nonzero_density(all[k]));
  d.push_back(nonzero_density(all.back()));  // the output's (not a synapse input)
  return d;
}

void compare_steps(const std::string& name, const ModelSpec& spec, const BatchTensors& bt,
                   const TrainConfig& c, double ts, int reps) {
  const std::vector<double> d = layer_input_densities(spec, bt.input);
  std::printf("%-22s", name.c_str());
  for (double v : d) std::printf(" %6.2f", 100 * v);
  std::fflush(stdout);
  double t[3] = {0, 0, 0}, cpu[3] = {0, 0, 0}, loss[3] = {0, 0, 0};
  const KernelPath paths[3] = {KernelPath::Dense, KernelPath::Sparse, KernelPath::Auto};
  for (int path = 0; path < 3; ++path) {
    SpikeMSNetwork net(spec);
    net->set_kernels(paths[path]);
    torch::optim::Adam opt(net->parameters(), torch::optim::AdamOptions(c.lr).amsgrad(true));
    std::vector<double> times, cpus;
    for (int r = 0; r <= reps; ++r) {  // the first step warms the allocator up, not timed
      auto t0 = Clock::now();
      const double c0 = cpu_seconds();
      const double l = train_step(net, opt, bt, c, ts);
      if (r == 0) loss[path] = l;
      if (r > 0) times.push_back(seconds_since(t0));
      if (r > 0) cpus.push_back(cpu_seconds() - c0);
    }
    t[path] = median(times);
    cpu[path] = median(cpus);
  }
  std::printf(" | %8.0f %8.0f %6.2fx %8.0f %6.2fx | %8.0f %8.0f %6.2fx | %.3g\n", 1e3 * t[0],
              1e3 * t[1], t[0] / t[1], 1e3 * t[2], t[0] / t[2], 1e3 * cpu[0], 1e3 * cpu[1],
              cpu[0] / cpu[1], std::abs(loss[0] - loss[1]) / std::max(1e-30, std::abs(loss[0])));
}

// One layer alone (psp + synapse, forward + backward with the input needing a gradient except
// for layer 1) at a given input density: dense and sparse ms.
void layer_crossover(const ModelSpec& spec, int64_t T, int64_t B, int64_t H0, int reps) {
  std::printf("\nper layer, psp + synapse forward + backward, ms dense / sparse (ratio)\n");
  std::printf("%-8s", "density");
  for (size_t k = 0; k < spec.layers.size(); ++k) std::printf("   layer %zu             ", k + 1);
  std::printf("\n");
  const double ts = spec.time_step_ms;
  for (double dens : {0.01, 0.03, 0.1, 0.2, 0.3, 0.5}) {
    std::printf("%6.0f %% ", 100 * dens);
    int64_t h = H0;
    for (size_t k = 0; k < spec.layers.size(); ++k) {
      const LayerSpec& l = spec.layers[k];
      torch::manual_seed(int64_t(k));
      torch::Tensor x0 = (torch::rand({T, B, l.in_channels, h, h}) < dens).to(torch::kFloat) / ts;
      torch::Tensor w =
          torch::randn(l.kind == LayerKind::Conv
                           ? std::vector<int64_t>{l.out_channels, l.in_channels, 3, 3}
                           : std::vector<int64_t>{l.in_channels, l.out_channels, 3, 3})
              .requires_grad_(true);
      const TemporalKernel eps = TemporalKernel::srm(l, ts);
      const SynapseGeometry g = SynapseGeometry::of(l);
      double t[2];
      for (int path = 0; path < 2; ++path) {
        std::vector<double> times;
        for (int r = 0; r <= reps; ++r) {
          torch::Tensor x = x0.clone().requires_grad_(k > 0);
          auto t0 = Clock::now();
          torch::Tensor u = path == 0 ? synapse_forward(psp(x, eps, ts), w, g)
                                      : sparse_synapse_psp(x, w, g, eps, ts);
          u.sum().backward();
          if (r > 0) times.push_back(seconds_since(t0));
        }
        t[path] = median(times);
      }
      std::printf(" %7.1f %7.1f (%4.2fx)", 1e3 * t[0], 1e3 * t[1], t[0] / t[1]);
      std::fflush(stdout);
      h = l.kind == LayerKind::Conv ? h / 2 : h * 2;
    }
    std::printf("\n");
  }
}

int run(const Options& o) {
  // Subnormal floats (tiny gradients) are slow on x86; this makes them zero (both paths), set
  // before the thread pool starts so that its threads inherit the mode.
  if (o.flush_denormal) at::globalContext().setFlushDenormal(true);
  // As `spikems train` (core/util/host_memory.h): freed tensors stay in the process.
  if (!o.system_malloc) keep_freed_memory();
  const int threads = set_torch_threads(o.threads);
  TrainConfig c = load_train_config(o.config, {"sample.crop=" + std::to_string(o.crop)});
  const double ts = double(c.sample.step_us) / 1000.0;
  ModelSpec shipped = load_model(o.model);
  shipped.time_step_ms = ts;

  BatchTensors bt;
  std::string input_note;
  if (std::filesystem::is_directory(o.data)) {
    DatasetSource src;
    src.path = o.data;
    std::vector<LabelledSequence> seqs = load_sequences(src);
    std::vector<const LabelledSequence*> ptr;
    std::vector<double> weights;
    for (auto& s : seqs) {
      ptr.push_back(&s);
      weights.push_back(1.0 / double(seqs.size()));
    }
    Batch b = BatchLoader::make(ptr, weights, c.sample, o.batch, c.seed, 0);
    bt = to_tensors(b.samples, ts, torch::kCPU);
    input_note = "one batch of " + o.data + " (the default config's sampling)";
  } else {
    const int64_t T = int64_t((c.sample.window_us + c.sample.warmup_us) / c.sample.step_us);
    torch::manual_seed(1);
    bt.input = (torch::rand({T, o.batch, 2, o.crop, o.crop}) < 0.02).to(torch::kFloat) / ts;
    bt.fg = (torch::rand({T, o.batch, o.crop, o.crop}) < 0.01).to(torch::kFloat);
    bt.warmup_steps = int(c.sample.warmup_us / c.sample.step_us);
    input_note = "random spikes at 2 % (no folder " + o.data + ")";
  }
  std::printf("bench_train_sparse: %d threads; input [T=%lld, B=%lld, 2, %lld, %lld], %s\n",
              threads, (long long)bt.input.size(0), (long long)bt.input.size(1),
              (long long)bt.input.size(3), (long long)bt.input.size(4), input_note.c_str());
  std::printf(
      "training step (forward, loss, backward, clip, Adam): median of %d, wall ms and process "
      "CPU ms\n\n",
      o.reps);
  // auto: run.kernels = "auto" (each layer by its rule, sparse_conv.h), as `spikems train` runs.
  std::printf("%-22s %s | %8s %8s %7s %8s %7s | %8s %8s %7s | %s\n", "weights",
              "in%  L1     L2     L3     L4     L5     L6 out%", "dense", "sparse", "ratio", "auto",
              "ratio", "CPU dns", "CPU sps", "ratio", "loss rel diff");
  compare_steps("shipped model", shipped, bt, c, ts, o.reps);
  for (double rate : o.rates) {
    ModelSpec s = shipped;
    SpikeMSNetwork net(s);
    std::vector<double> rates(s.layers.size(), rate);
    init_weights_from_data(net, bt.input, rates, ts, 1);
    s = net->to_spec();
    s.time_step_ms = ts;
    char name[64];
    std::snprintf(name, sizeof name, "init at %.0f %% rate", 100 * rate);
    compare_steps(name, s, bt, c, ts, o.reps);
  }
  if (o.layers)
    layer_crossover(shipped, bt.input.size(0), bt.input.size(1), bt.input.size(3), o.reps);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_train_sparse: %s needs a value\n", a.c_str());
        std::exit(1);
      }
      return argv[++i];
    };
    auto number = [&](int lo) {
      const std::string v = value();
      char* end = nullptr;
      const long n = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || n < lo || n > 100000) {
        std::fprintf(stderr, "bench_train_sparse: %s: bad value '%s'\n", a.c_str(), v.c_str());
        std::exit(1);
      }
      return int(n);
    };
    if (a == "--help" || a == "-h") {
      std::printf(
          "bench_train_sparse [--data DIR] [--model FILE] [--config FILE] [--reps N] "
          "[--threads N] [--crop N] [--batch N] [--rates R,R,...|none] [--flush-denormal] "
          "[--layers] [--system-malloc]\n"
          "Times one training step with the dense and the sparse synapse kernels on the same "
          "batch (run from the repository root), with the shipped model and with weights set to "
          "each firing rate of --rates (default 0.01,0.03,0.06,0.12,0.25). --layers adds the "
          "per-layer crossover density. --system-malloc: glibc's default allocator settings "
          "(spikems train keeps freed memory; core/util/host_memory.h).\n");
      return 0;
    } else if (a == "--data") {
      o.data = value();
    } else if (a == "--model") {
      o.model = value();
    } else if (a == "--config") {
      o.config = value();
    } else if (a == "--reps") {
      o.reps = number(1);
    } else if (a == "--threads") {
      o.threads = number(0);
    } else if (a == "--crop") {
      o.crop = number(16);
    } else if (a == "--batch") {
      o.batch = number(1);
    } else if (a == "--rates") {  // comma-separated firing rates; "none": the shipped model only
      const std::string v = value();
      o.rates.clear();
      size_t p = 0;
      while (v != "none" && p <= v.size()) {
        const size_t e = std::min(v.find(',', p), v.size());
        char* end = nullptr;
        const std::string item = v.substr(p, e - p);
        const double r = std::strtod(item.c_str(), &end);
        if (item.empty() || *end != '\0' || !(r > 0 && r < 1)) {
          std::fprintf(stderr, "bench_train_sparse: --rates: bad rate '%s'\n", item.c_str());
          return 1;
        }
        o.rates.push_back(r);
        p = e + 1;
      }
    } else if (a == "--flush-denormal") {
      o.flush_denormal = true;
    } else if (a == "--system-malloc") {  // glibc's defaults, as before the trainer kept memory
      o.system_malloc = true;
    } else if (a == "--layers") {
      o.layers = true;
    } else {
      std::fprintf(stderr, "bench_train_sparse: unknown argument '%s' (see --help)\n", a.c_str());
      return 1;
    }
  }
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_train_sparse: %s\n", e.what());
    return 1;
  }
}
