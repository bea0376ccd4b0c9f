// AEDAT 4.0 files whose FlatBuffers are aligned from the bytes after their size prefix, not from
// the prefix as dv-processing writes them (a real DAVIS346 clip trimmed from
// neuromorphicsystems/aedat's test data was refused before: "IOHeader fails verification").
// Built here byte by byte, with a check that the layout really is the other convention, then
// read back event for event.
#include <gtest/gtest.h>

#include <flatbuffers/flatbuffers.h>

#include "aedat4_events_generated.h"
#include "aedat4_ioheader_generated.h"
#include "common/test_paths.h"
#include "core/events/io.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

void append_le32(std::vector<uint8_t>& b, uint32_t v) {
  uint8_t q[4];
  store_le32(q, v);
  b.insert(b.end(), q, q + 4);
}

// A finished, unprefixed FlatBuffer with its size written in front of it (so its 8-byte fields
// sit 4 bytes off an 8-byte boundary when counted from the prefix).
std::vector<uint8_t> prefixed_after(const flatbuffers::FlatBufferBuilder& b) {
  std::vector<uint8_t> out;
  append_le32(out, b.GetSize());
  out.insert(out.end(), b.GetBufferPointer(), b.GetBufferPointer() + b.GetSize());
  return out;
}

TEST(Aedat4Alignment, BuffersAlignedAfterTheirSizePrefixAreRead) {
  // The info XML of a file our writer makes: one event stream, 32 x 16.
  const std::string path = test::scratch_dir() + "/ours.aedat4";
  EventStream e;
  e.sensor = {32, 16};
  for (int i = 0; i < 7; ++i) e.push_back(1000 + 10 * i, uint16_t(4 * i), uint16_t(2 * i), i % 2);
  WriteOptions opt;
  opt.compression = "none";
  auto w = open_writer(path, e.sensor, opt, "aedat4");
  w->write(e);
  w->close();
  const std::vector<uint8_t> ours = read_file_bytes(path);
  const std::string info = aedat4::GetSizePrefixedIOHeader(ours.data() + 14)->info_node()->str();

  flatbuffers::FlatBufferBuilder hb;
  hb.ForceDefaults(true);
  hb.Finish(aedat4::CreateIOHeader(hb, aedat4::CompressionType_NONE, -1, hb.CreateString(info)));
  const std::vector<uint8_t> header = prefixed_after(hb);
  std::vector<aedat4::Event> ev;
  for (size_t i = 0; i < e.size(); ++i)
    ev.emplace_back(e.t[i], int16_t(e.x[i]), int16_t(e.y[i]), e.p[i] != 0);
  flatbuffers::FlatBufferBuilder pb;
  pb.Finish(aedat4::CreateEventPacket(pb, pb.CreateVectorOfStructs(ev)));
  const std::vector<uint8_t> payload = prefixed_after(pb);

  // The other convention indeed: verified from the prefix, the header's int64 is misaligned.
  flatbuffers::Verifier from_prefix(header.data(), header.size());
  ASSERT_FALSE(from_prefix.VerifySizePrefixedBuffer<aedat4::IOHeader>(nullptr));

  std::vector<uint8_t> file;
  const std::string magic = "#!AER-DAT4.0\r\n";
  file.insert(file.end(), magic.begin(), magic.end());
  file.insert(file.end(), header.begin(), header.end());  // its prefix is the header size
  append_le32(file, 0);                                   // stream id
  append_le32(file, uint32_t(payload.size()));
  file.insert(file.end(), payload.begin(), payload.end());

  auto r = find_format("aedat4")->open_bytes(
      open_memory_source(file.data(), file.size(), "other.aedat4"), {});
  EventStream out;
  while (r->read(out, 4096) > 0) {
  }
  ASSERT_EQ(out.size(), e.size());
  EXPECT_EQ(out.sensor.width, 32);
  EXPECT_EQ(out.sensor.height, 16);
  for (size_t i = 0; i < e.size(); ++i) {
    EXPECT_EQ(out.t[i], e.t[i]) << i;
    EXPECT_EQ(out.x[i], e.x[i]) << i;
    EXPECT_EQ(out.y[i], e.y[i]) << i;
    EXPECT_EQ(out.p[i], e.p[i]) << i;
  }
}

}  // namespace
}  // namespace spikems
