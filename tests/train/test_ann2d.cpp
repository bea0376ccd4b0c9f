// The ANN-2D baseline in LibTorch against the core's LibTorch-free version (features and
// forward pass on random data), and its loss on a hand-made case.
#include <gtest/gtest.h>

#include <cmath>

#include "core/runtime/ann2d_network.h"
#include "core/runtime/ann_features.h"
#include "core/util/error.h"
#include "train/loss/ann_loss.h"
#include "train/network/ann2d_network.h"

namespace spikems::train {
namespace {

TEST(Ann2dTorch, FeaturesEqualTheCoreFeatures) {
  torch::manual_seed(3);
  const int64_t T = 13, B = 2, H = 5, W = 7, w0 = 3;
  const double ts = 0.5;  // spikes carry 1/Ts
  torch::Tensor spikes = (torch::rand({T, B, 2, H, W}) < 0.2).to(torch::kFloat);
  const torch::Tensor f = ann_feature_tensor(spikes / ts, w0, ts);
  ASSERT_EQ(f.sizes(), (std::vector<int64_t>{B, 4, H, W}));
  for (int64_t b = 0; b < B; ++b) {
    torch::Tensor win = spikes.narrow(0, w0, T - w0).select(1, b).to(torch::kUInt8).contiguous();
    const auto core = ann_features(win.data_ptr<uint8_t>(), int(T - w0), int(H), int(W));
    torch::Tensor fb = f[b].contiguous();
    for (size_t i = 0; i < core.size(); ++i)
      ASSERT_NEAR(fb.data_ptr<float>()[i], core[i], 1e-6) << "sample " << b << " value " << i;
  }
}

// Merged in runs of `group` steps, the features equal the core's on the window binned at
// group x Ts: a pixel spikes in a coarse step when it spiked in any of its fine steps.
TEST(Ann2dTorch, GroupedFeaturesEqualTheCoarseBinning) {
  torch::manual_seed(4);
  const int64_t T = 15, B = 2, H = 4, W = 6, w0 = 3, group = 4;  // window: 12 steps, 3 coarse
  const double ts = 0.5;
  torch::Tensor spikes = (torch::rand({T, B, 2, H, W}) < 0.15).to(torch::kFloat);
  const torch::Tensor f = ann_feature_tensor(spikes / ts, w0, ts, group);
  ASSERT_EQ(f.sizes(), (std::vector<int64_t>{B, 4, H, W}));
  for (int64_t b = 0; b < B; ++b) {
    std::vector<uint8_t> coarse(3 * 2 * H * W, 0);  // binned by hand, OR over each run
    for (int64_t t = 0; t < T - w0; ++t)
      for (int64_t i = 0; i < 2 * H * W; ++i)
        if (spikes[w0 + t][b].flatten()[i].item<float>() > 0)
          coarse[(t / group) * 2 * H * W + i] = 1;
    const auto core = ann_features(coarse.data(), 3, int(H), int(W));
    torch::Tensor fb = f[b].contiguous();
    for (size_t i = 0; i < core.size(); ++i)
      ASSERT_NEAR(fb.data_ptr<float>()[i], core[i], 1e-6) << "sample " << b << " value " << i;
  }
  // A window that is not a whole number of runs is refused.
  EXPECT_THROW(ann_feature_tensor(spikes / ts, w0, ts, 5), Error);
}

// With past frames (model.history): each frame's features equal the core's on that frame's
// steps, the window's first, then the frames before it, newest first.
TEST(Ann2dTorch, HistoryFeaturesAreThePastFramesNewestFirst) {
  torch::manual_seed(7);
  const int64_t T = 14, B = 2, H = 4, W = 5, w0 = 8, tw = T - w0;  // window 6 steps, 2 past
  const double ts = 0.5;
  torch::Tensor spikes = (torch::rand({T, B, 2, H, W}) < 0.2).to(torch::kFloat);
  const torch::Tensor f = ann_feature_tensor(spikes / ts, w0, ts, 1, 1);
  ASSERT_EQ(f.sizes(), (std::vector<int64_t>{B, 8, H, W}));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h <= 1; ++h) {
      torch::Tensor win =
          spikes.narrow(0, w0 - h * tw, tw).select(1, b).to(torch::kUInt8).contiguous();
      const auto core = ann_features(win.data_ptr<uint8_t>(), int(tw), int(H), int(W));
      torch::Tensor fb = f[b].narrow(0, 4 * h, 4).contiguous();
      for (size_t i = 0; i < core.size(); ++i)
        ASSERT_NEAR(fb.data_ptr<float>()[i], core[i], 1e-6)
            << "sample " << b << " frame " << h << " value " << i;
    }
  // Two past frames of 6 steps need 12 steps before the window; there are 8.
  EXPECT_THROW(ann_feature_tensor(spikes / ts, w0, ts, 1, 2), Error);
}

// Without and with U-Net skips (the input then padded at the bottom and right to a size the
// skips meet at, the output cropped back), on sizes that need it.
class Ann2dTorchSkips : public ::testing::TestWithParam<bool> {};

TEST_P(Ann2dTorchSkips, ForwardEqualsTheCoreForward) {
  torch::manual_seed(5);
  // Without and with two past frames (12 input channels).
  for (int history : {0, 2}) {
    Ann2dNetwork net(ann2d_architecture({16, 32, 64}, GetParam(), {}, history));  // PyTorch's init
    const ModelSpec spec = net->to_spec();
    for (const auto& l : spec.layers) ASSERT_EQ(l.bias.size(), size_t(l.out_channels));
    const Ann2dForward core(spec);
    // 21 x 30: not a multiple of 8, so the output is cropped / padded to the input.
    for (auto [H, W] : {std::pair{16, 24}, std::pair{21, 30}}) {
      torch::Tensor x = torch::rand({1, 4 * (1 + history), H, W});
      torch::NoGradGuard ng;
      torch::Tensor y = net->forward(x).contiguous();
      ASSERT_EQ(y.sizes(), (std::vector<int64_t>{1, 1, H, W}));
      torch::Tensor xc = x.contiguous();
      const auto ref = core.forward(
          std::vector<float>(xc.data_ptr<float>(), xc.data_ptr<float>() + xc.numel()), H, W);
      double err = 0, scale = 0;
      for (size_t i = 0; i < ref.size(); ++i) {
        err = std::max(err, double(std::abs(y.data_ptr<float>()[i] - ref[i])));
        scale = std::max(scale, double(std::abs(ref[i])));
      }
      EXPECT_LT(err, 1e-5 * std::max(1.0, scale)) << H << "x" << W << ", history " << history;
      EXPECT_GT(scale, 1e-4);  // not a trivially zero output
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Ann2d, Ann2dTorchSkips, ::testing::Bool());

// The skip's channel order: with the weights of the last layer's predecessor channels zero, the
// output is layer 0's ReLU output through the last layer's skip weights alone (functional ops).
TEST(Ann2dTorch, SkipChannelsFollowThePredecessors) {
  torch::manual_seed(6);
  Ann2dNetwork net(ann2d_architecture({4, 8, 8}, true));
  ModelSpec spec = net->to_spec();
  LayerSpec& last = spec.layers.back();  // transposed: weight [in, out, k, k], in = 4 + 4
  ASSERT_EQ(last.skip_from, 0);
  const int pred = spec.layers[spec.layers.size() - 2].out_channels;
  ASSERT_EQ(last.in_channels, pred + spec.layers[0].out_channels);
  const size_t per_in = size_t(last.out_channels * last.kernel * last.kernel);
  std::fill(last.weight.begin(), last.weight.begin() + pred * per_in, 0.f);
  Ann2dNetwork cut(spec);
  const Ann2dForward core(spec);
  torch::NoGradGuard ng;
  const torch::Tensor x = torch::rand({1, 4, 16, 16});
  const torch::Tensor y = cut->forward(x);
  const LayerSpec& first = spec.layers[0];
  const torch::Tensor w0 = torch::tensor(first.weight).reshape({first.out_channels, 4, 3, 3});
  const torch::Tensor h0 = torch::relu(torch::conv2d(x, w0, torch::tensor(first.bias), 2, 1));
  const torch::Tensor wl = torch::tensor(last.weight)
                               .reshape({last.in_channels, 1, 3, 3})
                               .narrow(0, pred, last.in_channels - pred);
  const torch::Tensor want = torch::conv_transpose2d(h0, wl, torch::tensor(last.bias), 2, 1, 1);
  ASSERT_EQ(want.sizes(), y.sizes());
  EXPECT_LT((y - want).abs().max().item<double>(), 1e-5);
  const torch::Tensor xc = x.contiguous();
  const auto ref = core.forward(
      std::vector<float>(xc.data_ptr<float>(), xc.data_ptr<float>() + xc.numel()), 16, 16);
  const torch::Tensor yc = y.contiguous();
  for (size_t i = 0; i < ref.size(); ++i) ASSERT_NEAR(yc.data_ptr<float>()[i], ref[i], 1e-5) << i;
}

TEST(Ann2dTorch, BalancedLossByHand) {
  // One sample, 3 event pixels (2 foreground, 1 background) and one pixel without events.
  torch::Tensor logits = torch::tensor({0.f, 2.f, -1.f, 5.f}).view({1, 1, 1, 4});
  torch::Tensor had = torch::tensor({1.f, 1.f, 1.f, 0.f}).view({1, 1, 4});
  torch::Tensor fg = torch::tensor({1.f, 1.f, 0.f, 1.f}).view({1, 1, 4});
  auto sp = [](double z) { return std::log1p(std::exp(-z)); };  // -log sigmoid(z)
  const double lf = (sp(0) + sp(2)) / 2, lb = sp(1);            // -log(1 - sigmoid(-1)) = sp(1)
  AnnLoss l = ann_loss(logits, had, fg, true, 0);
  EXPECT_NEAR(l.bce.item<double>(), 0.5 * (lf + lb), 1e-6);
  EXPECT_NEAR(l.iou.item<double>(), 0.0, 0);
  l = ann_loss(logits, had, fg, false, 1);
  EXPECT_NEAR(l.bce.item<double>(), (sp(0) + sp(2) + sp(1)) / 3, 1e-6);
  // Soft IoU: p = sigmoid(z) at event pixels, y = fg at event pixels; union p + y - p y is 1 at
  // the two foreground pixels, p at the background one, 0 where no event fell.
  const double p0 = 0.5, p1 = 1 / (1 + std::exp(-2.0)), p2 = 1 / (1 + std::exp(1.0));
  EXPECT_NEAR(l.iou.item<double>(), 1 - (p0 + p1 + 1) / (2 + p2 + 1), 1e-6);
}

}  // namespace
}  // namespace spikems::train
