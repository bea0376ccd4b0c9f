// The fused CUDA neuron kernels against the CPU kernels (which test_neuron.cpp checks against
// direct formulas): psp filter forward and adjoint, spike loop, both backward modes, every
// kernel form, float and double; then a whole SpikeMS network step on the GPU against the CPU.
// These skip where there is no CUDA device or the build has no CUDA kernels; the switch between
// fused kernels and tensor ops is also checked on the CPU.
#include <gtest/gtest.h>

#include "core/util/error.h"
#include "train/loss/spikems_loss.h"
#include "train/network/spikems_network.h"
#include "train/neuron/kernel_choice.h"
#include "train/neuron/neuron_cuda_torch.h"
#include "train/neuron/psp.h"
#include "train/neuron/spike.h"
#include "train/trainer/weight_init.h"

namespace spikems::train {
namespace {

bool have_cuda() {
  return cuda_kernels_built() && torch::cuda::is_available();
}

#define SKIP_WITHOUT_CUDA()                                                                   \
  if (!have_cuda())                                                                           \
  GTEST_SKIP() << (cuda_kernels_built() ? "no CUDA device here"                               \
                                        : "built without the CUDA kernels (SPIKEMS_CUDA=OFF " \
                                          "or a LibTorch without CUDA)")

std::vector<TemporalKernel> kernels() {
  return {TemporalKernel::fir({0.f, 0.8f, 1.f, 0.5f, 0.25f}),
          TemporalKernel::fir(sample_srm_kernel(5.0, 1.0)), TemporalKernel::alpha(2.0, 1.0, 1.0),
          TemporalKernel::delayed_exp(3.0, 1.0, -0.48), TemporalKernel::alpha(1.5, 0.5, -0.44)};
}

double max_diff(const torch::Tensor& a, const torch::Tensor& b) {
  return (a.cpu() - b.cpu()).abs().max().item<double>();
}

TEST(NeuronCuda, FilterMatchesTheCpuKernel) {
  SKIP_WITHOUT_CUDA();
  for (auto dt : {torch::kFloat, torch::kDouble})
    for (const auto& k : kernels())
      for (bool reverse : {false, true}) {
        torch::manual_seed(3);
        torch::Tensor x = (torch::rand({37, 1000}, torch::kDouble) < 0.2).to(dt) * 2.5;
        torch::Tensor cpu = apply_temporal_kernel_cpu(x, k, 1.7, reverse);
        torch::Tensor gpu = cuda_temporal_filter(x.cuda(), k, 1.7, reverse);
        ASSERT_TRUE(gpu.is_cuda());
        // Same rounded operations in the same order: equal to the last bit.
        EXPECT_EQ(max_diff(cpu, gpu), 0.0) << "form " << int(k.form) << " reverse " << reverse;
      }
}

TEST(NeuronCuda, SpikeForwardAndBackwardMatchTheCpuKernel) {
  SKIP_WITHOUT_CUDA();
  for (auto dt : {torch::kFloat, torch::kDouble})
    for (auto g : {SpikeGradient::Slayer, SpikeGradient::Exact})
      for (const auto& k :
           {TemporalKernel::fir(sample_refractory_kernel(NeuronParams{0.24f, 4, 3}, 1.0)),
            TemporalKernel::delayed_exp(3.0, 1.0, -0.48), TemporalKernel::alpha(1.0, 1.0, -0.48)}) {
        SpikeParams p;
        p.theta = 0.24f;
        p.refractory = k;
        p.gradient = g;
        p.ts = 1.0;
        torch::manual_seed(7);
        torch::Tensor u = (torch::rand({40, 3000}, torch::kDouble) * 0.6).to(dt);
        torch::Tensor gs = torch::randn({40, 3000}, torch::kDouble).to(dt);
        auto [s_cpu, ur_cpu] = spike_forward(u, p, true);
        auto [s_gpu, ur_gpu] = cuda_spike_forward(u.cuda(), p);
        EXPECT_EQ(max_diff(s_cpu, s_gpu), 0.0) << "spikes, form " << int(k.form);
        EXPECT_EQ(max_diff(ur_cpu, ur_gpu), 0.0) << "u~, form " << int(k.form);
        EXPECT_GT(s_cpu.sum().item<double>(), 100);  // the case spikes, refractory included
        torch::Tensor b_cpu = spike_backward(gs, ur_cpu, p, true);
        torch::Tensor b_gpu = cuda_spike_backward(gs.cuda(), ur_gpu, p);
        // exp() of the GPU and of glibc may differ in the last bits.
        const double tol = dt == torch::kFloat ? 1e-5 : 1e-12;
        EXPECT_LT(max_diff(b_cpu, b_gpu), tol * (1 + b_cpu.abs().max().item<double>()))
            << "gradient " << int(g) << " form " << int(k.form);
      }
}

TEST(NeuronCuda, NetworkStepOnTheGpuMatchesTheCpu) {
  SKIP_WITHOUT_CUDA();
  ModelSpec spec = spikems_architecture(true);
  torch::manual_seed(0);
  for (auto& l : spec.layers) {
    torch::Tensor w = torch::randn({l.weight_count()}) * 0.5;
    l.weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
  }
  torch::Tensor x = (torch::rand({20, 2, 2, 64, 64}) < 0.05).to(torch::kFloat);
  torch::Tensor mask = (torch::rand({2, 64, 64}) < 0.3).to(torch::kFloat);
  auto run = [&](torch::Device d, NeuronKernels k) {
    set_neuron_kernels(k);
    SpikeMSNetwork net(spec);
    net->to(d);
    torch::Tensor y = align_to_input(net->forward(x.to(d)), 64, 64);
    torch::Tensor loss = spikems_loss(y, x.to(d), mask.to(d), LossOptions{}).total;
    loss.backward();
    std::vector<torch::Tensor> grads;
    for (size_t i = 0; i < net->size(); ++i) grads.push_back(net->layer(i)->weight.grad().cpu());
    set_neuron_kernels(NeuronKernels::Fused);
    return std::tuple{y.cpu(), loss.item<double>(), grads};
  };
  auto [y_cpu, l_cpu, g_cpu] = run(torch::kCPU, NeuronKernels::Fused);
  auto [y_gpu, l_gpu, g_gpu] = run(torch::kCUDA, NeuronKernels::Fused);
  auto [y_ops, l_ops, g_ops] = run(torch::kCUDA, NeuronKernels::Ops);
  ASSERT_GT(y_cpu.sum().item<double>(), 0) << "the case must spike";
  // cuDNN's convolutions sum in another order than the CPU's, so a potential within rounding of
  // the threshold can flip a spike: compare spike counts and the loss to a small fraction.
  const double n = y_cpu.sum().item<double>();
  EXPECT_LT(std::abs(y_gpu.sum().item<double>() - n), 0.01 * n);
  EXPECT_LT(std::abs(y_ops.sum().item<double>() - n), 0.01 * n);
  EXPECT_NEAR(l_gpu, l_cpu, 1e-3 * std::abs(l_cpu));
  EXPECT_NEAR(l_ops, l_cpu, 1e-3 * std::abs(l_cpu));
  for (size_t i = 0; i < g_cpu.size(); ++i) {
    const double scale = g_cpu[i].abs().max().item<double>() + 1e-12;
    EXPECT_LT(max_diff(g_cpu[i], g_gpu[i]) / scale, 0.05) << "layer " << i;
    EXPECT_LT(max_diff(g_ops[i], g_gpu[i]) / scale, 0.05) << "layer " << i;
  }
}

// The trainer scales the initial weights on the training device (trainer.cpp): on the GPU the
// same random draws and bisection must reach the CPU's firing rates and nearly its weights.
TEST(NeuronCuda, DataInitOnTheGpuMatchesTheCpu) {
  SKIP_WITHOUT_CUDA();
  torch::manual_seed(3);
  const torch::Tensor x = (torch::rand({20, 2, 2, 64, 64}) < 0.05).to(torch::kFloat);
  const std::vector<double> target{0.03, 0.03, 0.03, 0.03, 0.03, 0.02};
  auto run = [&](torch::Device d) {
    SpikeMSNetwork net(spikems_architecture(true));
    net->to(d);
    auto rates = init_weights_from_data(net, x.to(d), target, 1.0, 7);
    std::vector<torch::Tensor> w;
    for (size_t i = 0; i < net->size(); ++i) w.push_back(net->layer(i)->weight.detach().cpu());
    return std::pair{rates, w};
  };
  auto [r_cpu, w_cpu] = run(torch::kCPU);
  auto [r_gpu, w_gpu] = run(torch::kCUDA);
  for (size_t i = 0; i < r_cpu.size(); ++i) {
    EXPECT_NEAR(r_cpu[i], target[i], 0.3 * target[i]) << "layer " << i;
    EXPECT_NEAR(r_gpu[i], r_cpu[i], 0.1 * r_cpu[i]) << "layer " << i;
    // Rounding flips a bisection step only where the rate is at the target: the gain moves little.
    EXPECT_LT(max_diff(w_gpu[i], w_cpu[i]) / (w_cpu[i].abs().max().item<double>() + 1e-12), 0.1)
        << "layer " << i;
  }
}

TEST(NeuronKernelChoice, OpsAndFusedAgreeOnTheCpu) {
  SpikeParams p;
  p.theta = 0.3f;
  p.refractory = TemporalKernel::delayed_exp(3.0, 1.0, -0.6);
  p.gradient = SpikeGradient::Exact;
  const TemporalKernel eps = TemporalKernel::alpha(2.0, 1.0, 1.0);
  torch::manual_seed(2);
  torch::Tensor x0 = (torch::rand({30, 4, 50}, torch::kDouble) < 0.3).to(torch::kDouble);
  auto run = [&](NeuronKernels k) {
    set_neuron_kernels(k);
    torch::Tensor x = x0.clone().requires_grad_(true);
    torch::Tensor s = spike(psp(x, eps, 1.0), p);
    torch::Tensor g = torch::autograd::grad({(s * torch::arange(50, x.options())).sum()}, {x})[0];
    set_neuron_kernels(NeuronKernels::Fused);
    return std::pair{s.detach(), g};
  };
  auto [s1, g1] = run(NeuronKernels::Fused);
  auto [s2, g2] = run(NeuronKernels::Ops);
  EXPECT_GT(s1.sum().item<double>(), 10);
  EXPECT_EQ(max_diff(s1, s2), 0.0);
  EXPECT_LT(max_diff(g1, g2), 1e-10 * (1 + g1.abs().max().item<double>()));
  EXPECT_GT(g1.abs().max().item<double>(), 0);
}

TEST(NeuronKernelChoice, ParsesItsNames) {
  EXPECT_EQ(parse_neuron_kernels("fused"), NeuronKernels::Fused);
  EXPECT_EQ(parse_neuron_kernels("ops"), NeuronKernels::Ops);
  EXPECT_THROW(parse_neuron_kernels("sparse"), Error);
  if (!cuda_kernels_built()) {
    EXPECT_THROW(
        cuda_temporal_filter(torch::zeros({2, 2}), TemporalKernel::alpha(1, 1, 1), 1, false),
        Error);
    EXPECT_EQ(cuda_device_name(), "");
  }
}

}  // namespace
}  // namespace spikems::train
