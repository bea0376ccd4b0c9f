// `spikems simulate` end to end: files, manifest splits, argument validation.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/test_paths.h"
#include "core/events/io.h"

using spikems::test::run_command;
using spikems::test::scratch_dir;
using spikems::test::spikems_binary;

TEST(SimulateCommand, WritesSequencesAndManifest) {
  if (!spikems::find_format("spikems-h5")) GTEST_SKIP() << "spikems-h5 not in this build";
  std::string dir = scratch_dir() + "/out";
  std::string out;
  int rc = run_command(spikems_binary() +
                           " simulate --preset tiny --sequences 5 --duration 40ms "
                           "--seed 3 --threads 2 --no-progress --out " +
                           dir,
                       &out);
  ASSERT_EQ(rc, 0) << out;
  std::ifstream f(dir + "/manifest.json");
  nlohmann::json m = nlohmann::json::parse(f);
  EXPECT_EQ(m["sequences"].size(), 5u);
  // tiny: val 0.2, test 0.2 of 5 -> 1 val, 1 test, 3 train; every file in exactly one split.
  EXPECT_EQ(m["splits"]["val"].size(), 1u);
  EXPECT_EQ(m["splits"]["test"].size(), 1u);
  EXPECT_EQ(m["splits"]["train"].size(), 3u);
  for (int i = 0; i < 5; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "seq_%04d.h5", i);
    ASSERT_TRUE(std::filesystem::exists(dir + "/" + name)) << name;
  }
  spikems::Recording r = spikems::read_recording(dir + "/seq_0000.h5");
  EXPECT_EQ(r.events.sensor.width, 64);
  EXPECT_TRUE(r.events.has_labels());
  EXPECT_EQ(r.masks.size(), 41u);  // every 1 ms from 0 to 40 ms
  ASSERT_TRUE(r.intrinsics.has_value());
  EXPECT_NEAR(r.intrinsics->fx, 0.65 * 64, 1e-9);
  EXPECT_LE(r.events.t_last(), 40000);
}

TEST(SimulateCommand, RejectsBadArguments) {
  std::string dir = scratch_dir();
  std::string b = spikems_binary() + " simulate --preset tiny --no-progress ";
  std::string out;
  EXPECT_NE(run_command(b + "--duration 2parsecs --out " + dir + "/a", &out), 0);
  EXPECT_NE(out.find("duration"), std::string::npos) << out;
  EXPECT_NE(run_command(b + "--duration -1s --out " + dir + "/a", &out), 0);
  EXPECT_NE(run_command(b + "--sequences 0 --out " + dir + "/a", &out), 0);
  EXPECT_NE(run_command(b + "--preset nope --out " + dir + "/a", &out), 0);
  EXPECT_NE(run_command(b + "--noise loud --out " + dir + "/a", &out), 0);
  EXPECT_NE(run_command(b + "--duration 10ms", &out), 0);  // no --out
  EXPECT_NE(out.find("--out"), std::string::npos) << out;
  EXPECT_NE(run_command(b + "--duration 10ms --out /proc/forbidden", &out), 0);
  std::ofstream(dir + "/bad.toml") << "[events]\nthreshhold = 0.3\n";
  EXPECT_NE(run_command(b + "--config " + dir + "/bad.toml --out " + dir + "/a", &out), 0);
  EXPECT_NE(out.find("threshhold"), std::string::npos) << out;
  EXPECT_EQ(run_command(spikems_binary() + " simulate --help", &out), 0);
  EXPECT_NE(out.find("--preset"), std::string::npos);
}
