// U-Net skip connections (model.skips, model.skip_levels): the architecture the config builds,
// the zero padding of inputs that do not fit, and that the skip path is live.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "common/test_paths.h"
#include "core/model/model_file.h"
#include "core/util/error.h"
#include "train/network/spikems_network.h"
#include "train/trainer/train_config.h"
#include "train_test_util.h"

namespace spikems::train {
namespace {

using test::random_model;
using test::random_spikes;

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

}  // namespace
}  // namespace spikems::train
