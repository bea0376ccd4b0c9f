// splitmix64 (Steele, Lea & Flood 2014; the seeding generator of xoshiro): a 64-bit mixing
// function that turns structured seeds (a global seed and an index) into independent ones.
#pragma once

#include <cstdint>

namespace spikems {

inline uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace spikems
