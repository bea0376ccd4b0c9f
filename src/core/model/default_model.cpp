#include "core/model/default_model.h"

#include <cstdlib>
#include <filesystem>
#include <set>
#include <vector>

#include "core/util/error.h"

namespace spikems {

namespace fs = std::filesystem;

namespace {
// The folders the shipped models live in: the source tree's models/ (the build in build/), an
// installed tree's share/spikems/models/.
std::vector<fs::path> model_dirs() {
  std::vector<fs::path> d;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    d.push_back(exe.parent_path().parent_path() / "models");
    d.push_back(exe.parent_path().parent_path() / "share" / "spikems" / "models");
  }
  return d;
}

std::vector<fs::path> candidates() {
  std::vector<fs::path> c;
  if (const char* env = std::getenv("SPIKEMS_MODEL"); env && *env) {
    c.emplace_back(env);  // set: the only place looked at
    return c;
  }
  for (const auto& d : model_dirs()) c.push_back(d / kDefaultModelName);
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

std::string resolve_model(const std::string& arg) {
  if (arg.empty()) return default_model_or_fail();
  std::error_code ec;
  if (arg.find('/') != std::string::npos || arg.find('.') != std::string::npos ||
      fs::exists(arg, ec))
    return arg;
  if (arg == "default") return default_model_or_fail();
  const std::string file = "spikems-" + arg + ".safetensors";
  std::string where;
  std::set<std::string> names;  // sorted, and once where several folders hold the same model
  for (const auto& d : model_dirs()) {
    where += (where.empty() ? "" : ", ") + d.string();
    if (fs::is_regular_file(d / file, ec)) return (d / file).string();
    for (const auto& e : fs::directory_iterator(d, ec)) {
      const std::string n = e.path().filename().string();
      if (n.rfind("spikems-", 0) == 0 && n.size() > 20 &&
          n.compare(n.size() - 12, 12, ".safetensors") == 0)
        names.insert(n.substr(8, n.size() - 20));
    }
  }
  std::string shipped;
  for (const auto& n : names) shipped += (shipped.empty() ? "" : ", ") + n;
  fail(arg, "",
       "no such model file, and no shipped model of that name (" + file + " in " + where +
           "); shipped: " + (shipped.empty() ? std::string("none") : shipped) +
           ". Give a model file's path");
}

}  // namespace spikems
