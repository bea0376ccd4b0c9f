// NumPy .npy/.npz: round trips, hand-made headers (byte order, Fortran order, pickles), bad
// input, and real files written by numpy (the SpikeMS reference and an EV-IMO sample).
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <numeric>

#include "common/error_text.h"
#include "common/test_paths.h"
#include "core/events/formats/npy.h"
#include "core/events/formats/zip.h"
#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// A .npy file with a hand-written header and payload.
std::vector<uint8_t> make_npy(const std::string& dict, const std::vector<uint8_t>& payload) {
  std::string h = dict;
  while ((10 + h.size() + 1) % 16) h += ' ';
  h += '\n';
  std::vector<uint8_t> out = {
      0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, uint8_t(h.size()), uint8_t(h.size() >> 8)};
  out.insert(out.end(), h.begin(), h.end());
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

using test::error_of;

TEST(Npy, RoundTripsEveryNumericType) {
  auto check = [](auto sample) {
    using T = decltype(sample);
    std::vector<T> v;
    for (int i = 0; i < 24; ++i) v.push_back(T(i * 3 % 7));
    auto a = NpyArray::from(v, {2, 3, 4});
    auto bytes = serialize_npy(a);
    EXPECT_EQ(bytes.size() % 64, a.data.size() % 64);  // data starts on a 64-byte boundary
    auto b = parse_npy(bytes.data(), bytes.size(), "mem");
    EXPECT_EQ(b.descr, std::string(npy_descr_of<T>()));
    EXPECT_EQ(b.shape, (std::vector<int64_t>{2, 3, 4}));
    EXPECT_EQ(b.template to<T>(), v);
    EXPECT_EQ(b.template to<double>()[5], double(v[5]));
  };
  check(float{});
  check(double{});
  check(int8_t{});
  check(uint8_t{});
  check(int16_t{});
  check(uint16_t{});
  check(int32_t{});
  check(uint32_t{});
  check(int64_t{});
  check(uint64_t{});
}

TEST(Npy, ScalarEmptyAndBoolShapes) {
  auto s = NpyArray::from(std::vector<double>{0.5}, {});
  auto bs = serialize_npy(s);
  std::string text(bs.begin(), bs.end());
  EXPECT_NE(text.find("'shape': ()"), std::string::npos);
  auto s2 = parse_npy(bs.data(), bs.size(), "mem");
  EXPECT_EQ(s2.numel(), 1);
  EXPECT_EQ(s2.to<double>()[0], 0.5);

  auto e = NpyArray::from(std::vector<int64_t>{}, {0, 4});
  auto be = serialize_npy(e);
  auto e2 = parse_npy(be.data(), be.size(), "mem");
  EXPECT_EQ(e2.numel(), 0);
  EXPECT_EQ(e2.shape, (std::vector<int64_t>{0, 4}));

  auto b = NpyArray::from(std::vector<bool>{true, false, true}, {3});
  EXPECT_EQ(b.descr, "|b1");
  auto bb = serialize_npy(b);
  std::string bt(bb.begin(), bb.end());
  EXPECT_NE(bt.find("'shape': (3,)"), std::string::npos);  // numpy's 1-tuple spelling
  EXPECT_EQ(parse_npy(bb.data(), bb.size(), "m").to<int>(), (std::vector<int>{1, 0, 1}));
}

TEST(Npy, ConvertsBetweenTypes) {
  auto a = NpyArray::from(std::vector<float>{1.75f, -2.5f, 300.f}, {3});
  EXPECT_EQ(a.to<int>(), (std::vector<int>{1, -2, 300}));
  EXPECT_EQ(a.to<double>(), (std::vector<double>{1.75, -2.5, 300.0}));
}

TEST(Npy, BigEndianIsSwappedOnLoad) {
  auto f = make_npy("{'descr': '>i4', 'fortran_order': False, 'shape': (2,), }",
                    {0, 0, 1, 2, 0xFF, 0xFF, 0xFF, 0xFE});
  auto a = parse_npy(f.data(), f.size(), "be");
  EXPECT_EQ(a.descr, "<i4");
  EXPECT_EQ(a.to<int32_t>(), (std::vector<int32_t>{258, -2}));
}

TEST(Npy, FortranOrderIsTransposedToC) {
  // Matrix [[1,2,3],[4,5,6]] in Fortran order is stored column by column: 1 4 2 5 3 6.
  std::vector<uint8_t> p = {1, 4, 2, 5, 3, 6};
  auto f = make_npy("{'descr': '|u1', 'fortran_order': True, 'shape': (2, 3), }", p);
  auto a = parse_npy(f.data(), f.size(), "F");
  EXPECT_FALSE(a.fortran_order);
  EXPECT_EQ(a.to<int>(), (std::vector<int>{1, 2, 3, 4, 5, 6}));
  // 3-D: element (i,j,k) of shape (2,2,2) at Fortran offset i + 2j + 4k holds 100i+10j+k.
  std::vector<uint8_t> q(8);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) q[i + 2 * j + 4 * k] = uint8_t(100 * i + 10 * j + k);
  auto g = make_npy("{'descr': '|u1', 'fortran_order': True, 'shape': (2, 2, 2), }", q);
  auto b = parse_npy(g.data(), g.size(), "F3").to<int>();
  EXPECT_EQ(b, (std::vector<int>{0, 1, 10, 11, 100, 101, 110, 111}));
}

