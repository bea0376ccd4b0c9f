#include "core/eval/window_list.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/util/error.h"

namespace spikems {

namespace {

[[noreturn]] void bad(const std::string& text, const std::string& item, const std::string& why) {
  fail("--windows", "'" + item + "'",
       why + " (in '" + text +
           "'; give milliseconds, comma-separated, or ranges FROM:TO[:STEP], e.g. 20,100 or "
           "1:25)");
}

// One value in ms, as whole microseconds.
int64_t parse_ms(const std::string& text, const std::string& item, const std::string& v) {
  if (v.empty()) bad(text, item, "a value is missing");
  char* end = nullptr;
  const double ms = std::strtod(v.c_str(), &end);
  if (end != v.c_str() + v.size() || !std::isfinite(ms) || v.find_first_of(" \t") == 0)
    bad(text, item, "'" + v + "' is not a number of milliseconds");
  if (ms <= 0) bad(text, item, "a window length must be positive");
  if (ms > 1e9) bad(text, item, "'" + v + "' is too long");
  const double us = ms * 1000.0;
  const int64_t r = std::llround(us);
  if (std::fabs(us - double(r)) > 1e-6) bad(text, item, "not a whole number of microseconds");
  return r;
}

}  // namespace

std::vector<int64_t> parse_window_list_ms(const std::string& text) {
  std::vector<int64_t> out;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string item =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (item.empty()) bad(text, item, "an empty item");
    std::vector<std::string> parts;
    for (size_t a = 0;;) {
      const size_t c = item.find(':', a);
      parts.push_back(item.substr(a, c == std::string::npos ? std::string::npos : c - a));
      if (c == std::string::npos) break;
      a = c + 1;
    }
    if (parts.size() == 1) {
      out.push_back(parse_ms(text, item, parts[0]));
    } else if (parts.size() <= 3) {
      const int64_t from = parse_ms(text, item, parts[0]), to = parse_ms(text, item, parts[1]);
      const int64_t step = parts.size() == 3 ? parse_ms(text, item, parts[2]) : 1000;
      if (to < from) bad(text, item, "the range runs backwards");
      if ((to - from) / step >= 10000) bad(text, item, "the range has more than 10000 values");
      for (int64_t w = from; w <= to; w += step) out.push_back(w);
    } else {
      bad(text, item, "a range is FROM:TO or FROM:TO:STEP");
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace spikems
