// The event-driven runtime (core, no LibTorch) against the LibTorch dense forward of src/train
// (forward_all_layers): per layer on the same input spikes (teacher forced) and end to end.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "core/runtime/streaming_network.h"
#include "train/network/spikems_network.h"

namespace spikems {
namespace {

ModelSpec random_model(Discretisation d, uint32_t seed, const std::vector<int>& widths) {
  ModelSpec m = spikems_architecture(true, d, widths);
  std::mt19937 rng(seed);
  for (auto& l : m.layers) {
    std::normal_distribution<float> g(0.25f / float(l.in_channels),
                                      1.0f / std::sqrt(float(l.in_channels) * 9));
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

// Runs one streaming layer on `in` and compares every step with torch's output spikes.
Cmp compare_layer(const LayerSpec& l, double ts, const torch::Tensor& in, const torch::Tensor& want,
                  double near) {
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
    sl->fire(int64_t(t), out);
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
            if (std::fabs(sl->potential(int64_t(t), n) - l.neuron.theta) >= near) ++r.far;
          }
        }
    sl->drive(int64_t(t), steps[t].data(), steps[t].size());
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
  StreamingNetwork net(m, 24, 32);
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
