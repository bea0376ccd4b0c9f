// An 8-bit RGB image and PNG input/output (libpng), for event frames and reports.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace spikems {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // 3 * width * height, row-major, top-left origin

  Image() = default;
  // A width x height image filled with one colour (white by default).
  Image(int w, int h, uint8_t r = 255, uint8_t g = 255, uint8_t b = 255);
  // Sets a pixel; coordinates outside the image are ignored.
  void set(int x, int y, uint8_t r, uint8_t g, uint8_t b);
  const uint8_t* px(int x, int y) const {
    return &rgb[(size_t(y) * size_t(width) + size_t(x)) * 3];
  }
  bool is(int x, int y, uint8_t r, uint8_t g, uint8_t b) const {
    const uint8_t* p = px(x, y);
    return p[0] == r && p[1] == g && p[2] == b;
  }
};

// Nearest-neighbour enlargement by an integer factor (>= 1).
Image upscale(const Image& img, int factor);
// a and b side by side (heights may differ: the rest is white), separated by `gap` white pixels.
Image hstack(const Image& a, const Image& b, int gap = 0);

// Panels side by side, each inside a 1-pixel grey frame (white panels stay apart), `gap`
// white pixels between frames, tops aligned; the rest is white. Empty input: an empty image.
inline constexpr uint8_t kFrameGrey = 150;
Image framed_row(const std::vector<Image>& panels, int gap = 6);

// Writes an 8-bit RGB PNG atomically (temporary file renamed into place).
void write_png(const std::string& path, const Image& img);
// Reads any PNG (grey, palette, alpha, 16-bit) converted to 8-bit RGB.
Image read_png_rgb(const std::string& path);

}  // namespace spikems
