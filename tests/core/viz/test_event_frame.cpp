// PNG round trips and event frames: exact pixel colours at known events and mask edges.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/test_paths.h"
#include "core/util/error.h"
#include "core/viz/event_frame.h"

using namespace spikems;

namespace {

bool is(const Image& img, int x, int y, Rgb c) {
  return img.is(x, y, c.r, c.g, c.b);
}

}  // namespace

TEST(Png, RoundTripIsExact) {
  Image img(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) img.set(x, y, uint8_t(x * 50), uint8_t(y * 100), uint8_t(x + y));
  img.set(99, 99, 0, 0, 0);  // outside: ignored
  std::string dir = test::scratch_dir();
  std::string path = dir + "/a.png";
  write_png(path, img);
  Image back = read_png_rgb(path);
  EXPECT_EQ(back.width, 5);
  EXPECT_EQ(back.height, 3);
  EXPECT_EQ(back.rgb, img.rgb);
  // The atomic write leaves no temporary file beside the PNG.
  int files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) (void)e, ++files;
  EXPECT_EQ(files, 1);
}

TEST(Png, ReadsTheSharedSixteenBitMask) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/evimo2_depth_mask_280.png");
  Image img = read_png_rgb(path);
  EXPECT_EQ(img.width, 640);  // EVIMO2 frame (README of data/formats)
  EXPECT_EQ(img.height, 480);
  EXPECT_EQ(img.rgb.size(), size_t(640 * 480 * 3));
}

TEST(Png, ErrorsNameTheFile) {
  std::string dir = test::scratch_dir();
  std::string bad = dir + "/bad.png";
  FILE* f = std::fopen(bad.c_str(), "wb");
  std::fputs("not a png", f);
  std::fclose(f);
  try {
    read_png_rgb(bad);
    FAIL() << "accepted a text file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos);
  }
  EXPECT_THROW(write_png(dir + "/no/such/folder/x.png", Image(2, 2)), Error);
  EXPECT_THROW(write_png(dir + "/empty.png", Image()), Error);
}

TEST(EventFrame, ColoursOfPolaritiesAndWindow) {
  EventStream ev;
  ev.sensor = {6, 4};
  ev.push_back(0, 0, 0, 1);   // before the window
  ev.push_back(10, 1, 1, 1);  // ON -> red
  ev.push_back(11, 2, 1, 0);  // OFF -> blue
  ev.push_back(12, 3, 1, 1);  // ON and OFF -> purple
  ev.push_back(13, 3, 1, 0);
  ev.push_back(20, 4, 2, 1);  // at t1: excluded
  Image img = render_events(ev, 10, 20, ev.sensor);
  ASSERT_EQ(img.width, 6);
  ASSERT_EQ(img.height, 4);
  EXPECT_TRUE(is(img, 1, 1, kOnColor));
  EXPECT_TRUE(is(img, 2, 1, kOffColor));
  EXPECT_TRUE(is(img, 3, 1, kBothColor));
  EXPECT_TRUE(is(img, 0, 0, kBackground));
  EXPECT_TRUE(is(img, 4, 2, kBackground));
  int white = 0;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) white += is(img, x, y, kBackground);
  EXPECT_EQ(white, 24 - 3);
}

TEST(EventFrame, MaskOutlineAndScale) {
  EventStream ev;
  ev.sensor = {5, 5};
  ev.push_back(0, 2, 2, 1);  // inside the region, not on its contour
  MaskFrame m;
  m.width = 5;
  m.height = 5;
  m.ids.assign(25, 0);
  for (int y = 1; y <= 3; ++y)
    for (int x = 1; x <= 3; ++x) m.ids[size_t(y * 5 + x)] = 2;  // 3x3 square
  RenderOptions opt;
  opt.scale = 2;
  Image one = render_events(ev, 0, 1, ev.sensor, &m, RenderOptions{});
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) {
      bool contour = x >= 1 && x <= 3 && y >= 1 && y <= 3 && !(x == 2 && y == 2);
      Rgb want = contour ? kOutlineColor : (x == 2 && y == 2) ? kOnColor : kBackground;
      EXPECT_TRUE(is(one, x, y, want)) << x << "," << y;
    }
  Image img = render_events(ev, 0, 1, ev.sensor, &m, opt);
  ASSERT_EQ(img.width, 10);
  ASSERT_EQ(img.height, 10);
  // Corner pixel (1,1): its block (2..3, 2..3) has the left and top sides drawn.
  EXPECT_TRUE(is(img, 2, 2, kOutlineColor));
  EXPECT_TRUE(is(img, 3, 2, kOutlineColor));
  EXPECT_TRUE(is(img, 2, 3, kOutlineColor));
  EXPECT_TRUE(is(img, 3, 3, kBackground));
  // Edge pixel (2,1): only its top side.
  EXPECT_TRUE(is(img, 4, 2, kOutlineColor));
  EXPECT_TRUE(is(img, 5, 2, kOutlineColor));
  EXPECT_TRUE(is(img, 4, 3, kBackground));
  // Centre (2,2): the ON event fills the whole block.
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) EXPECT_TRUE(is(img, 4 + dx, 4 + dy, kOnColor));
  // Bottom-right corner (3,3): right and bottom sides -> (7,6), (6,7), (7,7); (6,6) stays white.
  EXPECT_TRUE(is(img, 7, 6, kOutlineColor));
  EXPECT_TRUE(is(img, 6, 7, kOutlineColor));
  EXPECT_TRUE(is(img, 6, 6, kBackground));
  // Outside the region: white.
  EXPECT_TRUE(is(img, 0, 0, kBackground));
  EXPECT_TRUE(is(img, 9, 9, kBackground));
  // A region touching the border: border pixels are contour only where an inside neighbour is
  // background.
  std::vector<uint16_t> full(9, 1);
  auto c = mask_contour(full, 3, 3);
  EXPECT_EQ(c, std::vector<uint8_t>(9, 0));
}

