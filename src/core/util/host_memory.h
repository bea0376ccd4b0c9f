// How a process keeps freed host memory (glibc's allocator): `spikems train` and the
// streaming commands (`segment`, `eval`, `calibrate`) call it first.
#pragma once

namespace spikems {

// Keeps freed memory in the process for reuse instead of returning it to the kernel. A training
// step allocates and frees tensors of hundreds of MB (a whole-frame batch: T x B x C x H x W
// floats per layer); glibc maps each block above its mmap threshold anew and unmaps it on free,
// so every step faults in and zeroes all of its pages again: on the 2-core VM that was half of
// the CPU time (sys) and 2.5-3x the step time of configs/train/deep.toml (docs/performance.md).
// Peak resident memory grows by what one step frees (measured +33-35 %). The streaming runtime
// frees and allocates event batches, label queues and output chunks of hundreds of KB at every
// block of steps: the same faults, a few percent of `segment`'s time (docs/performance.md,
// "Start-up and output"). Returns false where the C library offers no such setting
// (not glibc).
bool keep_freed_memory();

}  // namespace spikems