TEST(Npy, StringArraysDecode) {
  std::vector<uint8_t> p(2 * 3 * 4, 0);
  const char* w[2] = {"ab", "xyz"};
  for (int i = 0; i < 2; ++i)
    for (int k = 0; w[i][k]; ++k) p[i * 12 + k * 4] = uint8_t(w[i][k]);
  auto f = make_npy("{'descr': '<U3', 'fortran_order': False, 'shape': (2,), }", p);
  auto a = parse_npy(f.data(), f.size(), "U");
  EXPECT_EQ(a.itemsize(), 12u);
  EXPECT_EQ(a.to_strings(), (std::vector<std::string>{"ab", "xyz"}));
  EXPECT_THROW(a.to<float>(), Error);
}

TEST(Npy, RejectsPicklesAndBadHeaders) {
  auto obj = make_npy("{'descr': '|O', 'fortran_order': False, 'shape': (), }", {0x80, 2, '.'});
  std::string m = error_of([&] { parse_npy(obj.data(), obj.size(), "x.npz:meta"); });
  EXPECT_NE(m.find("x.npz:meta"), std::string::npos) << m;
  EXPECT_NE(m.find("pickled"), std::string::npos) << m;

  auto ok = make_npy("{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }",
                     std::vector<uint8_t>(8, 0));
  EXPECT_NO_THROW(parse_npy(ok.data(), ok.size(), "ok"));
  // Every truncation is an error naming the file, never a crash.
  for (size_t cut = 0; cut < ok.size(); ++cut) {
    std::string e = error_of([&] { parse_npy(ok.data(), cut, "cut.npy"); });
    EXPECT_NE(e.find("cut.npy"), std::string::npos) << "cut at " << cut;
  }
  auto magic = ok;
  magic[1] = 'X';
  EXPECT_NE(error_of([&] { parse_npy(magic.data(), magic.size(), "m"); }).find("magic"),
            std::string::npos);
  auto version = ok;
  version[6] = 9;
  EXPECT_NE(error_of([&] { parse_npy(version.data(), version.size(), "v"); }).find("version"),
            std::string::npos);
  // Extra trailing bytes, absurd and overflowing shapes, structured dtypes, unknown dtypes.
  auto extra = ok;
  extra.push_back(0);
  EXPECT_THROW(parse_npy(extra.data(), extra.size(), "e"), Error);
  for (std::string dict :
       {"{'descr': '<f4', 'fortran_order': False, 'shape': (999999999999999, 999999999999999), }",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (4294967296, 4294967296, 16), }",
        "{'descr': [('t', '<i8')], 'fortran_order': False, 'shape': (1,), }",
        "{'descr': '<c8', 'fortran_order': False, 'shape': (1,), }",
        "{'descr': '<f4', 'fortran_order': Maybe, 'shape': (2,), }",
        "{'descr': '<f4', 'shape': (2,), }",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (-2,), }", "not a dict"}) {
    auto f = make_npy(dict, std::vector<uint8_t>(8, 0));
    EXPECT_THROW(parse_npy(f.data(), f.size(), "h"), Error) << dict;
  }
}

