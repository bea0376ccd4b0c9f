// One training step of the SpikeMS network on a CUDA GPU (forward, loss, backward, Adam step;
// batch 8) with the fused neuron kernels against the same network made of LibTorch operations
// only (NeuronKernels::Ops: per-step tensor ops for the psp filter and the spike loop), in one
// process: 128x128 crops with T = 40 (the default training sample: 30 ms warm-up + 10 ms
// window) and the whole 346x260 sensor with T = 10. Reports ms per step, samples/s and the peak
// GPU memory of the step (CUDA caching allocator). Weights: the shipped `default` model, so
// the firing rates are those of a trained network; input: 2 % of pixels spike per step.
// Skips where the build has no CUDA kernels or no GPU is present.
// Run: build/bench_train_gpu  (figures: docs/performance.md, "Training on a GPU").
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>

#include "core/model/model_file.h"
#include "train/loss/spikems_loss.h"
#include "train/network/spikems_network.h"
#include "train/neuron/kernel_choice.h"
#include "train/neuron/neuron_cuda_torch.h"

#ifdef SPIKEMS_WITH_CUDA
#include <c10/cuda/CUDACachingAllocator.h>
#endif

namespace {

using namespace spikems;
using namespace spikems::train;

[[maybe_unused]] ModelSpec model() {
  const std::string shipped =
      std::string(SPIKEMS_SOURCE_DIR) + "/models/spikems-default.safetensors";
  if (std::filesystem::exists(shipped)) return load_model(shipped);
  ModelSpec s = spikems_architecture(true);  // random weights where the model file is absent
  torch::manual_seed(0);
  for (auto& l : s.layers) {
    torch::Tensor w = torch::randn({l.weight_count()}) * 0.5;
    l.weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
  }
  return s;
}

void train_step(benchmark::State& st, NeuronKernels kernels) {
  if (!cuda_kernels_built() || !torch::cuda::is_available()) {
    st.SkipWithError(cuda_kernels_built() ? "no CUDA device" : "built without CUDA kernels");
    return;
  }
#ifdef SPIKEMS_WITH_CUDA
  const int64_t T = st.range(0), H = st.range(1), W = st.range(2), B = 8;
  const torch::Device dev(torch::kCUDA);
  set_neuron_kernels(kernels);
  SpikeMSNetwork net(model());
  net->to(dev);
  torch::optim::Adam opt(net->parameters(), torch::optim::AdamOptions(1e-3).amsgrad(true));
  torch::manual_seed(1);
  torch::Tensor x = (torch::rand({T, B, 2, H, W}, dev) < 0.02).to(torch::kFloat);
  torch::Tensor mask = (torch::rand({B, H, W}, dev) < 0.2).to(torch::kFloat);
  double seconds = 0, spikes = 0;
  auto step = [&] {
    opt.zero_grad();
    torch::Tensor y = align_to_input(net->forward(x), H, W);
    spikems_loss(y, x, mask, LossOptions{}).total.backward();
    opt.step();
    spikes = y.sum().item<double>();  // synchronises
  };
  step();  // warm-up: cuDNN algorithm choice, allocator pools
  torch::cuda::synchronize();
  c10::cuda::CUDACachingAllocator::resetPeakStats(0);
  for (auto _ : st) {
    auto t0 = std::chrono::steady_clock::now();
    step();
    torch::cuda::synchronize();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  const auto stats = c10::cuda::CUDACachingAllocator::getDeviceStats(0);
  const double peak = double(stats.allocated_bytes[0].peak);  // [0]: all pools together
  set_neuron_kernels(NeuronKernels::Fused);
  st.counters["ms_per_step"] = 1e3 * seconds / double(st.iterations());
  st.counters["samples_per_s"] = double(B) * double(st.iterations()) / seconds;
  st.counters["peak_GPU_MiB"] = peak / (1024.0 * 1024.0);
  st.counters["out_spikes"] = spikes;
  st.SetLabel(cuda_device_name());
#endif
}

void BM_TrainStepFused(benchmark::State& s) {
  train_step(s, NeuronKernels::Fused);
}
void BM_TrainStepOps(benchmark::State& s) {
  train_step(s, NeuronKernels::Ops);
}

#define SIZES(fn)                                                                     \
  BENCHMARK(fn)->Args({40, 128, 128})->Iterations(20)->Unit(benchmark::kMillisecond); \
  BENCHMARK(fn)->Args({10, 260, 346})->Iterations(20)->Unit(benchmark::kMillisecond)

SIZES(BM_TrainStepFused);
SIZES(BM_TrainStepOps);

}  // namespace

BENCHMARK_MAIN();
