// Mutated simulator configs. Every `key = value` line of configs/sim/tiny.toml is replaced by
// edge values of every TOML type (or removed); each config must be refused with a spikems
// error, or simulate 20 ms of its scene within a few seconds: never a crash, another exception
// type, or a run that would take hours (noise rates of 1e9 Hz did, before they were capped).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <typeinfo>
#include <vector>

#include "common/test_paths.h"
#include "core/sim/sim_config.h"
#include "core/sim/simulate.h"
#include "core/util/error.h"

namespace spikems::sim {
namespace {

TEST(SimConfigMutations, EveryValueReplacedOrRemovedGivesAnErrorOrAShortRun) {
  std::ifstream f(test::source_dir() + "/configs/sim/tiny.toml");
  std::vector<std::string> lines;
  for (std::string l; std::getline(f, l);) lines.push_back(l);
  ASSERT_GT(lines.size(), 30u);
  const std::vector<std::string> values = {
      "0",   "-1",    "0.5",  "7",  "1048576",    "1e300",          "-1e300", "nan",
      "inf", "\"x\"", "true", "[]", "[5.0, 1.0]", "[1e300, 1e301]", "[-1, 1]"};
  size_t accepted = 0, refused = 0, cases = 0;
  auto attempt = [&](const std::string& text, const std::string& what) {
    ++cases;
    try {
      SimConfig c = parse_sim_config(text, what);
      c.duration_us = std::min<int64_t>(c.duration_us, 20000);  // long durations are legitimate
      std::atomic<bool> cancel{false};
      const auto t0 = std::chrono::steady_clock::now();
      SimulateOptions opt;
      opt.cancel = &cancel;
      opt.on_progress = [&](int64_t) {
        if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(5)) cancel = true;
      };
      simulate_sequence(c, 1, opt);
      EXPECT_FALSE(cancel.load()) << what << ": 20 ms of the scene took more than 5 s";
      ++accepted;
    } catch (const Error&) {
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": " << typeid(e).name() << ": " << e.what();
    }
  };
  auto joined = [&](size_t skip, const std::string& replacement) {
    std::ostringstream o;
    for (size_t i = 0; i < lines.size(); ++i) o << (i == skip ? replacement : lines[i]) << "\n";
    return o.str();
  };
  attempt(joined(lines.size(), ""), "tiny.toml itself");
  ASSERT_EQ(accepted, 1u) << "the unmutated config must simulate";
  size_t keys = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const size_t eq = lines[i].find(" = ");
    if (lines[i].empty() || lines[i][0] == '#' || lines[i][0] == '[' || eq == std::string::npos)
      continue;
    ++keys;
    const std::string key = lines[i].substr(0, eq);
    for (const auto& v : values) attempt(joined(i, key + " = " + v), key + " = " + v);
    attempt(joined(i, ""), "without " + key);
  }
  EXPECT_GT(keys, 30u);
  EXPECT_EQ(cases, 1 + keys * (values.size() + 1));
  EXPECT_GT(refused, accepted) << accepted << " accepted, " << refused << " refused";
}

}  // namespace
}  // namespace spikems::sim
