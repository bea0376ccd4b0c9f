// Truncated warm-up (optim.warmup_backprop = false; SpikeMSNetworkImpl::forward_all_truncated):
// the window's spikes must equal the full pass's, and the weight gradients must equal those of
// the full-length network in which each layer's input and potential are cut off from the graph
// over the warm-up (the definition of truncated backpropagation through time), built here from
// the public psp / synapse / spike functions rather than from forward_window.
// Double precision: no spike decision flips, so spikes compare exactly and gradients to 1e-11.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "common/test_paths.h"
#include "core/model/model_file.h"
#include "core/util/error.h"
#include "train/loss/spikems_loss.h"
#include "train/network/spikems_network.h"
#include "train/neuron/psp.h"
#include "train/neuron/spike.h"
#include "train/synapse/conv.h"
#include "train/trainer/train_config.h"
#include "train_test_util.h"

namespace spikems::train {
namespace {

using test::random_model;
using test::random_spikes;
using test::rel_err;

// The reference: every layer over all T steps with gradients, its input's and its potential's
// first w0 steps detached. Returns each layer's spikes over all T steps.
std::vector<torch::Tensor> reference(SpikeMSNetwork& net, const ModelSpec& spec,
                                     const torch::Tensor& x, int64_t w0, SpikeGradient mode) {
  const int64_t T = x.size(0);
  auto cut = [&](const torch::Tensor& t) {
    return torch::cat({t.narrow(0, 0, w0).detach(), t.narrow(0, w0, T - w0)}, 0);
  };
  std::vector<torch::Tensor> out;
  torch::Tensor s = x;
  for (size_t k = 0; k < net->size(); ++k) {
    const LayerSpec& l = spec.layers[k];
    const double ts = spec.time_step_ms;
    if (l.skip_from >= 0) s = torch::cat({s, out[size_t(l.skip_from)]}, 2);  // U-Net skip
    torch::Tensor u = synapse_forward(psp(cut(s), TemporalKernel::srm(l, ts), ts),
                                      net->layer(k)->weight, SynapseGeometry::of(l));
    s = spike(cut(u), SpikeParams::from_layer(l, ts, mode));
    out.push_back(s);
  }
  return out;
}

TEST(TruncatedWarmup, WindowSpikesAndGradientsMatchTheDetachedFullPass) {
  const int64_t T = 18, w0 = 11, H = 32, W = 24;
  for (bool skips : {false, true})
    for (Discretisation d : {Discretisation::FIR, Discretisation::IIR})
      for (SpikeGradient mode : {SpikeGradient::Slayer, SpikeGradient::Exact})
        for (KernelPath path : {KernelPath::Dense, KernelPath::Sparse}) {
          if (skips && mode == SpikeGradient::Exact) continue;  // one backward mode is enough
          SCOPED_TRACE(std::string(d == Discretisation::FIR ? "FIR" : "IIR") +
                       (mode == SpikeGradient::Exact ? " exact" : " slayer") +
                       (path == KernelPath::Sparse ? " sparse" : " dense") +
                       (skips ? " skips" : ""));
          const ModelSpec spec = random_model(d, 7, skips);
          torch::manual_seed(8);
          const torch::Tensor x = random_spikes({T, 2, 2, H, W}, 0.06);
          const torch::Tensor mask = (torch::rand({2, H, W}) < 0.3).to(torch::kDouble);
          auto run = [&](bool truncated) {
            SpikeMSNetwork net(spec, mode);
            net->to(torch::kDouble);
            net->set_kernels(path);
            std::vector<torch::Tensor> all;
            if (truncated) {
              all = net->forward_all_truncated(x, w0);
            } else {
              for (auto& a : reference(net, spec, x, w0, mode))
                all.push_back(a.narrow(0, w0, T - w0));
            }
            torch::Tensor y = align_to_input(all.back(), H, W);
            LossOptions o;
            spikems_loss(y, x.narrow(0, w0, T - w0), mask, o).total.backward();
            std::vector<torch::Tensor> r;
            for (auto& a : all) r.push_back(a.detach());
            for (size_t k = 0; k < net->size(); ++k) r.push_back(net->layer(k)->weight.grad());
            return r;
          };
          const auto ref = run(false), trunc = run(true);
          ASSERT_EQ(trunc.size(), 12u);
          for (size_t k = 0; k < 6; ++k) {
            EXPECT_EQ(trunc[k].size(0), T - w0);
            EXPECT_GT(ref[k].sum().item<double>(), 0.0) << "layer " << k << " must fire";
            EXPECT_TRUE(torch::equal(trunc[k], ref[k])) << "window spikes of layer " << k;
            EXPECT_GT(ref[6 + k].abs().max().item<double>(), 0.0) << "layer " << k;
            EXPECT_LE(rel_err(trunc[6 + k], ref[6 + k]), 1e-11) << "weight gradient " << k;
          }
        }
}

// The forward values are those of the ordinary full pass (the reference above only changes
// gradients): the warm-up's refractory responses and psp tails carry into the window.
TEST(TruncatedWarmup, ForwardEqualsTheFullPassAndTheWarmupMatters) {
  const int64_t T = 20, w0 = 12;
  for (Discretisation d : {Discretisation::FIR, Discretisation::IIR}) {
    const ModelSpec spec = random_model(d, 9);
    torch::manual_seed(10);
    const torch::Tensor x = random_spikes({T, 1, 2, 32, 24}, 0.08);
    SpikeMSNetwork net(spec);
    net->to(torch::kDouble);
    torch::NoGradGuard ng;
    const auto full = net->forward_all(x), trunc = net->forward_all_truncated(x, w0);
    const auto cold = net->forward_all(x.narrow(0, w0, T - w0));  // no warm-up at all
    bool differs_from_cold = false;
    for (size_t k = 0; k < full.size(); ++k) {
      EXPECT_TRUE(torch::equal(trunc[k], full[k].narrow(0, w0, T - w0))) << "layer " << k;
      differs_from_cold = differs_from_cold || !torch::equal(trunc[k], cold[k]);
    }
    EXPECT_TRUE(differs_from_cold) << "the warm-up's state must reach the window";
    const auto same = net->forward_all_truncated(x, 0);  // no warm-up: the ordinary pass
    for (size_t k = 0; k < full.size(); ++k) EXPECT_TRUE(torch::equal(same[k], full[k]));
  }
}

TEST(TruncatedWarmup, ConfigKeyParsesAndRefusesDelays) {
  const std::string base = test::source_dir() + "/configs/train/deep.toml";
  EXPECT_FALSE(load_train_config(base, {}).warmup_backprop);
  EXPECT_TRUE(load_train_config(base, {"optim.warmup_backprop=true"}).warmup_backprop);
  try {
    load_train_config(base, {"model.delays=true"});
    FAIL() << "delays with a truncated warm-up must be refused";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("optim.warmup_backprop"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace spikems::train
