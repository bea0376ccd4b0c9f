// The machine's memory as the streaming runtime sees it: the latency of dependent random loads
// (a pointer chase through a random cycle of cache lines) and the throughput of independent
// random loads, over working sets of 0.25 to 64 MiB. The runtime's per-step state is a few
// megabytes out of ~16 MB; these figures tell where the cache ends on the machine at hand
// (docs/performance.md, "Streaming runtime"). Baseline in the same program: the 0.25 MiB
// working set (L2-resident), against which the counters give the ratio.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "core/util/huge_buffer.h"

namespace {

constexpr size_t kLine = 64;

struct Chase {
  spikems::HugeBuffer<uint64_t> mem;  // one "next line" index per line, 8 words per line
  size_t lines = 0;
  explicit Chase(size_t bytes) : mem(bytes / sizeof(uint64_t)), lines(bytes / kLine) {
    std::vector<uint64_t> order(lines);
    std::iota(order.begin(), order.end(), 0);
    std::mt19937_64 rng(7);
    std::shuffle(order.begin(), order.end(), rng);
    for (size_t i = 0; i < lines; ++i) mem[order[i] * 8] = order[(i + 1) % lines];
  }
};

// ns per load, and the ratio to the first (smallest, baseline) size of the same family, which
// Google Benchmark runs first.
void report(benchmark::State& state, double seconds, double loads, double& base_ns) {
  const double ns = seconds * 1e9 / loads;
  if (state.range(0) == 1) base_ns = ns;  // the baseline size runs first (last call kept)
  state.counters["ns_per_load"] = ns;
  state.counters["x_baseline"] = ns / base_ns;
  state.counters["MiB"] = double(state.range(0)) / 4;
}

void BM_DependentRandomLoad(benchmark::State& state) {
  const size_t bytes = size_t(state.range(0)) << 18;  // quarter MiB units
  Chase c(bytes);
  uint64_t cur = 0;
  const int kHops = 1 << 20;
  double seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < kHops; ++i) cur = c.mem[cur * 8];
    benchmark::DoNotOptimize(cur);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  static double base_ns = 0;
  report(state, seconds, double(state.iterations()) * kHops, base_ns);
}

// Independent loads at random lines: how many misses overlap.
void BM_IndependentRandomLoad(benchmark::State& state) {
  const size_t bytes = size_t(state.range(0)) << 18;
  Chase c(bytes);
  std::vector<uint32_t> idx(1 << 20);
  std::mt19937 rng(3);
  for (auto& i : idx) i = uint32_t(rng() % c.lines);
  uint64_t sum = 0;
  double seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    for (uint32_t i : idx) sum += c.mem[size_t(i) * 8];
    benchmark::DoNotOptimize(sum);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  static double base_ns = 0;
  report(state, seconds, double(state.iterations()) * double(idx.size()), base_ns);
}

void sizes(benchmark::internal::Benchmark* b) {
  for (int q : {1, 4, 8, 12, 16, 24, 32, 64, 256}) b->Arg(q);  // x 0.25 MiB
}
BENCHMARK(BM_DependentRandomLoad)->Apply(sizes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IndependentRandomLoad)->Apply(sizes)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
