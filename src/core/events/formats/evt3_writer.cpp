// Writes Prophesee RAW EVT 3.0 (docs.prophesee.ai, "EVT 3.0 Format"): an ASCII header with
// the geometry, then 16-bit words. Time: EVT_TIME_HIGH (bits 12-23 of the 24-bit time) and
// EVT_TIME_LOW (bits 0-11), always a TIME_LOW after a TIME_HIGH so that decoders which reset
// or keep the low bits agree. Rows: EVT_ADDR_Y when y changes. Runs of 3+ events of one
// timestamp, row and polarity with increasing x become VECT_BASE_X + VECT_12 words, others
// EVT_ADDR_X, so reading back gives the events in their original order.
// Gaps over 2^24 us get intermediate TIME_HIGH words (a decoder counts a wrap only when
// TIME_HIGH decreases). Recordings whose first time is >= 2^24 us are written relative to a
// multiple of 2^24 us, stored in the header as "% spikems_time_offset_us" (other readers see
// times relative to it).
#include <ctime>

#include "core/events/formats/camera_writers.h"
#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {

namespace {

class Evt3Writer final : public EventWriter {
 public:
  Evt3Writer(const std::string& path, SensorSize sensor) : file_(path), sensor_(sensor) {
    if (!sensor.known())
      fail(path, "", "EVT 3.0 needs the sensor size; pass it (e.g. --sensor 1280x720)");
    if (sensor.width > 2048 || sensor.height > 2048)
      fail(path, "",
           "EVT 3.0 holds sensors up to 2048x2048, not " + std::to_string(sensor.width) + "x" +
               std::to_string(sensor.height));
  }

  void write(const EventStream& s) override {
    const size_t n = s.size();
    size_t i = 0;
    while (i < n) {
      check(s, i);
      if (!header_written_) write_header(s.t[i]);
      emit_time(s.t[i] - offset_);
      if (s.y[i] != cur_y_) {
        word(0x0000 | s.y[i]);
        cur_y_ = s.y[i];
      }
      // A run: same time, row and polarity, strictly increasing x.
      size_t j = i + 1;
      while (j < n && s.t[j] == s.t[i] && s.y[j] == s.y[i] && s.p[j] == s.p[i] &&
             s.x[j] > s.x[j - 1] && s.x[j] < sensor_.width)
        ++j;
      if (j - i >= 3) {
        for (size_t k = i + 1; k < j; ++k) ++count_;  // checked by the loop condition above
        emit_vector(s, i, j);
      } else {
        word(uint16_t(0x2000 | (s.p[i] << 11) | s.x[i]));
        j = i + 1;
      }
      ++count_;
      i = j;
    }
    if (buf_.size() > (size_t(1) << 20)) flush();
  }

  void close() override {
    if (!header_written_) write_header(0);
    flush();
    file_.commit();
  }

 private:
  void check(const EventStream& s, size_t i) {
    if (s.x[i] >= sensor_.width || s.y[i] >= sensor_.height)
      fail_at_event(file_.target(), count_,
                    "coordinates (" + std::to_string(s.x[i]) + ", " + std::to_string(s.y[i]) +
                        ") are outside the " + std::to_string(sensor_.width) + "x" +
                        std::to_string(sensor_.height) + " sensor");
    if (s.p[i] > 1) fail_at_event(file_.target(), count_, "polarity is not 0 or 1");
    if (s.t[i] < 0)
      fail_at_event(file_.target(), count_, "EVT 3.0 cannot hold negative timestamps");
    if (s.t[i] < last_t_)
      fail_at_event(file_.target(), count_,
                    "events are not in time order (EVT 3.0 needs them sorted); sort them first");
    last_t_ = s.t[i];
  }

  void write_header(int64_t t0) {
    offset_ = t0 - t0 % (int64_t(1) << 24);
    char date[32] = "";
    std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S", std::gmtime(&now));
    std::string w = std::to_string(sensor_.width), h = std::to_string(sensor_.height);
    std::string hdr = "% date " + std::string(date) + "\n% evt 3.0\n% format EVT3;height=" + h +
                      ";width=" + w + "\n% geometry " + w + "x" + h +
                      "\n% integrator_name spikems\n";
    if (offset_ > 0) hdr += "% spikems_time_offset_us " + std::to_string(offset_) + "\n";
    hdr += "% end\n";
    file_.write(hdr);
    header_written_ = true;
  }

  void emit_time(int64_t t) {
    const int64_t th = t >> 12;
    const int tl = int(t & 0xFFF);
    if (!time_started_) {  // th < 4096 thanks to the offset
      word(uint16_t(0x8000 | th));
      word(uint16_t(0x6000 | tl));
      cur_th_ = th;
      cur_tl_ = tl;
      time_started_ = true;
      return;
    }
    if (th != cur_th_) {
      while (th - cur_th_ > 4095) {  // one step per < 2^24 us keeps every wrap visible
        cur_th_ += 4095;
        word(uint16_t(0x8000 | (cur_th_ & 0xFFF)));
      }
      cur_th_ = th;
      word(uint16_t(0x8000 | (th & 0xFFF)));
      word(uint16_t(0x6000 | tl));
      cur_tl_ = tl;
    } else if (tl != cur_tl_) {
      word(uint16_t(0x6000 | tl));
      cur_tl_ = tl;
    }
  }

  // Events [i, j): one row, one polarity, increasing x.
  void emit_vector(const EventStream& s, size_t i, size_t j) {
    size_t k = i;
    while (k < j) {
      uint16_t base = s.x[k];
      word(uint16_t(0x3000 | (s.p[i] << 11) | base));
      // Consecutive VECT_12 words while the next event lies in the next 12 columns.
      while (k < j && s.x[k] < base + 12) {
        uint32_t mask = 0;
        while (k < j && s.x[k] < base + 12) mask |= 1u << (s.x[k++] - base);
        word(uint16_t(0x4000 | mask));
        base = uint16_t(base + 12);
      }
    }
  }

  void word(uint16_t w) {
    size_t p = buf_.size();
    buf_.resize(p + 2);
    store_le16(buf_.data() + p, w);
  }

  void flush() {
    if (!buf_.empty()) file_.write(buf_.data(), buf_.size());
    buf_.clear();
  }

  AtomicFile file_;
  SensorSize sensor_;
  std::vector<uint8_t> buf_;
  bool header_written_ = false, time_started_ = false;
  int64_t offset_ = 0, last_t_ = INT64_MIN, cur_th_ = 0;
  int cur_tl_ = -1, cur_y_ = -1;
  uint64_t count_ = 0;
};

}  // namespace

std::unique_ptr<EventWriter> open_evt3_writer(const std::string& path, SensorSize sensor,
                                              const WriteOptions& opt) {
  return std::make_unique<Evt3Writer>(path, sensor);
}

}  // namespace spikems
