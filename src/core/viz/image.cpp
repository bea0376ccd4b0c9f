#include "core/viz/image.h"

#include <png.h>

#include <algorithm>
#include <cstring>

#include "core/util/atomic_file.h"
#include "core/util/error.h"

namespace spikems {

Image::Image(int w, int h, uint8_t r, uint8_t g, uint8_t b) : width(w), height(h) {
  if (w < 0 || h < 0) fail("image", "", "negative size");
  rgb.resize(size_t(w) * size_t(h) * 3);
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = r;
    rgb[i + 1] = g;
    rgb[i + 2] = b;
  }
}

void Image::set(int x, int y, uint8_t r, uint8_t g, uint8_t b) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  uint8_t* p = &rgb[(size_t(y) * size_t(width) + size_t(x)) * 3];
  p[0] = r;
  p[1] = g;
  p[2] = b;
}

Image upscale(const Image& img, int factor) {
  if (factor < 1) fail("image", "", "scale factor must be >= 1");
  if (factor == 1) return img;
  Image out(img.width * factor, img.height * factor);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      std::memcpy(&out.rgb[(size_t(y) * size_t(out.width) + size_t(x)) * 3],
                  img.px(x / factor, y / factor), 3);
  return out;
}

Image hstack(const Image& a, const Image& b, int gap) {
  Image out(a.width + gap + b.width, std::max(a.height, b.height));
  for (int y = 0; y < a.height; ++y)
    std::memcpy(&out.rgb[size_t(y) * size_t(out.width) * 3], a.px(0, y), size_t(a.width) * 3);
  for (int y = 0; y < b.height; ++y)
    std::memcpy(&out.rgb[(size_t(y) * size_t(out.width) + size_t(a.width + gap)) * 3], b.px(0, y),
                size_t(b.width) * 3);
  return out;
}

Image framed_row(const std::vector<Image>& panels, int gap) {
  if (panels.empty()) return {};
  int w = gap * int(panels.size() - 1), h = 0;
  for (const Image& p : panels) {
    w += p.width + 2;
    h = std::max(h, p.height + 2);
  }
  Image out(w, h);
  int x0 = 0;
  for (const Image& p : panels) {
    for (int x = 0; x < p.width + 2; ++x) {
      out.set(x0 + x, 0, kFrameGrey, kFrameGrey, kFrameGrey);
      out.set(x0 + x, p.height + 1, kFrameGrey, kFrameGrey, kFrameGrey);
    }
    for (int y = 0; y < p.height + 2; ++y) {
      out.set(x0, y, kFrameGrey, kFrameGrey, kFrameGrey);
      out.set(x0 + p.width + 1, y, kFrameGrey, kFrameGrey, kFrameGrey);
    }
    for (int y = 0; y < p.height; ++y)
      std::memcpy(&out.rgb[(size_t(y + 1) * size_t(out.width) + size_t(x0 + 1)) * 3], p.px(0, y),
                  size_t(p.width) * 3);
    x0 += p.width + 2 + gap;
  }
  return out;
}

void write_png(const std::string& path, const Image& img) {
  if (img.width <= 0 || img.height <= 0 ||
      img.rgb.size() != size_t(img.width) * size_t(img.height) * 3)
    fail(path, "", "cannot write an empty or inconsistent image");
  AtomicFile out(path);
  png_image pi;
  std::memset(&pi, 0, sizeof pi);
  pi.version = PNG_IMAGE_VERSION;
  pi.width = png_uint_32(img.width);
  pi.height = png_uint_32(img.height);
  pi.format = PNG_FORMAT_RGB;
  if (!png_image_write_to_file(&pi, out.temp_path().c_str(), 0, img.rgb.data(), 0, nullptr))
    fail(path, "",
         std::string("PNG write failed: ") + pi.message +
             " (is the folder writable and is there space left?)");
  out.commit();
}

Image read_png_rgb(const std::string& path) {
  png_image pi;
  std::memset(&pi, 0, sizeof pi);
  pi.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&pi, path.c_str()))
    fail(path, "", std::string("not a readable PNG: ") + pi.message);
  pi.format = PNG_FORMAT_RGB;
  if (pi.width == 0 || pi.height == 0 || pi.width > 65536 || pi.height > 65536) {
    png_image_free(&pi);
    fail(path, "",
         "PNG size " + std::to_string(pi.width) + "x" + std::to_string(pi.height) +
             " is outside 1..65536");
  }
  Image img;
  img.width = int(pi.width);
  img.height = int(pi.height);
  img.rgb.resize(PNG_IMAGE_SIZE(pi));
  if (!png_image_finish_read(&pi, nullptr, img.rgb.data(), 0, nullptr))
    fail(path, "", std::string("PNG decode failed: ") + pi.message);
  return img;
}

}  // namespace spikems
