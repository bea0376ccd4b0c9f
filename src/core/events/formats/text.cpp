#include "core/events/formats/text.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <deque>

#include "core/util/atomic_file.h"
#include "core/util/error.h"

namespace spikems {

namespace {

constexpr size_t kMaxLine = 4096;
constexpr size_t kUnitLookahead = 1000;

// Decimal digits of the numbers 00..99, two characters each.
constexpr auto kDigitPairs = [] {
  std::array<char, 200> d{};
  for (int i = 0; i < 100; ++i)
    d[size_t(2 * i)] = char('0' + i / 10), d[size_t(2 * i + 1)] = char('0' + i % 10);
  return d;
}();

// v in decimal at o; returns the end. The label writer's numbers: a time of up to 20 digits,
// and coordinates and labels of at most 5 (uint16). Two digits per division from the end,
// with the length found first by comparisons: ~20 ms for the 2.1 M label lines of a busy room
// against ~30 ms with std::to_chars (docs/performance.md, "Start-up and output").
inline char* put_decimal(char* o, uint64_t v) {
  int n = 1;
  for (uint64_t p = 10; n < 20 && v >= p; p *= 10) ++n;
  char* const end = o + n;
  char* q = end;
  while (v >= 100) {
    q -= 2;
    std::memcpy(q, &kDigitPairs[size_t(v % 100) * 2], 2);
    v /= 100;
  }
  if (v >= 10)
    std::memcpy(q - 2, &kDigitPairs[size_t(v) * 2], 2);
  else
    q[-1] = char('0' + v);
  return end;
}

inline char* put_small(char* o, uint32_t v) {  // v < 65536
  if (v < 10) {
    *o = char('0' + v);
    return o + 1;
  }
  if (v < 100) {
    std::memcpy(o, &kDigitPairs[v * 2], 2);
    return o + 2;
  }
  if (v < 1000) {
    *o = char('0' + v / 100);
    std::memcpy(o + 1, &kDigitPairs[(v % 100) * 2], 2);
    return o + 3;
  }
  return put_decimal(o, v);
}

// Buffered line splitter over a ByteSource (one virtual call per block, not per byte).
class LineInput {
 public:
  explicit LineInput(std::unique_ptr<ByteSource> src) : src_(std::move(src)), buf_(1 << 16) {}
  const std::string& name() const { return src_->name(); }
  uint64_t line_no() const { return line_no_; }
  // Next line without its terminator ('\r' stripped); false at the end.
  bool next(std::string_view& line) {
    for (;;) {
      const char* b = buf_.data() + pos_;
      const char* nl = static_cast<const char*>(std::memchr(b, '\n', end_ - pos_));
      if (nl) {
        size_t len = size_t(nl - b);
        pos_ += len + 1;
        return emit(b, len, line);
      }
      if (eof_) {
        if (pos_ == end_) return false;
        size_t len = end_ - pos_;
        pos_ = end_;
        return emit(b, len, line);
      }
      if (end_ - pos_ > kMaxLine)
        fail_at_line(name(), line_no_ + 1,
                     "line longer than " + std::to_string(kMaxLine) +
                         " bytes: this is not a text event file (binary data?)");
      std::memmove(buf_.data(), b, end_ - pos_);
      end_ -= pos_;
      pos_ = 0;
      size_t r = src_->read_some(buf_.data() + end_, buf_.size() - end_);
      if (r == 0) eof_ = true;
      end_ += r;
    }
  }

