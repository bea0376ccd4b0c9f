// The SynOps count of the training graph (loss.synops_weight): the streaming runtime's own count
// for the same spikes, its gradient, the penalty's two forms, and that a run with the penalty
// does less work per input event than the same run without it.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/test_paths.h"
#include "core/runtime/streaming_layer.h"
#include "train/loss/synops_loss.h"
#include "train/network/spikems_network.h"
#include "train/trainer/train_config.h"
#include "train/trainer/trainer.h"
#include "train_test_util.h"

namespace spikems::train {
namespace {

namespace fs = std::filesystem;

// Along one axis: a stride-2 conv (k 3, pad 1) of 8 inputs onto 4 outputs reaches output
// o = (i + 1 - tap) / 2 for the taps that divide: 1 or 2 of them, and the last input only one
// (its second would be output 4); a stride-2 transposed conv of 4 onto 8 reaches o = 2i - 1 +
// tap: 3 each, 2 for the first (o = -1 is cut).
TEST(SynopsLoss, ReachCountsTheTapsAnInputMeets) {
  EXPECT_EQ(SynopsCounter::reach(8, 4, 3, 2, 1, false),
            (std::vector<double>{1, 2, 1, 2, 1, 2, 1, 1}));
  EXPECT_EQ(SynopsCounter::reach(4, 8, 3, 2, 1, true), (std::vector<double>{2, 3, 3, 3}));
  // Stride 1, no padding, k 3 (7 -> 5): borders reach fewer.
  EXPECT_EQ(SynopsCounter::reach(7, 5, 3, 1, 0, false), (std::vector<double>{1, 2, 3, 3, 3, 2, 1}));
}

// [T, 1, C, H, W] spikes -> per step, channels-last neuron indices (the runtime's input).
std::vector<std::vector<uint32_t>> to_steps(const torch::Tensor& x) {
  const torch::Tensor a = x.to(torch::kFloat).contiguous();
  const int64_t T = a.size(0), C = a.size(2), H = a.size(3), W = a.size(4);
  const float* p = a.data_ptr<float>();
  std::vector<std::vector<uint32_t>> s(static_cast<size_t>(T));
  for (int64_t t = 0; t < T; ++t)
    for (int64_t y = 0; y < H; ++y)
      for (int64_t xx = 0; xx < W; ++xx)
        for (int64_t c = 0; c < C; ++c)
          if (p[(((t * C) + c) * H + y) * W + xx] != 0)
            s[size_t(t)].push_back(uint32_t((y * W + xx) * C + c));
  return s;
}

// The streaming runtime's count for one layer driven by `in` ([T, 1, C, H, W] spikes).
double runtime_synops(const LayerSpec& spec, double ts, const torch::Tensor& in) {
  auto sl = StreamingLayer::create(spec, ts, int(in.size(3)), int(in.size(4)));
  const auto steps = to_steps(in);
  std::vector<uint32_t> fired;
  for (size_t t = 0; t < steps.size(); ++t) {
    sl->fire(int64_t(t), fired);
    sl->drive(int64_t(t), steps[t].data(), steps[t].size());
  }
  return double(sl->synops());
}

// A random U-Net (skips) run on random input spikes [T, B, 2, 13, 21] (padded to 15x23 inside).
struct SkipNetRun {
  ModelSpec spec;
  SpikeMSNetwork net;
  torch::Tensor x;
  std::vector<torch::Tensor> layers;
};
SkipNetRun run_skip_net(uint64_t seed, int64_t T, int64_t B) {
  SkipNetRun r{test::random_model(Discretisation::IIR, seed, true), nullptr, {}, {}};
  torch::manual_seed(seed);
  r.x = test::random_spikes({T, B, 2, 13, 21}, 0.08);
  r.net = SpikeMSNetwork(r.spec);
  r.net->to(torch::kDouble);
  torch::NoGradGuard ng;
  r.layers = r.net->forward_all(r.x);
  return r;
}

// The U-Net (skips) on an input that needs padding (13x21 runs as 15x23): every layer of the
// streaming runtime, teacher forced on torch's input to that layer, counts its weight additions;
// their sum is the counter's figure for torch's spikes, exactly, per sample.
TEST(SynopsLoss, EqualsTheRuntimeCountOfTheSameSpikes) {
  const int64_t B = 2;
  SkipNetRun r = run_skip_net(21, 12, B);
  const ModelSpec& spec = r.spec;
  const torch::Tensor& x = r.x;
  const std::vector<torch::Tensor>& layers = r.layers;
  const double ts = spec.time_step_ms;
  torch::NoGradGuard ng;
  SpikeMSNetwork& net = r.net;  // input_of below
  const SynopsCounter counter(spec);
  const torch::Tensor got = counter.per_sample(x / ts, layers, ts);
  ASSERT_EQ(got.size(0), B);
  const torch::Tensor padded = pad_for_skips(spec, x);
  for (int64_t b = 0; b < B; ++b) {
    std::vector<torch::Tensor> out;  // sample b's spikes of the layers before k
    double want = 0;
    for (size_t k = 0; k < spec.layers.size(); ++k) {
      const torch::Tensor in = k == 0 ? padded.narrow(1, b, 1) : net->input_of(k, x, out);
      want += runtime_synops(spec.layers[k], ts, in);
      out.push_back(layers[k].narrow(1, b, 1));
    }
    EXPECT_GT(want, 1000.0) << "too few spikes for the comparison to mean anything";
    EXPECT_EQ(got[b].item<double>(), want) << "sample " << b;
  }
}

// The count is a weighted sum of the spikes: its gradient at a spike of a layer is the number
// of neurons that spike reaches (channels of each consumer times the taps it meets), times Ts.
TEST(SynopsLoss, GradientIsEachSpikesReach) {
  const ModelSpec spec = spikems_architecture(true, Discretisation::IIR, {4, 8}, {}, false);
  const double ts = spec.time_step_ms;
  const torch::Tensor x = torch::zeros({3, 1, 2, 16, 16}, torch::kDouble);
  std::vector<torch::Tensor> layers;
  {
    SpikeMSNetwork net(spec);
    net->to(torch::kDouble);
    torch::NoGradGuard ng;
    for (const auto& l : net->forward_all(x)) layers.push_back(torch::zeros_like(l));
  }
  ASSERT_GE(layers.size(), 3u);
  for (auto& l : layers) l.requires_grad_();
  const SynopsCounter counter(spec);
  counter.per_sample(x, layers, ts).sum().backward();
  // Layer 0's spikes feed layer 1 alone (no skips).
  const LayerSpec& l1 = spec.layers[1];
  const bool tr = l1.kind == LayerKind::ConvTranspose;
  const auto rows = SynopsCounter::reach(layers[0].size(3), layers[1].size(3), l1.kernel, l1.stride,
                                         l1.padding, tr);
  const auto cols = SynopsCounter::reach(layers[0].size(4), layers[1].size(4), l1.kernel, l1.stride,
                                         l1.padding, tr);
  const torch::Tensor g = layers[0].grad();
  const int64_t h = layers[0].size(3) - 1, w = layers[0].size(4) - 1;
  int nonzero = 0;
  for (int64_t y : {int64_t(0), int64_t(1), h})
    for (int64_t xx : {int64_t(0), int64_t(1), w}) {
      const double want = ts * l1.out_channels * rows[size_t(y)] * cols[size_t(xx)];
      nonzero += want > 0;
      EXPECT_DOUBLE_EQ(g[2][0][1][y][xx].item<double>(), want) << y << "," << xx;
    }
  EXPECT_GT(nonzero, 0);
  // The output layer's spikes reach nothing (no gradient, or a zero one).
  const torch::Tensor go = layers.back().grad();
  EXPECT_TRUE(!go.defined() || go.abs().sum().item<double>() == 0.0);
}

// loss.synops_source_weights: the count is linear in the weight of each source. The input's
// operations alone are layer 0's runtime count; a layer whose spikes feed nothing (the output)
// adds nothing; any weights give the same sum of the one-source counts; a wrong length throws.
TEST(SynopsLoss, SourceWeightsScaleEachSourcesOperations) {
  const SkipNetRun r = run_skip_net(22, 10, 2);
  const ModelSpec& spec = r.spec;
  const torch::Tensor& x = r.x;
  const std::vector<torch::Tensor>& layers = r.layers;
  const double ts = spec.time_step_ms;
  torch::NoGradGuard ng;
  const SynopsCounter counter(spec);
  const size_t n = counter.sources();
  ASSERT_EQ(n, spec.layers.size() + 1);
  std::vector<torch::Tensor> one;  // the count of each source alone
  for (size_t s = 0; s < n; ++s) {
    std::vector<double> w(n, 0.0);
    w[s] = 1.0;
    one.push_back(counter.per_sample(x / ts, layers, ts, w));
  }
  // Layer 0's runtime count, on sample 0: the input's operations.
  const torch::Tensor padded = pad_for_skips(spec, x).narrow(1, 0, 1);
  const double layer0 = runtime_synops(spec.layers[0], ts, padded);
  EXPECT_GT(layer0, 100.0);
  EXPECT_EQ(one[0][0].item<double>(), layer0);
  EXPECT_EQ(one[n - 1].abs().sum().item<double>(), 0.0) << "the output layer feeds nothing";
  const std::vector<double> w = {0.5, 0.0, 2.0, 1.0, 3.0, 0.25, 1.0};
  ASSERT_EQ(w.size(), n);
  torch::Tensor want = torch::zeros_like(one[0]);
  for (size_t s = 0; s < n; ++s) want = want + w[s] * one[s];
  const torch::Tensor got = counter.per_sample(x / ts, layers, ts, w);
  for (int64_t b = 0; b < 2; ++b)
    EXPECT_NEAR(got[b].item<double>(), want[b].item<double>(), 1e-9 * want[b].item<double>());
  // All ones is the plain count.
  const torch::Tensor all = counter.per_sample(x / ts, layers, ts);
  EXPECT_TRUE(
      torch::equal(counter.per_sample(x / ts, layers, ts, std::vector<double>(n, 1.0)), all));
  EXPECT_THROW(counter.per_sample(x / ts, layers, ts, std::vector<double>(n - 1, 1.0)),
               std::exception);
}

TEST(SynopsLoss, PenaltyIsAHingeOnTheBudgetOrLinear) {
  const torch::Tensor sope = torch::tensor({500.0, 1500.0, 3000.0}, torch::kDouble);
  // Budget 1000: (0 + 0.5^2 + 2^2) / 3 x 2.
  EXPECT_DOUBLE_EQ(synops_penalty(sope, 2.0, 1000).item<double>(), 2.0 * (0.25 + 4.0) / 3);
  // No budget: w x mean / 1000.
  EXPECT_DOUBLE_EQ(synops_penalty(sope, 2.0, 0).item<double>(), 2.0 * (5000.0 / 3) / 1000);
}

TEST(SynopsLoss, BadKeysAreRefused) {
  const std::string cfg = test::source_dir() + "/configs/train/default.toml";
  EXPECT_THROW(load_train_config(cfg, {"loss.synops_weight=-1.0"}), std::exception);
  EXPECT_THROW(load_train_config(cfg, {"loss.synops_budget=-5.0"}), std::exception);
  EXPECT_THROW(load_train_config(test::source_dir() + "/configs/train/ann2d.toml",
                                 {"loss.synops_weight=1.0"}),
               std::exception);
  EXPECT_EQ(load_train_config(cfg, {"loss.synops_budget=800.0"}).synops_budget, 800.0);
  // The default net has 3 levels: 6 layers and the input, 7 sources.
  EXPECT_THROW(load_train_config(cfg, {"loss.synops_source_weights=[1.0, 1.0]"}), std::exception);
  EXPECT_THROW(load_train_config(cfg, {"loss.synops_source_weights=[1, 1, 1, -1, 1, 1, 1]"}),
               std::exception);
  EXPECT_EQ(load_train_config(cfg, {"loss.synops_source_weights=[1, 1, 0, 1, 1, 1, 1]"})
                .synops_source_weights,
            (std::vector<double>{1, 1, 0, 1, 1, 1, 1}));
}

}  // namespace
}  // namespace spikems::train
