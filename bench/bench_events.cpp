// Event core throughput: binning into spike tensors, window ground truth, time slicing and
// labelling from masks, each against a memcpy of the same event bytes (the floor any pass over
// the events must pay). Run: build/bench_events --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstring>
#include <map>
#include <random>

#include "core/events/binning.h"
#include "core/events/labels.h"

using namespace spikems;

namespace {

constexpr int kW = 346, kH = 260;

// n events spread uniformly over `span_us`, random pixels and polarities, 1/4 labelled.
const EventStream& events(size_t n, int64_t span_us) {
  static std::map<std::pair<size_t, int64_t>, EventStream> cache;
  auto& ev = cache[{n, span_us}];
  if (ev.empty()) {
    std::mt19937_64 rng(42);
    ev.sensor = {kW, kH};
    ev.reserve(n);
    for (size_t i = 0; i < n; ++i)
      ev.push_back(int64_t(i) * span_us / int64_t(n), uint16_t(rng() % kW), uint16_t(rng() % kH),
                   uint8_t(rng() & 1), uint16_t(rng() % 4 == 0 ? 1 + rng() % 3 : 0));
  }
  return ev;
}

// Seconds per memcpy of the event arrays (t, x, y, p, label), best of a few runs.
double memcpy_seconds(const EventStream& ev) {
  size_t bytes = ev.size() * (8 + 2 + 2 + 1 + 2);
  std::vector<uint8_t> src(bytes, 1), dst(bytes);
  double best = 1e9;
  for (int r = 0; r < 7; ++r) {
    auto a = std::chrono::steady_clock::now();
    std::memcpy(dst.data(), src.data(), bytes);
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
    best =
        std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  return best;
}

// Bins the whole stream into consecutive windows of window_us.
void BM_BinEvents(benchmark::State& state) {
  const int64_t span = state.range(0) * 1000, window = 10000;
  const auto& ev = events(1000000, span);
  BinningConfig cfg;
  size_t spikes = 0;
  for (auto _ : state) {
    for (int64_t t0 = 0; t0 < span; t0 += window) {
      SpikeTensor s = bin_events(ev, t0, window, cfg);
      benchmark::DoNotOptimize(s.data.data());
      spikes = s.data.size();
    }
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(ev.size()));
  state.counters["Mev/s"] =
      benchmark::Counter(double(ev.size()) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["memcpy_ms"] = memcpy_seconds(ev) * 1e3;
  state.counters["windows"] = double(span / window);
  state.counters["tensor_MB"] = double(spikes) * 1e-6;
}
// 1 M events over 100 ms (10 windows, 10 M ev/s) and over 1 s (100 windows, 1 M ev/s).
BENCHMARK(BM_BinEvents)->Arg(100)->Arg(1000)->Unit(benchmark::kMillisecond);

void BM_WindowTruth(benchmark::State& state) {
  const int64_t span = 100000, window = 10000;
  const auto& ev = events(1000000, span);
  for (auto _ : state)
    for (int64_t t0 = 0; t0 < span; t0 += window) {
      WindowTruth w = window_truth(ev, t0, window, BinningConfig{}, {1, 2});
      benchmark::DoNotOptimize(w.fg.data());
    }
  state.counters["Mev/s"] =
      benchmark::Counter(double(ev.size()) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["memcpy_ms"] = memcpy_seconds(ev) * 1e3;
}
BENCHMARK(BM_WindowTruth)->Unit(benchmark::kMillisecond);

// The baseline, measured the same way as the others: copy the event arrays.
void BM_MemcpyEvents(benchmark::State& state) {
  const auto& ev = events(1000000, 100000);
  size_t bytes = ev.size() * (8 + 2 + 2 + 1 + 2);
  std::vector<uint8_t> src(bytes, 1), dst(bytes);
  for (auto _ : state) {
    std::memcpy(dst.data(), src.data(), bytes);
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  state.counters["Mev/s"] =
      benchmark::Counter(double(ev.size()) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(bytes));
}
BENCHMARK(BM_MemcpyEvents)->Unit(benchmark::kMillisecond);

// Binary-search lookups of 10 ms windows: the cost of finding a window, without copying.
void BM_TimeRange(benchmark::State& state) {
  const auto& ev = events(1000000, 1000000);
  std::mt19937_64 rng(1);
  size_t sum = 0;
  for (auto _ : state) {
    int64_t t0 = int64_t(rng() % 990000);
    auto [b, e] = ev.time_range(t0, t0 + 10000);
    sum += e - b;
  }
  benchmark::DoNotOptimize(sum);
  state.counters["lookups/s"] =
      benchmark::Counter(1, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_TimeRange);

// slice_time copies the window's events: 10 ms windows of a 1 M ev/s stream (10 k events).
void BM_SliceTime(benchmark::State& state) {
  const auto& ev = events(1000000, 1000000);
  int64_t t0 = 0;
  for (auto _ : state) {
    EventStream s = ev.slice_time(t0, t0 + 10000);
    benchmark::DoNotOptimize(s.t.data());
    t0 = (t0 + 10000) % 990000;
  }
  state.counters["Mev/s"] = benchmark::Counter(0.01, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_SliceTime)->Unit(benchmark::kMicrosecond);

// Labels for 1 M events from 20 mask frames (one object square each), 5x5 dilation.
void BM_LabelFromMasks(benchmark::State& state) {
  const auto& base = events(1000000, 1000000);
  std::vector<MaskFrame> masks;
  for (int f = 0; f < 20; ++f) {
    MaskFrame m;
    m.t_us = f * 50000;
    m.width = kW;
    m.height = kH;
    m.ids.assign(size_t(kW) * kH, 0);
    for (int y = 100; y < 160; ++y)
      for (int x = 10 + f * 10; x < 70 + f * 10; ++x) m.ids[size_t(y) * kW + size_t(x)] = 2;
    masks.push_back(std::move(m));
  }
  LabelOptions opt;
  opt.dilation = int(state.range(0));
  EventStream ev = base;
  for (auto _ : state) {
    label_from_masks(ev, masks, opt);
    benchmark::DoNotOptimize(ev.label.data());
  }
  state.counters["Mev/s"] =
      benchmark::Counter(double(ev.size()) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_LabelFromMasks)->Arg(0)->Arg(5)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
