// Read throughput of the research formats (text, npz stored/deflate, spikems-h5), through the
// same open_reader() path the commands use (detection, decoding, validation). Each benchmark
// also times memcpy of the file's bytes in the same process and reports the ratio
// (x_memcpy = read time / memcpy time: how far each format is from a raw copy). Times are
// thread CPU time; Mev_per_s is events per CPU second.
//   ./bench_formats_research --benchmark_min_time=1
#include <benchmark/benchmark.h>

#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>

#include <unistd.h>

#include "core/events/io.h"
#include "core/util/byte_source.h"

namespace {

using namespace spikems;
namespace fs = std::filesystem;

constexpr size_t kEvents = 2'000'000;

// A recording with a realistic mix: increasing time, spread coordinates, labels.
const std::string& dataset_dir() {
  static const std::string dir = [] {
    fs::path d = fs::temp_directory_path() / ("spikems_bench_formats_" + std::to_string(getpid()));
    fs::create_directories(d);
    Recording r;
    r.events.sensor = {346, 260};
    uint64_t s = 12345;
    int64_t t = 0;
    for (size_t i = 0; i < kEvents; ++i) {
      s = s * 6364136223846793005ULL + 1442695040888963407ULL;
      t += int64_t((s >> 60) & 7);
      r.events.push_back(t, uint16_t((s >> 20) % 346), uint16_t((s >> 40) % 260),
                         uint8_t((s >> 33) & 1), uint16_t((s >> 50) % 3));
    }
    auto write = [&](const char* name, const char* format, const char* comp) {
      WriteOptions o;
      o.compression = comp;
      write_recording((d / name).string(), r, o, format);
    };
    write("ev.txt", "text", "");
    write("stored.npz", "npz", "none");
    write("deflate.npz", "npz", "deflate");
    write("deflate.h5", "spikems-h5", "deflate");
    write("none.h5", "spikems-h5", "none");
    return d.string();
  }();
  return dir;
}

// Thread CPU time: the benchmark machine is shared, so wall time measures the neighbours.
double cpu_now() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double memcpy_seconds(size_t bytes) {
  std::vector<uint8_t> a(bytes, 1), b(bytes);
  double best = 1e9;
  for (int rep = 0; rep < 5; ++rep) {
    double t0 = cpu_now();
    std::memcpy(b.data(), a.data(), bytes);
    benchmark::DoNotOptimize(b.data());
    benchmark::ClobberMemory();
    best = std::min(best, cpu_now() - t0);
  }
  return best;
}

void read_file(benchmark::State& state, const char* name) {
  const std::string path = dataset_dir() + "/" + name;
  const size_t bytes = fs::file_size(path);
  const double copy = memcpy_seconds(bytes);
  double total = 0;
  for (auto _ : state) {
    double t0 = cpu_now();
    auto r = open_reader(path);
    EventStream chunk;
    size_t n = 0, got;
    while ((got = r->read(chunk, kReadChunk)) > 0) {
      n += got;
      benchmark::DoNotOptimize(chunk.t.data());
      chunk.clear();
    }
    if (n != kEvents) state.SkipWithError("wrong event count");
    total += cpu_now() - t0;
  }
  const double per_iter = total / double(state.iterations());
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(kEvents));
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(bytes));
  state.counters["Mev_per_s"] = double(kEvents) / per_iter / 1e6;
  state.counters["file_MB"] = double(bytes) / 1e6;
  state.counters["x_memcpy"] = per_iter / copy;
}

void BM_ReadText(benchmark::State& s) {
  read_file(s, "ev.txt");
}
void BM_ReadNpzStored(benchmark::State& s) {
  read_file(s, "stored.npz");
}
void BM_ReadNpzDeflate(benchmark::State& s) {
  read_file(s, "deflate.npz");
}
void BM_ReadSpikemsH5Deflate(benchmark::State& s) {
  read_file(s, "deflate.h5");
}
void BM_ReadSpikemsH5None(benchmark::State& s) {
  read_file(s, "none.h5");
}

// The baseline by itself: memcpy of as many bytes as the npz (stored) file.
void BM_MemcpyStoredNpzBytes(benchmark::State& state) {
  const size_t bytes = fs::file_size(dataset_dir() + "/stored.npz");
  std::vector<uint8_t> a(bytes, 1), b(bytes);
  for (auto _ : state) {
    std::memcpy(b.data(), a.data(), bytes);
    benchmark::DoNotOptimize(b.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(bytes));
}

BENCHMARK(BM_MemcpyStoredNpzBytes)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadText)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadNpzStored)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadNpzDeflate)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadSpikemsH5Deflate)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadSpikemsH5None)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  fs::remove_all(dataset_dir());
  return 0;
}
