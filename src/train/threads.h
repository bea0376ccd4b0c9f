// LibTorch's intra-op thread count (Debian's build starts with 1 thread), and the BLAS
// library's own thread pool.
#pragma once

namespace spikems::train {

// n <= 0: the number of hardware threads. Sets LibTorch's intra-op threads to n and the BLAS
// library's own pool to one thread (limit_blas_threads). Returns LibTorch's count in effect.
int set_torch_threads(int n);

// Debian's LibTorch calls the system BLAS (OpenBLAS where `libopenblas0-pthread` provides
// libblas.so.3) from inside its own parallel regions. OpenBLAS starts one worker per core of
// its own, which then busy-wait (sched_yield) beside LibTorch's OpenMP threads: on the 2-core
// machine a training step with 2 LibTorch threads took 1.4x as long as with the BLAS held to
// one thread, and varied 2x from run to run (docs/performance.md, "BLAS threads"). LibTorch
// parallelises over the batch and the layers' outer loops itself, so the BLAS runs on one
// thread per caller. SPIKEMS_BLAS_THREADS=N (1-1024) asks for N instead; another value throws
// Error. Returns the BLAS's thread count afterwards, or 0 when the BLAS in use has no such
// control (the reference BLAS is single-threaded anyway).
int limit_blas_threads();

// The BLAS's own thread count now (0 when it has no such query): for tests and logs.
int blas_threads();

}  // namespace spikems::train
