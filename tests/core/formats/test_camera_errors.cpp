// Bad camera files: truncated, corrupted, absurd headers. Every one must end in a
// spikems::Error that names the byte offset (never a crash, a hang or a huge allocation),
// and the CLI must exit non-zero on them.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "common/test_paths.h"
#include "core/events/io.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// Reads all events; returns the error message, or "" when the bytes decoded cleanly.
std::string try_read(const std::vector<uint8_t>& b, const std::string& format, size_t* count) {
  try {
    auto r = find_format(format)->open_bytes(open_memory_source(b.data(), b.size(), "bad"), {});
    EventStream out;
    while (r->read(out, 4096) > 0) {
    }
    if (count) *count = out.size();
    return "";
  } catch (const Error& e) {
    return e.what();
  }
}

struct File {
  const char* name;
  const char* format;
};

class CameraBadInput : public ::testing::TestWithParam<File> {};

TEST_P(CameraBadInput, TruncationsErrorWithOffsetOrDecodeAPrefix) {
  const File f = GetParam();
  SPIKEMS_REQUIRE_SHARED(path, std::string("data/formats/") + f.name);
  std::vector<uint8_t> all = read_file_bytes(path);
  size_t full = 0;
  ASSERT_EQ(try_read(all, f.format, &full), "");
  std::mt19937 rng(42);
  int errors = 0;
  for (int k = 0; k < 40; ++k) {
    size_t cut = k < 20 ? size_t(k) * 7 : rng() % all.size();  // header cuts, then anywhere
    std::vector<uint8_t> b(all.begin(), all.begin() + cut);
    size_t n = 0;
    std::string msg = try_read(b, f.format, &n);
    if (msg.empty()) {
      EXPECT_LE(n, full) << "cut at " << cut;
    } else {
      ++errors;
      EXPECT_NE(msg.find("byte"), std::string::npos) << "cut at " << cut << ": " << msg;
    }
  }
  EXPECT_GT(errors, 10);  // most cuts land inside a header, a record or a packet
}

TEST_P(CameraBadInput, FlippedBytesNeverCrash) {
  const File f = GetParam();
  SPIKEMS_REQUIRE_SHARED(path, std::string("data/formats/") + f.name);
  std::vector<uint8_t> all = read_file_bytes(path);
  std::mt19937 rng(7);
  for (int k = 0; k < 30; ++k) {
    std::vector<uint8_t> b = all;
    for (int j = 0; j < 8; ++j) b[rng() % b.size()] ^= uint8_t(1 + rng() % 255);
    size_t n = 0;
    try_read(b, f.format, &n);  // any outcome but a crash or a foreign exception
  }
}

INSTANTIATE_TEST_SUITE_P(Files, CameraBadInput,
                         ::testing::Values(File{"evt2_sample.raw", "evt2"},
                                           File{"evt3_sample.raw", "evt3"},
                                           File{"sample_ncars.dat", "dat"},
                                           File{"sample.aedat4", "aedat4"}, File{"dvs.es", "es"}),
                         [](const auto& info) { return std::string(info.param.format); });

std::vector<uint8_t> aedat4_with_header_size(int32_t size) {
  std::vector<uint8_t> b;
  std::string m = "#!AER-DAT4.0\r\n";
  b.assign(m.begin(), m.end());
  for (int s = 0; s < 32; s += 8) b.push_back(uint8_t(uint32_t(size) >> s));
  b.resize(b.size() + 64, 0);
  return b;
}

TEST(CameraBadInput, AbsurdSizesAreRefusedBeforeAllocating) {
  std::string msg = try_read(aedat4_with_header_size(0x7FFFFFFF), "aedat4", nullptr);
  EXPECT_NE(msg.find("IOHeader size"), std::string::npos) << msg;
  EXPECT_NE(msg.find("byte 14"), std::string::npos) << msg;
  EXPECT_NE(try_read(aedat4_with_header_size(-5), "aedat4", nullptr), "");
  // A valid header followed by a packet claiming 1.9 GB.
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/sample.aedat4");
  std::vector<uint8_t> b = read_file_bytes(path);
  size_t first_packet = 18 + load_le32(b.data() + 14);
  store_le32(b.data() + first_packet + 4, 0x70000000);
  msg = try_read(b, "aedat4", nullptr);
  EXPECT_NE(msg.find("packet size"), std::string::npos) << msg;
  EXPECT_NE(msg.find("byte " + std::to_string(first_packet)), std::string::npos) << msg;
}

