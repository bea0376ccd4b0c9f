#include "core/events/formats/camera_reader.h"

#include <algorithm>
#include <cstring>

#include "core/util/error.h"

namespace spikems {

BlockInput::BlockInput(std::unique_ptr<ByteSource> src, size_t block)
    : src_(std::move(src)), block_(block) {
  base_ = src_->offset();
  // No larger than the input (a small file should not cost a large zeroed buffer).
  uint64_t size = src_->size();
  if (size != UINT64_MAX && size - std::min(size, base_) + 16 < block_)
    block_ = size_t(size - std::min(size, base_) + 16);
  buf_.resize(block_);
}

size_t BlockInput::fill(size_t n) {
  if (avail() >= n || eof_) return avail();
  if (pos_ > 0) {  // move the unread tail to the front
    std::memmove(buf_.data(), buf_.data() + pos_, end_ - pos_);
    end_ -= pos_;
    base_ += pos_;
    pos_ = 0;
  }
  if (buf_.size() < n) buf_.resize(n);
  while (end_ < n) {
    size_t r = src_->read_some(buf_.data() + end_, buf_.size() - end_);
    if (r == 0) {
      eof_ = true;
      break;
    }
    end_ += r;
  }
  return avail();
}

void BlockInput::read_exact(void* dst, size_t n, const char* what) {
  uint64_t start = offset();
  auto* d = static_cast<uint8_t*>(dst);
  size_t got = std::min(n, avail());
  std::memcpy(d, ptr(), got);
  consume(got);
  if (got < n && !eof_) {
    // Large reads go straight to the source; the block is empty now.
    base_ += pos_;
    pos_ = end_ = 0;
    while (got < n) {
      size_t r = src_->read_some(d + got, n - got);
      if (r == 0) {
        eof_ = true;
        break;
      }
      got += r;
      base_ += r;
    }
  }
  if (got < n)
    fail_at_byte(name(), start,
                 std::string("file is truncated: expected ") + std::to_string(n) + " bytes of " +
                     what + ", found " + std::to_string(got));
}

void BlockInput::skip(uint64_t n, const char* what) {
  uint64_t start = offset();
  uint64_t from_buf = std::min<uint64_t>(n, avail());
  consume(size_t(from_buf));
  n -= from_buf;
  if (n == 0) return;
  if (src_->size() != UINT64_MAX && src_->size() < offset() + n)
    fail_at_byte(name(), start,
                 std::string("file is truncated inside ") + what + " (" + std::to_string(n) +
                     " more bytes expected than the file holds)");
  base_ = offset() + n;
  pos_ = end_ = 0;
  src_->seek(base_);
}

std::vector<std::string> BlockInput::read_header_lines(char prefix, const std::string& end_line,
                                                       size_t max_bytes) {
  std::vector<std::string> lines;
  uint64_t start = offset();
  while (fill(1) > 0 && ptr()[0] == uint8_t(prefix)) {
    // Old files have no end line: binary data that happens to start with the prefix byte
    // is told from a header line by its control bytes, and ends the header.
    fill(4096);
    const uint8_t* q = ptr();
    const void* q_nl = std::memchr(q, '\n', avail());
    size_t q_len = q_nl ? size_t(static_cast<const uint8_t*>(q_nl) - q) : avail();
    if (std::any_of(q, q + q_len, [](uint8_t c) { return c < 0x20 && c != '\t' && c != '\r'; }))
      break;
    std::string line;
    for (;;) {
      if (fill(1) == 0) break;
      const uint8_t* p = ptr();
      size_t a = avail();
      const void* nl = std::memchr(p, '\n', a);
      size_t take = nl ? size_t(static_cast<const uint8_t*>(nl) - p) : a;
      line.append(reinterpret_cast<const char*>(p), take);
      consume(nl ? take + 1 : take);
      if (offset() - start > max_bytes)
        fail_at_byte(name(), start,
                     "header longer than " + std::to_string(max_bytes) +
                         " bytes: not a valid header (binary data where text was expected)");
      if (nl) break;
      if (fill(1) == 0)
        fail_at_byte(name(), offset(), "file is truncated inside its header (a line has no end)");
    }
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
    if (!end_line.empty() && line == end_line) break;
  }
  return lines;
}

size_t CameraReader::read(EventStream& out, size_t max_events) {
  if (max_events == 0) return 0;
  const size_t start = out.size();
  const size_t cap = std::min<size_t>(max_events, size_t(1) << 22);
  const bool labels = out.has_labels();
  std::vector<Event> pending;
  pending.swap(carry_);
  Out o{nullptr, nullptr, nullptr, nullptr, 0, 0};
  // Grow the arrays step by step (zero-filling a whole chunk for a short file costs more
  // than decoding it); each step lets decode() write by index.
  for (;;) {
    o.cap = std::min(cap, o.n + (size_t(1) << 16));
    const size_t room = start + std::max(o.cap, o.n + pending.size()) + kSlack;
    out.t.resize(room);
    out.x.resize(room);
    out.y.resize(room);
    out.p.resize(room);
    o.t = out.t.data() + start;
    o.x = out.x.data() + start;
    o.y = out.y.data() + start;
    o.p = out.p.data() + start;
    for (const Event& e : pending) {
      o.t[o.n] = e.t;
      o.x[o.n] = e.x;
      o.y[o.n] = e.y;
      o.p[o.n] = e.p;
      ++o.n;
    }
    pending.clear();
    if (o.n < o.cap) decode(o);
    if (o.n < o.cap || o.n >= cap) break;  // the input ended, or the chunk is full
  }
  for (size_t i = cap; i < o.n; ++i) carry_.push_back(Event{o.t[i], o.x[i], o.y[i], o.p[i], 0});
  size_t n = std::min(o.n, cap);
  out.t.resize(start + n);
  out.x.resize(start + n);
  out.y.resize(start + n);
  out.p.resize(start + n);
  if (labels) out.label.resize(start + n, 0);
  if (sensor_.known()) out.sensor = sensor_;
  return n;
}

std::string trim(const std::string& s) {
  size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  size_t e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

SensorSize parse_geometry(const std::string& s) {
  SensorSize r;
  unsigned w = 0, h = 0;
  char c = 0;
  std::string t = trim(s);
  if (std::sscanf(t.c_str(), "%u %c %u", &w, &c, &h) == 3 && (c == 'x' || c == 'X') && w > 0 &&
      h > 0 && w <= 65535 && h <= 65535) {
    r.width = int(w);
    r.height = int(h);
  }
  return r;
}

bool starts_with(const std::vector<uint8_t>& head, const std::string& magic) {
  return head.size() >= magic.size() && std::memcmp(head.data(), magic.data(), magic.size()) == 0;
}

}  // namespace spikems
