#include "core/model/model_scale.h"

#include <cmath>

#include "core/util/error.h"

namespace spikems {

namespace {
int grid(int side, int f) {
  return (side + f - 1) / f;
}
}  // namespace

int nearest_downsample(const ModelSpec& m, int width, int height) {
  if (m.type != ModelType::SNN || width <= 0 || height <= 0) return 1;
  if (m.input_width > 0 && m.input_height > 0) {
    for (int f : kDownsampleFactors)
      if (grid(width, f) == m.input_width && grid(height, f) == m.input_height) return f;
    return 1;  // the runtime then names the mismatch
  }
  if (m.train_width <= 0 || m.train_height <= 0) return 1;
  const double target = 0.5 * std::log2(double(m.train_width) * m.train_height);
  int best = 1;
  double best_d = 1e300;
  for (int f : kDownsampleFactors) {
    const double d = std::abs(0.5 * std::log2(double(grid(width, f)) * grid(height, f)) - target);
    if (d < best_d - 1e-9) {
      best = f;
      best_d = d;
    }
  }
  return best;
}

int resolve_downsample(const ModelSpec& m, int width, int height, int requested,
                       const std::string& source) {
  if (requested == 0) return nearest_downsample(m, width, height);
  for (int f : kDownsampleFactors)
    if (requested == f) return f;
  fail(source, "",
       "the downsampling factor must be auto, 1, 2, 4 or 8, not " + std::to_string(requested));
}

int parse_downsample(const std::string& text, const std::string& what) {
  if (text == "auto") return 0;
  for (int f : kDownsampleFactors)
    if (text == std::to_string(f)) return f;
  fail(what, "", "'" + text + "' is not a downsampling factor: use auto, 1, 2, 4 or 8");
}

}  // namespace spikems
