#include "core/util/text_format.h"

#include <cstdio>

namespace spikems {

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace spikems
