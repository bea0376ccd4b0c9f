// Prophesee RAW, EVT 3.0: 16-bit little-endian words, type in the top 4 bits.
// Reference: docs.prophesee.ai, "EVT 3.0 Format". The decoder keeps the state the format
// implies (row y, vector base x and polarity, time high/low) and writes events by index.
#include <bit>

#include "core/events/formats/camera_reader.h"
#include "core/events/formats/camera_writers.h"
#include "core/events/formats/prophesee_header.h"
#include "core/util/error.h"

namespace spikems {

namespace {

enum : unsigned {
  kAddrY = 0x0,
  kAddrX = 0x2,
  kVectBaseX = 0x3,
  kVect12 = 0x4,
  kVect8 = 0x5,
  kTimeLow = 0x6,
  kTimeHigh = 0x8,
};

class Evt3Reader final : public CameraReader {
 public:
  explicit Evt3Reader(std::unique_ptr<ByteSource> src) : in_(std::move(src)) {
    auto lines = in_.read_header_lines('%', "% end");
    PropheseeHeader h = parse_prophesee_header(lines, in_.name());
    if (!h.evt.empty() && h.evt != "3.0")
      fail_at_byte(in_.name(), 0,
                   "the header says this RAW file is EVT " + h.evt + ", not EVT 3.0; read it as " +
                       (h.evt == "2.0" ? std::string("--format evt2") : "another format"));
    sensor_ = h.sensor;
    wrap_ = h.time_offset_us;
  }
  std::string format_name() const override { return "evt3"; }

 protected:
  void decode(Out& o) override {
    // State in locals for the hot loop; written back when the chunk is done.
    int64_t wrap = wrap_, tc = tc_;
    uint32_t th = th_;
    uint16_t y = y_, bx = bx_;
    uint8_t pol = pol_;
    bool have_t = have_t_;
    size_t n = o.n;
    const size_t cap = o.cap;
    int64_t* T = o.t;
    uint16_t* X = o.x;
    uint16_t* Y = o.y;
    uint8_t* P = o.p;
    while (n < cap) {
      size_t a = in_.fill(2);
      if (a < 2) {
        if (a == 1)
          fail_at_byte(in_.name(), in_.offset(), "file ends inside a 16-bit EVT 3.0 word");
        break;
      }
      const uint8_t* b = in_.ptr();
      const size_t nw = a / 2;
      size_t i = 0;
      for (; i < nw && n < cap; ++i) {
        const uint32_t w = load_le16(b + 2 * i);
        switch (w >> 12) {
          case kAddrY:
            y = uint16_t(w & 0x7FF);
            break;
          case kAddrX:
            if (have_t) {
              T[n] = tc;
              X[n] = uint16_t(w & 0x7FF);
              Y[n] = y;
              P[n] = uint8_t((w >> 11) & 1);
              ++n;
            }
            break;
          case kVectBaseX:
            bx = uint16_t(w & 0x7FF);
            pol = uint8_t((w >> 11) & 1);
            break;
          case kVect12:
          case kVect8: {
            uint32_t m = (w >> 12) == kVect12 ? (w & 0xFFF) : (w & 0xFF);
            if (have_t) {
              while (m) {
                int k = std::countr_zero(m);
                T[n] = tc;
                X[n] = uint16_t(bx + k);
                Y[n] = y;
                P[n] = pol;
                ++n;
                m &= m - 1;
              }
            }
            bx = uint16_t(bx + ((w >> 12) == kVect12 ? 12 : 8));
            break;
          }
          case kTimeLow:
            tc = wrap + (int64_t(th) << 12) + (w & 0xFFF);
            break;
          case kTimeHigh: {
            uint32_t v = w & 0xFFF;
            // The 24-bit time base wraps: only a DECREASING time high means a wrap.
            if (have_t && v < th) wrap += int64_t(1) << 24;
            th = v;
            have_t = true;
            tc = wrap + (int64_t(th) << 12);
            break;
          }
          default:  // EXT_TRIGGER, OTHERS, CONTINUED: no CD event
            break;
        }
      }
      in_.consume(2 * i);
    }
    o.n = n;
    wrap_ = wrap;
    tc_ = tc;
    th_ = th;
    y_ = y;
    bx_ = bx;
    pol_ = pol;
    have_t_ = have_t;
  }

 private:
  BlockInput in_;
  int64_t wrap_ = 0, tc_ = 0;
  uint32_t th_ = 0;
  uint16_t y_ = 0, bx_ = 0;
  uint8_t pol_ = 0;
  bool have_t_ = false;  // CD events before the first TIME_HIGH have no time: dropped
};

}  // namespace

FormatInfo evt3_format() {
  FormatInfo f;
  f.name = "evt3";
  f.description = "Prophesee RAW, EVT 3.0 (16-bit vectorised words, Gen4/IMX636 cameras)";
  f.extensions = {".raw"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    std::string h = prophesee_header_text(head);
    if (h.empty()) return 0;
    if (h.find("% evt 3.0") != std::string::npos || h.find("% format evt3") != std::string::npos)
      return 100;
    if (h.find("% evt ") != std::string::npos || h.find("% format ") != std::string::npos) return 0;
    // No evt field: Gen4-class plugins produce EVT 3.0.
    if (h.find("gen4") != std::string::npos || h.find("imx6") != std::string::npos) return 40;
    return 0;
  };
  f.open_bytes = [](std::unique_ptr<ByteSource> src, const ReadOptions&) {
    return std::unique_ptr<EventReader>(std::make_unique<Evt3Reader>(std::move(src)));
  };
  f.open_writer = open_evt3_writer;
  return f;
}

}  // namespace spikems
