// ANN-to-SNN weight transfer (weight_init.h, ann_weight_directions; model.init_ann): each
// layer of an ANN-2D model starts the spiking network of the same hourglass, and the data
// initialisation then scales each layer without changing its pattern.
#include <gtest/gtest.h>

#include <cmath>

#include "core/model/model_file.h"
#include "core/util/error.h"
#include "train/network/ann2d_network.h"
#include "train/network/spikems_network.h"
#include "train/trainer/weight_init.h"

namespace spikems::train {
namespace {

// An ANN-2D of the given widths with random weights and biases.
ModelSpec random_ann(const std::vector<int>& widths, bool skips = false, int history = 0) {
  ModelSpec a = ann2d_architecture(widths, skips, {}, history);
  for (auto& l : a.layers) {
    const torch::Tensor w = torch::randn({l.weight_count()});
    l.weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
    const torch::Tensor b = torch::randn({int64_t(l.out_channels)});
    l.bias.assign(b.data_ptr<float>(), b.data_ptr<float>() + b.numel());
  }
  return a;
}

torch::Tensor weights_of(const LayerSpec& l) {
  const bool t = l.kind == LayerKind::ConvTranspose;
  return torch::tensor(l.weight).reshape(
      {t ? l.in_channels : l.out_channels, t ? l.out_channels : l.in_channels, l.kernel, l.kernel});
}

// A teacher with past frames starts the student from its weights for the window's own frame
// (input channels 0-3); the rest of the hourglass maps as without history.
TEST(AnnWeightTransfer, ATeacherWithHistoryGivesItsOwnFramesWeights) {
  torch::manual_seed(23);
  const ModelSpec hist = random_ann({4, 8}, false, 2);
  ASSERT_EQ(hist.layers[0].in_channels, 12);
  ModelSpec plain = ann2d_architecture({4, 8});
  plain.layers = hist.layers;
  plain.ann_history = 0;
  plain.layers[0].in_channels = 4;
  plain.layers[0].weight.clear();  // [out, 12, 3, 3] -> [out, 4, 3, 3]: the first 4 inputs
  const torch::Tensor w = weights_of(hist.layers[0]).narrow(1, 0, 4).contiguous();
  plain.layers[0].weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
  const ModelSpec snn = spikems_architecture(true, Discretisation::IIR, {4, 8});
  const auto a = ann_weight_directions(hist, snn, "test");
  const auto b = ann_weight_directions(plain, snn, "test");
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) EXPECT_TRUE(torch::equal(a[k], b[k])) << "layer " << k;
}

TEST(AnnWeightTransfer, MapsEachLayerAsDocumented) {
  torch::manual_seed(21);
  const ModelSpec ann = random_ann({4, 8, 8});
  const ModelSpec snn = spikems_architecture(true, Discretisation::IIR, {4, 8, 8}, {}, true);
  const std::vector<torch::Tensor> d = ann_weight_directions(ann, snn, "test");
  ASSERT_EQ(d.size(), snn.layers.size());
  for (size_t k = 0; k < d.size(); ++k) {
    SCOPED_TRACE("layer " + std::to_string(k));
    const LayerSpec &a = ann.layers[k], &s = snn.layers[k];
    const torch::Tensor wa = weights_of(a);
    EXPECT_EQ(d[k].sizes(), weights_of(s).sizes());
    if (k == 0) {
      // The analytic case: one spike of each polarity in a one-step window gives the ANN the
      // features (ln 2, ln 2, 1/2, 1/2) at that pixel (ann_features.h); the ANN's pre-activation
      // without bias is then the SNN's weights applied to the two spikes.
      const torch::Tensor spikes = (torch::rand({1, 2, 8, 8}) < 0.4).to(torch::kFloat);
      const torch::Tensor feat =
          torch::cat({std::log(2.0) * spikes, 0.5 * spikes}, 1);  // channels OFF, ON, tOFF, tON
      const torch::Tensor ya = torch::conv2d(feat, wa, {}, 2, 1);
      const torch::Tensor ys = torch::conv2d(spikes, d[k], {}, 2, 1);
      EXPECT_LT((ya - ys).abs().max().item<double>(), 1e-5);
    } else if (k + 1 == d.size()) {
      // The output: the one logit channel in both output channels, the skip's inputs zero.
      const int pred = a.in_channels;
      for (int o = 0; o < 2; ++o)
        EXPECT_TRUE(torch::equal(d[k].narrow(0, 0, pred).narrow(1, o, 1), wa));
      EXPECT_EQ(d[k].narrow(0, pred, s.in_channels - pred).abs().sum().item<double>(), 0.0);
    } else if (s.skip_from >= 0) {
      const int pred = a.in_channels;
      EXPECT_GT(s.in_channels, pred);
      EXPECT_TRUE(torch::equal(d[k].narrow(0, 0, pred), wa));
      EXPECT_EQ(d[k].narrow(0, pred, s.in_channels - pred).abs().sum().item<double>(), 0.0);
    } else {
      EXPECT_TRUE(torch::equal(d[k], wa));
    }
  }
  // Other widths, another depth, a spiking model: refused, naming the source.
  auto message = [](const ModelSpec& a, const ModelSpec& s) {
    try {
      ann_weight_directions(a, s, "model.init_ann: x.safetensors");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message(random_ann({4, 8, 16}), snn).find("model.init_ann: x.safetensors: layer 2"),
            std::string::npos);
  EXPECT_NE(message(random_ann({4, 8}), snn).find("4 layers, the network 6"), std::string::npos);
  EXPECT_NE(message(snn, snn).find("not an ANN-2D"), std::string::npos);
}

// A teacher with the student's skips passes its skip weights on too: every layer but the first
// (polarities, analytic case above) and the last (one logit broadcast) is the ANN's exactly.
TEST(AnnWeightTransfer, ATeacherWithSkipsFillsTheSkipChannels) {
  torch::manual_seed(23);
  const ModelSpec ann = random_ann({4, 8, 8}, true);
  const ModelSpec snn = spikems_architecture(true, Discretisation::IIR, {4, 8, 8}, {}, true);
  const std::vector<torch::Tensor> d = ann_weight_directions(ann, snn, "test");
  for (size_t k = 1; k + 1 < d.size(); ++k)
    EXPECT_TRUE(torch::equal(d[k], weights_of(ann.layers[k]))) << k;
  const torch::Tensor wl = weights_of(ann.layers.back());  // [4 + 4, 1, 3, 3]
  for (int o = 0; o < 2; ++o) EXPECT_TRUE(torch::equal(d.back().narrow(1, o, 1), wl)) << o;
  EXPECT_GT(d.back().narrow(0, 4, 4).abs().sum().item<double>(), 0.0);  // the skip's part
  // A student with only some of the teacher's skips is refused at the first that differs.
  const ModelSpec some = spikems_architecture(true, Discretisation::IIR, {4, 8, 8}, {}, true, {2});
  EXPECT_THROW(ann_weight_directions(ann, some, "test"), Error);
}

TEST(AnnWeightTransfer, DataInitKeepsEachLayersPattern) {
  torch::manual_seed(22);
  at::set_num_threads(1);
  const ModelSpec ann = random_ann({4, 8});
  SpikeMSNetwork net(spikems_architecture(true, Discretisation::IIR, {4, 8}, {}, true));
  const std::vector<torch::Tensor> d = ann_weight_directions(ann, net->to_spec(), "test");
  const torch::Tensor input = (torch::rand({12, 2, 2, 16, 16}) < 0.15).to(torch::kFloat);
  const std::vector<double> rates = {0.05, 0.05, 0.05, 0.03};
  const std::vector<double> reached = init_weights_from_data(net, input, rates, 1.0, 3, d);
  for (size_t k = 0; k < d.size(); ++k) {
    SCOPED_TRACE("layer " + std::to_string(k));
    const torch::Tensor w = net->layer(k)->weight.detach().flatten(), v = d[k].flatten();
    // A positive multiple of the ANN's pattern: cosine 1.
    const double cos = (w.dot(v) / (w.norm() * v.norm())).item<double>();
    EXPECT_NEAR(cos, 1.0, 1e-5);
    // The bisection reaches the target from above within its resolution (or the layer's input
    // is too sparse to; then it is at least not silent).
    EXPECT_GT(reached[k], 0.0);
  }
  // A direction of the wrong shape is refused.
  std::vector<torch::Tensor> bad = d;
  bad[1] = bad[1].narrow(0, 0, 2);
  EXPECT_THROW(init_weights_from_data(net, input, rates, 1.0, 3, bad), std::exception);
}

}  // namespace
}  // namespace spikems::train
