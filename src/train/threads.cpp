#include "train/threads.h"

#include <dlfcn.h>
#include <torch/torch.h>

#include <cstdlib>
#include <string>
#include <thread>

#include "core/util/error.h"

namespace spikems::train {

namespace {
// OpenBLAS's controls, looked up at run time: the library that provides libblas.so.3 is chosen
// by the system (update-alternatives), so none of them may be linked against by name.
template <class F>
F blas_symbol(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_DEFAULT, name));
}
}  // namespace

int blas_threads() {
  using Get = int (*)();
  if (const Get get = blas_symbol<Get>("openblas_get_num_threads")) return get();
  return 0;
}

int limit_blas_threads() {
  using Set = void (*)(int);
  // SPIKEMS_BLAS_THREADS=N gives the pool N threads instead (benchmarks compare with it).
  int n = 1;
  if (const char* e = std::getenv("SPIKEMS_BLAS_THREADS")) {
    char* end = nullptr;
    const long v = std::strtol(e, &end, 10);
    if (end == e || *end != '\0' || v < 1 || v > 1024)
      throw Error("SPIKEMS_BLAS_THREADS must be a whole number from 1 to 1024, not '" +
                  std::string(e) + "'");
    n = int(v);
  }
  if (const Set set = blas_symbol<Set>("openblas_set_num_threads")) set(n);
  return blas_threads();
}

int set_torch_threads(int n) {
  if (n <= 0) n = int(std::max(1u, std::thread::hardware_concurrency()));
  limit_blas_threads();
  torch::set_num_threads(n);
  return torch::get_num_threads();
}

}  // namespace spikems::train