TEST(EventFrame, LabelTint) {
  EventStream ev;
  ev.sensor = {3, 1};
  ev.push_back(0, 0, 0, 1, 0);
  ev.push_back(0, 1, 0, 1, 5);
  RenderOptions opt;
  opt.show_labels = true;
  Image img = render_events(ev, 0, 1, ev.sensor, nullptr, opt);
  EXPECT_TRUE(is(img, 0, 0, kOnColor));
  EXPECT_TRUE(is(img, 1, 0, label_color(5)));
  EXPECT_FALSE(is(img, 1, 0, kOnColor));
}

TEST(EventFrame, MaskComparisonSpikesAndStacking) {
  std::vector<uint8_t> pred{1, 1, 0, 0}, truth{1, 0, 1, 0};
  Image c = render_comparison(pred, truth, 2, 2);
  EXPECT_TRUE(is(c, 0, 0, kTruePositive));
  EXPECT_TRUE(is(c, 1, 0, kFalsePositive));
  EXPECT_TRUE(is(c, 0, 1, kFalseNegative));
  EXPECT_TRUE(is(c, 1, 1, kBackground));
  Image m = render_mask(pred, 2, 2);
  EXPECT_TRUE(is(m, 0, 0, kMaskColor));
  EXPECT_TRUE(is(m, 0, 1, kBackground));
  Image s = hstack(c, m, 1);
  EXPECT_EQ(s.width, 5);
  EXPECT_TRUE(is(s, 2, 0, kBackground));  // the gap
  EXPECT_TRUE(is(s, 3, 0, kMaskColor));
  EXPECT_THROW(render_mask(pred, 3, 2), Error);

  SpikeTensor t;
  t.T = 2;
  t.H = 1;
  t.W = 3;
  t.data.assign(2 * 2 * 3, 0);
  t.data[t.index(0, 1, 0, 0)] = 1;
  t.data[t.index(1, 0, 0, 1)] = 1;
  t.data[t.index(0, 0, 0, 2)] = 1;
  t.data[t.index(1, 1, 0, 2)] = 1;
  Image r = render_spikes(t);
  EXPECT_TRUE(is(r, 0, 0, kOnColor));
  EXPECT_TRUE(is(r, 1, 0, kOffColor));
  EXPECT_TRUE(is(r, 2, 0, kBothColor));
}

TEST(EventFrame, FramedRowKeepsPanelsApart) {
  // A 2x1 red panel and a 1x2 blue one, gap 1: frames 4x3 and 3x4, 4 + 1 + 3 = 8 wide, 4 high.
  Image a(2, 1, 255, 0, 0), b(1, 2, 0, 0, 255);
  Image r = framed_row({a, b}, 1);
  ASSERT_EQ(r.width, 8);
  ASSERT_EQ(r.height, 4);
  const Rgb grey{kFrameGrey, kFrameGrey, kFrameGrey};
  EXPECT_TRUE(is(r, 0, 0, grey));
  EXPECT_TRUE(is(r, 3, 2, grey));      // first frame's bottom-right corner
  EXPECT_TRUE(is(r, 1, 1, kOnColor));  // first panel
  EXPECT_TRUE(is(r, 2, 1, kOnColor));
  EXPECT_TRUE(is(r, 1, 3, kBackground));  // below the shorter panel
  EXPECT_TRUE(is(r, 4, 0, kBackground));  // the gap
  EXPECT_TRUE(is(r, 5, 0, grey));
  EXPECT_TRUE(is(r, 6, 1, kOffColor));  // second panel
  EXPECT_TRUE(is(r, 6, 2, kOffColor));
  EXPECT_TRUE(is(r, 7, 3, grey));
  EXPECT_EQ(framed_row({}).width, 0);
}
