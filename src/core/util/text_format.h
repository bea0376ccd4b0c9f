// One number as text with a printf format ("%.1f", "%g"): the tables, reports and summaries
// the commands print all go through it.
#pragma once

#include <string>

namespace spikems {

// `f` must hold exactly one floating-point conversion; the result is cut at 63 characters.
std::string fmt(const char* f, double v);

}  // namespace spikems
