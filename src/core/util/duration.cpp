#include "core/util/duration.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/util/error.h"

namespace spikems {

int64_t parse_duration_us(const std::string& text) {
  auto bad = [&](const std::string& why) -> int64_t {
    fail("duration '" + text + "'", "",
         why + " (write e.g. 1.5s, 250ms, 1200us or 2min; a plain number is seconds)");
  };
  size_t b = text.find_first_not_of(" \t");
  size_t e = text.find_last_not_of(" \t");
  if (b == std::string::npos) return bad("empty");
  std::string s = text.substr(b, e - b + 1);
  // strtod also accepts "inf", "nan" and hex: reject those before parsing.
  for (char c : s)
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+' ||
          c == ' ' || std::isalpha(static_cast<unsigned char>(c)) ||
          static_cast<unsigned char>(c) >= 0x80))
      return bad("unexpected character '" + std::string(1, c) + "'");
  size_t num_end = 0;
  while (num_end < s.size() &&
         (std::isdigit(static_cast<unsigned char>(s[num_end])) || s[num_end] == '.' ||
          (num_end == 0 && (s[num_end] == '-' || s[num_end] == '+'))))
    ++num_end;
  std::string num = s.substr(0, num_end);
  std::string unit = s.substr(num_end);
  while (!unit.empty() && unit.front() == ' ') unit.erase(unit.begin());
  bool has_digit = false;
  for (char c : num) has_digit |= std::isdigit(static_cast<unsigned char>(c)) != 0;
  if (!has_digit) return bad("no number");
  errno = 0;
  char* end = nullptr;
  double v = std::strtod(num.c_str(), &end);
  if (end != num.c_str() + num.size() || errno == ERANGE) return bad("not a number");
  double scale;
  if (unit.empty() || unit == "s")
    scale = 1e6;
  else if (unit == "ms")
    scale = 1e3;
  else if (unit == "us" || unit == "\xC2\xB5s" || unit == "\xCE\xBCs")
    scale = 1;
  else if (unit == "min")
    scale = 60e6;
  else
    return bad("unknown unit '" + unit + "'");
  double us = std::round(v * scale);
  // Keep far from the int64 edge so callers can add windows without overflow.
  if (!std::isfinite(us) || std::fabs(us) > 4.0e18) return bad("out of range");
  return int64_t(us);
}

std::string format_duration_us(int64_t us) {
  char buf[64];
  double a = std::fabs(double(us));
  if (a >= 1e6)
    std::snprintf(buf, sizeof buf, "%.3f s", double(us) / 1e6);
  else if (a >= 1e3)
    std::snprintf(buf, sizeof buf, "%.3f ms", double(us) / 1e3);
  else
    std::snprintf(buf, sizeof buf, "%lld us", static_cast<long long>(us));
  return buf;
}

}  // namespace spikems
