#include "core/runtime/ann2d_network.h"

#include <algorithm>
#include <tuple>

#include "core/runtime/ann_features.h"
#include "core/util/error.h"

namespace spikems {

namespace {

// in [C_in, H, W] -> out [C_out, Ho, Wo] = bias + the layer's convolution of in. A convolution
// gathers output (oy, ox) from input (oy s - p + ky, ox s - p + kx); a transposed one scatters
// input (iy, ix) to output (iy s - p + ky, ix s - p + kx).
void layer_forward(const LayerSpec& l, const std::vector<float>& in, int H, int W,
                   std::vector<float>& out, int Ho, int Wo) {
  const int k = l.kernel, s = l.stride, p = l.padding;
  const bool transposed = l.kind == LayerKind::ConvTranspose;
  const size_t po = size_t(Ho) * size_t(Wo), pi = size_t(H) * size_t(W);
  out.assign(size_t(l.out_channels) * po, 0.f);
  for (int co = 0; co < l.out_channels; ++co) {
    float* o = out.data() + size_t(co) * po;
    std::fill(o, o + po, l.bias[size_t(co)]);
    for (int ci = 0; ci < l.in_channels; ++ci) {
      const float* x = in.data() + size_t(ci) * pi;
      for (int ky = 0; ky < k; ++ky)
        for (int kx = 0; kx < k; ++kx) {
          const size_t pair =
              transposed ? size_t(ci) * l.out_channels + co : size_t(co) * l.in_channels + ci;
          const float w = l.weight[(pair * k + ky) * k + kx];
          if (!transposed) {
            // Output columns whose input column ox*s - p + kx lies inside [0, W).
            const int ox0 = std::max(0, (p - kx + s - 1) / s);
            const int ox1 = std::min(Wo, (W - 1 + p - kx) / s + 1);
            for (int oy = 0; oy < Ho; ++oy) {
              const int iy = oy * s - p + ky;
              if (iy < 0 || iy >= H) continue;
              const float* xr = x + size_t(iy) * W;
              float* orow = o + size_t(oy) * Wo;
              for (int ox = ox0; ox < ox1; ++ox) orow[ox] += w * xr[ox * s - p + kx];
            }
          } else {
            for (int iy = 0; iy < H; ++iy) {
              const int oy = iy * s - p + ky;
              if (oy < 0 || oy >= Ho) continue;
              const float* xr = x + size_t(iy) * W;
              float* orow = o + size_t(oy) * Wo;
              for (int ix = 0; ix < W; ++ix) {
                const int ox = ix * s - p + kx;
                if (ox >= 0 && ox < Wo) orow[ox] += w * xr[ix];
              }
            }
          }
        }
    }
  }
}

}  // namespace

Ann2dForward::Ann2dForward(ModelSpec model) : model_(std::move(model)) {
  model_.validate(model_.name);
  if (model_.type != ModelType::ANN2D)
    fail(model_.name, "", "not an ANN-2D model (its type is the spiking network)");
}

std::vector<float> Ann2dForward::forward(const std::vector<float>& features, int H, int W) const {
  const int C = model_.ann_input_channels();
  if (H < 1 || W < 1 || features.size() != size_t(C) * H * W)
    fail(model_.name, "", "ANN-2D input must be " + std::to_string(C) + " x H x W features");
  std::vector<float> x = features, y;
  int h = H, w = W;
  if (model_.has_skips()) {  // zeros at the bottom and right up to a size the skips meet at
    std::tie(h, w) = model_.fitted_input_size(H, W);
    model_.check_input_size(h, w, model_.name);
    x.assign(size_t(C) * h * w, 0.f);
    for (int c = 0; c < C; ++c)
      for (int r = 0; r < H; ++r)
        std::copy_n(features.data() + (size_t(c) * H + r) * W, W,
                    x.data() + (size_t(c) * h + r) * w);
  }
  std::vector<std::vector<float>> kept(model_.layers.size());  // outputs that skips read
  for (size_t k = 0; k < model_.layers.size(); ++k) {
    const LayerSpec& l = model_.layers[k];
    if (l.skip_from >= 0) {  // [C_pred, h, w] then the skip source's channels (same size)
      const auto& src = kept[size_t(l.skip_from)];
      x.insert(x.end(), src.begin(), src.end());
    }
    const int ho = l.output_size(h), wo = l.output_size(w);
    if (ho < 1 || wo < 1) fail(model_.name, "", "input too small for the network");
    layer_forward(l, x, h, w, y, ho, wo);
    if (k + 1 < model_.layers.size())
      for (float& v : y) v = std::max(v, 0.f);
    std::swap(x, y);
    h = ho;
    w = wo;
    if (std::any_of(model_.layers.begin(), model_.layers.end(),
                    [k](const LayerSpec& m) { return m.skip_from == int(k); }))
      kept[k] = x;
  }
  std::vector<float> out(size_t(H) * size_t(W), 0.f);  // top-left aligned, channel 0
  for (int r = 0; r < std::min(H, h); ++r)
    std::copy_n(x.data() + size_t(r) * w, std::min(W, w), out.data() + size_t(r) * W);
  return out;
}

}  // namespace spikems
