// A dense, time-major float tensor [T, C, H, W] of spikes or potentials, for the dense reference
// forward and for tests. The streaming runtime never materialises one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace spikems {

struct DenseTensor {
  int T = 0, C = 0, H = 0, W = 0;
  std::vector<float> v;  // spikes are 0 or 1

  DenseTensor() = default;
  DenseTensor(int t, int c, int h, int w) : T(t), C(c), H(h), W(w), v(size_t(t) * c * h * w, 0.f) {}
  size_t index(int t, int c, int y, int x) const { return ((size_t(t) * C + c) * H + y) * W + x; }
  float& at(int t, int c, int y, int x) { return v[index(t, c, y, x)]; }
  float at(int t, int c, int y, int x) const { return v[index(t, c, y, x)]; }
  size_t frame_size() const { return size_t(C) * H * W; }
  double sum() const {
    double s = 0;
    for (float f : v) s += f;
    return s;
  }
};

}  // namespace spikems
