// Hand-built models for tests: a 1x1 convolution from the two polarity channels to two output
// channels with the given weights [out][in], FIR kernels sampled from the default neuron. With
// eps[0] = 0 and eps[1] = 0.82 > theta, an input spike on a weight-1 path makes an output spike
// one step later (one step per layer).
#pragma once

#include <random>
#include <utility>
#include <vector>

#include "core/model/model_file.h"

namespace spikems::test {

inline ModelSpec pointwise_model(std::vector<float> weight, const char* name = "pointwise") {
  ModelSpec m;
  m.name = name;
  LayerSpec l;
  l.in_channels = 2;
  l.out_channels = 2;
  l.kernel = 1;
  l.stride = 1;
  l.weight = std::move(weight);
  m.layers = {l};
  fill_fir_kernels(m);
  return m;
}

// Two 3x3 convolutions (2 -> 4 -> 2 channels, stride 1, padding 1) with weights drawn uniformly
// from [w_lo, w_hi) by a generator seeded with `seed`; FIR kernels of the default neuron.
inline ModelSpec random_conv_model(unsigned seed, float w_lo, float w_hi) {
  ModelSpec m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(w_lo, w_hi);
  for (auto [ci, co] : {std::pair{2, 4}, std::pair{4, 2}}) {
    LayerSpec l;
    l.in_channels = ci;
    l.out_channels = co;
    l.kernel = 3;
    l.stride = 1;
    l.padding = 1;
    l.weight.resize(size_t(l.weight_count()));
    for (auto& w : l.weight) w = u(rng);
    m.layers.push_back(l);
  }
  fill_fir_kernels(m);
  return m;
}

}  // namespace spikems::test
