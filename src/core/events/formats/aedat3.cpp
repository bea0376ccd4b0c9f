// iniVation AEDAT 3.1 (docs.inivation.com, "AEDAT 3.1"): '#' header lines from
// "#!AER-DAT3.1" to "#!END-HEADER", then packets, little-endian: a 28-byte header (int16
// eventType, int16 eventSource, int32 eventSize, eventTSOffset, eventTSOverflow,
// eventCapacity, eventNumber, eventValid) and eventCapacity * eventSize bytes of events.
// Polarity events (type 1, 8 bytes): uint32 data (bit 0 valid, bit 1 polarity, y in bits
// 2-16, x in bits 17-31, top-left origin) and int32 timestamp, extended to 64 bits by
// eventTSOverflow << 31. Other packet types are skipped.
#include "core/events/formats/aedat_chips.h"
#include "core/events/formats/camera_reader.h"
#include "core/util/error.h"

namespace spikems {

namespace {

const std::string kMagic = "#!AER-DAT3.1";

class Aedat3Reader final : public CameraReader {
 public:
  Aedat3Reader(std::unique_ptr<ByteSource> src, const ReadOptions& opt) : in_(std::move(src)) {
    auto lines = in_.read_header_lines('#', "#!END-HEADER");
    if (lines.empty() || lines[0] != kMagic)
      fail_at_byte(in_.name(), 0, "not an AEDAT 3.1 file (first line is not #!AER-DAT3.1)");
    if (lines.back() != "#!END-HEADER")
      fail_at_byte(in_.name(), in_.offset(), "the AEDAT 3.1 header has no #!END-HEADER line");
    for (const auto& l : lines)
      if (l.rfind("#Source", 0) == 0 && !sensor_.known()) sensor_ = inivation_sensor_from_text(l);
    if (opt.sensor.known()) sensor_ = opt.sensor;
  }
  std::string format_name() const override { return "aedat3"; }

 protected:
  void decode(Out& o) override {
    while (o.n < o.cap) {
      if (left_ == 0 && !next_packet()) return;
      size_t a = in_.fill(8);
      if (a < 8)
        fail_at_byte(in_.name(), in_.offset(), "file is truncated inside a polarity packet");
      const uint8_t* b = in_.ptr();
      size_t k = std::min({a / 8, left_, o.cap - o.n});
      for (size_t i = 0; i < k; ++i) {
        uint32_t d = load_le32(b + 8 * i);
        int32_t ts = int32_t(load_le32(b + 8 * i + 4));
        if (!(d & 1)) continue;  // invalidated event
        o.t[o.n] = overflow_ + (ts < 0 ? 0 : ts);
        o.x[o.n] = uint16_t(d >> 17);
        o.y[o.n] = uint16_t((d >> 2) & 0x7FFF);
        o.p[o.n] = uint8_t((d >> 1) & 1);
        ++o.n;
      }
      in_.consume(8 * k);
      left_ -= k;
      if (left_ == 0 && skip_after_ > 0) {
        in_.skip(skip_after_, "a packet");
        skip_after_ = 0;
      }
    }
  }

 private:
  bool next_packet() {
    for (;;) {
      size_t a = in_.fill(28);
      if (a == 0) return false;
      uint64_t off = in_.offset();
      if (a < 28)
        fail_at_byte(
            in_.name(), off,
            "file is truncated: " + std::to_string(a) + " bytes of a 28-byte packet header");
      const uint8_t* h = in_.ptr();
      int16_t type = int16_t(load_le16(h));
      int32_t size = int32_t(load_le32(h + 4)), tsoff = int32_t(load_le32(h + 8));
      int32_t ovf = int32_t(load_le32(h + 12)), capacity = int32_t(load_le32(h + 16));
      int32_t number = int32_t(load_le32(h + 20));
      if (type < 0) fail_at_byte(in_.name(), off, "compressed AEDAT 3.1 packets are not supported");
      if (size <= 0 || capacity < 0 || number < 0 || number > capacity || ovf < 0 ||
          uint64_t(size) * uint64_t(capacity) > in_.remaining() ||
          uint64_t(size) * uint64_t(capacity) > (uint64_t(1) << 32))
        fail_at_byte(in_.name(), off,
                     "bad packet header (event size " + std::to_string(size) + ", capacity " +
                         std::to_string(capacity) + ", number " + std::to_string(number) +
                         "): the file is corrupt or truncated");
      in_.consume(28);
      uint64_t bytes = uint64_t(size) * uint64_t(capacity);
      if (type != 1 || number == 0) {
        in_.skip(bytes, "a packet");
        continue;
      }
      if (size != 8 || tsoff != 4)
        fail_at_byte(in_.name(), off,
                     "polarity packet with event size " + std::to_string(size) +
                         " (expected 8, timestamp at offset 4)");
      overflow_ = int64_t(ovf) << 31;
      left_ = size_t(number);
      skip_after_ = bytes - uint64_t(number) * 8;
      return true;
    }
  }

  BlockInput in_;
  int64_t overflow_ = 0;
  size_t left_ = 0;
  uint64_t skip_after_ = 0;
};

}  // namespace

FormatInfo aedat3_format() {
  FormatInfo f;
  f.name = "aedat3";
  f.description = "iniVation AEDAT 3.1 (cAER/libcaer packets; polarity events)";
  f.extensions = {".aedat", ".aedat3"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    return starts_with(head, kMagic) ? 100 : 0;
  };
  f.open_bytes = [](std::unique_ptr<ByteSource> src, const ReadOptions& opt) {
    return std::unique_ptr<EventReader>(std::make_unique<Aedat3Reader>(std::move(src), opt));
  };
  return f;
}

}  // namespace spikems
