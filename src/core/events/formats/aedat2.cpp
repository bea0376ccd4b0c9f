// iniVation / jAER AEDAT 2.0: '#' header lines (the first "#!AER-DAT2.0"), then big-endian
// pairs of int32 address and int32 timestamp (us). The address layout is the jAER chip
// class's (docs.inivation.com, "AEDAT 2.0"/"AEDAT 1.0"); supported:
//   DAVIS family (DAVIS240A/B/C, DAVIS346, DAVIS640; the default): bit 31 = 1 for APS/IMU
//     samples (skipped), bit 10 = 1 for external/special events (skipped), y in bits 22-30,
//     x in bits 12-21, polarity in bit 11 (1 = ON);
//   DVS128 (header names DVS128): bit 15 external event (skipped), y in bits 8-14, x in bits
//     1-7, polarity in bit 0 (1 = ON).
// jAER puts (0, 0) in the lower-left corner: y is flipped to the top-left origin, which needs
// the sensor height (from the AEChip/HardwareInterface header lines, or --sensor).
#include "core/events/formats/aedat_chips.h"
#include "core/events/formats/camera_reader.h"
#include "core/util/error.h"

namespace spikems {

namespace {

const std::string kMagic = "#!AER-DAT2.0";

class Aedat2Reader final : public CameraReader {
 public:
  Aedat2Reader(std::unique_ptr<ByteSource> src, const ReadOptions& opt) : in_(std::move(src)) {
    auto lines = in_.read_header_lines('#');
    if (lines.empty() || lines[0].rfind(kMagic, 0) != 0)
      fail_at_byte(in_.name(), 0, "not an AEDAT 2.0 file (first line is not #!AER-DAT2.0)");
    std::string chip;
    for (const auto& l : lines)
      if (l.find("AEChip") != std::string::npos || l.find("HardwareInterface") != std::string::npos)
        chip += l + "\n";
    dvs128_ = chip.find("DVS128") != std::string::npos;
    sensor_ = opt.sensor.known() ? opt.sensor : inivation_sensor_from_text(chip);
    if (!sensor_.known())
      fail(in_.name(), "header",
           "the AEDAT 2.0 header names no known camera (DVS128, DAVIS240/346/640), so the sensor "
           "size needed to flip jAER's bottom-left y is unknown; pass --sensor WxH");
  }
  std::string format_name() const override { return "aedat2"; }

 protected:
  void decode(Out& o) override {
    size_t n = o.n;
    const int h1 = sensor_.height - 1;
    while (n < o.cap) {
      size_t a = in_.fill(8);
      if (a < 8) {
        if (a > 0)
          fail_at_byte(in_.name(), in_.offset(),
                       "file is truncated: " + std::to_string(a) + " bytes of an 8-byte event");
        break;
      }
      const uint8_t* b = in_.ptr();
      const size_t nr = std::min(a / 8, o.cap - n);
      for (size_t i = 0; i < nr; ++i) {
        uint32_t addr = load_be32(b + 8 * i), ts = load_be32(b + 8 * i + 4);
        uint32_t x, y, p;
        if (dvs128_) {
          if (addr & 0x8000) continue;
          y = (addr >> 8) & 0x7F;
          x = (addr >> 1) & 0x7F;
          p = addr & 1;
        } else {
          if (addr & 0x80000000u || addr & 0x400) continue;  // APS/IMU or external event
          y = (addr >> 22) & 0x1FF;
          x = (addr >> 12) & 0x3FF;
          p = (addr >> 11) & 1;
        }
        if (int(y) > h1)
          fail_at_byte(in_.name(), in_.offset() + 8 * i,
                       "event y " + std::to_string(y) + " is outside the " +
                           std::to_string(sensor_.width) + "x" + std::to_string(sensor_.height) +
                           " sensor (wrong camera? pass --sensor WxH)");
        // int32 microseconds wrap after 71 minutes: a large step back is a wrap.
        int64_t t = (time_ & ~int64_t(0xFFFFFFFF)) | ts;
        if (t < time_ && time_ - t > (int64_t(1) << 31)) t += int64_t(1) << 32;
        time_ = t;
        o.t[n] = t;
        o.x[n] = uint16_t(x);
        o.y[n] = uint16_t(h1 - int(y));
        o.p[n] = uint8_t(p);
        ++n;
      }
      in_.consume(8 * nr);
    }
    o.n = n;
  }

 private:
  BlockInput in_;
  bool dvs128_ = false;
  int64_t time_ = 0;
};

}  // namespace

FormatInfo aedat2_format() {
  FormatInfo f;
  f.name = "aedat2";
  f.description = "iniVation/jAER AEDAT 2.0 (DAVIS240/346/640 and DVS128 address layouts)";
  f.extensions = {".aedat", ".dat"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    return starts_with(head, kMagic) ? 100 : 0;
  };
  f.open_bytes = [](std::unique_ptr<ByteSource> src, const ReadOptions& opt) {
    return std::unique_ptr<EventReader>(std::make_unique<Aedat2Reader>(std::move(src), opt));
  };
  return f;
}

}  // namespace spikems
