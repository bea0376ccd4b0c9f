// Energy: SynOps counted by the runtime and ANN MACs on small layers counted by hand, borders
// included, and the per-sample arithmetic of the report.
#include <gtest/gtest.h>

#include <algorithm>

#include "core/eval/energy.h"
#include "core/eval/metrics.h"
#include "core/runtime/streaming_network.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// One layer, weights 0.01 (nothing fires; SynOps count the additions all the same).
ModelSpec one_layer(LayerKind kind, int cin, int cout, int output_padding = 0) {
  ModelSpec m;
  LayerSpec l;
  l.kind = kind;
  l.in_channels = cin;
  l.out_channels = cout;
  l.kernel = 3;
  l.stride = 2;
  l.padding = 1;
  l.output_padding = output_padding;
  l.weight.assign(size_t(l.weight_count()), 0.01f);
  m.layers = {l};
  fill_fir_kernels(m);
  return m;
}

// Input neuron of pixel (x, y), polarity p on a width-w input.
uint32_t in(int x, int y, int p, int w) {
  return uint32_t((y * w + x) * 2 + p);
}

uint64_t synops_of(const ModelSpec& m, int h, int w, std::vector<uint32_t> spikes) {
  StreamingNetwork net(m, h, w);
  std::sort(spikes.begin(), spikes.end());
  net.step(spikes);
  net.step({});
  return net.stats()[0].synops;
}

TEST(Energy, ConvSynOpsCountTheNeuronsReachedAtTheBorders) {
  // 3x3, stride 2, padding 1 on 5x5 -> 3x3. Output o sees inputs 2o-1 .. 2o+1, so input x = 0
  // reaches o = 0 only, x = 1 reaches o = 0 and 1, x = 2 reaches o = 1, x = 4 reaches o = 2.
  const ModelSpec m = one_layer(LayerKind::Conv, 2, 3);
  EXPECT_EQ(synops_of(m, 5, 5, {in(0, 0, 0, 5)}), 1u * 3);  // corner: 1 position x 3 channels
  EXPECT_EQ(synops_of(m, 5, 5, {in(1, 1, 1, 5)}), 4u * 3);  // 2 x 2 positions
  EXPECT_EQ(synops_of(m, 5, 5, {in(4, 4, 0, 5)}), 1u * 3);
  EXPECT_EQ(synops_of(m, 5, 5, {in(2, 0, 1, 5)}), 1u * 3);
  EXPECT_EQ(synops_of(m, 5, 5, {in(0, 0, 0, 5), in(1, 1, 1, 5), in(4, 4, 0, 5), in(2, 0, 1, 5)}),
            21u);
  // The ANN: 3x3 output positions x C_out 3 x C_in 2 x 9 taps.
  const auto s = layer_shapes(m, 5, 5);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].out_height, 3);
  EXPECT_EQ(ann_macs(s[0]), 9u * 3 * 2 * 9);
}

TEST(Energy, TransposedConvSynOpsAndMacs) {
  // Transposed 3x3, stride 2, padding 1, output padding 1 on 3x3 -> 6x6. Input i reaches
  // outputs 2i-1 .. 2i+1 inside [0, 6): i = 0 -> {0, 1}, i = 1 -> {1, 2, 3}, i = 2 -> {3, 4, 5}.
  const ModelSpec m = one_layer(LayerKind::ConvTranspose, 2, 3, 1);
  EXPECT_EQ(synops_of(m, 3, 3, {in(0, 0, 0, 3)}), 4u * 3);  // 2 x 2
  EXPECT_EQ(synops_of(m, 3, 3, {in(1, 1, 0, 3)}), 9u * 3);  // 3 x 3
  EXPECT_EQ(synops_of(m, 3, 3, {in(2, 0, 1, 3)}), 6u * 3);  // 3 x 2
  // The ANN: 3x3 input positions x C_in 2 x C_out 3 x 9 taps (cut-off taps counted).
  const auto s = layer_shapes(m, 3, 3);
  EXPECT_EQ(s[0].out_height, 6);
  EXPECT_EQ(ann_macs(s[0]), 9u * 2 * 3 * 9);
  // A 4x5 input: 20 positions.
  EXPECT_EQ(ann_macs(layer_shapes(m, 4, 5)[0]), 20u * 2 * 3 * 9);
  EXPECT_THROW(layer_shapes(one_layer(LayerKind::Conv, 2, 3), 0, 5), Error);
}

