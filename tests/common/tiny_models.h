// Hand-built models for tests: a 1x1 convolution from the two polarity channels to two output
// channels with the given weights [out][in], FIR kernels sampled from the default neuron. With
// eps[0] = 0 and eps[1] = 0.82 > theta, an input spike on a weight-1 path makes an output spike
// one step later (one step per layer).
#pragma once

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

}  // namespace spikems::test
