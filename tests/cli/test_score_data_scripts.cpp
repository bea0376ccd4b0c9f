// scripts/score and scripts/data as a user runs them: usage, the refusals that name what is
// missing, and one score of a hand-built model on tiny simulated rooms (no data from elsewhere).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "common/test_paths.h"
#include "common/text_file.h"
#include "common/tiny_models.h"
#include "core/model/model_file.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::source_dir;
using test::spikems_binary;

TEST(ScoreScript, HelpUsageAndRefusals) {
  const std::string score = source_dir() + "/scripts/score";
  const std::string env = "SPIKEMS=" + spikems_binary() + " ";
  std::string out;
  ASSERT_EQ(run_command(score + " --help", &out), 0) << out;
  EXPECT_NE(out.find("[ECD=DIR] [DATA=data] [THREADS=1] scripts/score MODEL OUT"),
            std::string::npos)
      << out;
  EXPECT_EQ(run_command(score + " only-one-argument", &out), 1);
  EXPECT_NE(out.find("usage: scripts/score MODEL OUT"), std::string::npos) << out;
  const std::string dir = test::scratch_dir();
  EXPECT_EQ(run_command(env + score + " nosuchmodel " + dir + "/out", &out), 1);
  EXPECT_NE(out.find("score: no model nosuchmodel (a file, or a shipped model: default, fast)"),
            std::string::npos)
      << out;
  EXPECT_EQ(run_command("SPIKEMS=" + dir + "/nothing " + score + " default " + dir, &out), 1);
  EXPECT_NE(out.find("score: no spikems at " + dir + "/nothing"), std::string::npos) << out;
  // A shipped model's name is found; the held-out rooms are not there.
  EXPECT_EQ(run_command(env + "DATA=" + dir + "/none " + score + " default " + dir + "/out", &out),
            1);
  EXPECT_NE(out.find("score: no " + dir + "/none/mod-heldout6001: run scripts/data"),
            std::string::npos)
      << out;
  EXPECT_FALSE(fs::exists(dir + "/out")) << "nothing written before the checks pass";
}

// One tiny room (configs/sim/tiny.toml) copied under the four held-out names, scored with a
// model that calls every event moving after one step: every line of summary.txt, which is also
// what the script prints, names its results.json; the event recall is 100 % in every window.
TEST(ScoreScript, ScoresTheFourHeldOutSetsIntoSummary) {
  const std::string dir = test::scratch_dir();
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " simulate --config " + source_dir() +
                            "/configs/sim/tiny.toml --sequences 1 --seed 1 --threads 1 --out " +
                            dir + "/data/mod-heldout6001",
                        &out),
            0)
      << out;
  for (const char* s : {"mod-heldout6002", "mod-heldout7001", "mod-heldout7002"})
    fs::copy(dir + "/data/mod-heldout6001", dir + "/data/" + s);
  save_model(dir + "/pass.safetensors", test::pointwise_model({1.f, 0.f, 0.f, 1.f}, "pass"));
  ASSERT_EQ(run_command("SPIKEMS=" + spikems_binary() + " DATA=" + dir + "/data " + source_dir() +
                            "/scripts/score " + dir + "/pass.safetensors " + dir + "/out",
                        &out),
            0)
      << out;
  const std::string summary = test::read_text(dir + "/out/summary.txt");
  EXPECT_NE(out.find(summary), std::string::npos) << out;
  const std::string lines = "\n" + summary;
  for (const char* run : {"rooms", "authors", "rooms7k", "authors7k"}) {
    EXPECT_TRUE(fs::exists(dir + "/out/" + run + "/results.json")) << run;
    EXPECT_NE(lines.find(std::string("\n") + run + "/results.json: "), std::string::npos) << lines;
  }
  // The same room under both seeds' names: the two all-windows lines agree, 9 of the 10 20 ms
  // windows and the one 100 ms window of each copy hold moving events.
  const auto line = [&](const std::string& run) {
    const std::string key = "\n" + run + "/results.json: ";
    const auto at = lines.find(key);
    if (at == std::string::npos) return std::string("(no line)");
    const auto b = at + key.size();
    return lines.substr(b, lines.find('\n', b) - b);
  };
  EXPECT_EQ(line("rooms"), line("rooms7k")) << lines;
  EXPECT_NE(line("rooms").find("/100.0 (18 windows); 100 ms: IoU "), std::string::npos) << lines;
  EXPECT_NE(line("rooms").find("/100.0 (2 windows)"), std::string::npos) << lines;
  if (lines.find("\nsegment: ") != std::string::npos)  // ../shared's poster is there
    EXPECT_NE(lines.find("events moving (100.000 %)\n"), std::string::npos) << lines;
}

TEST(DataScript, HelpUsageAndOnly) {
  const std::string data = source_dir() + "/scripts/data";
  std::string out;
  ASSERT_EQ(run_command(data + " --help", &out), 0) << out;
  EXPECT_NE(out.find("[THREADS=N] [ONLY=\"NAME ...\"] scripts/data [OUTDIR]"), std::string::npos)
      << out;
  EXPECT_NE(out.find("mod-heldout6001 mod-heldout6002 (24 x 2 s)"), std::string::npos) << out;
  EXPECT_EQ(run_command(data + " a b", &out), 1);
  EXPECT_NE(out.find("usage: scripts/data [OUTDIR]"), std::string::npos) << out;
  EXPECT_EQ(run_command(data + " --bad", &out), 1);
  // ONLY naming no set makes none.
  const std::string dir = test::scratch_dir() + "/d";
  ASSERT_EQ(run_command("SPIKEMS=" + spikems_binary() + " ONLY=none " + data + " " + dir, &out), 0)
      << out;
  EXPECT_NE(out.find("data: the data sets are in " + dir), std::string::npos) << out;
  EXPECT_TRUE(fs::is_empty(dir)) << out;
}

}  // namespace
}  // namespace spikems
