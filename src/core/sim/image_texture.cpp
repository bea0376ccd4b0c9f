#include "core/sim/image_texture.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>

#include "core/sim/texture.h"
#include "core/util/error.h"

namespace spikems::sim {

namespace {

double srgb_to_linear(double c) {
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// Area-average weights from `src` samples onto `dst` (each destination sample is the mean of
// the source interval it covers): for each destination i, (first source, weights).
struct AreaWeights {
  std::vector<int> first;
  std::vector<std::vector<float>> w;
};

AreaWeights area_weights(int src, int dst) {
  AreaWeights a;
  const double scale = double(src) / dst;
  for (int i = 0; i < dst; ++i) {
    double lo = i * scale, hi = (i + 1) * scale;
    int j0 = int(std::floor(lo)), j1 = std::min(src - 1, int(std::ceil(hi)) - 1);
    a.first.push_back(j0);
    std::vector<float> w;
    for (int j = j0; j <= j1; ++j)
      w.push_back(float((std::min(hi, j + 1.0) - std::max(lo, double(j))) / scale));
    a.w.push_back(std::move(w));
  }
  return a;
}

// Header check only (signature and IHDR): cheap enough to run on every file of a folder.
void check_png_header(const std::string& path) {
  png_image pi{};
  pi.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&pi, path.c_str()))
    fail(path, "", std::string("not a readable PNG: ") + pi.message);
  png_image_free(&pi);
}

std::mutex& cache_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

std::vector<float> image_to_tile(const Image& img) {
  const int n = Texture::kTile;
  const int side = std::min(img.width, img.height);
  const int ox = (img.width - side) / 2, oy = (img.height - side) / 2;
  float lut[256];
  for (int i = 0; i < 256; ++i) lut[i] = float(srgb_to_linear(i / 255.0));
  const AreaWeights aw = area_weights(side, n);
  // Horizontal pass over the crop's rows, then vertical.
  std::vector<float> rows(size_t(side) * n);
  std::vector<float> lum(static_cast<size_t>(side));
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const uint8_t* p = img.px(ox + x, oy + y);
      lum[size_t(x)] = 0.2126f * lut[p[0]] + 0.7152f * lut[p[1]] + 0.0722f * lut[p[2]];
    }
    for (int i = 0; i < n; ++i) {
      float s = 0;
      for (size_t k = 0; k < aw.w[size_t(i)].size(); ++k)
        s += aw.w[size_t(i)][k] * lum[size_t(aw.first[size_t(i)]) + k];
      rows[size_t(y) * n + i] = s;
    }
  }
  std::vector<float> t(size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      float s = 0;
      for (size_t k = 0; k < aw.w[size_t(j)].size(); ++k)
        s += aw.w[size_t(j)][k] * rows[(size_t(aw.first[size_t(j)]) + k) * n + i];
      t[size_t(j) * n + i] = std::log(std::max(s, 0.0f) + 0.01f);
    }
  std::vector<float> sorted = t;
  std::sort(sorted.begin(), sorted.end());
  const float p1 = sorted[sorted.size() / 100], p99 = sorted[sorted.size() * 99 / 100];
  for (auto& v : t) v = p99 - p1 > 1e-6f ? std::clamp((v - p1) / (p99 - p1), 0.0f, 1.0f) : 0.5f;
  return t;
}

const std::vector<std::string>& image_texture_files(const std::string& dir) {
  namespace fs = std::filesystem;
  static std::map<std::string, std::vector<std::string>> cache;
  {
    std::lock_guard<std::mutex> lock(cache_mutex());
    auto it = cache.find(dir);
    if (it != cache.end()) return it->second;  // map nodes are stable
  }
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    fail(dir, "",
         "texture image folder not found (a relative path is taken from the config "
         "file's folder, or the current one for a preset)");
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png" && e.is_regular_file()) files.push_back(e.path().string());
  }
  if (ec) fail(dir, "", "cannot list the texture image folder: " + ec.message());
  if (files.empty()) fail(dir, "", "no PNG file (*.png) in the texture image folder");
  std::sort(files.begin(), files.end());
  for (const auto& f : files) check_png_header(f);
  std::lock_guard<std::mutex> lock(cache_mutex());
  return cache.emplace(dir, std::move(files)).first->second;
}

std::shared_ptr<const std::vector<float>> image_texture_tile(const std::string& file) {
  static std::map<std::string, std::shared_ptr<const std::vector<float>>> cache;
  {
    std::lock_guard<std::mutex> lock(cache_mutex());
    auto it = cache.find(file);
    if (it != cache.end()) return it->second;
  }
  // Decoded outside the lock; two threads may decode one file at once, with equal results.
  auto tile = std::make_shared<const std::vector<float>>(image_to_tile(read_png_rgb(file)));
  std::lock_guard<std::mutex> lock(cache_mutex());
  return cache.emplace(file, std::move(tile)).first->second;
}

}  // namespace spikems::sim
