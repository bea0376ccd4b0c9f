// Window lengths on the command line (`spikems eval --windows`): milliseconds, comma-separated,
// with ranges: "20,100", "1:25" (1, 2, ..., 25), "5:100:5" (5, 10, ..., 100), "0.5,2.5".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace spikems {

// Lengths in microseconds, ascending, each once. Throws Error quoting the text and the item
// for an empty list or item, a value that is not a number, not positive, not a whole number of
// microseconds, or a range that is empty, runs backwards or has more than 10000 values.
std::vector<int64_t> parse_window_list_ms(const std::string& text);

}  // namespace spikems