TEST(Npy, WriteAndReadFilesAtomically) {
  std::string dir = test::scratch_dir();
  auto a = NpyArray::from(std::vector<int16_t>{-3, 7, 9}, {3});
  write_npy(dir + "/a.npy", a);
  EXPECT_EQ(read_npy(dir + "/a.npy").to<int16_t>(), (std::vector<int16_t>{-3, 7, 9}));
  int files = 0;
  for ([[maybe_unused]] auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1);  // no temporary left behind
}

std::map<std::string, NpyArray> sample_arrays() {
  std::vector<float> big(5000);
  for (size_t i = 0; i < big.size(); ++i) big[i] = float(i % 17) * 0.25f;
  return {{"t", NpyArray::from(std::vector<int64_t>{1, 5, 9}, {3})},
          {"big", NpyArray::from(big, {50, 100})},
          {"name.with.dots", NpyArray::from(std::vector<uint8_t>{1, 0}, {2})},
          {"empty", NpyArray::from(std::vector<double>{}, {0})}};
}

TEST(Npz, RoundTripStoredAndDeflate) {
  std::string dir = test::scratch_dir();
  auto arrays = sample_arrays();
  for (bool compress : {false, true}) {
    std::string p = dir + (compress ? "/c.npz" : "/s.npz");
    write_npz(p, arrays, compress);
    auto bytes = read_file_bytes(p);
    auto entries = ZipArchive(bytes.data(), bytes.size(), p).entries();
    ASSERT_EQ(entries.size(), arrays.size());
    for (auto& e : entries) EXPECT_EQ(e.method, compress ? 8 : 0);
    auto back = read_npz(p);
    ASSERT_EQ(back.size(), arrays.size());
    for (auto& [k, a] : arrays) {
      ASSERT_TRUE(back.count(k)) << k;
      EXPECT_EQ(back[k].descr, a.descr);
      EXPECT_EQ(back[k].shape, a.shape);
      EXPECT_EQ(back[k].data, a.data) << k;
    }
  }
  EXPECT_LT(std::filesystem::file_size(dir + "/c.npz"),
            std::filesystem::file_size(dir + "/s.npz") / 4);
}

TEST(Npz, TruncatedOrCorruptArchivesAreErrors) {
  std::string dir = test::scratch_dir();
  for (bool compress : {false, true}) {
    std::string p = dir + "/x.npz";
    write_npz(p, sample_arrays(), compress);
    auto bytes = read_file_bytes(p);
    for (size_t cut : {size_t(0), size_t(3), size_t(30), bytes.size() / 3, bytes.size() / 2,
                       bytes.size() - 23, bytes.size() - 1}) {
      std::string e = error_of([&] { parse_npz(bytes.data(), cut, "cut.npz"); });
      EXPECT_NE(e.find("cut.npz"), std::string::npos) << "cut " << cut << ": " << e;
    }
    // Flip one byte of array data: the CRC (stored) or inflate/CRC (deflate) must catch it.
    auto bad = bytes;
    bad[200] ^= 0x5A;
    EXPECT_THROW(parse_npz(bad.data(), bad.size(), "flip.npz"), Error);
    auto magic = bytes;
    magic[0] = 'Q';
    EXPECT_NE(error_of([&] { parse_npz(magic.data(), magic.size(), "m.npz"); }).find("magic"),
              std::string::npos);
  }
}

