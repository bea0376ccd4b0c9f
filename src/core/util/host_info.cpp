#include "core/util/host_info.h"

#include <fstream>

namespace spikems {

std::string cpu_name() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0 && line.find(':') != line.npos)
      return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

}  // namespace spikems
