// The library code that replaced two hand-written parsers, beside the hand-written code it
// replaced (bench/legacy/, compiled into this program only), on the same bytes in the same
// process; the ratios (library time / hand-written time) are printed at the end.
//   ninja -C build bench_formats_libs && build/bench_formats_libs
// - npz: whole archives from memory (every array decoded): libzip (NpzFile) vs the old ZIP
//   reader + parse_npy. Inputs: ../shared/data/formats/poster_translation.npz (numpy,
//   deflate) and synthetic 2M-event archives written stored and deflated.
// - AEDAT 4.0: the FlatBuffers layer alone, on packets decompressed beforehand: the generated
//   Verifier + accessors vs the old bounds-checked FlatView, each copying every event out.
//   Inputs: ../shared/data/formats/sample.aedat4 and a synthetic 2M-event file. Whole-file
//   decodes (new reader, LZ4 included) are given for scale.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <random>

#include "aedat4_events_generated.h"
#include "aedat4_ioheader_generated.h"
#include "core/events/formats/aedat4_common.h"
#include "core/events/formats/npy.h"
#include "core/events/io.h"
#include "core/util/byte_source.h"
#include "legacy/legacy_flatbuffer.h"
#include "legacy/legacy_zip.h"

namespace spikems {
namespace {

std::string shared(const std::string& name) {
  return std::string(SPIKEMS_SHARED_DIR) + "/data/formats/" + name;
}

std::string temp_path(const std::string& ext) {
  return (std::filesystem::temp_directory_path() /
          ("spikems_bench_libs_" + std::to_string(getpid()) + ext))
      .string();
}

EventStream synthetic(size_t n) {
  std::mt19937 rng(3);
  EventStream e;
  e.sensor = {640, 480};
  for (size_t i = 0; i < n; ++i)
    e.push_back(int64_t(i / 4), uint16_t(rng() % 640), uint16_t(rng() % 480), uint8_t(rng() & 1));
  return e;
}

// --- npz ---------------------------------------------------------------------------------

struct NpzInput {
  std::string name;
  std::vector<uint8_t> bytes;
};

const std::vector<NpzInput>& npz_inputs() {
  static std::vector<NpzInput> v = [] {
    std::vector<NpzInput> v;
    if (std::filesystem::exists(shared("poster_translation.npz")))
      v.push_back({"poster_translation", read_file_bytes(shared("poster_translation.npz"))});
    EventStream e = synthetic(2000000);
    std::map<std::string, NpyArray> arrays = {{"t", NpyArray::from(e.t, {int64_t(e.size())})},
                                              {"x", NpyArray::from(e.x, {int64_t(e.size())})},
                                              {"y", NpyArray::from(e.y, {int64_t(e.size())})},
                                              {"p", NpyArray::from(e.p, {int64_t(e.size())})}};
    for (bool deflate : {false, true}) {
      const std::string p = temp_path(".npz");
      write_npz(p, arrays, deflate);
      v.push_back({deflate ? "synthetic_deflate" : "synthetic_stored", read_file_bytes(p)});
      std::filesystem::remove(p);
    }
    return v;
  }();
  return v;
}

void BM_NpzLibzip(benchmark::State& state) {
  const NpzInput& in = npz_inputs()[size_t(state.range(0))];
  for (auto _ : state) {
    auto m = parse_npz(in.bytes.data(), in.bytes.size(), in.name);
    benchmark::DoNotOptimize(m.begin()->second.data.data());
  }
  state.counters["MB_per_s"] = benchmark::Counter(double(in.bytes.size()) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

// The pre-libzip NpzFile::get: stored members parsed from a view, deflated ones inflated.
void BM_NpzHandWritten(benchmark::State& state) {
  const NpzInput& in = npz_inputs()[size_t(state.range(0))];
  const uint8_t* d = in.bytes.data();
  const size_t n = in.bytes.size();
  for (auto _ : state) {
    std::map<std::string, NpyArray> m;
    for (const auto& e : legacy::zip_list(d, n, in.name)) {
      if (e.method == 0) {
        auto [p, k] = legacy::zip_stored_view(d, n, e, in.name);
        m.emplace(e.name, parse_npy(p, k, in.name));
      } else {
        auto raw = legacy::zip_extract(d, n, e, in.name);
        m.emplace(e.name, parse_npy(raw.data(), raw.size(), in.name));
      }
    }
    benchmark::DoNotOptimize(m.begin()->second.data.data());
  }
  state.counters["MB_per_s"] = benchmark::Counter(double(in.bytes.size()) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

// --- AEDAT 4.0 ---------------------------------------------------------------------------

struct AedatInput {
  std::string name;
  std::vector<uint8_t> bytes;                 // the whole file
  std::vector<std::vector<uint8_t>> packets;  // its event packets, decompressed
  uint64_t events = 0;
};

AedatInput load_aedat(const std::string& name, std::vector<uint8_t> bytes) {
  AedatInput in{name, std::move(bytes), {}, 0};
  const uint8_t* b = in.bytes.data();
  const uint32_t hsize = load_le32(b + 14);
  const auto* h = aedat4::GetSizePrefixedIOHeader(b + 14);
  int events_stream = -1;
  for (const auto& s : parse_aedat4_info(h->info_node()->string_view()))
    if (s.type == "EVTS" && events_stream < 0) events_stream = s.id;
  for (size_t off = 18 + hsize; off + 8 <= in.bytes.size();) {
    const int32_t stream = int32_t(load_le32(b + off));
    const uint32_t size = load_le32(b + off + 4);
    if (stream == events_stream) {
      in.packets.emplace_back();
      aedat4_decompress(int(h->compression()), b + off + 8, size, in.packets.back(), name, off);
      in.events += aedat4::GetSizePrefixedEventPacket(in.packets.back().data())->elements()->size();
    }
    off += 8 + size;
  }
  return in;
}

const std::vector<AedatInput>& aedat_inputs() {
  static std::vector<AedatInput> v = [] {
    std::vector<AedatInput> v;
    if (std::filesystem::exists(shared("sample.aedat4")))
      v.push_back(load_aedat("sample", read_file_bytes(shared("sample.aedat4"))));
    EventStream e = synthetic(2000000);
    const std::string p = temp_path(".aedat4");
    auto w = open_writer(p, e.sensor, {}, "aedat4");
    w->write(e);
    w->close();
    v.push_back(load_aedat("synthetic_lz4", read_file_bytes(p)));
    std::filesystem::remove(p);
    return v;
  }();
  return v;
}

struct EventsOut {
  std::vector<int64_t> t;
  std::vector<uint16_t> x, y;
  std::vector<uint8_t> p;
  explicit EventsOut(size_t n) : t(n), x(n), y(n), p(n) {}
};

void aedat_counters(benchmark::State& state, const AedatInput& in) {
  state.counters["Mev_per_s"] =
      benchmark::Counter(double(in.events) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
}

void BM_Aedat4PacketsFlatc(benchmark::State& state) {
  const AedatInput& in = aedat_inputs()[size_t(state.range(0))];
  EventsOut o(in.events);
  for (auto _ : state) {
    size_t k = 0;
    for (const auto& pk : in.packets) {
      flatbuffers::Verifier v(pk.data(), size_t(load_le32(pk.data())) + 4);
      if (!v.VerifySizePrefixedBuffer<aedat4::EventPacket>(nullptr)) std::abort();
      const auto* els = aedat4::GetSizePrefixedEventPacket(pk.data())->elements();
      const aedat4::Event* e = els->Get(0);
      for (size_t i = 0; i < els->size(); ++i, ++e, ++k) {
        o.t[k] = e->timestamp();
        o.x[k] = uint16_t(e->x());
        o.y[k] = uint16_t(e->y());
        o.p[k] = e->polarity() ? 1 : 0;
      }
    }
    benchmark::DoNotOptimize(o.t.data());
    benchmark::ClobberMemory();
  }
  aedat_counters(state, in);
}

void BM_Aedat4PacketsHandWritten(benchmark::State& state) {
  const AedatInput& in = aedat_inputs()[size_t(state.range(0))];
  EventsOut o(in.events);
  for (auto _ : state) {
    size_t k = 0;
    for (const auto& pk : in.packets) {
      legacy::FlatView fv(pk.data() + 4, load_le32(pk.data()), in.name, 4);
      legacy::FlatView::Vector vec = fv.vector(fv.root(), 0, 16);
      const uint8_t* e = fv.data() + vec.pos;
      for (size_t i = 0; i < vec.count; ++i, e += 16, ++k) {
        o.t[k] = int64_t(load_le64(e));
        o.x[k] = load_le16(e + 8);
        o.y[k] = load_le16(e + 10);
        o.p[k] = e[12] ? 1 : 0;
      }
    }
    benchmark::DoNotOptimize(o.t.data());
    benchmark::ClobberMemory();
  }
  aedat_counters(state, in);
}

void BM_Aedat4WholeFile(benchmark::State& state) {
  const AedatInput& in = aedat_inputs()[size_t(state.range(0))];
  EventStream out;
  out.reserve(kReadChunk + 1024);
  for (auto _ : state) {
    auto r =
        find_format("aedat4")->open_bytes(open_memory_source(in.bytes.data(), in.bytes.size()), {});
    while (r->read(out, kReadChunk) > 0) {
      benchmark::DoNotOptimize(out.t.data());
      out.clear();
    }
  }
  aedat_counters(state, in);
}

// Keeps each run's CPU time per iteration so that main() can print library / hand-written
// (CPU time: on a shared machine the wall time measures the neighbours).
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> ns;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs)
      if (r.run_type == Run::RT_Iteration)
        ns[r.run_name.function_name + "/" + r.run_name.args] = r.GetAdjustedCPUTime();
    ConsoleReporter::ReportRuns(runs);
  }
};

void add(const std::string& name, void (*fn)(benchmark::State&), size_t i) {
  benchmark::RegisterBenchmark(name.c_str(), fn)
      ->Arg(int64_t(i))
      ->Unit(benchmark::kMillisecond)
      ->MinTime(0.5);
}

void register_all(std::vector<std::pair<std::string, std::string>>& pairs) {
  for (size_t i = 0; i < npz_inputs().size(); ++i) {
    const std::string n = npz_inputs()[i].name, a = "npz_libzip/" + n, b = "npz_hand/" + n;
    add(a, BM_NpzLibzip, i);
    add(b, BM_NpzHandWritten, i);
    pairs.push_back({a + "/" + std::to_string(i), b + "/" + std::to_string(i)});
  }
  for (size_t i = 0; i < aedat_inputs().size(); ++i) {
    const std::string n = aedat_inputs()[i].name, a = "aedat4_packets_flatc/" + n,
                      b = "aedat4_packets_hand/" + n;
    add(a, BM_Aedat4PacketsFlatc, i);
    add(b, BM_Aedat4PacketsHandWritten, i);
    add("aedat4_file_new_reader/" + n, BM_Aedat4WholeFile, i);
    pairs.push_back({a + "/" + std::to_string(i), b + "/" + std::to_string(i)});
  }
}

}  // namespace
}  // namespace spikems

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::vector<std::pair<std::string, std::string>> pairs;
  spikems::register_all(pairs);
  spikems::RatioReporter rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  std::printf("\nlibrary CPU time / hand-written CPU time (below 1: the library is faster)\n");
  for (const auto& [lib, hand] : pairs)
    if (rep.ns.count(lib) && rep.ns.count(hand))
      std::printf("  %-44s %.2f\n", lib.c_str(), rep.ns[lib] / rep.ns[hand]);
  benchmark::Shutdown();
  return 0;
}
