#include "core/runtime/ann_features.h"

#include <cmath>

#include "core/util/error.h"

namespace spikems {

std::vector<float> ann_features(const uint8_t* spikes, int T, int H, int W) {
  if (T < 1 || H < 1 || W < 1) fail("ann features", "", "empty window or frame");
  const size_t plane = size_t(H) * size_t(W);
  std::vector<float> f(kAnnFeatureChannels * plane, 0.f);
  float* count = f.data();             // channels 0, 1
  float* time = f.data() + 2 * plane;  // channels 2, 3: sums first, means below
  for (int t = 0; t < T; ++t) {
    const float when = (float(t) + 0.5f) / float(T);
    const uint8_t* s = spikes + size_t(t) * 2 * plane;
    for (size_t i = 0; i < 2 * plane; ++i)
      if (s[i]) {
        count[i] += 1.f;
        time[i] += when;
      }
  }
  for (size_t i = 0; i < 2 * plane; ++i) {
    if (count[i] > 0) time[i] /= count[i];
    count[i] = std::log1p(count[i]);
  }
  return f;
}

}  // namespace spikems