 private:
  bool emit(const char* b, size_t len, std::string_view& line) {
    if (len > kMaxLine)
      fail_at_line(name(), line_no_ + 1, "line longer than " + std::to_string(kMaxLine) + " bytes");
    if (len && b[len - 1] == '\r') --len;
    ++line_no_;
    line = std::string_view(b, len);
    return true;
  }
  std::unique_ptr<ByteSource> src_;
  std::vector<char> buf_;
  size_t pos_ = 0, end_ = 0;
  bool eof_ = false;
  uint64_t line_no_ = 0;
};

bool is_sep(char c) {
  return c == ' ' || c == '\t' || c == ',';
}

// Splits a data line into at most 6 fields; returns the count.
int split(std::string_view s, std::string_view* f) {
  int n = 0;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_sep(s[i])) ++i;
    if (i >= s.size()) break;
    size_t j = i;
    while (j < s.size() && !is_sep(s[j])) ++j;
    if (n == 6) return 7;
    f[n++] = s.substr(i, j - i);
    i = j;
  }
  return n;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// A CSV column-header row such as "timestamp,x,y,polarity": 4 or 5 fields, none a number.
bool is_column_header(std::string_view line) {
  std::string_view f[7];
  int k = split(line, f);
  if (k != 4 && k != 5) return false;
  for (int j = 0; j < k; ++j) {
    char c = f[j].front();
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.')
      return false;
  }
  return true;
}

bool looks_fractional(std::string_view t) {
  return t.find_first_of(".eE") != std::string_view::npos;
}

class TextReader final : public EventReader {
 public:
  TextReader(std::unique_ptr<ByteSource> src, const ReadOptions& opt) : in_(std::move(src)) {
    if (opt.time_unit != "auto" && opt.time_unit != "s" && opt.time_unit != "us")
      fail(in_.name(), "", "time unit '" + opt.time_unit + "' is not auto, s or us");
    if (opt.sensor.known()) sensor_ = opt.sensor;
    // Read comments and up to kUnitLookahead data lines to settle the header and time unit.
    std::string_view line;
    std::string unit_comment;
    while (pending_.size() < kUnitLookahead && in_.next(line)) {
      std::string_view s = trim(line);
      if (s.empty()) continue;
      if (s.front() == '#') {
        if (pending_.empty()) header_comment(s, unit_comment, opt.sensor.known());
        continue;
      }
      if (pending_.empty() && !header_row_seen_ && is_column_header(s)) {
        header_row_seen_ = true;  // CSV column names: skipped
        continue;
      }
      pending_.push_back({in_.line_no(), std::string(s)});
    }
    if (opt.time_unit != "auto") {
      seconds_ = opt.time_unit == "s";
    } else if (!unit_comment.empty()) {
      seconds_ = unit_comment == "s";
    } else {
      std::string_view f[7];
      for (const auto& p : pending_)
        if (split(p.second, f) >= 1 && looks_fractional(f[0])) seconds_ = true;
    }
  }
  std::string format_name() const override { return "text"; }
  SensorSize sensor() const override {
    if (sensor_.known()) return sensor_;
    if (any_) return {max_x_ + 1, max_y_ + 1};
    return {};
  }
  size_t read(EventStream& out, size_t max_events) override {
    if (sensor_.known()) out.sensor = sensor_;
    size_t n = 0;
    std::string_view line;
    while (n < max_events) {
      uint64_t no;
      if (!pending_.empty()) {
        held_ = std::move(pending_.front().second);
        no = pending_.front().first;
        pending_.pop_front();
        line = held_;
      } else {
        if (!in_.next(line)) break;
        no = in_.line_no();
        line = trim(line);
        if (line.empty() || line.front() == '#') continue;
      }
      parse_line(line, no, out);
      ++n;
    }
    return n;
  }

 private:
  void header_comment(std::string_view s, std::string& unit, bool sensor_forced) {
    s.remove_prefix(1);
    s = trim(s);
    std::string_view f[7];
    int k = split(s, f);
    if (k == 3 && f[0] == "sensor") {
      int w = 0, h = 0;
      auto r1 = std::from_chars(f[1].data(), f[1].data() + f[1].size(), w);
      auto r2 = std::from_chars(f[2].data(), f[2].data() + f[2].size(), h);
      if (r1.ec != std::errc() || r2.ec != std::errc() || w <= 0 || h <= 0 || w > 65536 ||
          h > 65536)
        fail_at_line(in_.name(), in_.line_no(), "bad '# sensor W H' comment");
      if (!sensor_forced) sensor_ = {w, h};
    } else if (k == 2 && f[0] == "time_unit") {
      if (f[1] != "s" && f[1] != "us")
        fail_at_line(in_.name(), in_.line_no(), "'# time_unit' must be s or us");
      unit = std::string(f[1]);
    }
  }

  [[noreturn]] void bad(uint64_t no, const std::string& why, std::string_view line) {
    fail_at_line(in_.name(), no, why + " in \"" + std::string(line.substr(0, 120)) + "\"");
  }

