// 16-bit (and 8-bit) PNG images through libpng, for ground-truth frames such as EV-IMO's
// depth/mask PNGs (16 bits, 3 channels: in OpenCV's BGR order channel 0 is depth in mm and
// channel 2 the object id x 1000; in the file's own RGB order that mask is channel 0).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace spikems {

struct Image16 {
  int width = 0, height = 0;
  int channels = 0;            // 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA (file order)
  int bit_depth = 0;           // 8 or 16 as stored in the file; values are kept unscaled
  std::vector<uint16_t> data;  // row-major, channels interleaved
  uint16_t at(int x, int y, int c) const {
    return data[(size_t(y) * size_t(width) + size_t(x)) * size_t(channels) + size_t(c)];
  }
  // Channel c in OpenCV's BGR numbering (cv2.imread order) for 3- and 4-channel images.
  uint16_t at_bgr(int x, int y, int c) const { return at(x, y, channels >= 3 ? 2 - c : c); }
};

Image16 decode_png16(const uint8_t* data, size_t n, const std::string& source);
Image16 read_png16(const std::string& path);
std::vector<uint8_t> encode_png16(const Image16& img);          // 16-bit, channels as given
void write_png16(const std::string& path, const Image16& img);  // atomic

}  // namespace spikems
