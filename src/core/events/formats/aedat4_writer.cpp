// Writes iniVation AEDAT 4.0 with one event stream (id 0): the signature, a size-prefixed
// IOHeader FlatBuffer ("IOHE": compression, dataTablePosition = -1, infoNode XML with the
// stream's typeIdentifier EVTS and sizeX/sizeY), then packets of up to kPacketEvents events,
// each a size-prefixed EventPacket FlatBuffer ("EVTS") compressed as one LZ4 frame or zstd
// frame. No data table is written (dataTablePosition = -1): dv-processing then indexes the
// file by scanning its packets.
#include <lz4frame.h>
#include <lz4hc.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>

#include "core/events/formats/aedat4_common.h"
#include "core/events/formats/camera_writers.h"
#include "core/events/formats/flatbuffer.h"
#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {

namespace {

constexpr size_t kPacketEvents = 8192;

const char* compression_name(int c) {
  switch (c) {
    case kAedatLz4:
      return "LZ4";
    case kAedatLz4High:
      return "LZ4_HIGH";
    case kAedatZstd:
      return "ZSTD";
    case kAedatZstdHigh:
      return "ZSTD_HIGH";
    default:
      return "NONE";
  }
}

std::string info_node(SensorSize s, int compression) {
  const std::string p = "/mainloop/Recorder/outInfo/";
  return "<dv version=\"2.0\">\n"
         "    <node name=\"outInfo\" path=\"" +
         p +
         "\">\n"
         "        <node name=\"0\" path=\"" +
         p +
         "0/\">\n"
         "            <attr key=\"compression\" type=\"string\">" +
         compression_name(compression) +
         "</attr>\n"
         "            <attr key=\"originalModuleName\" type=\"string\">spikems</attr>\n"
         "            <attr key=\"originalOutputName\" type=\"string\">events</attr>\n"
         "            <attr key=\"typeDescription\" type=\"string\">Array of events (polarity "
         "ON/OFF).</attr>\n"
         "            <attr key=\"typeIdentifier\" type=\"string\">EVTS</attr>\n"
         "            <node name=\"info\" path=\"" +
         p +
         "0/info/\">\n"
         "                <attr key=\"sizeX\" type=\"int\">" +
         std::to_string(s.width) +
         "</attr>\n"
         "                <attr key=\"sizeY\" type=\"int\">" +
         std::to_string(s.height) +
         "</attr>\n"
         "                <attr key=\"source\" type=\"string\">spikems</attr>\n"
         "                <attr key=\"tsOffset\" type=\"long\">0</attr>\n"
         "            </node>\n"
         "        </node>\n"
         "    </node>\n"
         "</dv>\n";
}

// Size-prefixed IOHeader: [size][root][IOHE][vtable 10 B][pad][table: soffset, compression,
// dataTablePosition, infoNode offset][string]. Positions are relative to the prefix, which
// is where FlatBuffers measures alignment.
std::vector<uint8_t> build_io_header(int compression, const std::string& info) {
  FlatBuilder b;
  b.put_u32(0);                // size prefix, set at the end
  size_t root = b.put_u32(0);  // root offset (relative to byte 4)
  b.put_bytes("IOHE", 4);
  size_t vt = b.put_u16(10);  // vtable size
  b.put_u16(20);              // table size
  b.put_u16(4);               // field 0: compression
  b.put_u16(8);               // field 1: dataTablePosition
  b.put_u16(16);              // field 2: infoNode
  b.pad_to(8);
  size_t table = b.put_u32(0);
  b.set_u32(table, uint32_t(table - vt));
  b.put_u32(uint32_t(compression));
  b.put_u64(uint64_t(int64_t(-1)));
  size_t str_ref = b.put_u32(0);
  size_t str = b.put_u32(uint32_t(info.size()));
  b.set_u32(str_ref, uint32_t(str - str_ref));
  b.put_bytes(info.data(), info.size());
  b.buf.push_back(0);  // strings are NUL-terminated
  b.pad_to(8);
  b.set_u32(root, uint32_t(table - 4));
  b.set_u32(0, uint32_t(b.buf.size() - 4));
  return b.buf;
}

class Aedat4Writer final : public EventWriter {
 public:
  Aedat4Writer(const std::string& path, SensorSize sensor, const WriteOptions& opt)
      : file_(path), sensor_(sensor) {
    if (!sensor.known())
      fail(path, "", "AEDAT 4.0 needs the sensor size; pass it (e.g. --sensor 346x260)");
    if (sensor.width > 32767 || sensor.height > 32767)
      fail(path, "", "AEDAT 4.0 coordinates are int16: the sensor is too large");
    std::string c = opt.compression;
    std::transform(c.begin(), c.end(), c.begin(), ::tolower);
    level_ = opt.level;
    if (c.empty() || c == "lz4")
      compression_ = level_ > 0 ? kAedatLz4High : kAedatLz4;
    else if (c == "lz4_high")
      compression_ = kAedatLz4High;
    else if (c == "zstd")
      compression_ = kAedatZstd;
    else if (c == "zstd_high")
      compression_ = kAedatZstdHigh;
    else if (c == "none")
      compression_ = kAedatNone;
    else
      fail(path, "",
           "unknown AEDAT 4.0 compression '" + opt.compression +
               "' (use lz4, lz4_high, zstd, zstd_high or none)");
    file_.write("#!AER-DAT4.0\r\n", 14);
    auto hdr = build_io_header(compression_, info_node(sensor, compression_));
    file_.write(hdr.data(), hdr.size());
  }

