// Prophesee DAT (CD events): '%' header lines, then one byte event type and one byte event
// size, then 8-byte records: uint32 timestamp (us), uint32 with x in bits 0-13, y in bits
// 14-27 and polarity in bits 28-31. Reference: docs.prophesee.ai, "DAT File Format".
#include "core/events/formats/camera_reader.h"
#include "core/events/formats/prophesee_header.h"
#include "core/util/error.h"

namespace spikems {

namespace {

class DatReader final : public CameraReader {
 public:
  explicit DatReader(std::unique_ptr<ByteSource> src) : in_(std::move(src)) {
    auto lines = in_.read_header_lines('%', "% end");
    PropheseeHeader h = parse_prophesee_header(lines, in_.name());
    sensor_ = h.sensor;
    time_ = h.time_offset_us;
    if (in_.fill(2) < 2)
      fail_at_byte(in_.name(), in_.offset(),
                   "file is truncated: the event type and size bytes after the header are missing");
    uint8_t type = in_.ptr()[0], size = in_.ptr()[1];
    // 0x00 (Event2D) and 0x0C (EventCD) are CD events; other types hold no CD events.
    if (type != 0x00 && type != 0x0C)
      fail_at_byte(in_.name(), in_.offset(),
                   "DAT event type " + std::to_string(type) +
                       " is not a CD event type (0 or 12); only CD DAT files are supported");
    if (size != 8)
      fail_at_byte(in_.name(), in_.offset() + 1,
                   "DAT event size " + std::to_string(size) + " is not 8 bytes");
    in_.consume(2);
  }
  std::string format_name() const override { return "dat"; }

 protected:
  void decode(Out& o) override {
    size_t n = o.n;
    while (n < o.cap) {
      size_t a = in_.fill(8);
      if (a < 8) {
        if (a > 0)
          fail_at_byte(in_.name(), in_.offset(),
                       "file is truncated: " + std::to_string(a) + " bytes of an 8-byte record");
        break;
      }
      const uint8_t* b = in_.ptr();
      const size_t nr = std::min(a / 8, o.cap - n);
      for (size_t i = 0; i < nr; ++i) {
        uint32_t ts = load_le32(b + 8 * i), w = load_le32(b + 8 * i + 4);
        // 32-bit microseconds wrap after 71 minutes: a large step back is a wrap.
        int64_t t = (time_ & ~int64_t(0xFFFFFFFF)) | ts;
        if (t < time_ && time_ - t > (int64_t(1) << 31)) t += int64_t(1) << 32;
        time_ = t;
        o.t[n] = t;
        o.x[n] = uint16_t(w & 0x3FFF);
        o.y[n] = uint16_t((w >> 14) & 0x3FFF);
        o.p[n] = uint8_t(w >> 28);
        ++n;
      }
      in_.consume(8 * nr);
    }
    o.n = n;
  }

 private:
  BlockInput in_;
  int64_t time_ = 0;
};

}  // namespace

FormatInfo dat_format() {
  FormatInfo f;
  f.name = "dat";
  f.description = "Prophesee DAT, CD events (8-byte records; N-CARS, GEN1 datasets)";
  f.extensions = {".dat"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    std::string h = prophesee_header_text(head);
    if (h.empty()) return 0;
    if (h.find("% evt ") != std::string::npos || h.find("% format evt") != std::string::npos)
      return 0;  // a RAW file
    if (h.find("% data file containing") != std::string::npos) return 90;
    if (h.find("% version") != std::string::npos) return 30;
    return 0;
  };
  f.open_bytes = [](std::unique_ptr<ByteSource> src, const ReadOptions&) {
    return std::unique_ptr<EventReader>(std::make_unique<DatReader>(std::move(src)));
  };
  return f;
}

}  // namespace spikems
