// The sparse synapse path (train/synapse/sparse_conv.h) against the dense one (psp, then the
// LibTorch convolution): values and gradients on random sparse inputs, every layer geometry of
// the SpikeMS network (padded and the authors' unpadded), FIR and IIR, both backward modes, and
// a whole network forward + backward.
//
// Tolerances: the two paths add the same products in a different order, so in float they
// differ by rounding: |sparse - dense| <= 2e-5 * max|dense| (float has 6e-8 relative precision;
// sums run over up to ~600 terms). In double the bound is 1e-11; there no spike decision flips,
// so layer spikes and network outputs are compared exactly.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "common/test_paths.h"
#include "core/model/model_file.h"
#include "core/util/error.h"
#include "train/block/spiking_layer.h"
#include "train/loss/spikems_loss.h"
#include "train/network/spikems_network.h"
#include "train/neuron/psp.h"
#include "train/synapse/sparse_conv.h"
#include "train/trainer/train_config.h"
#include "train_test_util.h"

namespace spikems::train {
namespace {

using test::rel_err;

// Random spikes of the given density with value 1/ts (and a few double spikes, 2/ts, as a bin
// with two events gives), [T, B, C, H, W].
torch::Tensor random_spikes(std::vector<int64_t> shape, double density, double ts,
                            torch::ScalarType type) {
  torch::Tensor u = torch::rand(shape, torch::kDouble);
  torch::Tensor s = (u < density).to(type) / ts;
  s = s + (u < density * 0.1).to(type) / ts;
  return s;
}

struct Case {
  LayerSpec layer;
  int64_t h, w;
};

// The six layers of the network, each with the input size it has for a 32x24 input.
std::vector<Case> network_layers(bool padded, Discretisation d) {
  ModelSpec spec = spikems_architecture(padded, d);
  std::vector<Case> cases;
  int64_t h = 32, w = 24;
  for (const auto& l : spec.layers) {
    cases.push_back({l, h, w});
    auto out = [&](int64_t n) {
      return l.kind == LayerKind::Conv
                 ? (n + 2 * l.padding - l.kernel) / l.stride + 1
                 : (n - 1) * l.stride - 2 * l.padding + l.kernel + l.output_padding;
    };
    h = out(h);
    w = out(w);
  }
  return cases;
}

// Synapse level: u = W (*) (eps * s) both ways, and the gradients of sum(u * G) w.r.t. s and W.
void compare_synapse(const Case& c, double density, torch::ScalarType type, double tol) {
  const double ts = 1.0;
  const LayerSpec& l = c.layer;
  const int64_t T = 14, B = 2;
  SCOPED_TRACE(std::string(l.kind == LayerKind::Conv ? "conv " : "conv_transpose ") +
               std::to_string(l.in_channels) + "->" + std::to_string(l.out_channels) + " pad " +
               std::to_string(l.padding) + " density " + std::to_string(density));
  torch::Tensor s0 = random_spikes({T, B, l.in_channels, c.h, c.w}, density, ts, type);
  torch::Tensor w0 = torch::randn(l.kind == LayerKind::Conv
                                      ? std::vector<int64_t>{l.out_channels, l.in_channels, 3, 3}
                                      : std::vector<int64_t>{l.in_channels, l.out_channels, 3, 3},
                                  torch::TensorOptions().dtype(type));
  const TemporalKernel eps = TemporalKernel::srm(l, ts);
  const SynapseGeometry g = SynapseGeometry::of(l);

  auto run = [&](bool sparse) {
    torch::Tensor s = s0.clone().requires_grad_(true), w = w0.clone().requires_grad_(true);
    torch::Tensor u =
        sparse ? sparse_synapse_psp(s, w, g, eps, ts) : synapse_forward(psp(s, eps, ts), w, g);
    torch::manual_seed(7);
    torch::Tensor G = torch::randn(u.sizes(), u.options().requires_grad(false));
    (u * G).sum().backward();
    return std::array<torch::Tensor, 3>{u.detach(), s.grad(), w.grad()};
  };
  auto dense = run(false), sparse = run(true);
  ASSERT_EQ(sparse[0].sizes(), dense[0].sizes());
  EXPECT_GT(dense[0].abs().max().item<double>(), 0.0);
  EXPECT_LE(rel_err(sparse[0], dense[0]), tol) << "forward";
  EXPECT_LE(rel_err(sparse[1], dense[1]), tol) << "input gradient";
  EXPECT_LE(rel_err(sparse[2], dense[2]), tol) << "weight gradient";
}

TEST(SparseKernels, SynapseMatchesDenseOnEveryLayerGeometryFloat) {
  torch::manual_seed(1);
  for (bool padded : {true, false})
    for (Discretisation d : {Discretisation::FIR, Discretisation::IIR})
      for (const Case& c : network_layers(padded, d))
        for (double density : {0.01, 0.05, 0.3}) compare_synapse(c, density, torch::kFloat, 2e-5);
}

TEST(SparseKernels, SynapseMatchesDenseOnEveryLayerGeometryDouble) {
  torch::manual_seed(2);
  for (bool padded : {true, false})
    for (Discretisation d : {Discretisation::FIR, Discretisation::IIR})
      for (const Case& c : network_layers(padded, d))
        compare_synapse(c, 0.05, torch::kDouble, 1e-11);
}

// SameStep neurons (model.srm_onset): the sparse path's own recursion of the lead kernel.
TEST(SparseKernels, SynapseMatchesDenseWithSameStepOnset) {
  torch::manual_seed(3);
  for (Case c : network_layers(true, Discretisation::IIR)) {
    c.layer.neuron.srm_onset = SrmOnset::SameStep;
    ASSERT_EQ(TemporalKernel::srm(c.layer, 1.0).form, TemporalKernel::Form::AlphaLead);
    compare_synapse(c, 0.05, torch::kFloat, 2e-5);
    compare_synapse(c, 0.05, torch::kDouble, 1e-11);
  }
}

// A hand-counted case: one spike at (t=0, c=0, y=2, x=2) through a 1->1 stride-2 conv with
// padding 1 and weight w[ky][kx] = 10 ky + kx. Input row y reaches output row oy through tap
// ky = y + 1 - 2 oy: oy = 1 (ky = 1) only, as ky = 3 and -1 do not exist; the same for columns.
// So output (1, 1) alone gets w[1][1] = 11, then the psp filter h spreads it in time.
TEST(SparseKernels, SingleSpikeScattersTheWeightColumnThenFiltersInTime) {
  LayerSpec l;
  l.kind = LayerKind::Conv;
  l.in_channels = l.out_channels = 1;
  l.padding = 1;
  l.neuron.discretisation = Discretisation::IIR;
  l.neuron.tau_s = 2;
  torch::Tensor s = torch::zeros({6, 1, 1, 5, 5});
  s[0][0][0][2][2] = 1.0;
  torch::Tensor w = torch::empty({1, 1, 3, 3});
  for (int ky = 0; ky < 3; ++ky)
    for (int kx = 0; kx < 3; ++kx) w[0][0][ky][kx] = 10.0 * ky + kx;
  const TemporalKernel eps = TemporalKernel::srm(l, 1.0);
  torch::Tensor u = sparse_synapse_psp(s, w, SynapseGeometry::of(l), eps, 1.0);
  ASSERT_EQ(u.sizes(), (std::vector<int64_t>{6, 1, 1, 3, 3}));
  const std::vector<double> h = eps.impulse_response(6);
  for (int t = 0; t < 6; ++t)
    for (int oy = 0; oy < 3; ++oy)
      for (int ox = 0; ox < 3; ++ox) {
        const int ky = 2 + 1 - 2 * oy, kx = 2 + 1 - 2 * ox;
        const double wv = (ky >= 0 && ky < 3 && kx >= 0 && kx < 3) ? 10.0 * ky + kx : 0.0;
        EXPECT_NEAR(u[t][0][0][oy][ox].item<double>(), wv * h[size_t(t)], 1e-5)
            << "t " << t << " (" << oy << ", " << ox << ")";
      }
  EXPECT_NEAR(u[2][0][0][1][1].item<double>(), 11.0 * h[2], 1e-5);
  EXPECT_EQ((u.abs() > 0).sum().item<int64_t>(), 5);  // h[0] = 0: t = 1..5
}

TEST(SparseKernels, SilentInputGivesZeroPotentialAndZeroWeightGradient) {
  ModelSpec spec = spikems_architecture(true, Discretisation::IIR);
  const LayerSpec& l = spec.layers[3];  // transposed conv 64 -> 32
  torch::Tensor s = torch::zeros({5, 2, 64, 4, 4}, torch::requires_grad());
  torch::Tensor w = torch::randn({64, 32, 3, 3}, torch::requires_grad());
  torch::Tensor u =
      sparse_synapse_psp(s, w, SynapseGeometry::of(l), TemporalKernel::srm(l, 1.0), 1.0);
  EXPECT_EQ(u.sizes(), (std::vector<int64_t>{5, 2, 32, 8, 8}));
  EXPECT_EQ(u.abs().sum().item<double>(), 0.0);
  (u * torch::randn(u.sizes())).sum().backward();
  EXPECT_EQ(w.grad().abs().sum().item<double>(), 0.0);
  EXPECT_GT(s.grad().abs().sum().item<double>(), 0.0);  // the input gradient stays dense
}

// Random weights that make every layer of a 32x24 network fire (N(0, 0.5) as bench_train).
ModelSpec random_model(Discretisation d) {
  ModelSpec s = spikems_architecture(true, d);
  torch::manual_seed(0);
  for (auto& l : s.layers) {
    torch::Tensor w = torch::randn({l.weight_count()}, torch::kDouble) * 0.5;
    for (size_t i = 0; i < l.weight.size(); ++i) l.weight[i] = float(w[int64_t(i)].item<double>());
  }
  return s;
}

// One layer (psp, synapse, spike) in double: spikes identical, gradients within 1e-11.
TEST(SparseKernels, LayerMatchesDenseForBothBackwardModes) {
  for (Discretisation d : {Discretisation::FIR, Discretisation::IIR}) {
    ModelSpec spec = random_model(d);
    for (SpikeGradient mode : {SpikeGradient::Slayer, SpikeGradient::Exact})
      for (size_t k : {size_t(0), size_t(3)}) {  // a conv and a transposed conv
        SCOPED_TRACE("layer " + std::to_string(k) + (d == Discretisation::FIR ? " FIR" : " IIR") +
                     (mode == SpikeGradient::Exact ? " exact" : " slayer"));
        const LayerSpec& l = spec.layers[k];
        torch::manual_seed(3);
        torch::Tensor x0 = random_spikes({12, 2, l.in_channels, 16, 12}, 0.08, 1.0, torch::kDouble);
        auto run = [&](KernelPath path) {
          SpikingLayer layer(l, 1.0, mode);
          layer->to(torch::kDouble);
          layer->set_kernels(path);
          torch::Tensor x = x0.clone().requires_grad_(true);
          torch::Tensor y = layer->forward(x);
          torch::manual_seed(4);
          (y * torch::randn(y.sizes(), y.options().requires_grad(false))).sum().backward();
          return std::array<torch::Tensor, 3>{y.detach(), x.grad(), layer->weight.grad()};
        };
        auto dense = run(KernelPath::Dense), sparse = run(KernelPath::Sparse);
        EXPECT_GT(dense[0].sum().item<double>(), 0.0) << "the layer must fire";
        EXPECT_TRUE(torch::equal(sparse[0], dense[0]));
        EXPECT_LE(rel_err(sparse[1], dense[1]), 1e-11);
        EXPECT_LE(rel_err(sparse[2], dense[2]), 1e-11);
      }
  }
}

// The whole network on a small crop: forward, the training loss, backward; every layer fires.
TEST(SparseKernels, WholeNetworkForwardBackwardMatchesDense) {
  for (Discretisation d : {Discretisation::FIR, Discretisation::IIR}) {
    SCOPED_TRACE(d == Discretisation::FIR ? "FIR" : "IIR");
    ModelSpec spec = random_model(d);
    torch::manual_seed(5);
    const int64_t T = 16, H = 32, W = 24;
    torch::Tensor x = random_spikes({T, 2, 2, H, W}, 0.05, 1.0, torch::kDouble);
    torch::Tensor mask = (torch::rand({2, H, W}) < 0.3).to(torch::kDouble);
    auto run = [&](KernelPath path) {
      SpikeMSNetwork net(spec);
      net->to(torch::kDouble);
      net->set_kernels(path);
      auto all = net->forward_all(x);
      torch::Tensor y = align_to_input(all.back(), H, W);
      LossOptions o;
      spikems_loss(y, x, mask, o).total.backward();
      std::vector<torch::Tensor> r;
      for (auto& a : all) r.push_back(a.detach());
      for (size_t k = 0; k < net->size(); ++k) r.push_back(net->layer(k)->weight.grad());
      return r;
    };
    auto dense = run(KernelPath::Dense), sparse = run(KernelPath::Sparse);
    for (size_t k = 0; k < 6; ++k) {
      EXPECT_GT(dense[k].sum().item<double>(), 0.0) << "layer " << k << " must fire";
      EXPECT_TRUE(torch::equal(sparse[k], dense[k])) << "spikes of layer " << k;
      EXPECT_GT(dense[6 + k].abs().max().item<double>(), 0.0);
      EXPECT_LE(rel_err(sparse[6 + k], dense[6 + k]), 1e-11) << "weight gradient " << k;
    }
  }
}

TEST(SparseKernels, AutoChoosesByLayerKindOutputsAndInputDensity) {
  torch::Tensor sparse = random_spikes({4, 1, 2, 16, 16}, 0.02, 1.0, torch::kFloat);
  torch::Tensor dense = torch::ones({4, 1, 2, 16, 16});
  EXPECT_NEAR(nonzero_density(dense), 1.0, 1e-12);
  EXPECT_NEAR(nonzero_density(torch::zeros({3, 7})), 0.0, 1e-12);
  torch::Tensor half = torch::zeros({100});
  half.narrow(0, 0, 37).fill_(2.0);
  EXPECT_NEAR(nonzero_density(half), 0.37, 1e-12);
  // Auto: transposed convolutions by density and output channels, convolutions always dense
  // (the crossovers measured with bench_train_sparse --layers).
  const SynapseGeometry up{LayerKind::ConvTranspose, 2, 1, 1}, down{LayerKind::Conv, 2, 1, 0};
  EXPECT_TRUE(use_sparse_path(KernelPath::Auto, sparse, up, 16));
  EXPECT_TRUE(use_sparse_path(KernelPath::Auto, sparse, up, 2));
  EXPECT_FALSE(use_sparse_path(KernelPath::Auto, dense, up, 64));
  EXPECT_FALSE(use_sparse_path(KernelPath::Auto, sparse, down, 64));
  torch::Tensor tenth = random_spikes({4, 1, 2, 16, 16}, 0.1, 1.0, torch::kFloat);
  const double d = nonzero_density(tenth);
  ASSERT_GT(d, 0.05);
  ASSERT_LT(d, 0.12);
  EXPECT_FALSE(use_sparse_path(KernelPath::Auto, tenth, up, 2));  // 2 outputs: up to 5 %
  EXPECT_TRUE(use_sparse_path(KernelPath::Auto, tenth, up, 16));  // 16: up to 12 %
  EXPECT_EQ(sparse_density_threshold(down, 16), 0.0);
  EXPECT_EQ(sparse_density_threshold(up, 2), 0.05);
  EXPECT_EQ(sparse_density_threshold(up, 16), 0.12);
  EXPECT_EQ(sparse_density_threshold(up, 32), 0.18);
  EXPECT_EQ(sparse_density_threshold(up, 64), 0.30);
  // Forced paths ignore the rule; unsupported inputs never go sparse.
  EXPECT_TRUE(use_sparse_path(KernelPath::Sparse, dense, down, 64));
  EXPECT_FALSE(use_sparse_path(KernelPath::Dense, sparse, up, 16));
  EXPECT_FALSE(use_sparse_path(KernelPath::Sparse, sparse.to(torch::kInt32), up, 16));
}

TEST(SparseKernels, ConfigKeyAndNames) {
  const std::string cfg = test::source_dir() + "/configs/train/default.toml";
  EXPECT_EQ(load_train_config(cfg, {}).kernels, "auto");
  EXPECT_EQ(load_train_config(cfg, {"run.kernels=\"sparse\""}).kernels, "sparse");
  EXPECT_EQ(load_train_config(cfg, {"run.kernels=dense"}).kernels, "dense");
  try {
    load_train_config(cfg, {"run.kernels=fast"});
    ADD_FAILURE() << "run.kernels=fast was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("run.kernels"), std::string::npos) << e.what();
  }
  EXPECT_EQ(parse_kernel_path("auto"), KernelPath::Auto);
  EXPECT_EQ(parse_kernel_path("sparse"), KernelPath::Sparse);
  EXPECT_EQ(parse_kernel_path("dense"), KernelPath::Dense);
  EXPECT_THROW(parse_kernel_path("Sparse"), Error);
  EXPECT_STREQ(kernel_path_name(KernelPath::Sparse), "sparse");
}

}  // namespace
}  // namespace spikems::train

namespace spikems::train {
namespace {

// `spikems train --kernels` takes only the three names (CLI11 refuses others before any work).
TEST(SparseKernels, TrainRefusesAnUnknownKernelsFlag) {
  std::string out;
  const int rc =
      test::run_command(test::spikems_binary() + " train --kernels fast --config " +
                            test::source_dir() + "/configs/train/default.toml --out /nonexistent",
                        &out);
  EXPECT_NE(rc, 0);
  EXPECT_NE(out.find("--kernels"), std::string::npos) << out;
  EXPECT_EQ(test::run_command(test::spikems_binary() + " train --help", &out), 0);
  EXPECT_NE(out.find("--kernels"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems::train
