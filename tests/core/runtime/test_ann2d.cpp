// The ANN-2D baseline without LibTorch: the event-frame features on a hand-made window, the
// forward pass of single layers computed by hand (convolution, transposed convolution, borders,
// bias, ReLU, output alignment), and the model file round trip. (Its MACs: test_energy.cpp.)
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/model/model_file.h"
#include "core/runtime/ann2d_network.h"
#include "core/runtime/ann_features.h"
#include "core/util/error.h"

namespace spikems {
namespace {

TEST(AnnFeatures, CountsAndMeanTimesPerPolarity) {
  // T = 4 steps, 1x2 pixels. Pixel 0: ON at steps 0 and 3; OFF at step 1. Pixel 1: nothing.
  const int T = 4, H = 1, W = 2;
  std::vector<uint8_t> s(size_t(T) * 2 * H * W, 0);
  auto at = [&](int t, int c, int x) -> uint8_t& { return s[(size_t(t) * 2 + c) * W + x]; };
  at(0, 1, 0) = 1;
  at(3, 1, 0) = 1;
  at(1, 0, 0) = 1;
  const auto f = ann_features(s.data(), T, H, W);
  ASSERT_EQ(f.size(), 8u);
  EXPECT_FLOAT_EQ(f[0], std::log1p(1.f));  // OFF count, pixel 0
  EXPECT_FLOAT_EQ(f[1], 0.f);
  EXPECT_FLOAT_EQ(f[2], std::log1p(2.f));  // ON count
  EXPECT_FLOAT_EQ(f[4], 1.5f / 4);         // OFF mean time: step 1 -> (1 + 0.5) / 4
  EXPECT_FLOAT_EQ(f[6], (0.5f / 4 + 3.5f / 4) / 2);
  EXPECT_FLOAT_EQ(f[7], 0.f);
  EXPECT_THROW(ann_features(s.data(), 0, H, W), Error);
}

// A one-layer "ANN-2D" is not a valid model (4 in, 1 out needed across the stack), so single
// layers are checked through a 4 -> 1 model of one layer.
ModelSpec one_layer(LayerKind kind, int stride, int padding, int output_padding) {
  ModelSpec m;
  m.type = ModelType::ANN2D;
  LayerSpec l;
  l.kind = kind;
  l.in_channels = 4;
  l.out_channels = 1;
  l.stride = stride;
  l.padding = padding;
  l.output_padding = output_padding;
  l.weight.assign(36, 0.f);
  l.bias = {0.5f};
  m.layers.push_back(l);
  return m;
}

TEST(Ann2dForward, ConvolutionByHand) {
  // 3x3 stride 2 padding 1 on a 4x4 input, channel 0 = 1..16, weight 1 at the kernel centre
  // and 2 at its top-left; other channels 0. Output 2x2:
  // out(oy, ox) = 0.5 + x(2oy, 2ox) + 2 x(2oy - 1, 2ox - 1) (0 outside).
  ModelSpec m = one_layer(LayerKind::Conv, 2, 1, 0);
  m.layers[0].weight[4] = 1.f;  // [co 0][ci 0][1][1]
  m.layers[0].weight[0] = 2.f;  // [0][0][0][0]
  std::vector<float> f(4 * 16, 0.f);
  for (int i = 0; i < 16; ++i) f[size_t(i)] = float(i + 1);
  const Ann2dForward net(m);
  const auto y = net.forward(f, 4, 4);  // output 2x2 put top-left in 4x4, zeros elsewhere
  ASSERT_EQ(y.size(), 16u);
  EXPECT_FLOAT_EQ(y[0], 0.5f + 1);           // (0,0): x(0,0)=1, x(-1,-1) outside
  EXPECT_FLOAT_EQ(y[1], 0.5f + 3);           // (0,1): x(0,2)=3, x(-1,1) outside
  EXPECT_FLOAT_EQ(y[4], 0.5f + 9);           // (1,0): x(2,0)=9, x(1,-1) outside
  EXPECT_FLOAT_EQ(y[5], 0.5f + 11 + 2 * 6);  // (1,1): x(2,2)=11, x(1,1)=6
  EXPECT_FLOAT_EQ(y[2], 0.f);                // beyond the 2x2 output: zero logits
}

TEST(Ann2dForward, TransposedConvolutionByHand) {
  // 3x3 stride 2 padding 1 output_padding 1 on 2x2: output 4x4; weight 1 at kernel (1,1) and
  // 3 at (2,2): input (i, j) adds v at (2i, 2j) and 3v at (2i + 1, 2j + 1).
  ModelSpec m = one_layer(LayerKind::ConvTranspose, 2, 1, 1);
  m.layers[0].weight[4] = 1.f;  // [ci 0][co 0][1][1]
  m.layers[0].weight[8] = 3.f;  // [0][0][2][2]
  std::vector<float> f(4 * 4, 0.f);
  f[0] = 1, f[1] = 2, f[2] = 3, f[3] = 4;
  const Ann2dForward net(m);
  const auto y = net.forward(f, 2, 2);  // 4x4 output cropped to the 2x2 input, top-left
  ASSERT_EQ(y.size(), 4u);
  EXPECT_FLOAT_EQ(y[0], 0.5f + 1);      // (0,0) from input (0,0)
  EXPECT_FLOAT_EQ(y[1], 0.5f);          // (0,1): nothing lands there
  EXPECT_FLOAT_EQ(y[3], 0.5f + 3 * 1);  // (1,1) from input (0,0) via kernel (2,2)
}

TEST(Ann2dForward, ReluBetweenLayersNotAfterTheLast) {
  ModelSpec m = ann2d_architecture();
  // Every bias of the hidden layers -1 (ReLU gives 0), the last bias 0.25: logits 0.25.
  for (size_t k = 0; k < m.layers.size(); ++k)
    std::fill(m.layers[k].bias.begin(), m.layers[k].bias.end(),
              k + 1 < m.layers.size() ? -1.f : 0.25f);
  for (auto& l : m.layers) std::fill(l.weight.begin(), l.weight.end(), 0.1f);
  const Ann2dForward net(m);
  const auto y = net.forward(std::vector<float>(4 * 16 * 24, 0.f), 16, 24);
  for (float v : y) ASSERT_FLOAT_EQ(v, 0.25f);
}

TEST(Ann2dModel, FileRoundTripAndValidation) {
  ModelSpec m = ann2d_architecture();
  for (auto& l : m.layers)
    for (size_t i = 0; i < l.bias.size(); ++i) l.bias[i] = 0.01f * float(i);
  m.layers[2].weight[7] = -0.5f;
  const std::string p =
      (std::filesystem::temp_directory_path() / "spikems_ann2d_roundtrip.safetensors").string();
  save_model(p, m);
  const ModelSpec r = load_model(p);
  std::filesystem::remove(p);
  EXPECT_EQ(r.type, ModelType::ANN2D);
  ASSERT_EQ(r.layers.size(), 6u);
  EXPECT_EQ(r.layers[2].weight, m.layers[2].weight);
  EXPECT_EQ(r.layers[5].bias, m.layers[5].bias);
  EXPECT_EQ(r.layers[0].in_channels, 4);
  // Missing biases, biases on a spiking model, a wrong input width: errors.
  ModelSpec bad = m;
  bad.layers[1].bias.clear();
  EXPECT_THROW(bad.validate("t"), Error);
  ModelSpec snn = spikems_architecture(true);
  snn.layers[0].bias.assign(16, 0.f);
  EXPECT_THROW(snn.validate("t"), Error);
  EXPECT_THROW(Ann2dForward{spikems_architecture(true)}, Error);
  EXPECT_THROW(Ann2dForward(m).forward(std::vector<float>(10), 4, 4), Error);
}

TEST(Ann2dModel, HistoryRoundTripsAndSetsTheInputChannels) {
  ModelSpec m = ann2d_architecture({16, 32}, false, {}, 3);
  EXPECT_EQ(m.ann_history, 3);
  EXPECT_EQ(m.layers[0].in_channels, 16);  // 4 features x (the window + 3 past frames)
  m.layers[0].weight[5] = 0.25f;
  const std::string p =
      (std::filesystem::temp_directory_path() / "spikems_ann2d_history.safetensors").string();
  save_model(p, m);
  const ModelSpec r = load_model(p);
  std::filesystem::remove(p);
  EXPECT_EQ(r.ann_history, 3);
  EXPECT_EQ(r.layers[0].weight, m.layers[0].weight);
  // Inputs of the wrong width: 4 channels for a model that reads 16.
  EXPECT_THROW(Ann2dForward(r).forward(std::vector<float>(4 * 8 * 8), 8, 8), Error);
  EXPECT_EQ(Ann2dForward(r).forward(std::vector<float>(16 * 8 * 8), 8, 8).size(), 64u);
  ModelSpec bad = m;  // history and first-layer channels disagree
  bad.ann_history = 2;
  EXPECT_THROW(bad.validate("t"), Error);
  ModelSpec snn = spikems_architecture(true);  // a spiking network keeps its own past
  snn.ann_history = 1;
  EXPECT_THROW(snn.validate("t"), Error);
  EXPECT_THROW(ann2d_architecture({16}, false, {}, kMaxAnnHistory + 1), Error);
  EXPECT_THROW(ann2d_architecture({16}, false, {}, -1), Error);
}

}  // namespace
}  // namespace spikems
