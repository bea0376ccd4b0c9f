// `spikems simulate --preview`: the contact sheet's layout and content.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/test_paths.h"
#include "core/events/io.h"
#include "core/viz/image.h"

using spikems::test::run_command;
using spikems::test::scratch_dir;
using spikems::test::spikems_binary;

// 5 tiny sequences: 3 x 2 tiles of 64 x (12 + 48) px with 2-px grey gaps; every tile shows
// events (red/blue) under its index (black digits); the sixth cell is empty (grey).
TEST(SimulatePreview, ContactSheet) {
  if (!spikems::find_format("spikems-h5")) GTEST_SKIP() << "spikems-h5 not in this build";
  std::string dir = scratch_dir() + "/prev";
  std::string out;
  int rc = run_command(spikems_binary() +
                           " simulate --preset tiny --sequences 5 --duration 40ms "
                           "--seed 3 --threads 2 --no-progress --preview --out " +
                           dir,
                       &out);
  ASSERT_EQ(rc, 0) << out;
  ASSERT_TRUE(std::filesystem::exists(dir + "/preview.png")) << out;
  spikems::Image img = spikems::read_png_rgb(dir + "/preview.png");
  ASSERT_EQ(img.width, 3 * 64 + 4 * 2);
  ASSERT_EQ(img.height, 2 * (12 + 48) + 3 * 2);
  for (int i = 0; i < 5; ++i) {
    int x0 = 2 + (i % 3) * 66, y0 = 2 + (i / 3) * 62 + 12;
    int events = 0, digits = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x)
        events += img.is(x0 + x, y0 + y, 255, 0, 0) || img.is(x0 + x, y0 + y, 0, 0, 255);
    for (int y = y0 - 12; y < y0; ++y)
      for (int x = x0; x < x0 + 16; ++x) digits += img.is(x, y, 0, 0, 0);
    EXPECT_GT(events, 20) << "tile " << i;
    EXPECT_GT(digits, 10) << "tile " << i;
  }
  EXPECT_TRUE(img.is(2 + 2 * 66 + 30, 2 + 62 + 30, 160, 160, 160));
  // No leftover temporary files beside it.
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}
