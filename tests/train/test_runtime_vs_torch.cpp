// The event-driven runtime (core, no LibTorch) against the LibTorch dense forward of src/train
// (forward_all_layers): per layer on the same input spikes (teacher forced) and end to end.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <tuple>

#include "core/runtime/streaming_network.h"
#include "train/network/spikems_network.h"

namespace spikems {
namespace {

ModelSpec random_model(Discretisation d, uint32_t seed, const std::vector<int>& widths,
                       bool skips = false, float gain = 1.f, bool same_step = false) {
  ModelSpec m = spikems_architecture(true, d, widths, {}, skips);
  if (same_step)
    for (auto& l : m.layers) l.neuron.srm_onset = SrmOnset::SameStep;
  std::mt19937 rng(seed);
  for (auto& l : m.layers) {
    std::normal_distribution<float> g(0.25f * gain / float(l.in_channels),
                                      gain / std::sqrt(float(l.in_channels) * 9));
    for (auto& w : l.weight) w = g(rng);
  }
  fill_fir_kernels(m);
  return m;
}

// [T, 1, C, H, W] spikes -> per-step channels-last neuron indices.
std::vector<std::vector<uint32_t>> to_steps(const torch::Tensor& x) {
  auto a = x.contiguous();
  const int64_t T = a.size(0), C = a.size(2), H = a.size(3), W = a.size(4);
  const float* p = a.data_ptr<float>();
  std::vector<std::vector<uint32_t>> s(static_cast<size_t>(T));
  for (int64_t t = 0; t < T; ++t)
    for (int64_t c = 0; c < C; ++c)
      for (int64_t y = 0; y < H; ++y)
        for (int64_t xx = 0; xx < W; ++xx)
          if (p[(((t * C) + c) * H + y) * W + xx] != 0)
            s[size_t(t)].push_back(uint32_t((y * W + xx) * C + c));
  return s;
}

struct Cmp {
  int mismatches = 0, far = 0, torch_spikes = 0;
};

// Runs one streaming layer on `in` and compares every step with torch's output spikes. A
// SameStep layer's spikes of step t are those its step(t) computes (labelled t + 1 inside it).
Cmp compare_layer(const LayerSpec& l, double ts, const torch::Tensor& in, const torch::Tensor& want,
                  double near) {
  const int64_t lead = l.neuron.srm_onset == SrmOnset::SameStep ? 1 : 0;
  auto sl = StreamingLayer::create(l, ts, int(in.size(3)), int(in.size(4)));
  sl->record_potentials(true);
  auto steps = to_steps(in);
  auto w = want.contiguous();
  const int64_t C = w.size(2), H = w.size(3), W = w.size(4);
  EXPECT_EQ(sl->out_height(), H);
  EXPECT_EQ(sl->out_width(), W);
  const float* p = w.data_ptr<float>();
  Cmp r;
  std::vector<uint32_t> out;
  std::vector<uint8_t> got(size_t(C * H * W));
  for (size_t t = 0; t < steps.size(); ++t) {
    out.clear();
    if (lead) sl->drive(int64_t(t), steps[t].data(), steps[t].size());
    sl->fire(int64_t(t) + lead, out);
    std::fill(got.begin(), got.end(), 0);
    for (uint32_t n : out) got[n] = 1;
    for (int64_t c = 0; c < C; ++c)
      for (int64_t y = 0; y < H; ++y)
        for (int64_t x = 0; x < W; ++x) {
          const bool ts_spike = p[((int64_t(t) * C + c) * H + y) * W + x] != 0;
          r.torch_spikes += ts_spike;
          const uint32_t n = uint32_t((y * W + x) * C + c);
          if (bool(got[n]) != ts_spike) {
            ++r.mismatches;
            if (std::fabs(sl->potential(int64_t(t) + lead, n) - l.neuron.theta) >= near) ++r.far;
          }
        }
    if (!lead) sl->drive(int64_t(t), steps[t].data(), steps[t].size());
  }
  return r;
}

void check(Discretisation d, uint32_t seed, double near,
           const std::vector<int>& widths = {16, 32, 64}) {
  ModelSpec m = random_model(d, seed, widths);
  torch::manual_seed(seed);
  torch::Tensor input = (torch::rand({30, 1, 2, 24, 32}) < 0.05).to(torch::kFloat);
  auto layers = train::forward_all_layers(m, input);
  ASSERT_EQ(layers.size(), m.layers.size());
  torch::Tensor in = input;
  for (size_t k = 0; k < m.layers.size(); ++k) {
    ModelSpec one = m;
    one.layers = {m.layers[k]};
    torch::Tensor want = train::forward_all_layers(one, in)[0];
    Cmp c = compare_layer(m.layers[k], m.time_step_ms, in, want, near);
    std::printf("layer %zu: %d torch spikes, %d mismatches\n", k + 1, c.torch_spikes, c.mismatches);
    EXPECT_GT(c.torch_spikes, 0) << "layer " << k;
    EXPECT_EQ(c.far, 0) << "layer " << k;
    EXPECT_LE(c.mismatches, 3) << "layer " << k;
    in = want;
  }
  EXPECT_GT(layers.back().sum().item<float>(), 20.f);  // not a vacuous comparison
  // End to end.
  StreamingNetwork net(m, 24, 32, true);
  auto steps = to_steps(input);
  auto last = layers.back().contiguous();
  const int64_t C = last.size(2), H = last.size(3), W = last.size(4);
  const float* p = last.data_ptr<float>();
  int mism = 0;
  for (size_t t = 0; t < steps.size(); ++t) {
    std::vector<uint8_t> got(size_t(C * H * W), 0);
    for (uint32_t n : net.step(steps[t])) got[n] = 1;
    for (int64_t c = 0; c < C; ++c)
      for (int64_t y = 0; y < H; ++y)
        for (int64_t x = 0; x < W; ++x)
          mism += bool(got[size_t((y * W + x) * C + c)]) !=
                  (p[((int64_t(t) * C + c) * H + y) * W + x] != 0);
  }
  std::printf("end to end, last layer: %d mismatches\n", mism);
  EXPECT_LE(mism, 30);
}

// Per step, the spikes of a [T, 1, C, H, W] tensor, ascending (the runtime's order).
std::vector<std::vector<uint32_t>> sorted_steps(const torch::Tensor& x) {
  auto s = to_steps(x);
  for (auto& v : s) std::sort(v.begin(), v.end());
  return s;
}

// The U-Net variant (layer 4 takes layers 3 and 1, layer 5 layers 4 and 0) on a 21x13 input,
// which forward_all_layers pads to 23x15 (the fitted size: its outputs are in that geometry,
// 24x16 at the end). The runtime, given the unpadded sensor's spikes, gives the same spikes:
// each layer teacher forced on torch's concatenated input; every layer at every step of the
// whole network through step(); and the output layer's at every step through step_block() on
// one thread and the pipeline on two and three threads. The skips matter: without their
// weights torch's decoder spikes differently.
// The same for SameStep neurons (model.srm_onset): an input spike reaches the output in its own
// step, and the runtime's layers then run one after another within a step.
TEST(RuntimeVsTorch, SkipModelMatchesInEveryPath) {
  for (auto [d, seed, near, same] : {std::tuple{Discretisation::FIR, 25u, 1e-5, false},
                                     std::tuple{Discretisation::IIR, 26u, 1e-4, false},
                                     std::tuple{Discretisation::IIR, 29u, 1e-4, true}}) {
    SCOPED_TRACE(std::string(d == Discretisation::FIR ? "FIR" : "IIR") +
                 (same ? ", same-step onset" : ""));
    const ModelSpec m = random_model(d, seed, {4, 6, 8}, true, 0.3f, same);  // 5-50 % firing
    torch::manual_seed(seed);
    const torch::Tensor input = (torch::rand({40, 1, 2, 13, 21}) < 0.05).to(torch::kFloat);
    const auto layers = train::forward_all_layers(m, input);
    ASSERT_EQ(layers.size(), 6u);
    ASSERT_EQ(layers[0].size(3), 8);  // ceil(15 / 2): the padded input
    ASSERT_EQ(layers[0].size(4), 12);
    ASSERT_EQ(layers.back().size(3), 16);
    ASSERT_EQ(layers.back().size(4), 24);
    // Teacher forced.
    const torch::Tensor padded = torch::constant_pad_nd(input, {0, 2, 0, 2}, 0);
    for (size_t k = 0; k < m.layers.size(); ++k) {
      const int skip = m.layers[k].skip_from;
      const torch::Tensor in = k == 0     ? padded
                               : skip < 0 ? layers[k - 1]
                                          : torch::cat({layers[k - 1], layers[size_t(skip)]}, 2);
      Cmp c = compare_layer(m.layers[k], m.time_step_ms, in, layers[k], near);
      std::printf("layer %zu: %d torch spikes, %d mismatches\n", k + 1, c.torch_spikes,
                  c.mismatches);
      EXPECT_GT(c.torch_spikes, 20) << "layer " << k;
      EXPECT_EQ(c.mismatches, 0) << "layer " << k;
    }
    // The whole network, every layer at every step.
    std::vector<std::vector<std::vector<uint32_t>>> want;
    for (const auto& l : layers) want.push_back(sorted_steps(l));
    const auto steps = to_steps(input);  // the sensor's geometry, (y*21 + x)*2 + p
    const size_t T = steps.size(), L = m.layers.size();
    StreamingNetwork net(m, 13, 21, true);
    for (size_t t = 0; t < T; ++t) {
      net.step(steps[t]);
      for (size_t k = 0; k < L; ++k) {
        auto got = net.layer_spikes(k);
        std::sort(got.begin(), got.end());
        ASSERT_EQ(got, want[k][t]) << "step " << t << " layer " << k;
      }
    }
    // Blocks and the pipeline.
    for (int threads : {1, 2, 3}) {
      StreamingNetwork b(m, 13, 21, true);
      b.set_threads(threads);
      std::vector<std::vector<uint32_t>> got;
      size_t t = 0;
      for (size_t n : {5, 1, 16, 3, 15}) {
        const size_t ready = b.step_block(&steps[t], n);
        for (size_t j = 0; j < ready; ++j) got.push_back(b.block_output(j));
        t += n;
      }
      ASSERT_EQ(t, T);
      while (b.in_flight()) {
        const size_t ready = b.step_block(nullptr, 0);
        for (size_t j = 0; j < ready; ++j) got.push_back(b.block_output(j));
      }
      ASSERT_EQ(got.size(), T) << threads << " threads";
      for (size_t s = 0; s < T; ++s)
        ASSERT_EQ(got[s], want[L - 1][s]) << threads << " threads, step " << s;
    }
    ModelSpec cut = m;
    for (size_t k : {size_t(4), size_t(5)}) {  // convT weights [C_in, C_out, 3, 3]
      LayerSpec& l = cut.layers[k];
      std::fill(
          l.weight.begin() + std::ptrdiff_t(m.layers[k - 1].out_channels) * l.out_channels * 9,
          l.weight.end(), 0.f);
    }
    const auto cut_layers = train::forward_all_layers(cut, input);
    EXPECT_FALSE(torch::equal(cut_layers[4], layers[4]));
    EXPECT_FALSE(torch::equal(cut_layers[5], layers[5]));
  }
}

// The output gate (ModelSpec::output_gate_steps = 3): LibTorch's last layer keeps a spike of step
// t only where the sensor pixel had an input event in steps t-2 .. t (checked by the definition,
// on the 24x16 output of the 21x13 input, whose last rows and columns have none), the other
// layers are untouched; the truncated forward (the trainer's warm-up) gates its window alike;
// and the runtime's outputs equal torch's, step by step and through the pipeline.
TEST(RuntimeVsTorch, OutputGateMatches) {
  const ModelSpec m = random_model(Discretisation::IIR, 26, {4, 6, 8}, true, 0.3f);
  ModelSpec g = m;
  g.output_gate_steps = 3;
  torch::manual_seed(26);
  const torch::Tensor input = (torch::rand({40, 1, 2, 13, 21}) < 0.05).to(torch::kFloat);
  const auto plain = train::forward_all_layers(m, input);
  const auto gated = train::forward_all_layers(g, input);
  const size_t L = m.layers.size();
  for (size_t k = 0; k + 1 < L; ++k) EXPECT_TRUE(torch::equal(plain[k], gated[k])) << k;
  const auto in = input.accessor<float, 5>();
  const auto po = plain.back().accessor<float, 5>();
  const auto go = gated.back().accessor<float, 5>();
  int kept = 0, removed = 0;
  for (int64_t t = 0; t < po.size(0); ++t)
    for (int64_t c = 0; c < po.size(2); ++c)
      for (int64_t y = 0; y < po.size(3); ++y)
        for (int64_t x = 0; x < po.size(4); ++x) {
          bool event = false;
          for (int64_t u = std::max<int64_t>(0, t - 2); u <= t; ++u)
            for (int64_t p = 0; p < 2; ++p)
              event = event || (y < 13 && x < 21 && in[u][0][p][y][x] > 0);
          ASSERT_EQ(go[t][0][c][y][x], event ? po[t][0][c][y][x] : 0.f)
              << "t " << t << " c " << c << " y " << y << " x " << x;
          if (po[t][0][c][y][x] > 0) (event ? kept : removed) += 1;
        }
  EXPECT_GT(kept, 20);
  EXPECT_GT(removed, kept);
  {
    torch::NoGradGuard ng;
    train::SpikeMSNetwork net(g);
    const auto window = net->forward_all_truncated(input, 12);
    EXPECT_TRUE(torch::equal(window.back(), gated.back().narrow(0, 12, 28)));
    EXPECT_TRUE(torch::equal(net->forward(input), gated.back()));
  }
  const auto want = sorted_steps(gated.back());
  const auto steps = to_steps(input);
  StreamingNetwork net(g, 13, 21, true);
  for (size_t t = 0; t < steps.size(); ++t) {
    auto got = net.step(steps[t]);
    std::sort(got.begin(), got.end());
    ASSERT_EQ(got, want[t]) << "step " << t;
  }
  for (int threads : {1, 3}) {
    StreamingNetwork b(g, 13, 21, true);
    b.set_threads(threads);
    std::vector<std::vector<uint32_t>> got;
    for (size_t t = 0; t < steps.size(); t += 8) {
      const size_t ready = b.step_block(&steps[t], 8);
      for (size_t j = 0; j < ready; ++j) got.push_back(b.block_output(j));
    }
    while (b.in_flight()) {
      const size_t ready = b.step_block(nullptr, 0);
      for (size_t j = 0; j < ready; ++j) got.push_back(b.block_output(j));
    }
    ASSERT_EQ(got.size(), steps.size());
    for (size_t t = 0; t < got.size(); ++t) {
      std::sort(got[t].begin(), got[t].end());
      ASSERT_EQ(got[t], want[t]) << threads << " threads, step " << t;
    }
  }
}

// The potential readout (model.readout = "potential"): the output layer without refractory
// (scale_ref = 0) spikes at every step its potential is at or above theta, in torch and in
// the runtime alike, so the runtime labels events by the potential the loss scored.
TEST(RuntimeVsTorch, ReadoutWithoutRefractoryMatches) {
  for (auto [d, seed] :
       {std::tuple{Discretisation::FIR, 27u}, std::tuple{Discretisation::IIR, 28u}}) {
    SCOPED_TRACE(d == Discretisation::FIR ? "FIR" : "IIR");
    ModelSpec m = random_model(d, seed, {4, 6, 8}, true, 0.3f);
    m.layers.back().neuron.scale_ref = 0;
    fill_fir_kernels(m);
    torch::manual_seed(seed);
    const torch::Tensor input = (torch::rand({40, 1, 2, 13, 21}) < 0.05).to(torch::kFloat);
    torch::Tensor u;
    std::vector<torch::Tensor> layers;
    {
      torch::NoGradGuard ng;
      train::SpikeMSNetwork net(m);
      layers = net->forward_all(input, &u);
    }
    const double ts = m.time_step_ms, theta = m.layers.back().neuron.theta;
    ASSERT_EQ(u.sizes(), layers.back().sizes());
    // Torch's output spikes are exactly u >= theta at every step, and some pixel spikes at
    // consecutive steps (which a refractory would forbid).
    EXPECT_TRUE(torch::equal(layers.back() * ts, (u >= theta).to(torch::kFloat)));
    const torch::Tensor o = layers.back();
    const int64_t both = ((o.narrow(0, 1, o.size(0) - 1) > 0) & (o.narrow(0, 0, o.size(0) - 1) > 0))
                             .sum()
                             .item<int64_t>();
    EXPECT_GT(both, 5) << "no output pixel stayed above threshold: the case tests nothing";
    const auto want = sorted_steps(layers.back());
    const auto steps = to_steps(input);
    StreamingNetwork net(m, 13, 21, true);
    int spikes = 0;
    for (size_t t = 0; t < steps.size(); ++t) {
      net.step(steps[t]);
      auto got = net.layer_spikes(m.layers.size() - 1);
      std::sort(got.begin(), got.end());
      spikes += int(got.size());
      ASSERT_EQ(got, want[t]) << "step " << t;
    }
    EXPECT_GT(spikes, 50);
  }
}

TEST(RuntimeVsTorch, FirLayersMatch) {
  check(Discretisation::FIR, 21, 1e-5);
}
TEST(RuntimeVsTorch, IirLayersMatch) {
  check(Discretisation::IIR, 22, 1e-4);
}
// model.channels: widths off the runtime's whole-vector fast path, and a fourth level.
TEST(RuntimeVsTorch, OtherWidthsAndDepthMatch) {
  check(Discretisation::IIR, 23, 1e-4, {8, 24, 40, 48});
  check(Discretisation::FIR, 24, 1e-5, {12, 20});
}

}  // namespace
}  // namespace spikems