TEST(CameraBadInput, CorruptCompressedPacketIsAnError) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/sample.aedat4");
  std::vector<uint8_t> b = read_file_bytes(path);
  size_t first_packet = 18 + load_le32(b.data() + 14);
  for (size_t i = first_packet + 8 + 16; i < first_packet + 8 + 400; ++i) b[i] ^= 0x5A;
  std::string msg = try_read(b, "aedat4", nullptr);
  EXPECT_NE(msg, "");
  EXPECT_NE(msg.find("byte " + std::to_string(first_packet)), std::string::npos) << msg;
}

// AEDAT 4.0 FlatBuffers go through the generated Verifier before any field is read: a bad
// offset or a vector longer than its buffer is an error naming the file, the byte and why.
TEST(CameraBadInput, Aedat4FlatBuffersFailingVerificationAreClearErrors) {
  const std::string path = test::scratch_dir() + "/raw.aedat4";
  EventStream e;
  e.sensor = {32, 16};
  for (int i = 0; i < 5; ++i) e.push_back(1000 + 10 * i, uint16_t(3 * i), uint16_t(i), i % 2);
  WriteOptions opt;
  opt.compression = "none";  // packet payloads are the FlatBuffers themselves
  auto w = open_writer(path, e.sensor, opt, "aedat4");
  w->write(e);
  w->close();
  const std::vector<uint8_t> good = read_file_bytes(path);
  size_t n = 0;
  ASSERT_EQ(try_read(good, "aedat4", &n), "");
  ASSERT_EQ(n, 5u);
  const size_t packet = 18 + load_le32(good.data() + 14), payload = packet + 8;

  auto b = good;  // IOHeader root offset past its end
  store_le32(b.data() + 18, 0x00FFFFF0);
  std::string msg = try_read(b, "aedat4", nullptr);
  EXPECT_NE(msg.find("IOHeader fails verification"), std::string::npos) << msg;
  EXPECT_NE(msg.find("byte 18"), std::string::npos) << msg;

  b = good;  // EventPacket root offset past its end
  store_le32(b.data() + payload + 4, 0x00FFFFF0);
  msg = try_read(b, "aedat4", nullptr);
  EXPECT_NE(msg.find("EventPacket fails verification"), std::string::npos) << msg;
  EXPECT_NE(msg.find("byte " + std::to_string(packet)), std::string::npos) << msg;

  b = good;  // the events vector claims far more elements than the packet holds
  size_t count_at = 0;
  for (size_t q = payload; q + 12 <= b.size(); ++q)
    if (load_le64(b.data() + q + 4) == 1000 && load_le32(b.data() + q) == 5) count_at = q;
  ASSERT_NE(count_at, 0u);
  store_le32(b.data() + count_at, 0x01000000);
  msg = try_read(b, "aedat4", nullptr);
  EXPECT_NE(msg.find("EventPacket fails verification"), std::string::npos) << msg;
  EXPECT_NE(msg.find("byte " + std::to_string(packet)), std::string::npos) << msg;
}

TEST(CameraBadInput, BadHeadersAreClearErrors) {
  auto bytes = [](const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); };
  EXPECT_NE(try_read(bytes(std::string("Event Stream\x09\x00\x00\x01", 16) + "abcd"), "es", nullptr)
                .find("version"),
            std::string::npos);
  EXPECT_NE(try_read(bytes(std::string("Event Stream\x02\x00\x00\x03", 16) + "abcd"), "es", nullptr)
                .find("type"),
            std::string::npos);
  EXPECT_NE(try_read(bytes("% evt 2.0\n% end\n"), "evt3", nullptr).find("EVT 2.0"),
            std::string::npos);
  EXPECT_NE(try_read(bytes("% Version 2\n\x05\x08"), "dat", nullptr).find("event type"),
            std::string::npos);
  EXPECT_NE(try_read(bytes("#!AER-DAT2.0\r\n# no chip\r\n"), "aedat2", nullptr).find("--sensor"),
            std::string::npos);
  // An odd trailing byte in EVT 3.0 cannot be half a word.
  EXPECT_NE(try_read(bytes("% evt 3.0\n% end\n\x01\x80\x07"), "evt3", nullptr).find("byte 18"),
            std::string::npos);
}

TEST(CameraBadInput, CliExitsNonZeroOnATruncatedFile) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/sample.aedat4");
  std::vector<uint8_t> b = read_file_bytes(path);
  std::string cut = test::scratch_dir() + "/cut.aedat4";
  std::ofstream(cut, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), 5000);
  std::string out;
  int rc = test::run_command(test::spikems_binary() + " info " + cut, &out);
  if (out.find("info") != std::string::npos && out.find("required") != std::string::npos)
    GTEST_SKIP() << "spikems info not built yet";
  EXPECT_NE(rc, 0) << out;
  EXPECT_NE(out.find("byte"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems
