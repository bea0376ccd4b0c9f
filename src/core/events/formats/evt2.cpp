// Prophesee RAW, EVT 2.0: 32-bit little-endian words, type in the top 4 bits.
// Reference: docs.prophesee.ai, "EVT 2.0 Format". CD word: type | 6-bit time low | 11-bit x |
// 11-bit y; EVT_TIME_HIGH carries the upper 28 bits of the 34-bit microsecond time.
#include "core/events/formats/camera_reader.h"
#include "core/events/formats/prophesee_header.h"
#include "core/util/error.h"

namespace spikems {

namespace {

enum : unsigned { kCdOff = 0x0, kCdOn = 0x1, kTimeHigh = 0x8 };

class Evt2Reader final : public CameraReader {
 public:
  explicit Evt2Reader(std::unique_ptr<ByteSource> src) : in_(std::move(src)) {
    auto lines = in_.read_header_lines('%', "% end");
    PropheseeHeader h = parse_prophesee_header(lines, in_.name());
    if (!h.evt.empty() && h.evt != "2.0")
      fail_at_byte(in_.name(), 0,
                   "the header says this RAW file is EVT " + h.evt + ", not EVT 2.0; read it as " +
                       (h.evt == "3.0" ? std::string("--format evt3") : "another format"));
    sensor_ = h.sensor;
    wrap_ = h.time_offset_us;
  }
  std::string format_name() const override { return "evt2"; }

 protected:
  void decode(Out& o) override {
    int64_t base = base_, wrap = wrap_;
    uint32_t th = th_;
    bool have_t = have_t_;
    size_t n = o.n;
    while (n < o.cap) {
      size_t a = in_.fill(4);
      if (a < 4) {
        if (a > 0) fail_at_byte(in_.name(), in_.offset(), "file ends inside a 32-bit EVT 2.0 word");
        break;
      }
      const uint8_t* b = in_.ptr();
      const size_t nw = std::min(a / 4, o.cap - n);  // at most one event per word
      for (size_t i = 0; i < nw; ++i) {
        const uint32_t w = load_le32(b + 4 * i);
        const uint32_t type = w >> 28;
        if (type <= kCdOn) {
          if (have_t) {
            o.t[n] = base + ((w >> 22) & 0x3F);
            o.x[n] = uint16_t((w >> 11) & 0x7FF);
            o.y[n] = uint16_t(w & 0x7FF);
            o.p[n] = uint8_t(type);
            ++n;
          }
        } else if (type == kTimeHigh) {
          uint32_t v = w & 0x0FFFFFFF;
          if (have_t && v < th) wrap += int64_t(1) << 34;  // the 34-bit time wrapped
          th = v;
          have_t = true;
          base = wrap + (int64_t(v) << 6);
        }  // EXT_TRIGGER, OTHERS, CONTINUED: no CD event
      }
      in_.consume(4 * nw);
    }
    o.n = n;
    base_ = base;
    wrap_ = wrap;
    th_ = th;
    have_t_ = have_t;
  }

 private:
  BlockInput in_;
  int64_t base_ = 0, wrap_ = 0;
  uint32_t th_ = 0;
  bool have_t_ = false;
};

}  // namespace

FormatInfo evt2_format() {
  FormatInfo f;
  f.name = "evt2";
  f.description = "Prophesee RAW, EVT 2.0 (32-bit words, Gen3 cameras)";
  f.extensions = {".raw"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    std::string h = prophesee_header_text(head);
    if (h.empty()) return 0;
    if (h.find("% evt 2.0") != std::string::npos || h.find("% format evt2;") != std::string::npos ||
        h.find("% format evt2\n") != std::string::npos)
      return 100;
    if (h.find("% evt ") != std::string::npos || h.find("% format ") != std::string::npos) return 0;
    if (h.find("gen3") != std::string::npos) return 40;  // Gen3 plugins produce EVT 2.0
    return 0;
  };
  f.open_bytes = [](std::unique_ptr<ByteSource> src, const ReadOptions&) {
    return std::unique_ptr<EventReader>(std::make_unique<Evt2Reader>(std::move(src)));
  };
  return f;
}

}  // namespace spikems
