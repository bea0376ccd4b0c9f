// SpikeMS network (padded geometry, FIR kernels as the authors') forward and forward+backward
// per sample on the CPU, against the same network written naively with per-step LibTorch
// operations (psp as a sum of shifted copies, spike loop with per-step tensor ops + autograd,
// conv called once per time step). Run: build-train/bench_train (figures: docs/performance.md).
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>

#include "core/model/model_file.h"
#include "train/loss/spikems_loss.h"
#include "train/loss/synops_loss.h"
#include "train/network/spikems_network.h"
#include "train/threads.h"

namespace {

using namespace spikems;
using namespace spikems::train;

ModelSpec random_model() {
  ModelSpec s = spikems_architecture(true);
  torch::manual_seed(0);
  for (auto& l : s.layers) {
    torch::Tensor w = torch::randn({l.weight_count()}) * 0.5;
    for (size_t i = 0; i < l.weight.size(); ++i) l.weight[i] = w[int64_t(i)].item<float>();
  }
  return s;
}

torch::Tensor input(int64_t T, int64_t H, int64_t W) {
  torch::manual_seed(1);
  return (torch::rand({T, 1, 2, H, W}) < 0.05).to(torch::kFloat);
}

// Straight-through surrogate for the naive network (SLAYER backward).
struct NaiveStep : torch::autograd::Function<NaiveStep> {
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, torch::Tensor u, double th) {
    ctx->save_for_backward({u});
    ctx->saved_data["th"] = th;
    return (u >= th).to(u.dtype());
  }
  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list g) {
    auto u = ctx->get_saved_variables()[0];
    double th = ctx->saved_data["th"].toDouble();
    return {g[0] * (0.2 / th) * torch::exp(-torch::abs(u - th) / (0.3 * th)), {}};
  }
};

torch::Tensor naive_forward(const ModelSpec& s, const std::vector<torch::Tensor>& w,
                            torch::Tensor x) {
  const int64_t T = x.size(0);
  for (size_t k = 0; k < s.layers.size(); ++k) {
    const auto& l = s.layers[k];
    std::vector<torch::Tensor> us;
    for (int64_t t = 0; t < T; ++t) {  // psp and conv per time step
      torch::Tensor a = torch::zeros_like(x[0]);
      for (int64_t i = 1; i < int64_t(l.srm_kernel.size()) && i <= t; ++i)
        a = a + double(l.srm_kernel[size_t(i)]) * x[t - i];
      us.push_back(
          l.kind == LayerKind::Conv
              ? torch::conv2d(a, w[k], {}, l.stride, l.padding)
              : torch::conv_transpose2d(a, w[k], {}, l.stride, l.padding, l.output_padding));
    }
    std::vector<torch::Tensor> ss;
    for (int64_t t = 0; t < T; ++t) {  // spike loop with the refractory of earlier spikes
      torch::Tensor u = us[size_t(t)];
      for (int64_t j = 1; j < int64_t(l.ref_kernel.size()) && j <= t; ++j)
        u = u + double(l.ref_kernel[size_t(j)]) * ss[size_t(t - j)].detach();
      ss.push_back(NaiveStep::apply(u, double(l.neuron.theta)));
    }
    x = torch::stack(ss, 0);
  }
  return x;
}

long peak_rss_mb() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  return r.ru_maxrss / 1024;
}

void run(benchmark::State& st, bool naive, bool backward) {
  set_torch_threads(2);
  const int64_t T = st.range(0), H = st.range(1), W = st.range(2);
  ModelSpec spec = random_model();
  SpikeMSNetwork net(spec);
  std::vector<torch::Tensor> w;
  for (size_t k = 0; k < net->size(); ++k) w.push_back(net->layer(k)->weight);
  torch::Tensor x = input(T, H, W);
  torch::Tensor mask = torch::zeros({1, H, W});
  double spikes = 0, seconds = 0;
  for (auto _ : st) {
    auto t0 = std::chrono::steady_clock::now();
    if (!backward) {
      torch::NoGradGuard ng;
      torch::Tensor y = naive ? naive_forward(spec, w, x) : net->forward(x);
      spikes = y.sum().item<double>();
    } else {
      torch::Tensor y = naive ? naive_forward(spec, w, x) : net->forward(x);
      y = align_to_input(y, H, W);
      auto l = spikems_loss(y, x, mask, LossOptions{}).total;
      l.backward();
      spikes = y.sum().item<double>();
    }
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  // Wall time per sample (one window of T steps) and per time step.
  st.counters["ms_per_sample"] = 1e3 * seconds / double(st.iterations());
  st.counters["ms_per_step"] = 1e3 * seconds / double(st.iterations()) / double(T);
  st.counters["out_spikes"] = spikes;
  st.counters["peak_rss_MB"] = double(peak_rss_mb());
}

void BM_Forward(benchmark::State& s) {
  run(s, false, false);
}
void BM_ForwardNaive(benchmark::State& s) {
  run(s, true, false);
}
void BM_ForwardBackward(benchmark::State& s) {
  run(s, false, true);
}
void BM_ForwardBackwardNaive(benchmark::State& s) {
  run(s, true, true);
}

// The trainer's SynOps count (loss.synops_weight; logged every step whatever the weight) on the
// spikes of one forward pass, against that forward pass in the same process: the count's share
// of a step (the backward pass, not timed here, makes the step longer still).
void BM_SynopsCountVsForward(benchmark::State& st) {
  set_torch_threads(2);
  const int64_t T = st.range(0), H = st.range(1), W = st.range(2);
  const ModelSpec spec = random_model();
  SpikeMSNetwork net(spec);
  const SynopsCounter counter(spec);
  const torch::Tensor x = input(T, H, W);
  torch::NoGradGuard ng;
  double forward_s = 0, count_s = 0, synops = 0;
  for (auto _ : st) {
    auto t0 = std::chrono::steady_clock::now();
    const std::vector<torch::Tensor> layers = net->forward_all(x);
    auto t1 = std::chrono::steady_clock::now();
    synops = counter.per_sample(x, layers, spec.time_step_ms).sum().item<double>();
    auto t2 = std::chrono::steady_clock::now();
    forward_s += std::chrono::duration<double>(t1 - t0).count();
    count_s += std::chrono::duration<double>(t2 - t1).count();
  }
  st.counters["forward_ms"] = 1e3 * forward_s / double(st.iterations());
  st.counters["count_ms"] = 1e3 * count_s / double(st.iterations());
  st.counters["count_over_forward"] = count_s / forward_s;
  st.counters["synops"] = synops;
}
BENCHMARK(BM_SynopsCountVsForward)
    ->Args({10, 260, 346})
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond);

#define SIZES(fn, it_small, it_big)                                                         \
  BENCHMARK(fn)->Args({10, 128, 128})->Iterations(it_small)->Unit(benchmark::kMillisecond); \
  BENCHMARK(fn)->Args({40, 128, 128})->Iterations(it_small)->Unit(benchmark::kMillisecond); \
  BENCHMARK(fn)->Args({10, 260, 346})->Iterations(it_big)->Unit(benchmark::kMillisecond);   \
  BENCHMARK(fn)->Args({40, 260, 346})->Iterations(it_big)->Unit(benchmark::kMillisecond)

SIZES(BM_Forward, 3, 1);
SIZES(BM_ForwardNaive, 3, 1);
SIZES(BM_ForwardBackward, 2, 1);
SIZES(BM_ForwardBackwardNaive, 2, 1);

}  // namespace

BENCHMARK_MAIN();
