// Where an input coordinate of a convolution lands along one axis, shared by the sparse synapse
// kernels (which scatter each spike to it) and the SynOps count (which counts the landings):
//   conv:             in = out * stride - pad + tap
//   transposed conv:  out = in * stride - pad + tap
#pragma once

#include <cstdint>

namespace spikems::train {

// The output coordinate that input coordinate i reaches through kernel tap `tap`, or -1 where it
// reaches none (off the output's [0, out) or, for a strided conv, between output positions).
inline int64_t tap_output(int64_t i, int64_t tap, int64_t stride, int64_t pad, bool transposed,
                          int64_t out) {
  int64_t o;
  if (transposed) {
    o = i * stride - pad + tap;
  } else {
    const int64_t num = i + pad - tap;
    if (num < 0 || num % stride != 0) return -1;
    o = num / stride;
  }
  return o >= 0 && o < out ? o : -1;
}

}  // namespace spikems::train