  void parse_line(std::string_view line, uint64_t no, EventStream& out) {
    std::string_view f[7];
    int k = split(line, f);
    if (k != 4 && k != 5)
      bad(no, "expected 4 or 5 fields (t x y p [label]), found " + std::to_string(k), line);
    if (columns_ == 0) columns_ = k;
    if (k != columns_)
      bad(no,
          "this line has " + std::to_string(k) + " fields, earlier lines " +
              std::to_string(columns_),
          line);
    int64_t t;
    if (seconds_) {
      double s;
      auto r = std::from_chars(f[0].data(), f[0].data() + f[0].size(), s);
      if (r.ec != std::errc() || r.ptr != f[0].data() + f[0].size())
        bad(no, "timestamp is not a number", line);
      if (!std::isfinite(s) || std::fabs(s) > 9e12)
        bad(no, "timestamp is not finite or out of range", line);
      t = std::llround(s * 1e6);
    } else {
      auto r = std::from_chars(f[0].data(), f[0].data() + f[0].size(), t);
      if (r.ec != std::errc() || r.ptr != f[0].data() + f[0].size())
        bad(no,
            looks_fractional(f[0]) ? "fractional timestamp in a file read as microseconds "
                                     "(pass --time-unit s)"
                                   : "timestamp is not an integer number of microseconds",
            line);
    }
    auto coord = [&](std::string_view v, const char* what) {
      int c = -1;
      auto r = std::from_chars(v.data(), v.data() + v.size(), c);
      if (r.ec != std::errc() || r.ptr != v.data() + v.size() || c < 0 || c > 65535)
        bad(no, std::string(what) + " is not a pixel coordinate (0..65535)", line);
      return uint16_t(c);
    };
    uint16_t x = coord(f[1], "x"), y = coord(f[2], "y");
    std::string_view pv = f[3];
    if (!pv.empty() && pv.front() == '+') pv.remove_prefix(1);
    uint8_t p;
    if (pv == "1" || pv == "1.0")
      p = 1;
    else if (pv == "0" || pv == "-1" || pv == "0.0" || pv == "-1.0")
      p = 0;
    else
      bad(no, "polarity must be 0/1 or -1/+1", line);
    if (k == 5) {
      uint16_t l = coord(f[4], "label");
      out.push_back(t, x, y, p, l);
    } else {
      out.push_back(t, x, y, p);
    }
    any_ = true;
    max_x_ = std::max<int>(max_x_, x);
    max_y_ = std::max<int>(max_y_, y);
  }

  LineInput in_;
  std::deque<std::pair<uint64_t, std::string>> pending_;
  std::string held_;
  SensorSize sensor_;
  bool seconds_ = false;
  bool header_row_seen_ = false;
  int columns_ = 0;
  bool any_ = false;
  int max_x_ = 0, max_y_ = 0;
};

class TextWriter final : public EventWriter {
 public:
  TextWriter(const std::string& path, SensorSize sensor, const WriteOptions& opt)
      : sensor_(sensor) {
    if (opt.time_unit != "us" && opt.time_unit != "s")
      fail(path, "", "time unit '" + opt.time_unit + "' is not s or us");
    seconds_ = opt.time_unit == "s";
    if (path == "-")
      out_ = stdout;
    else
      file_ = std::make_unique<AtomicFile>(path);
  }
  void write(const EventStream& ev) override {
    if (!header_done_) header(ev);
    // Straight into a fixed buffer (a line is at most kMaxLine bytes): at 1 M ev/s the text
    // labels of `spikems segment` cost a tenth of its time with a growing string.
    const bool labelled = labels_ && ev.has_labels();
    for (size_t i = 0; i < ev.size(); ++i) {
      if (pos_ > kBuffer - kMaxLine) flush();
      char* o = buf_.get() + pos_;
      if (seconds_) {  // exact: integer seconds, then six digits of microseconds
        int64_t t = ev.t[i];
        if (t < 0) *o++ = '-', t = -t;
        o = put_decimal(o, uint64_t(t / 1000000));
        *o++ = '.';
        const int64_t us = t % 1000000;
        for (int64_t d = 100000; d > 0; d /= 10) *o++ = char('0' + (us / d) % 10);
      } else {
        const int64_t t = ev.t[i];
        if (t < 0) *o++ = '-';
        o = put_decimal(o, t < 0 ? uint64_t(0) - uint64_t(t) : uint64_t(t));
      }
      *o++ = ' ';
      o = put_small(o, ev.x[i]);
      *o++ = ' ';
      o = put_small(o, ev.y[i]);
      *o++ = ' ';
      *o++ = char('0' + ev.p[i]);
      if (labels_) {
        *o++ = ' ';
        o = put_small(o, labelled ? ev.label[i] : 0u);
      }
      *o++ = '\n';
      pos_ = size_t(o - buf_.get());
    }
    if (out_) {  // stdout: every batch goes on at once (a pipe, a live stream's labels)
      flush();
      std::fflush(out_);
    }
  }
  void close() override {
    if (!header_done_) header(EventStream{});
    flush();
    if (file_)
      file_->commit();
    else
      std::fflush(out_);
  }

