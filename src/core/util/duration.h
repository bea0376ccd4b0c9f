// Durations and times on the command line: one parser for every command, so `--from 1.5s`,
// `--window 250ms` and `--step 1200us` mean the same everywhere.
#pragma once

#include <cstdint>
#include <string>

namespace spikems {

// Parses "<number>[unit]" into microseconds. Units: s, ms, us (also µs), min. A plain number
// (no unit) is in seconds, like the time column of EV-IMO files. Fractions are rounded to the
// nearest microsecond ("0.5us" -> 1). Throws spikems::Error naming the text and what is wrong
// (empty, not a number, unknown unit, out of range).
int64_t parse_duration_us(const std::string& text);

// "1.500 s", "250 ms", "12 us": the largest unit that keeps the value >= 1 (for reports).
std::string format_duration_us(int64_t us);

}  // namespace spikems
