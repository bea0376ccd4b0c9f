// Cheap float approximations for the per-pixel loops (the build has no -msse4.1, so
// std::floor and std::log are library calls). Accuracy is stated per function; tests compare
// against the std versions.
#pragma once

#include <cstdint>
#include <cstring>

namespace spikems::sim {

// floor for |x| < 2^31.
inline float fast_floor(float x) {
  float t = float(int32_t(x));
  return t > x ? t - 1.f : t;
}

// log2(x) for normal positive x; absolute error < 1e-5 (least-squares degree-6 polynomial of
// log2(1 + y) on y in [0, 1)).
inline float fast_log2(float x) {
  uint32_t b;
  std::memcpy(&b, &x, 4);
  const float e = float(int32_t((b >> 23) & 0xFF) - 127);
  b = (b & 0x007FFFFFu) | 0x3F800000u;
  float m;
  std::memcpy(&m, &b, 4);
  const float y = m - 1.f;
  float p = -0.026067478f;
  p = p * y + 0.121917308f;
  p = p * y - 0.277368220f;
  p = p * y + 0.456895616f;
  p = p * y - 0.717898670f;
  p = p * y + 1.442517053f;
  return e + p * y;
}

inline float fast_log(float x) {
  return fast_log2(x) * 0.69314718f;
}

}  // namespace spikems::sim