TEST(Npz, LazyFileSkipsMembersItCannotDecode) {
  std::string dir = test::scratch_dir();
  auto obj = make_npy("{'descr': '|O', 'fortran_order': False, 'shape': (), }", {0x80, 2, '.'});
  AtomicFile f(dir + "/evimo.npz");
  ZipWriter z(f, false);
  auto ev = serialize_npy(NpyArray::from(std::vector<float>{0.5f, 1, 2, 1}, {1, 4}));
  z.add("events.npy", ev.data(), ev.size());
  z.add("meta.npy", obj.data(), obj.size());
  z.finish();
  f.commit();
  NpzFile npz(dir + "/evimo.npz");
  EXPECT_EQ(npz.keys(), (std::vector<std::string>{"events", "meta"}));
  EXPECT_EQ(npz.get("events").to<float>()[0], 0.5f);
  std::string e = error_of([&] { npz.get("meta"); });
  EXPECT_NE(e.find("evimo.npz:meta"), std::string::npos) << e;
  EXPECT_NE(e.find("pickled"), std::string::npos) << e;
  EXPECT_THROW(read_npz(dir + "/evimo.npz"), Error);
  EXPECT_NE(error_of([&] { npz.get("nope"); }).find("events, meta"), std::string::npos);
}

// A file cut anywhere (on disk, read through libzip's file source) is an error naming the
// file and saying what is wrong, never a crash or a silent partial read.
TEST(Npz, TruncatedFileOnDiskNamesFileAndReason) {
  std::string dir = test::scratch_dir();
  for (bool compress : {false, true}) {
    write_npz(dir + "/whole.npz", sample_arrays(), compress);
    auto bytes = read_file_bytes(dir + "/whole.npz");
    for (size_t cut : {size_t(10), bytes.size() / 2, bytes.size() - 10}) {
      const std::string p = dir + "/cut.npz";
      write_file_atomic(p, std::string(bytes.begin(), bytes.begin() + long(cut)));
      std::string e = error_of([&] { read_npz(p); });
      EXPECT_NE(e.find(p), std::string::npos) << cut << ": " << e;
      EXPECT_TRUE(e.find("too short") != std::string::npos ||
                  e.find("truncated or corrupt") != std::string::npos)
          << cut << ": " << e;
    }
  }
}

// Members not named *.npy are skipped; a *.npy member that is not an npy array is an error
// naming "<file>:<key>" and the reason.
TEST(Npz, MembersThatAreNotNpy) {
  std::string dir = test::scratch_dir();
  const std::string text = "hello, not an array";
  auto good = serialize_npy(NpyArray::from(std::vector<int16_t>{7, -8}, {2}));
  {
    AtomicFile f(dir + "/mixed.npz");
    ZipWriter z(f, true);
    z.add("README.txt", reinterpret_cast<const uint8_t*>(text.data()), text.size());
    z.add("t.npy", reinterpret_cast<const uint8_t*>(text.data()), text.size());
    z.add("x.npy", good.data(), good.size());
    z.finish();
    f.commit();
  }
  NpzFile npz(dir + "/mixed.npz");
  EXPECT_EQ(npz.keys(), (std::vector<std::string>{"t", "x"}));
  EXPECT_EQ(npz.get("x").to<int>(), (std::vector<int>{7, -8}));
  std::string e = error_of([&] { npz.get("t"); });
  EXPECT_NE(e.find("mixed.npz:t"), std::string::npos) << e;
  EXPECT_NE(e.find("magic"), std::string::npos) << e;
  // Only a text member: a ZIP, but no arrays.
  {
    AtomicFile f(dir + "/text.npz");
    ZipWriter z(f, false);
    z.add("README.txt", reinterpret_cast<const uint8_t*>(text.data()), text.size());
    z.finish();
    f.commit();
  }
  EXPECT_TRUE(read_npz(dir + "/text.npz").empty());
  e = error_of([&] { NpzFile(dir + "/text.npz").get("t"); });
  EXPECT_NE(e.find("no array 't'"), std::string::npos) << e;
}

// The writer's output depends only on the arrays (fixed dates), and an empty archive is a
// valid one (numpy writes a bare end record).
TEST(Npz, WriterIsReproducibleAndWritesEmptyArchives) {
  std::string dir = test::scratch_dir();
  for (bool compress : {false, true}) {
    write_npz(dir + "/a.npz", sample_arrays(), compress);
    write_npz(dir + "/b.npz", sample_arrays(), compress);
    EXPECT_EQ(read_file_bytes(dir + "/a.npz"), read_file_bytes(dir + "/b.npz"));
  }
  write_npz(dir + "/empty.npz", {}, false);
  EXPECT_EQ(std::filesystem::file_size(dir + "/empty.npz"), 22u);
  EXPECT_TRUE(read_npz(dir + "/empty.npz").empty());
  // No temporaries left beside the outputs (AtomicFile's nor libzip's).
  int files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 3);
}