  void write(const EventStream& s) override {
    for (size_t i = 0; i < s.size(); ++i) {
      if (s.x[i] >= sensor_.width || s.y[i] >= sensor_.height)
        fail_at_event(file_.target(), count_ + i,
                      "coordinates (" + std::to_string(s.x[i]) + ", " + std::to_string(s.y[i]) +
                          ") are outside the " + std::to_string(sensor_.width) + "x" +
                          std::to_string(sensor_.height) + " sensor");
      if (s.p[i] > 1) fail_at_event(file_.target(), count_ + i, "polarity is not 0 or 1");
      if (pending_.empty()) start_packet();
      uint8_t* e = grow(16);
      store_le64(e, uint64_t(s.t[i]));
      store_le16(e + 8, s.x[i]);
      store_le16(e + 10, s.y[i]);
      e[12] = s.p[i];
      e[13] = e[14] = e[15] = 0;
      if (++in_packet_ == kPacketEvents) finish_packet();
    }
    count_ += s.size();
  }

  void close() override {
    if (in_packet_ > 0) finish_packet();
    file_.commit();
  }

 private:
  uint8_t* grow(size_t n) {
    size_t p = pending_.size();
    pending_.resize(p + n);
    return pending_.data() + p;
  }
  // Size-prefixed EventPacket: [size][root][EVTS][vtable 6 B][pad][table: soffset, vector
  // offset][pad][count][16-byte events, 8-aligned].
  void start_packet() {
    pending_.assign(32, 0);
    in_packet_ = 0;
  }
  void finish_packet() {
    uint8_t* b = pending_.data();
    store_le32(b + 0, uint32_t(pending_.size() - 4));
    store_le32(b + 4, 16);  // root table at 20 = 4 + 16
    std::memcpy(b + 8, "EVTS", 4);
    store_le16(b + 12, 6);        // vtable size
    store_le16(b + 14, 8);        // table size
    store_le16(b + 16, 4);        // field 0 (elements) at table + 4
    store_le16(b + 18, 0);        // padding
    store_le32(b + 20, 8);        // table at 20, vtable at 12
    store_le32(b + 24, 28 - 24);  // vector at 28
    store_le32(b + 28, uint32_t(in_packet_));
    compress();
    uint8_t h[8];
    store_le32(h, 0);  // stream id
    store_le32(h + 4, uint32_t(out_.size()));
    file_.write(h, 8);
    file_.write(out_.data(), out_.size());
    pending_.clear();
    in_packet_ = 0;
  }
  void compress() {
    const size_t n = pending_.size();
    if (compression_ == kAedatNone) {
      out_ = pending_;
      return;
    }
    if (compression_ == kAedatLz4 || compression_ == kAedatLz4High) {
      LZ4F_preferences_t prefs{};
      prefs.compressionLevel =
          compression_ == kAedatLz4High ? (level_ > 0 ? level_ : LZ4HC_CLEVEL_DEFAULT) : 0;
      out_.resize(LZ4F_compressFrameBound(n, &prefs));
      size_t r = LZ4F_compressFrame(out_.data(), out_.size(), pending_.data(), n, &prefs);
      if (LZ4F_isError(r))
        fail(file_.target(), "", std::string("LZ4 compression failed: ") + LZ4F_getErrorName(r));
      out_.resize(r);
      return;
    }
    int level = level_ > 0 ? level_ : (compression_ == kAedatZstdHigh ? 19 : 3);
    out_.resize(ZSTD_compressBound(n));
    size_t r = ZSTD_compress(out_.data(), out_.size(), pending_.data(), n, level);
    if (ZSTD_isError(r))
      fail(file_.target(), "", std::string("zstd compression failed: ") + ZSTD_getErrorName(r));
    out_.resize(r);
  }

  AtomicFile file_;
  SensorSize sensor_;
  int compression_ = kAedatLz4, level_ = -1;
  std::vector<uint8_t> pending_, out_;
  size_t in_packet_ = 0;
  uint64_t count_ = 0;
};

}  // namespace

std::unique_ptr<EventWriter> open_aedat4_writer(const std::string& path, SensorSize sensor,
                                                const WriteOptions& opt) {
  return std::make_unique<Aedat4Writer>(path, sensor, opt);
}

}  // namespace spikems
