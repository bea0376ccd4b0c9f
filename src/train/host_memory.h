// How the trainer's process keeps freed host memory (glibc's allocator).
#pragma once

namespace spikems::train {

// Keeps freed memory in the process for reuse instead of returning it to the kernel. A training
// step allocates and frees tensors of hundreds of MB (a whole-frame batch: T x B x C x H x W
// floats per layer); glibc maps each block above its mmap threshold anew and unmaps it on free,
// so every step faults in and zeroes all of its pages again: on the 2-core VM that was half of
// the CPU time (sys) and 2.5-3x the step time of configs/train/deep.toml (docs/performance.md).
// Peak resident memory grows by what one step frees (measured +33-35 %). Returns false where the
// C library offers no such setting (not glibc).
bool keep_freed_memory();

}  // namespace spikems::train
