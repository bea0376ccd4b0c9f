#include "core/model/default_model.h"

#include <cstdlib>
#include <filesystem>
#include <vector>

#include "core/util/error.h"

namespace spikems {

namespace fs = std::filesystem;

namespace {
std::vector<fs::path> candidates() {
  std::vector<fs::path> c;
  if (const char* env = std::getenv("SPIKEMS_MODEL"); env && *env) {
    c.emplace_back(env);  // set: the only place looked at
    return c;
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path dir = exe.parent_path();
    c.push_back(dir.parent_path() / "models" / kDefaultModelName);
    c.push_back(dir.parent_path() / "share" / "spikems" / "models" / kDefaultModelName);
  }
  return c;
}
}  // namespace

std::string find_default_model() {
  std::error_code ec;
  for (const auto& p : candidates())
    if (fs::is_regular_file(p, ec)) return p.string();
  return "";
}

std::string default_model_or_fail() {
  std::string p = find_default_model();
  if (!p.empty()) return p;
  std::string where;
  for (const auto& c : candidates()) where += (where.empty() ? "" : ", ") + c.string();
  fail("spikems", "",
       "no model given and the shipped model was not found (looked at: " + where +
           "): give --model FILE, or set SPIKEMS_MODEL");
}

}  // namespace spikems
