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
