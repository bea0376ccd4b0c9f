// Division of 32-bit unsigned integers by a divisor fixed at set-up, by one multiplication
// (the quotient of spike indices by channel count and row width is taken for every spike).
// With m = ceil(2^64 / d) and e = m*d - 2^64 < d, n*m / 2^64 = n/d + n*e / (d * 2^64); the
// excess is below n / 2^64 < 1/d for n, d < 2^32, so it never reaches the next integer and
// floor(n*m / 2^64) = floor(n/d) (Granlund and Montgomery, "Division by invariant integers
// using multiplication", PLDI 1994).
#pragma once

#include <cstdint>

namespace spikems {

class FastDiv {
 public:
  FastDiv() = default;
  explicit FastDiv(uint32_t d) : d_(d), m_(d > 1 ? ~uint64_t(0) / d + 1 : 0) {}
  uint32_t divisor() const { return d_; }
  uint32_t operator()(uint32_t n) const {
    if (m_ == 0) return n;  // d == 1
    return uint32_t((static_cast<unsigned __int128>(n) * m_) >> 64);
  }

 private:
  uint32_t d_ = 1;
  uint64_t m_ = 0;
};

}  // namespace spikems
