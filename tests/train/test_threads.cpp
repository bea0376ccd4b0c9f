// The thread settings every LibTorch command applies (train/threads.h).
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstdlib>
#include <string>

#include "core/util/error.h"
#include "train/threads.h"

namespace spikems::train {
namespace {

TEST(Threads, TorchGetsTheThreadsAndTheBlasPoolOne) {
  using Set = void (*)(int);
  const Set set = reinterpret_cast<Set>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  if (set == nullptr || blas_threads() == 0)
    GTEST_SKIP() << "the BLAS in use is not OpenBLAS (no thread pool of its own to limit)";
  set(2);  // as OpenBLAS starts on a 2-core machine
  ASSERT_EQ(blas_threads(), 2);
  EXPECT_EQ(set_torch_threads(2), 2);
  EXPECT_EQ(torch::get_num_threads(), 2);
  EXPECT_EQ(blas_threads(), 1);
  EXPECT_EQ(set_torch_threads(1), 1);
  EXPECT_EQ(blas_threads(), 1);
  // The override, and a bad one named.
  setenv("SPIKEMS_BLAS_THREADS", "3", 1);
  EXPECT_EQ(limit_blas_threads(), 3);
  for (const char* bad : {"0", "two", "4x", "", "100000"}) {
    setenv("SPIKEMS_BLAS_THREADS", bad, 1);
    try {
      limit_blas_threads();
      ADD_FAILURE() << "accepted SPIKEMS_BLAS_THREADS=" << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("SPIKEMS_BLAS_THREADS"), std::string::npos);
    }
  }
  unsetenv("SPIKEMS_BLAS_THREADS");
  EXPECT_EQ(limit_blas_threads(), 1);
}

}  // namespace
}  // namespace spikems::train
