// scripts/real_moving and scripts/fetch_real as a user runs them, without event data from
// elsewhere or the network: a text recording and its boxes file written here, scored through
// the script to numbers counted by hand; a download that does not match its recorded checksum is
// refused.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/model/model_file.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::source_dir;
using test::spikems_binary;

const std::string kUsage = "scripts/real_moving MODEL DIR [FACTORS]";

TEST(RealMovingScript, HelpPrintsTheUsage) {
  std::string out;
  ASSERT_EQ(run_command(source_dir() + "/scripts/real_moving --help", &out), 0) << out;
  EXPECT_NE(out.find(kUsage), std::string::npos) << out;
  EXPECT_NE(out.find("# sensor: W H"), std::string::npos) << out;
  EXPECT_EQ(run_command(source_dir() + "/scripts/real_moving only-one-argument", &out), 1);
  EXPECT_NE(out.find("usage: " + kUsage), std::string::npos) << out;
}

// The scene of test_cmd_eval_boxes.cpp through the script, at 10 ms windows on a 32x32
// sensor: window 0 predicts the 60 ON-event pixels of the 100-pixel box and 10 OFF-event pixels
// outside (IoU 54.5 %), window 1 one pixel outside it (IoU 0); a second box over window 2 (3x3
// pixels) holds an ON event at (5,5) and OFF events at (4,4) and (6,6), the last at 29,999 us, so
// its spike falls after the window (IoU 2 / 9). The pass-through model labels every event moving:
// recall 100 %, both boxes found. A model passing ON events only: window 0 IoU 60 / 100, window
// 2 1 / 9; the second box has 1 of its 3 events moving, so it is not found; recall 61 / 63.
// A second boxes file names a recording that is not in DIR: skipped with a note.
TEST(RealMovingScript, ScoresEachRecordingAgainstItsBoxesAndPools) {
  const std::string dir = test::scratch_dir();
  fs::create_directories(dir + "/rec");
  fs::create_directories(dir + "/boxes");
  {
    std::ofstream ev(dir + "/rec/ball.txt");
    int64_t t = -10;
    for (int y = 10; y <= 19; ++y)
      for (int x = 10; x <= 15; ++x) ev << (t += 10) << ' ' << x << ' ' << y << " 1\n";
    for (int x = 0; x <= 9; ++x) ev << (t += 10) << ' ' << x << " 0 0\n";
    ev << "12000 0 31 1\n25000 5 5 1\n27000 4 4 0\n29999 6 6 0\n";
  }
  std::ofstream(dir + "/boxes/ball_boxes.csv")
      << "# recording: ball.txt\n# sensor: 32 32\n# time_unit: us\n"
         "t_start_us,t_end_us,x0,y0,x1,y1,id\n0,20000,10,10,19,19,1\n20000,30000,4,4,6,6,2\n";
  std::ofstream(dir + "/boxes/gone_boxes.csv")
      << "# recording: gone.txt\n# sensor: 32 32\nt_start_us,t_end_us,x0,y0,x1,y1\n0,1,0,0,1,1\n";
  save_model(dir + "/pass.safetensors", test::pointwise_model({1.f, 0.f, 0.f, 1.f}, "pass"));
  save_model(dir + "/on.safetensors", test::pointwise_model({0.f, 0.f, 0.f, 1.f}, "on"));
  const std::string env = "SPIKEMS_BIN=" + spikems_binary() + " BOXES=" + dir +
                          "/boxes OUT=" + dir + "/out WINDOWS=10 ";
  std::string out;
  ASSERT_EQ(run_command(env + source_dir() + "/scripts/real_moving " + dir + "/pass.safetensors " +
                            dir + "/rec 1,2",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("gone.txt absent, gone skipped"), std::string::npos) << out;
  EXPECT_NE(out.find("| model | factor | ball: IoU %, recall %, found / boxed | pooled: found / "
                     "boxed | IoU % | recall % |"),
            std::string::npos)
      << out;
  // The pass-through model predicts the same pixels at any output factor here.
  for (const char* factor : {"1", "2"})
    EXPECT_NE(out.find(std::string("| pass.safetensors | ") + factor +
                       " | 25.6, 100.0, 2 / 2 | 2 / 2 (100.0 %) | 25.6 | 100.0 |"),
              std::string::npos)
        << out;
  // A model that passes ON events only: the OFF events of the second box stay background.
  ASSERT_EQ(run_command(env + source_dir() + "/scripts/real_moving " + dir + "/on.safetensors " +
                            dir + "/rec",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("| on.safetensors | 1 | 23.7, 96.8, 1 / 2 | 1 / 2 (50.0 %) | 23.7 | 96.8 |"),
            std::string::npos)
      << out;
  std::ifstream summary(dir + "/out/summary.md");
  std::string first;
  ASSERT_TRUE(std::getline(summary, first));
  EXPECT_EQ(first.rfind("| model | factor | ball:", 0), 0u) << first;
  EXPECT_TRUE(fs::exists(dir + "/out/ball/results.json"));
  // A boxes file without the header that names its recording stops the run.
  std::ofstream(dir + "/boxes/bare_boxes.csv") << "t_start_us,t_end_us,x0,y0,x1,y1\n0,1,0,0,1,1\n";
  EXPECT_EQ(run_command(env + source_dir() + "/scripts/real_moving " + dir + "/pass.safetensors " +
                            dir + "/rec",
                        &out),
            1);
  EXPECT_NE(out.find("bare_boxes.csv: needs '# recording:' and '# sensor: W H' lines"),
            std::string::npos)
      << out;
}

// A file from the mirror whose size and checksum differ from the recorded ones is not kept,
// and the run ends with exit 1; a wrong set name prints the usage.
TEST(FetchRealScript, RefusesAFileThatDoesNotMatchItsChecksum) {
  if (run_command("command -v curl") != 0) GTEST_SKIP() << "curl not installed (file:// mirror)";
  const std::string dir = test::scratch_dir();
  const std::string rel =
      "tub-rip/events_viz/dfc6fd27688c70f11e98b349111e35a5aad9a718/slider_depth";
  fs::create_directories(dir + "/mirror/" + rel);
  std::ofstream(dir + "/mirror/" + rel + "/events_chunk.txt") << "0.1 1 1 1\n";
  std::string out;
  EXPECT_EQ(run_command("MIRROR=file://" + dir + "/mirror " + source_dir() +
                            "/scripts/fetch_real static " + dir + "/got",
                        &out),
            1);
  EXPECT_NE(out.find("10 bytes"), std::string::npos) << out;
  EXPECT_NE(out.find("expected 1053808 bytes"), std::string::npos) << out;
  EXPECT_NE(out.find("cannot download file://"), std::string::npos) << out;  // the other three
  EXPECT_TRUE(fs::is_empty(dir + "/got")) << "nothing kept, no temporary left";
  EXPECT_EQ(run_command(source_dir() + "/scripts/fetch_real everything " + dir, &out), 1);
  EXPECT_NE(out.find("usage: scripts/fetch_real static|moving|all DIR"), std::string::npos) << out;
}

}  // namespace
}  // namespace spikems
