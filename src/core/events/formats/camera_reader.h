// Plumbing shared by the camera-format readers (Prophesee RAW/DAT, AEDAT, Event Stream):
// a block-buffered input that knows absolute byte offsets, and a base reader that decodes
// straight into the EventStream's arrays (resize once, write by index) so that the inner
// loops of the decoders carry no per-event push_back or virtual call.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/events/io.h"
#include "core/util/byte_source.h"

namespace spikems {

// Reads a ByteSource in large blocks; the decoder looks at ptr()/avail() and consumes.
class BlockInput {
 public:
  explicit BlockInput(std::unique_ptr<ByteSource> src, size_t block = size_t(1) << 20);
  // Makes at least n bytes available unless the input ends first; returns avail().
  size_t fill(size_t n);
  const uint8_t* ptr() const { return buf_.data() + pos_; }
  size_t avail() const { return end_ - pos_; }
  void consume(size_t n) { pos_ += n; }
  uint64_t offset() const { return base_ + pos_; }  // absolute offset of ptr()
  const std::string& name() const { return src_->name(); }
  uint64_t size() const { return src_->size(); }  // UINT64_MAX when unknown
  // Bytes left before the end of the input, when its size is known (else UINT64_MAX).
  uint64_t remaining() const {
    return size() == UINT64_MAX ? UINT64_MAX : (size() > offset() ? size() - offset() : 0);
  }
  // Reads exactly n bytes into dst (any size, bypassing the block for large reads).
  void read_exact(void* dst, size_t n, const char* what);
  void skip(uint64_t n, const char* what);
  // Reads the ASCII header lines starting with `prefix` (e.g. '%' or '#'); stops before the
  // first line that does not start with it, or after a line equal to `end_line` (if given).
  std::vector<std::string> read_header_lines(char prefix, const std::string& end_line = "",
                                             size_t max_bytes = size_t(1) << 20);

 private:
  std::unique_ptr<ByteSource> src_;
  std::vector<uint8_t> buf_;
  size_t block_;
  size_t pos_ = 0, end_ = 0;
  uint64_t base_ = 0;
  bool eof_ = false;
};

// Base of the camera readers. read() sizes the output once and lets decode() write events by
// index; events a decoder produces past the requested count (a vector word yields up to 32)
// wait in a small carry-over list for the next call, so chunk boundaries never matter.
class CameraReader : public EventReader {
 public:
  size_t read(EventStream& out, size_t max_events) final;
  SensorSize sensor() const override { return sensor_; }

 protected:
  struct Out {
    int64_t* t;
    uint16_t* x;
    uint16_t* y;
    uint8_t* p;
    size_t n;    // events written so far
    size_t cap;  // decode() stops once n >= cap; it may write up to kSlack more
  };
  static constexpr size_t kSlack = 64;
  // Decodes until o.n >= o.cap or the input ends (then it returns with o.n < o.cap).
  virtual void decode(Out& o) = 0;
  SensorSize sensor_;

 private:
  std::vector<Event> carry_;
};

// "WxH" or "W x H" → sensor size (unknown when the text does not parse).
SensorSize parse_geometry(const std::string& s);
// Trims ASCII spaces, tabs and CR at both ends.
std::string trim(const std::string& s);
// True when `head` starts with `magic`.
bool starts_with(const std::vector<uint8_t>& head, const std::string& magic);

}  // namespace spikems
