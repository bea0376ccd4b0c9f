// Event Stream 2.x ("es", Neuromorphic-Paris / sepia), DVS and ATIS types. Header: "Event
// Stream", three version bytes, a type byte (1 = DVS, 2 = ATIS), uint16 LE width and height.
// DVS, byte by byte: 0xFF = overflow (time += 127 us), 0xFE = reset (ignored), else an event
// of 5 bytes: (time delta << 1 | is_increase), uint16 LE x, uint16 LE y.
// ATIS: 0xFC = reset, 0xFD..0xFF = overflow (time += 63 us x the low two bits), else 5 bytes:
// (time delta << 2 | polarity << 1 | is_tc), x, y; threshold crossings (is_tc = 1, exposure
// measurements) are skipped, DVS events kept.
// y has a bottom-left origin and is flipped to spikems' top-left origin.
// Reference: github.com/neuromorphic-paris/event_stream (README).
#include "core/events/formats/camera_reader.h"
#include "core/util/error.h"

namespace spikems {

namespace {

const std::string kMagic = "Event Stream";

class EsReader final : public CameraReader {
 public:
  explicit EsReader(std::unique_ptr<ByteSource> src) : in_(std::move(src)) {
    uint8_t h[20];
    in_.read_exact(h, 16, "the Event Stream header");
    if (std::string(reinterpret_cast<char*>(h), 12) != kMagic)
      fail_at_byte(in_.name(), 0, "not an Event Stream file (no 'Event Stream' signature)");
    if (h[12] != 2)
      fail_at_byte(in_.name(), 12,
                   "Event Stream version " + std::to_string(h[12]) + "." + std::to_string(h[13]) +
                       "." + std::to_string(h[14]) + " is not supported (only 2.x)");
    if (h[15] != 1 && h[15] != 2)
      fail_at_byte(in_.name(), 15,
                   "Event Stream type " + std::to_string(h[15]) +
                       " is not supported: only DVS (1) and ATIS (2) streams hold polarity events");
    atis_ = h[15] == 2;
    in_.read_exact(h + 16, 4, "the Event Stream sensor size");
    sensor_ = {load_le16(h + 16), load_le16(h + 18)};
    if (!sensor_.known()) fail_at_byte(in_.name(), 16, "the sensor size is zero");
  }
  std::string format_name() const override { return "es"; }

 protected:
  void decode(Out& o) override {
    size_t n = o.n;
    int64_t t = t_;
    const int h1 = sensor_.height - 1;
    const uint8_t special = atis_ ? 0xFC : 0xFE;
    const int shift = atis_ ? 2 : 1;
    while (n < o.cap) {
      size_t a = in_.fill(5);
      if (a == 0) break;
      const uint8_t* b = in_.ptr();
      size_t i = 0;
      while (n < o.cap) {
        if (i < a && b[i] >= special) {  // overflow or reset
          if (atis_)
            t += 63 * (b[i] & 3);  // 0xFC (reset) adds 0
          else if (b[i] == 0xFF)
            t += 127;
          ++i;
          continue;
        }
        if (i + 5 > a) break;
        uint16_t y = load_le16(b + i + 3);
        if (y > h1)
          fail_at_byte(in_.name(), in_.offset() + i,
                       "event y " + std::to_string(y) + " is outside the " +
                           std::to_string(sensor_.width) + "x" + std::to_string(sensor_.height) +
                           " sensor");
        t += b[i] >> shift;
        o.t[n] = t;
        o.x[n] = load_le16(b + i + 1);
        o.y[n] = uint16_t(h1 - y);
        o.p[n] = atis_ ? (b[i] >> 1) & 1 : b[i] & 1;
        n += atis_ ? 1 - (b[i] & 1) : 1;  // ATIS threshold crossings are not kept
        i += 5;
      }
      in_.consume(i);
      if (i == 0 && n < o.cap) {  // fewer than 5 bytes left at the end: a cut event
        fail_at_byte(in_.name(), in_.offset(),
                     "file is truncated: " + std::to_string(a) + " bytes of a 5-byte DVS event");
      }
    }
    t_ = t;
    o.n = n;
  }

 private:
  BlockInput in_;
  int64_t t_ = 0;
  bool atis_ = false;
};

}  // namespace

FormatInfo es_format() {
  FormatInfo f;
  f.name = "es";
  f.description = "Event Stream 2.x, DVS and ATIS types (Neuromorphic-Paris, sepia, faery)";
  f.extensions = {".es"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    return starts_with(head, kMagic) ? 100 : 0;
  };
  f.open_bytes = [](std::unique_ptr<ByteSource> src, const ReadOptions&) {
    return std::unique_ptr<EventReader>(std::make_unique<EsReader>(std::move(src)));
  };
  return f;
}

}  // namespace spikems
