// The LibTorch commands run in the helper program spikems-torch (src/cli/torch_helper.h):
// `spikems` itself must not load LibTorch, `spikems train|forward` must behave as if they were
// its own subcommands (help, errors, exit codes), and a missing helper must say what to do.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/test_paths.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;
using test::spikems_binary;

// The shared libraries an executable names (readelf -d, NEEDED entries).
std::string needed_libraries(const std::string& exe) {
  std::string out;
  if (run_command("readelf -d '" + exe + "'", &out) != 0) return "";
  std::string needed;
  size_t pos = 0;
  while ((pos = out.find("(NEEDED)", pos)) != std::string::npos) {
    const size_t eol = out.find('\n', pos);
    needed += out.substr(pos, eol - pos) + "\n";
    pos = eol;
  }
  return needed;
}

fs::path helper_path() {
  return fs::path(spikems_binary()).parent_path() / "spikems-torch";
}

TEST(TorchHelper, SpikemsDoesNotLinkLibTorch) {
  std::string probe;
  if (run_command("readelf --version", &probe) != 0) GTEST_SKIP() << "readelf (binutils) missing";
  const std::string needed = needed_libraries(spikems_binary());
  ASSERT_NE(needed.find("libc.so"), std::string::npos) << "readelf output not understood";
  EXPECT_EQ(needed.find("libtorch"), std::string::npos) << needed;
  if (SPIKEMS_TEST_WITH_TRAIN) {
    EXPECT_NE(needed_libraries(helper_path().string()).find("libtorch"), std::string::npos)
        << "the helper should carry LibTorch";
  }
}

TEST(TorchHelper, TrainAndForwardBehaveAsSubcommands) {
  if (!SPIKEMS_TEST_WITH_TRAIN) GTEST_SKIP() << "built without training (SPIKEMS_WITH_TRAIN=OFF)";
  std::string out;
  ASSERT_EQ(run_command(spikems_binary() + " --help", &out), 0) << out;
  EXPECT_NE(out.find("Train the SpikeMS network"), std::string::npos) << out;
  EXPECT_NE(out.find("Dense forward pass"), std::string::npos) << out;
  // Listed in their place: after import-slayer, before formats (orders 60, 62 < 90).
  EXPECT_LT(out.find("import-slayer"), out.find("  train")) << out;
  EXPECT_LT(out.find("  forward"), out.find("  formats")) << out;

  ASSERT_EQ(run_command(spikems_binary() + " train --help", &out), 0) << out;
  EXPECT_NE(out.find("--resume"), std::string::npos) << out;
  EXPECT_NE(out.find("--world-size"), std::string::npos) << out;

  // Errors and exit codes come through unchanged.
  const std::string d = test::scratch_dir();
  EXPECT_EQ(run_command(spikems_binary() + " train --out " + d + "/run", &out), 1) << out;
  EXPECT_NE(out.find("give --config FILE and --out DIR"), std::string::npos) << out;
  EXPECT_NE(run_command(spikems_binary() + " forward --model " + d + "/none.safetensors --input " +
                            d + "/none.npz --output " + d + "/o.npz",
                        &out),
            0);
  EXPECT_NE(out.find("none.safetensors"), std::string::npos) << out;
}

TEST(TorchHelper, MissingHelperSaysWhatToDo) {
  const std::string d = test::scratch_dir();
  const fs::path lone = fs::path(d) / "spikems";
  fs::copy_file(spikems_binary(), lone);
  std::string out;
  // Without training built there is no `train` at all (with --help CLI11 would print the
  // program's help and exit 0, so ask for a run).
  const int rc =
      run_command(lone.string() + (SPIKEMS_TEST_WITH_TRAIN ? " train --help" : " train"), &out);
  EXPECT_NE(rc, 0) << out;
  if (SPIKEMS_TEST_WITH_TRAIN) {
    EXPECT_EQ(rc, 1);
    EXPECT_NE(out.find((fs::path(d) / "spikems-torch").string()), std::string::npos) << out;
    EXPECT_NE(out.find("lib/spikems/spikems-torch"), std::string::npos) << out;
    EXPECT_NE(out.find("scripts/build"), std::string::npos) << out;
  }
  // Every other command is unaffected.
  EXPECT_EQ(run_command(lone.string() + " formats", &out), 0) << out;
}

}  // namespace
}  // namespace spikems
