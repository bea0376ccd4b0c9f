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

using test::rel_err;

// Random weights that make every layer of a 32x24 network fire.
ModelSpec random_model(Discretisation d, uint64_t seed, bool skips = false) {
  ModelSpec s = spikems_architecture(true, d, {16, 32, 64}, {}, skips);
  torch::manual_seed(seed);
  for (auto& l : s.layers) {
    torch::Tensor w = torch::randn({l.weight_count()}, torch::kDouble) * 0.5;
    for (size_t i = 0; i < l.weight.size(); ++i) l.weight[i] = float(w[int64_t(i)].item<double>());
  }
  return s;
}

torch::Tensor random_spikes(std::vector<int64_t> shape, double density) {
  return (torch::rand(shape, torch::kDouble) < density).to(torch::kDouble);
}

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

// A skip network pads an input that does not fit (21x13 for three levels) to the fitted size
// with zeros at the bottom and right: the same spikes as padding it by hand. Each padded conv
// gives ceil(n/2), each transposed one 2n: 13 -> 7 -> 4 -> 2 -> 4 -> 8 != 7, while
// 15 -> 8 -> 4 -> 2 -> 4 -> 8 -> 16 meets both skips; 21 -> 11 ... -> 12 != 11, 23 fits.
TEST(Skips, InputIsZeroPaddedToTheFittedSize) {
  const ModelSpec spec = random_model(Discretisation::IIR, 11, true);
  EXPECT_EQ(spec.fitted_input_size(13, 21), (std::pair<int, int>{15, 23}));
  torch::manual_seed(12);
  const torch::Tensor x = random_spikes({14, 1, 2, 13, 21}, 0.1);
  SpikeMSNetwork net(spec);
  net->to(torch::kDouble);
  torch::NoGradGuard ng;
  const auto got = net->forward_all(x);
  const auto want = net->forward_all(torch::constant_pad_nd(x, {0, 2, 0, 2}, 0));
  ASSERT_EQ(got.size(), want.size());
  EXPECT_EQ(got.back().size(3), 16);
  EXPECT_EQ(got.back().size(4), 24);
  for (size_t k = 0; k < got.size(); ++k) EXPECT_TRUE(torch::equal(got[k], want[k])) << k;
  EXPECT_GT(got.back().sum().item<double>(), 0.0);
  // Without the skips' spikes (their weights zeroed) the output changes: the path is live.
  ModelSpec cut = spec;
  for (auto& l : cut.layers)
    if (l.skip_from >= 0) {
      const int c_prev = l.in_channels - spec.layers[size_t(l.skip_from)].out_channels;
      // conv_transpose weight [C_in, C_out, 3, 3]: the skip's input channels come last
      std::fill(l.weight.begin() + int64_t(c_prev) * l.out_channels * 9, l.weight.end(), 0.f);
    }
  SpikeMSNetwork cut_net(cut);
  cut_net->to(torch::kDouble);
  EXPECT_FALSE(torch::equal(cut_net->forward_all(x).back(), got.back()));
}

TEST(Skips, ConfigKeyBuildsTheUNetAndNeedsPadding) {
  const std::string base = test::source_dir() + "/configs/train/deep.toml";
  EXPECT_TRUE(load_train_config(base, {}).skips);  // deep.toml needs them to learn
  EXPECT_FALSE(load_train_config(base, {"model.skips=false"}).skips);
  EXPECT_FALSE(load_train_config(test::source_dir() + "/configs/train/default.toml", {}).skips);
  EXPECT_THROW(load_train_config(base, {"model.skips=true", "model.padded=false"}), std::exception);
  const ModelSpec s = spikems_architecture(true, Discretisation::IIR, {8, 16, 32}, {}, true);
  // Encoder 0..2; decoder 3 (bottleneck, no skip), 4 <- layer 1, 5 <- layer 0.
  const int want_skip[] = {-1, -1, -1, -1, 1, 0};
  const int want_in[] = {2, 8, 16, 32, 16 + 16, 8 + 8};
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(s.layers[k].skip_from, want_skip[k]) << k;
    EXPECT_EQ(s.layers[k].in_channels, want_in[k]) << k;
  }
}

// model.skip_levels keeps only the named encoder levels' skips (1 = the finest): [2] on three
// levels leaves decoder layer 4 <- layer 1 and drops the finest (layer 5 <- layer 0).
TEST(Skips, SkipLevelsChooseWhichLevelsFeedTheDecoder) {
  const std::string base = test::source_dir() + "/configs/train/deep.toml";
  EXPECT_TRUE(load_train_config(base, {}).skip_levels.empty());
  const TrainConfig c = load_train_config(base, {"model.skip_levels=[3, 5]"});
  EXPECT_EQ(c.skip_levels, (std::vector<int>{3, 5}));
  auto msg = [&](const std::vector<std::string>& ov) {
    try {
      load_train_config(base, ov);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(msg({"model.skip_levels=[6]"}).find("1..5"), std::string::npos);  // the bottleneck
  EXPECT_NE(msg({"model.skip_levels=[0]"}).find("model.skip_levels"), std::string::npos);
  EXPECT_NE(msg({"model.skip_levels=[2, 2]"}).find("twice"), std::string::npos);
  EXPECT_NE(msg({"model.skip_levels=[2]", "model.skips=false"}).find("model.skips = true"),
            std::string::npos);
  const ModelSpec s = spikems_architecture(true, Discretisation::IIR, {8, 16, 32}, {}, true, {2});
  const int want_skip[] = {-1, -1, -1, -1, 1, -1};
  const int want_in[] = {2, 8, 16, 32, 16 + 16, 8};
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(s.layers[k].skip_from, want_skip[k]) << k;
    EXPECT_EQ(s.layers[k].in_channels, want_in[k]) << k;
  }
  EXPECT_TRUE(s.has_skips());
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {8, 16, 32}, {}, true, {3}), Error);
  EXPECT_THROW(spikems_architecture(true, Discretisation::IIR, {8, 16, 32}, {}, false, {1}), Error);
  // The LibTorch network runs it on an input it must pad (11x13), to the model's output size.
  SpikeMSNetwork net(s);
  const torch::Tensor x = (torch::rand({6, 1, 2, 11, 13}) < 0.2).to(torch::kFloat);
  const torch::Tensor y = net->forward(x);
  const auto [fh, fw] = s.fitted_input_size(11, 13);
  const auto [oh, ow] = s.output_size(fh, fw);
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{6, 1, 2, oh, ow}));
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
