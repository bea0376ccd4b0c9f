// Simulator throughput: wall seconds per simulated second of the `mod` preset and events per
// second, adaptive steps against the fixed-step baseline (every step = dt_min) in the same
// program, plus the cost of one rendered frame and the renderer against ReferenceRenderer (the
// first, per-pixel implementation) on the same scenes. Run:
//   build/bench_sim --benchmark_counters_tabular=true
// Figures: docs/performance.md.
#include <benchmark/benchmark.h>

#include <chrono>
#include <ctime>
#include <thread>
#include <vector>

#include "core/sim/presets.h"
#include "core/sim/reference_renderer.h"
#include "core/sim/renderer.h"
#include "core/sim/simulate.h"

using namespace spikems::sim;

namespace {

// CPU seconds of the whole process (all threads): on a shared machine wall time also counts
// other people's work, CPU time does not.
double process_cpu_s() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + double(ts.tv_nsec) * 1e-9;
}

// Simulates two 0.5 s sequences of the mod preset on `workers` threads (each sequence on one
// thread, as `spikems simulate --threads 2` does); reports per simulated second.
void run_sequences(benchmark::State& state, bool fixed, int workers, int64_t dt_min_us = 0) {
  SimConfig cfg = preset_config("mod");
  cfg.duration_us = 500000;
  if (dt_min_us > 0) cfg.dt_min_us = dt_min_us;
  double wall = 0, cpu = 0, sim = 0, events = 0, frames = 0;
  for (auto _ : state) {
    std::vector<SimStats> st(2);
    std::vector<size_t> ev(2);
    auto one = [&](int seq) {
      SimulateOptions o;
      o.fixed_step = fixed;
      o.keep_masks = false;
      auto rec = simulate_sequence(cfg, sequence_seed(2026, seq), o, &st[size_t(seq)]);
      ev[size_t(seq)] = rec.events.size();
    };
    auto t0 = std::chrono::steady_clock::now();
    const double c0 = process_cpu_s();
    if (workers >= 2) {
      std::thread a(one, 0), b(one, 1);
      a.join();
      b.join();
    } else {
      one(0);
      one(1);
    }
    wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    cpu += process_cpu_s() - c0;
    for (int k = 0; k < 2; ++k) {
      sim += double(st[size_t(k)].simulated_us) * 1e-6;
      events += double(ev[size_t(k)]);
      frames += double(st[size_t(k)].frames_rendered);
    }
  }
  state.counters["wall_s_per_sim_s"] = wall / sim;
  state.counters["cpu_s_per_sim_s"] = cpu / sim;
  state.counters["Mevents_per_wall_s"] = events / wall * 1e-6;
  state.counters["Mevents_per_sim_s"] = events / sim * 1e-6;
  state.counters["frames_per_sim_s"] = frames / sim;
}

void BM_ModAdaptive(benchmark::State& s) {
  run_sequences(s, false, int(s.range(0)));
}
void BM_ModFixedStep(benchmark::State& s) {
  run_sequences(s, true, int(s.range(0)));
}
// Fine fixed step (200 us): the accuracy-first baseline.
void BM_ModFixedStep200us(benchmark::State& s) {
  run_sequences(s, true, int(s.range(0)), 200);
}

void BM_RenderFrame(benchmark::State& state) {
  SimConfig cfg = preset_config("mod");
  std::mt19937_64 rng(sequence_seed(2026, 0));
  Camera cam = camera_from_config(cfg);
  Scene scene = make_random_scene(cfg, cam, rng);
  Renderer r(scene, cam, cfg.log_eps);
  Frame f;
  double t = 0;
  for (auto _ : state) {
    r.render(t, f, int(state.range(0)));
    t += 1e-4;
    benchmark::DoNotOptimize(f.log_intensity.data());
  }
  state.counters["Mpixels_per_s"] = benchmark::Counter(
      double(cam.width) * cam.height * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
}

// Renderer against ReferenceRenderer on three mod scenes (seeds sequence_seed(2026, 0..2)),
// 20 frames each over 0.2 s, alternating the two in every iteration so that load from other
// processes hits both alike. Counters: frames and Mpixels per second (thread CPU time of the
// rendering thread, or wall time with T > 1) and the speed-up.
void BM_RendererVsReference(benchmark::State& state) {
  const int threads = int(state.range(0));
  SimConfig cfg = preset_config("mod");
  Camera cam = camera_from_config(cfg);
  std::vector<Scene> scenes;
  for (int seq = 0; seq < 3; ++seq) {
    std::mt19937_64 rng(sequence_seed(2026, seq));
    scenes.push_back(make_random_scene(cfg, cam, rng));
  }
  auto clock = [threads] {
    if (threads > 1)
      return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
          .count();
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + double(ts.tv_nsec) * 1e-9;
  };
  double s_new = 0, s_ref = 0, frames = 0;
  Frame f;
  for (auto _ : state) {
    for (const Scene& sc : scenes) {
      Renderer r(sc, cam, cfg.log_eps);
      ReferenceRenderer ref(sc, cam, cfg.log_eps);
      for (int i = 0; i < 20; ++i) {
        const double t = 0.01 * i;
        double c0 = clock();
        r.render(t, f, threads);
        double c1 = clock();
        ref.render(t, f, threads);
        double c2 = clock();
        benchmark::DoNotOptimize(f.log_intensity.data());
        s_new += c1 - c0;
        s_ref += c2 - c1;
        frames += 1;
      }
    }
  }
  const double px = double(cam.width) * cam.height * 1e-6;
  state.counters["new_frames_per_s"] = frames / s_new;
  state.counters["ref_frames_per_s"] = frames / s_ref;
  state.counters["new_Mpixels_per_s"] = frames * px / s_new;
  state.counters["ref_Mpixels_per_s"] = frames * px / s_ref;
  state.counters["speedup"] = s_ref / s_new;
}

}  // namespace

BENCHMARK(BM_RendererVsReference)->Arg(1)->Arg(2)->Iterations(3)->Unit(benchmark::kSecond);
BENCHMARK(BM_ModAdaptive)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_ModFixedStep)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_ModFixedStep200us)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_RenderFrame)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
