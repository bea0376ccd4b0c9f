// LibTorch's intra-op thread count (Debian's build starts with 1 thread).
#pragma once

namespace spikems::train {

// n <= 0: the number of hardware threads. Returns the count in effect.
int set_torch_threads(int n);

}  // namespace spikems::train