// A ZIP64 archive as numpy writes for large arrays: 0xFFFFFFFF in the fixed size and offset
// fields, the real values in ZIP64 extra fields, and ZIP64 end records.
TEST(Npz, Zip64RecordsAndExtraFields) {
  auto npy = serialize_npy(NpyArray::from(std::vector<int32_t>{4, 5, 6}, {3}));
  const std::string name = "arr.npy";
  std::vector<uint8_t> z;
  auto u16 = [&](uint16_t v) {
    z.push_back(uint8_t(v));
    z.push_back(uint8_t(v >> 8));
  };
  auto u32 = [&](uint32_t v) {
    u16(uint16_t(v));
    u16(uint16_t(v >> 16));
  };
  auto u64 = [&](uint64_t v) {
    u32(uint32_t(v));
    u32(uint32_t(v >> 32));
  };
  uLong crc = crc32(0L, npy.data(), uInt(npy.size()));
  // Local header with placeholder sizes (as Python's zipfile writes with force_zip64).
  u32(0x04034b50);
  u16(45);
  u16(0);
  u16(0);
  u16(0);
  u16(0x21);
  u32(uint32_t(crc));
  u32(0xFFFFFFFF);
  u32(0xFFFFFFFF);
  u16(uint16_t(name.size()));
  u16(20);
  z.insert(z.end(), name.begin(), name.end());
  u16(1);
  u16(16);
  u64(0);
  u64(0);
  z.insert(z.end(), npy.begin(), npy.end());
  const uint64_t cd = z.size();
  u32(0x02014b50);
  u16(45);
  u16(45);
  u16(0);
  u16(0);
  u16(0);
  u16(0x21);
  u32(uint32_t(crc));
  u32(0xFFFFFFFF);
  u32(0xFFFFFFFF);
  u16(uint16_t(name.size()));
  u16(28);
  u16(0);
  u16(0);
  u16(0);
  u32(0);
  u32(0xFFFFFFFF);
  z.insert(z.end(), name.begin(), name.end());
  u16(1);
  u16(24);
  u64(npy.size());
  u64(npy.size());
  u64(0);
  const uint64_t cd_size = z.size() - cd, z64 = z.size();
  u32(0x06064b50);
  u64(44);
  u16(45);
  u16(45);
  u32(0);
  u32(0);
  u64(1);
  u64(1);
  u64(cd_size);
  u64(cd);
  u32(0x07064b50);
  u32(0);
  u64(z64);
  u32(1);
  u32(0x06054b50);
  u16(0);
  u16(0);
  u16(0xFFFF);
  u16(0xFFFF);
  u32(0xFFFFFFFF);
  u32(0xFFFFFFFF);
  u16(0);
  auto m = parse_npz(z.data(), z.size(), "z64.npz");
  ASSERT_EQ(m.count("arr"), 1u);
  EXPECT_EQ(m["arr"].to<int>(), (std::vector<int>{4, 5, 6}));
  // A ZIP64 end record pointing outside the file is an error, not a crash.
  auto bad = z;
  bad[bad.size() - 22 - 20 + 8] = 0xEE;
  EXPECT_THROW(parse_npz(bad.data(), bad.size(), "bad.npz"), Error);
}

// Real archives written by numpy (np.savez_compressed): values from the reference README.
TEST(NpzReal, CaseRandomDeflate) {
  SPIKEMS_REQUIRE_SHARED(path, "reference/spikems-evimo/case_random.npz");
  auto z = read_npz(path);
  ASSERT_TRUE(z.count("input") && z.count("spike_counts") && z.count("layer6"));
  EXPECT_EQ(z["input"].shape, (std::vector<int64_t>{1, 2, 64, 80, 40}));
  auto in = z["input"].to<float>();
  EXPECT_EQ(std::count(in.begin(), in.end(), 1.0f), 20494);
  EXPECT_EQ(std::count(in.begin(), in.end(), 0.0f), int64_t(in.size()) - 20494);
  auto counts = z["spike_counts"].to<double>();
  EXPECT_EQ(counts, (std::vector<double>{305170, 304432, 100952, 117236, 196718, 182704}));
  for (int k = 1; k <= 6; ++k) {
    auto l = z["layer" + std::to_string(k)].to<double>();
    EXPECT_EQ(std::accumulate(l.begin(), l.end(), 0.0), counts[k - 1]) << "layer" << k;
  }
  EXPECT_EQ(z["layer6"].shape, (std::vector<int64_t>{1, 2, 63, 79, 40}));
}

