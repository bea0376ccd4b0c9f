// Paths for tests: the shared material beside the checkout (skipped where absent) and a
// scratch folder per test.
#pragma once

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>

#include <filesystem>
#include <string>
#include <vector>

namespace spikems::test {

inline std::string shared_dir() {
  return SPIKEMS_SHARED_DIR;
}
inline std::string source_dir() {
  return SPIKEMS_SOURCE_DIR;
}
inline std::string spikems_binary() {
  return SPIKEMS_BINARY;
}

// Path of a shared file, or "" when ../shared is absent (fresh clone).
inline std::string shared_file(const std::string& rel) {
  std::string p = shared_dir() + "/" + rel;
  return std::filesystem::exists(p) ? p : std::string();
}

#define SPIKEMS_REQUIRE_SHARED(var, rel)               \
  std::string var = ::spikems::test::shared_file(rel); \
  if (var.empty())                                     \
  GTEST_SKIP() << "shared material absent (" << rel    \
               << " not found beside the checkout); this test runs in CI"

// Scratch folders made by this test program, removed when it exits (set
// SPIKEMS_KEEP_SCRATCH=1 to keep them for a look after a failure).
struct ScratchRegistry {
  std::vector<std::filesystem::path> dirs;
  ~ScratchRegistry() {
    if (std::getenv("SPIKEMS_KEEP_SCRATCH")) return;
    std::error_code ec;
    for (const auto& d : dirs) std::filesystem::remove_all(d, ec);
  }
};
inline ScratchRegistry scratch_registry;

// A fresh, empty scratch folder unique to the running test.
inline std::string scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path p = std::filesystem::temp_directory_path() /
                            ("spikems_test_" + std::string(info->test_suite_name()) + "_" +
                             info->name() + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  scratch_registry.dirs.push_back(p);
  return p.string();
}

// Runs a shell command, returns its exit status; output goes to `out` (stdout+stderr).
inline int run_command(const std::string& cmd, std::string* out = nullptr) {
  FILE* f = popen((cmd + " 2>&1").c_str(), "r");
  if (!f) return -1;
  char buf[4096];
  size_t n;
  std::string s;
  while ((n = fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
  int st = pclose(f);
  if (out) *out = s;
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

}  // namespace spikems::test