TEST(Energy, MacsOfTheWholeAnn2dByHand) {
  // The ANN-2D (model_file.h) at 16 x 24: convs 4->16 at 8x12, 16->32 at 4x6, 32->64 at 2x3
  // (output positions); convTs from 2x3 (64->32), 4x6 (32->16), 8x12 (16->1) (input positions).
  uint64_t total = 0;
  for (const auto& s : layer_shapes(ann2d_architecture(), 16, 24)) total += ann_macs(s);
  EXPECT_EQ(total, 9u * (96 * 4 * 16 + 24 * 16 * 32 + 6 * 32 * 64 + 6 * 64 * 32 + 24 * 32 * 16 +
                         96 * 16 * 1));
}

// A model with skips is counted on the size the runtime pads a 21x13 sensor to (23x15), and
// a decoder layer's input channels include its skip source's.
TEST(Energy, SkipModelShapesAreTheRuntimes) {
  const ModelSpec m = spikems_architecture(true, Discretisation::IIR, {4, 6, 8}, {}, true);
  const auto s = layer_shapes(m, 13, 21);
  ASSERT_EQ(s.size(), 6u);
  EXPECT_EQ(s[0].in_height, 15);
  EXPECT_EQ(s[0].in_width, 23);
  // Layer 4: layer 3's 6 channels and layer 1's 6, at 4x6 -> 8x12.
  EXPECT_EQ(s[4].in_channels, 12);
  EXPECT_EQ(s[4].in_height, 4);
  EXPECT_EQ(s[4].in_width, 6);
  EXPECT_EQ(ann_macs(s[4]), 4u * 6 * 12 * 4 * 9);
  EXPECT_EQ(s[5].out_height, 16);
  EXPECT_EQ(s[5].out_width, 24);
  StreamingNetwork net(m, 13, 21, /*whole=*/true);  // as `energy` runs it
  net.step({in(3, 4, 1, 21)});
  EnergyReport r;
  EXPECT_NO_THROW(fill_layers(r, net, m));  // neuron counts agree with the runtime's layers
  EXPECT_EQ(r.layers[5].neurons, 16u * 24 * 2);
}

TEST(Energy, PerSampleValuesAndEnergy) {
  const ModelSpec m = one_layer(LayerKind::Conv, 2, 3);
  StreamingNetwork net(m, 5, 5);
  net.step({in(0, 0, 0, 5), in(1, 1, 1, 5), in(4, 4, 0, 5)});  // 3 + 12 + 3 = 18 SynOps
  net.step({});
  EnergyReport r;
  fill_layers(r, net, m);
  fill_layers(r, net, m);  // a second sequence with the same counts
  r.window_ms = 10;
  r.seconds = 0.04;  // 4 samples
  r.steps = 2 * 40;
  finish_report(r);
  ASSERT_EQ(r.layers.size(), 1u);
  EXPECT_EQ(r.layers[0].synops, 36u);
  EXPECT_EQ(r.layers[0].in_spikes, 6u);
  EXPECT_EQ(r.layers[0].neurons, 27u);
  EXPECT_DOUBLE_EQ(r.samples, 4.0);
  EXPECT_DOUBLE_EQ(r.synops(), 9.0);
  EXPECT_DOUBLE_EQ(r.ann_macs(), 486.0);
  EXPECT_DOUBLE_EQ(r.snn_pj(), 9.0 * 0.9);
  EXPECT_DOUBLE_EQ(r.ann_pj(), 486.0 * 4.6);
  EXPECT_DOUBLE_EQ(r.benefit(), 486.0 * 4.6 / (9.0 * 0.9));
  const auto j = energy_json(r);
  EXPECT_EQ(j["layers"][0]["ann_macs_per_sample"], 486);
  EXPECT_DOUBLE_EQ(j["per_sample"]["synops"].get<double>(), 9.0);
  EXPECT_NE(energy_table(r).find("58-144"), std::string::npos);  // the paper's row beside
}

}  // namespace
}  // namespace spikems