TEST(NpzReal, WeightsStored) {
  SPIKEMS_REQUIRE_SHARED(path, "reference/spikems-evimo/weights.npz");
  auto z = read_npz(path);
  EXPECT_EQ(z.size(), 23u);  // 6 weights, 12 kernels, names, params, 3 layer tables
  EXPECT_EQ(z["conv1.weight"].shape, (std::vector<int64_t>{16, 2, 3, 3, 1}));
  EXPECT_EQ(z["deconv4.0.weight"].shape, (std::vector<int64_t>{64, 32, 3, 3, 1}));
  auto srm = z["slayer_conv1.srmKernel"].to<float>();
  ASSERT_EQ(srm.size(), 16u);
  EXPECT_EQ(srm[0], 0.0f);
  EXPECT_NEAR(srm[1], 0.824360609f, 1e-7);
  EXPECT_EQ(srm[2], 1.0f);
  EXPECT_NEAR(srm[15], 0.0112757944f, 1e-8);
  auto ref = z["slayer_conv3.refKernel"].to<float>();
  ASSERT_EQ(ref.size(), 13u);
  EXPECT_NEAR(ref[1], -0.479999989f, 1e-7);
  EXPECT_EQ(z["layer_is_transposed"].to<int>(), (std::vector<int>{0, 0, 0, 1, 1, 1}));
  EXPECT_EQ(z["layer_stride"].to<int>(), (std::vector<int>(6, 2)));
  auto names = z["neuron_param_names"].to_strings();
  EXPECT_EQ(names, (std::vector<std::string>{"theta", "tauSr", "tauRef", "scaleRef", "tauRho",
                                             "scaleRho", "Ts", "tSample"}));
  auto np = z["neuron_params"].to<float>();
  EXPECT_EQ(z["neuron_params"].shape, (std::vector<int64_t>{6, 8}));
  EXPECT_NEAR(np[0], 0.22f, 1e-7);   // layer 1 theta
  EXPECT_EQ(np[2 * 8 + 1], 4.0f);    // layer 3 tauSr
  EXPECT_EQ(np[3 * 8 + 2], 3.0f);    // layer 4 tauRef
  EXPECT_EQ(np[5 * 8 + 7], 100.0f);  // tSample
}

TEST(NpzReal, RewriteKeepsEveryByteOfData) {
  SPIKEMS_REQUIRE_SHARED(path, "reference/spikems-evimo/case_random.npz");
  auto z = read_npz(path);
  std::string out = test::scratch_dir() + "/copy.npz";
  write_npz(out, z, true);
  auto back = read_npz(out);
  for (auto& [k, a] : z) EXPECT_EQ(back[k].data, a.data) << k;
}

TEST(NpzReal, PosterTranslationArrays) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/poster_translation.npz");
  NpzFile z(path);
  EXPECT_EQ(z.keys(), (std::vector<std::string>{"events", "index", "K", "D", "discretization"}));
  auto ev = z.get("events");
  EXPECT_EQ(ev.descr, "<f4");
  EXPECT_EQ(ev.shape, (std::vector<int64_t>{100000, 4}));
  auto v = ev.to<double>();
  EXPECT_EQ(std::llround(v[1]), 221);  // first event x (golden.json)
  EXPECT_EQ(std::llround(v[2]), 134);
  EXPECT_EQ(z.get("K").shape, (std::vector<int64_t>{3, 3}));
  EXPECT_EQ(z.get("discretization").numel(), 1);
}

}  // namespace
}  // namespace spikems
