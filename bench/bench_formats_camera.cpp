// Decode throughput of the camera formats, from memory on one core, in million events per
// second, beside a memcpy of the same bytes in the same program (the ratio says how far a
// decoder is from the cost of merely touching its input).
//   ./bench_formats_camera --benchmark_counters_tabular=true
// Inputs: the real files of ../shared/data/formats (repeated to ~64 MB where small) and a
// synthetic EVT 3.0 / AEDAT 4.0 recording written by spikems' own writers.
#include <benchmark/benchmark.h>

#include <cstring>
#include <filesystem>
#include <random>

#include "core/events/io.h"
#include "core/util/byte_source.h"

namespace spikems {
namespace {

struct Input {
  std::string format;
  std::vector<uint8_t> bytes;
  uint64_t events = 0;
};

// Decodes everything once (to count events) and returns the input.
Input load(const std::string& format, std::vector<uint8_t> bytes) {
  Input in{format, std::move(bytes), 0};
  auto r =
      find_format(format)->open_bytes(open_memory_source(in.bytes.data(), in.bytes.size()), {});
  EventStream out;
  size_t n;
  while ((n = r->read(out, kReadChunk)) > 0) {
    in.events += n;
    out.clear();
  }
  return in;
}

std::string shared(const std::string& name) {
  return std::string(SPIKEMS_SHARED_DIR) + "/data/formats/" + name;
}

// A synthetic recording: 8M events at ~20 Mev/s, rows of activity as a moving edge makes.
EventStream synthetic(SensorSize s) {
  std::mt19937 rng(1);
  EventStream e;
  e.sensor = s;
  int64_t t = 0;
  while (e.size() < 8000000) {
    t += 1;
    int rows = 1 + rng() % 8;
    for (int r = 0; r < rows; ++r) {
      uint16_t y = uint16_t(rng() % s.height), x = uint16_t(rng() % (s.width - 64));
      uint8_t p = uint8_t(rng() & 1);
      int len = 1 + rng() % 24;
      for (int k = 0; k < len; ++k, x = uint16_t(x + 1 + rng() % 2)) e.push_back(t, x, y, p);
    }
  }
  return e;
}

std::vector<uint8_t> written(const EventStream& e, const std::string& ext,
                             const std::string& compression) {
  std::string path = (std::filesystem::temp_directory_path() /
                      ("spikems_bench_camera_" + std::to_string(getpid()) + ext))
                         .string();
  WriteOptions opt;
  opt.compression = compression;
  auto w = open_writer(path, e.sensor, opt);
  w->write(e);
  w->close();
  auto b = read_file_bytes(path);
  std::filesystem::remove(path);
  return b;
}

const std::vector<Input>& inputs() {
  static std::vector<Input> v = [] {
    std::vector<Input> v;
    for (auto [file, fmt] :
         std::vector<std::pair<std::string, std::string>>{{"evt2_sample.raw", "evt2"},
                                                          {"evt3_sample.raw", "evt3"},
                                                          {"sample_ncars.dat", "dat"},
                                                          {"sample.aedat4", "aedat4"},
                                                          {"dvs.es", "es"}}) {
      if (!std::filesystem::exists(shared(file))) continue;
      v.push_back(load(fmt, read_file_bytes(shared(file))));
    }
    EventStream s = synthetic({1280, 720});
    v.push_back(load("evt3", written(s, ".raw", "")));
    v.back().format = "evt3_synthetic";
    v.push_back(load("aedat4", written(s, ".aedat4", "lz4")));
    v.back().format = "aedat4_lz4_synthetic";
    v.push_back(load("aedat4", written(s, ".aedat4", "zstd")));
    v.back().format = "aedat4_zstd_synthetic";
    return v;
  }();
  return v;
}

std::string base_format(const std::string& name) {
  return name.substr(0, name.find('_'));
}

void BM_Decode(benchmark::State& state) {
  const Input& in = inputs()[size_t(state.range(0))];
  state.SetLabel(in.format);
  const FormatInfo* f = find_format(base_format(in.format));
  EventStream out;
  out.reserve(kReadChunk + 1024);
  for (auto _ : state) {
    auto r = f->open_bytes(open_memory_source(in.bytes.data(), in.bytes.size()), {});
    while (r->read(out, kReadChunk) > 0) {
      benchmark::DoNotOptimize(out.t.data());
      out.clear();
    }
  }
  state.counters["Mev_per_s"] =
      benchmark::Counter(double(in.events) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["MB_per_s"] = benchmark::Counter(double(in.bytes.size()) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
  state.counters["events"] = double(in.events);
}

// Baseline: memcpy of the same bytes into a buffer of the same size.
void BM_Memcpy(benchmark::State& state) {
  const Input& in = inputs()[size_t(state.range(0))];
  state.SetLabel(in.format);
  std::vector<uint8_t> dst(in.bytes.size());
  for (auto _ : state) {
    std::memcpy(dst.data(), in.bytes.data(), in.bytes.size());
    benchmark::ClobberMemory();
  }
  state.counters["MB_per_s"] = benchmark::Counter(double(in.bytes.size()) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

void register_all() {
  for (size_t i = 0; i < inputs().size(); ++i) {
    benchmark::RegisterBenchmark(("decode/" + inputs()[i].format).c_str(), BM_Decode)
        ->Arg(int64_t(i))
        ->Unit(benchmark::kMillisecond)
        ->MinTime(0.5);
    benchmark::RegisterBenchmark(("memcpy/" + inputs()[i].format).c_str(), BM_Memcpy)
        ->Arg(int64_t(i))
        ->Unit(benchmark::kMillisecond)
        ->MinTime(0.5);
  }
}

}  // namespace
}  // namespace spikems

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  spikems::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
