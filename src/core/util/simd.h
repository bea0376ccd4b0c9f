// Function multiversioning for the hot loops: one clone per instruction set, chosen once at
// load time (ifunc), so one binary runs on any x86-64 and still uses AVX2 / AVX-512 where the
// CPU has them. Inner helpers are SPIKEMS_INLINE so that they are compiled into each clone.
// The libraries using this build with -ffp-contract=off: no clone fuses a*b+c, so every
// clone rounds exactly like the portable one and results do not depend on the CPU.
#pragma once

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && \
    !defined(SPIKEMS_NO_MULTIVERSION)
#define SPIKEMS_MULTIVERSION __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define SPIKEMS_MULTIVERSION
#endif

#if defined(__GNUC__) || defined(__clang__)
#define SPIKEMS_INLINE inline __attribute__((always_inline))
#define SPIKEMS_INLINE_LAMBDA __attribute__((always_inline))  // after a lambda's parameters
#else
#define SPIKEMS_INLINE inline
#define SPIKEMS_INLINE_LAMBDA
#endif

// Explicit per-instruction-set entry points, for code that needs intrinsics (target_clones
// compiles one body for all sets, so it cannot use them): a function marked
// SPIKEMS_TARGET_AVX512 / _AVX2 calls SPIKEMS_INLINE templates taking an Isa, which pick
// helpers like at_least_avx512() with `if constexpr`; the caller chooses with
// simd::best_isa() at run time. Those helpers carry the target attribute and are plain
// `inline`, not always_inline: GCC refuses to force an AVX-512 function into a template
// compiled for the baseline, but inlines it once the template sits inside the AVX-512 entry
// point.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__)) && \
    !defined(SPIKEMS_NO_MULTIVERSION)
#define SPIKEMS_HAVE_ISA_TARGETS 1
#define SPIKEMS_TARGET_AVX512 __attribute__((target("avx512f,avx2,bmi,bmi2,popcnt,lzcnt")))
#define SPIKEMS_TARGET_AVX2 __attribute__((target("avx2,bmi,bmi2,popcnt,lzcnt")))
#else
#define SPIKEMS_HAVE_ISA_TARGETS 0
#define SPIKEMS_TARGET_AVX512
#define SPIKEMS_TARGET_AVX2
#endif

#if defined(__GNUC__) || defined(__clang__)
#include <cstdint>
#if SPIKEMS_HAVE_ISA_TARGETS
#include <immintrin.h>
#endif
namespace spikems::simd {

enum class Isa { Default, Avx2, Avx512 };

// The widest set this CPU runs (checked once).
inline Isa best_isa() {
#if SPIKEMS_HAVE_ISA_TARGETS
  static const Isa isa = __builtin_cpu_supports("avx512f") ? Isa::Avx512
                         : __builtin_cpu_supports("avx2")  ? Isa::Avx2
                                                           : Isa::Default;
  return isa;
#else
  return Isa::Default;
#endif
}

// 16 floats as one value (GCC/Clang vector extensions): each clone lowers it to its widest
// registers (one zmm, two ymm or four xmm), and comparisons stay in registers instead of
// going through memory lane by lane. Element-wise arithmetic rounds as the scalar code does.
using F16 = float __attribute__((vector_size(64), aligned(64)));
using I16 = int32_t __attribute__((vector_size(64), aligned(64)));
// The same, for memory that is only float-aligned, read and written through float pointers.
using F16U = float __attribute__((vector_size(64), aligned(4), may_alias));
using I16U = int32_t __attribute__((vector_size(64), aligned(4), may_alias));

SPIKEMS_INLINE F16 load(const float* p) {
  return *reinterpret_cast<const F16U*>(p);
}
SPIKEMS_INLINE void store(float* p, F16 v) {
  *reinterpret_cast<F16U*>(p) = v;
}
SPIKEMS_INLINE I16 load(const int32_t* p) {
  return *reinterpret_cast<const I16U*>(p);
}
// Every lane x. In code compiled for one instruction set, use splat<I>(): GCC 12 compiles a
// vector initialiser written in a function without a target attribute, once inlined into an
// AVX-512 one, to 16 masked broadcasts, one per lane (measured: a third of a layer's time).
SPIKEMS_INLINE F16 splat(float x) {
  return F16{x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x};
}

// Bit i set where v[i] >= th (false for NaN), in registers: the compare selects each lane's
// bit, then halves are OR-ed together.
SPIKEMS_INLINE uint32_t at_least_generic(F16 v, float th) {
  using I8 = int32_t __attribute__((vector_size(32)));
  using I4 = int32_t __attribute__((vector_size(16)));
  const I16 bit = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 32768};
  const I16 m = (v >= th) & bit;
  const I8 h = __builtin_shufflevector(m, m, 0, 1, 2, 3, 4, 5, 6, 7) |
               __builtin_shufflevector(m, m, 8, 9, 10, 11, 12, 13, 14, 15);
  const I4 q =
      __builtin_shufflevector(h, h, 0, 1, 2, 3) | __builtin_shufflevector(h, h, 4, 5, 6, 7);
  return uint32_t(q[0] | q[1] | q[2] | q[3]);
}

