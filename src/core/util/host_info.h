// Facts about the machine that run records and summaries name (training metadata, recipes).
#pragma once

#include <string>

namespace spikems {

// The CPU's "model name" from /proc/cpuinfo, "unknown CPU" where there is none.
std::string cpu_name();

}  // namespace spikems
