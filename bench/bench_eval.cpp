// `spikems eval`'s scoring without the network: WindowScorer over 1 M labelled events
// (1 s at 1 M ev/s, 346x260, a quarter moving), windows of 20 and 100 ms, with and without
// each window's moving share (the size bands). Both variants run in this process; the counter
// `ratio_vs_off` is the tracked variant's time over the untracked one's (best of 5 each).
// Run: build/bench_eval --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <random>

#include "core/eval/window_scorer.h"

using namespace spikems;

namespace {

constexpr int kW = 346, kH = 260;

const EventStream& events() {
  static EventStream ev;
  if (ev.empty()) {
    std::mt19937_64 rng(7);
    ev.sensor = {kW, kH};
    const size_t n = 1000000;
    ev.reserve(n);
    for (size_t i = 0; i < n; ++i)
      ev.push_back(int64_t(i), uint16_t(rng() % kW), uint16_t(rng() % kH), uint8_t(rng() & 1),
                   uint16_t(rng() % 4 == 0 ? 1 : 0));
  }
  return ev;
}

// Scores the stream in chunks of 10,000 events (as eval feeds it), no predictions.
double score_once(bool shares) {
  const EventStream& ev = events();
  const auto a = std::chrono::steady_clock::now();
  WindowScorer s(ev.sensor, {20000, 100000});
  s.track_moving_share(shares);
  for (size_t i = 0; i < ev.size(); i += 10000) {
    const EventStream chunk = ev.slice_index(i, std::min(ev.size(), i + 10000));
    s.add_events(chunk);
  }
  s.finish(ev.t_last() + 1);
  benchmark::DoNotOptimize(s.scores().data());
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}

double best_of(bool shares, int runs) {
  double best = 1e9;
  for (int r = 0; r < runs; ++r) best = std::min(best, score_once(shares));
  return best;
}

void BM_ScoreWindows(benchmark::State& state) {
  const bool shares = state.range(0) != 0;
  events();
  for (auto _ : state) benchmark::DoNotOptimize(score_once(shares));
  state.counters["Mev/s"] = benchmark::Counter(double(events().size()) * 1e-6,
                                               benchmark::Counter::kIsIterationInvariantRate);
  state.counters["ratio_vs_off"] = best_of(true, 5) / best_of(false, 5);
}
// 0: without moving shares (--share-bands none), 1: with them (the default).
BENCHMARK(BM_ScoreWindows)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