#if SPIKEMS_HAVE_ISA_TARGETS
SPIKEMS_TARGET_AVX512 inline uint32_t at_least_avx512(F16 v, float th) {
  return _mm512_cmp_ps_mask(__m512(v), _mm512_set1_ps(th), _CMP_GE_OQ);
}
SPIKEMS_TARGET_AVX2 inline uint32_t at_least_avx2(F16 v, float th) {
  using F8 = float __attribute__((vector_size(32)));
  const __m256 t = _mm256_set1_ps(th);
  const F8 lo = __builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7);
  const F8 hi = __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15);
  return uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(__m256(lo), t, _CMP_GE_OQ))) |
         uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(__m256(hi), t, _CMP_GE_OQ))) << 8;
}
// Writes base + i for each bit i of m, in order, to out (which has 16 spare entries);
// returns the new end.
SPIKEMS_TARGET_AVX512 inline uint32_t* compress_avx512(uint32_t* out, uint32_t m, uint32_t base) {
  const __m512i idx =
      _mm512_add_epi32(_mm512_set1_epi32(int(base)),
                       _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
  _mm512_storeu_si512(out, _mm512_maskz_compress_epi32(__mmask16(m), idx));
  return out + __builtin_popcount(m);
}
#endif

#if SPIKEMS_HAVE_ISA_TARGETS
SPIKEMS_TARGET_AVX512 inline F16 splat_avx512(float x) {
  return F16{x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x};
}
SPIKEMS_TARGET_AVX2 inline F16 splat_avx2(float x) {
  return F16{x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x};
}
#endif
template <Isa I>
SPIKEMS_INLINE F16 splat(float x) {
#if SPIKEMS_HAVE_ISA_TARGETS
  if constexpr (I == Isa::Avx512) return splat_avx512(x);
  if constexpr (I == Isa::Avx2) return splat_avx2(x);
#endif
  return splat(x);
}

// Bit i set where v[i] >= th (false for NaN), with the instructions of I.
template <Isa I>
SPIKEMS_INLINE uint32_t at_least(F16 v, float th) {
#if SPIKEMS_HAVE_ISA_TARGETS
  if constexpr (I == Isa::Avx512) return at_least_avx512(v, th);
  if constexpr (I == Isa::Avx2) return at_least_avx2(v, th);
#endif
  return at_least_generic(v, th);
}
template <Isa I>
SPIKEMS_INLINE uint32_t* compress(uint32_t* out, uint32_t m, uint32_t base) {
#if SPIKEMS_HAVE_ISA_TARGETS
  if constexpr (I == Isa::Avx512) return compress_avx512(out, m, base);
#endif
  for (; m != 0; m &= m - 1) *out++ = base + uint32_t(__builtin_ctz(m));
  return out;
}
}  // namespace spikems::simd
#endif
