// A whole file as a string, for tests that compare what a command wrote ("" when unreadable).
#pragma once

#include <fstream>
#include <sstream>
#include <string>

namespace spikems::test {

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace spikems::test
