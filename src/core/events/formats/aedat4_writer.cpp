// Writes iniVation AEDAT 4.0 with one event stream (id 0): the signature, a size-prefixed
// IOHeader FlatBuffer ("IOHE": compression, dataTablePosition = -1, infoNode XML with the
// stream's typeIdentifier EVTS and sizeX/sizeY), then packets of up to kPacketEvents events,
// each a size-prefixed EventPacket FlatBuffer ("EVTS") compressed as one LZ4 frame or zstd
// frame, both built with flatc-generated code (aedat4_*.fbs). No data table is written
// (dataTablePosition = -1): dv-processing then indexes the file by scanning its packets.
#include <lz4frame.h>
#include <lz4hc.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>

#include "aedat4_events_generated.h"
#include "aedat4_ioheader_generated.h"
#include "core/events/formats/aedat4_common.h"
#include "core/events/formats/camera_writers.h"
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

// Size-prefixed IOHeader ("IOHE"). Every field is written, defaults included, so that a
// reader that ignores schema defaults still finds compression and dataTablePosition.
std::vector<uint8_t> build_io_header(int compression, const std::string& info) {
  flatbuffers::FlatBufferBuilder b(256 + info.size());
  b.ForceDefaults(true);
  auto xml = b.CreateString(info);
  auto h = aedat4::CreateIOHeader(b, aedat4::CompressionType(compression), -1, xml);
  aedat4::FinishSizePrefixedIOHeaderBuffer(b, h);
  return std::vector<uint8_t>(b.GetBufferPointer(), b.GetBufferPointer() + b.GetSize());
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
      pending_.emplace_back(s.t[i], int16_t(s.x[i]), int16_t(s.y[i]), s.p[i] != 0);
      if (pending_.size() == kPacketEvents) finish_packet();
    }
    count_ += s.size();
  }

  void close() override {
    if (!pending_.empty()) finish_packet();
    file_.commit();
  }

 private:
  // One size-prefixed EventPacket ("EVTS"), compressed as one frame, after its 8-byte
  // packet header (stream id, size).
  void finish_packet() {
    fbb_.Clear();
    auto events = fbb_.CreateVectorOfStructs(pending_);
    aedat4::FinishSizePrefixedEventPacketBuffer(fbb_, aedat4::CreateEventPacket(fbb_, events));
    compress(fbb_.GetBufferPointer(), fbb_.GetSize());
    uint8_t h[8];
    store_le32(h, 0);  // stream id
    store_le32(h + 4, uint32_t(out_.size()));
    file_.write(h, 8);
    file_.write(out_.data(), out_.size());
    pending_.clear();
  }
  void compress(const uint8_t* src, size_t n) {
    if (compression_ == kAedatNone) {
      out_.assign(src, src + n);
      return;
    }
    if (compression_ == kAedatLz4 || compression_ == kAedatLz4High) {
      LZ4F_preferences_t prefs{};
      prefs.compressionLevel =
          compression_ == kAedatLz4High ? (level_ > 0 ? level_ : LZ4HC_CLEVEL_DEFAULT) : 0;
      out_.resize(LZ4F_compressFrameBound(n, &prefs));
      size_t r = LZ4F_compressFrame(out_.data(), out_.size(), src, n, &prefs);
      if (LZ4F_isError(r))
        fail(file_.target(), "", std::string("LZ4 compression failed: ") + LZ4F_getErrorName(r));
      out_.resize(r);
      return;
    }
    int level = level_ > 0 ? level_ : (compression_ == kAedatZstdHigh ? 19 : 3);
    out_.resize(ZSTD_compressBound(n));
    size_t r = ZSTD_compress(out_.data(), out_.size(), src, n, level);
    if (ZSTD_isError(r))
      fail(file_.target(), "", std::string("zstd compression failed: ") + ZSTD_getErrorName(r));
    out_.resize(r);
  }

  AtomicFile file_;
  SensorSize sensor_;
  int compression_ = kAedatLz4, level_ = -1;
  std::vector<aedat4::Event> pending_;
  flatbuffers::FlatBufferBuilder fbb_{16 * kPacketEvents + 64};
  std::vector<uint8_t> out_;
  uint64_t count_ = 0;
};

}  // namespace

std::unique_ptr<EventWriter> open_aedat4_writer(const std::string& path, SensorSize sensor,
                                                const WriteOptions& opt) {
  return std::make_unique<Aedat4Writer>(path, sensor, opt);
}

}  // namespace spikems