 private:
  void header(const EventStream& first) {
    header_done_ = true;
    labels_ = first.has_labels();
    if (!sensor_.known()) sensor_ = first.sensor;
    std::string h = labels_ ? "# spikems events: t x y p label\n" : "# spikems events: t x y p\n";
    if (sensor_.known())
      h +=
          "# sensor " + std::to_string(sensor_.width) + " " + std::to_string(sensor_.height) + "\n";
    h += seconds_ ? "# time_unit s\n" : "# time_unit us\n";
    std::memcpy(buf_.get() + pos_, h.data(), h.size());  // the buffer is empty: it fits
    pos_ += h.size();
  }
  void flush() {
    if (file_)
      file_->write(buf_.get(), pos_);
    else if (std::fwrite(buf_.get(), 1, pos_, out_) != pos_)
      throw Error("<stdout>: write failed");
    pos_ = 0;
  }
  SensorSize sensor_;
  bool seconds_ = false, header_done_ = false, labels_ = false;
  std::unique_ptr<AtomicFile> file_;
  std::FILE* out_ = nullptr;
  // '-' t (19 digits) '.' 6 digits, x, y (5 each), p, label (5), spaces and newline: < 64.
  static constexpr size_t kMaxLine = 64, kBuffer = size_t(1) << 20;
  std::unique_ptr<char[]> buf_ = std::make_unique<char[]>(kBuffer);
  size_t pos_ = 0;
};

}  // namespace

std::unique_ptr<EventReader> open_text_reader(std::unique_ptr<ByteSource> src,
                                              const ReadOptions& opt) {
  return std::make_unique<TextReader>(std::move(src), opt);
}

FormatInfo text_format() {
  FormatInfo f;
  f.name = "text";
  f.description = "Text lines 't x y p [label]' (t in s or us; '# sensor W H' header; '-' = stdin)";
  f.extensions = {".txt", ".csv"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    if (path == "-") return 30;
    // Printable text whose first data line holds 4 or 5 numbers.
    size_t i = 0;
    for (uint8_t c : head)
      if (c < 9 || (c > 13 && c < 32) || c > 126) return 0;
    std::string s(head.begin(), head.end());
    bool header_row = false;
    while (i < s.size()) {
      size_t e = s.find('\n', i);
      if (e == std::string::npos) e = s.size();
      std::string_view l = trim(std::string_view(s).substr(i, e - i));
      if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
      i = e + 1;
      if (l.empty() || l.front() == '#') continue;
      if (!header_row && is_column_header(l)) {
        header_row = true;
        continue;
      }
      std::string_view fl[7];
      int k = split(l, fl);
      if (k != 4 && k != 5) return 0;
      for (int j = 0; j < k; ++j) {
        double v;
        auto r =
            std::from_chars(fl[j].data() + (fl[j].front() == '+'), fl[j].data() + fl[j].size(), v);
        if (r.ec != std::errc()) return 0;
      }
      return 40;
    }
    return 0;
  };
  f.open_bytes = open_text_reader;
  f.open_path = [](const std::string& path, const ReadOptions& opt) {
    return open_text_reader(path == "-" ? open_stdin_source() : open_file_source(path), opt);
  };
  f.open_writer = [](const std::string& path, SensorSize s,
                     const WriteOptions& opt) -> std::unique_ptr<EventWriter> {
    return std::make_unique<TextWriter>(path, s, opt);
  };
  return f;
}

}  // namespace spikems
