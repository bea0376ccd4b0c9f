#include "core/runtime/dense_reference.h"

#include <algorithm>
#include <cmath>

#include "core/util/error.h"

namespace spikems {

double srm_kernel_value(const NeuronParams& n, double ts, int step) {
  // SameStep: sampled at the end of the spike's own step, one step ahead of SLAYER's.
  if (n.srm_onset == SrmOnset::SameStep) ++step;
  double t = step * ts / double(n.tau_s);
  return t * std::exp(1.0 - t);
}

double refractory_kernel_value(const NeuronParams& n, double ts, int step) {
  double mult = -double(n.scale_ref) * double(n.theta);
  if (step <= 0) return 0.0;
  if (n.refractory == RefractoryShape::SpikeMS)
    return mult * std::exp(-(step - 1) * ts / double(n.tau_r));
  double t = step * ts / double(n.tau_r);
  return mult * t * std::exp(1.0 - t);
}

namespace {

// Synaptic op of one time step: a [C_in, H, W] -> u [C_out, Ho, Wo] (u zeroed by caller).
template <typename F>
void synaptic_op(const LayerSpec& l, const F* a, int H, int W, F* u, int Ho, int Wo) {
  const int k = l.kernel, s = l.stride, p = l.padding;
  const int ci_n = l.in_channels, co_n = l.out_channels;
  if (l.kind == LayerKind::Conv) {
    // u[co,oy,ox] = sum_{ci,ky,kx} W[co,ci,ky,kx] a[ci, s*oy-p+ky, s*ox-p+kx]
    for (int co = 0; co < co_n; ++co)
      for (int oy = 0; oy < Ho; ++oy)
        for (int ox = 0; ox < Wo; ++ox) {
          F acc = 0;
          for (int ci = 0; ci < ci_n; ++ci)
            for (int ky = 0; ky < k; ++ky) {
              int y = s * oy - p + ky;
              if (y < 0 || y >= H) continue;
              for (int kx = 0; kx < k; ++kx) {
                int x = s * ox - p + kx;
                if (x < 0 || x >= W) continue;
                F w = l.weight[((size_t(co) * ci_n + ci) * k + ky) * k + kx];
                acc += w * a[(size_t(ci) * H + y) * W + x];
              }
            }
          u[(size_t(co) * Ho + oy) * Wo + ox] = acc;
        }
  } else {
    // u[co, s*y-p+ky, s*x-p+kx] += W[ci,co,ky,kx] a[ci,y,x]; output_padding only adds rows
    // and columns at the end (reached by no tap when p = 0).
    for (int ci = 0; ci < ci_n; ++ci)
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          F av = a[(size_t(ci) * H + y) * W + x];
          if (av == 0) continue;
          for (int co = 0; co < co_n; ++co)
            for (int ky = 0; ky < k; ++ky) {
              int oy = s * y - p + ky;
              if (oy < 0 || oy >= Ho) continue;
              for (int kx = 0; kx < k; ++kx) {
                int ox = s * x - p + kx;
                if (ox < 0 || ox >= Wo) continue;
                F w = l.weight[((size_t(ci) * co_n + co) * k + ky) * k + kx];
                u[(size_t(co) * Ho + oy) * Wo + ox] += w * av;
              }
            }
        }
  }
}

template <typename F>
DenseLayerOutput forward_impl(const LayerSpec& l, double ts, const DenseTensor& in,
                              const std::vector<F>& eps, const std::vector<F>& nu) {
  const int T = in.T, H = in.H, W = in.W;
  const int Ho = l.output_size(H), Wo = l.output_size(W);
  if (Ho <= 0 || Wo <= 0) fail("dense forward", "", "input too small for the layer");
  const size_t in_frame = in.frame_size();
  // 1. psp, per input neuron, i ascending (as the SLAYER kernel sums).
  std::vector<F> a(size_t(T) * in_frame, F(0));
  const int K = int(eps.size());
  for (int t = 0; t < T; ++t)
    for (size_t n = 0; n < in_frame; ++n) {
      F acc = 0;
      for (int i = 0; i < K && i <= t; ++i) acc += in.v[size_t(t - i) * in_frame + n] * eps[i];
      a[size_t(t) * in_frame + n] = acc;
    }
  // 2. synaptic op, independently at every step.
  DenseLayerOutput out{DenseTensor(T, l.out_channels, Ho, Wo),
                       DenseTensor(T, l.out_channels, Ho, Wo)};
  const size_t out_frame = out.spikes.frame_size();
  std::vector<F> u(size_t(T) * out_frame, F(0));
  for (int t = 0; t < T; ++t)
    synaptic_op<F>(l, &a[size_t(t) * in_frame], H, W, &u[size_t(t) * out_frame], Ho, Wo);
  // 3. spikes, sequential in time, refractory added in place to the future potential.
  const F theta = F(l.neuron.theta);
  const int R = int(nu.size());
  for (size_t n = 0; n < out_frame; ++n)
    for (int t = 0; t < T; ++t) {
      F ut = u[size_t(t) * out_frame + n];
      out.potential.v[size_t(t) * out_frame + n] = float(ut);
      if (ut >= theta) {
        out.spikes.v[size_t(t) * out_frame + n] = 1.f;
        for (int j = 0; j < R && t + j < T; ++j) u[size_t(t + j) * out_frame + n] += nu[j];
      }
    }
  return out;
}

}  // namespace

DenseLayerOutput dense_layer_forward(const LayerSpec& l, double ts, const DenseTensor& in) {
  if (in.C != l.in_channels)
    fail("dense forward", "",
         "input has " + std::to_string(in.C) + " channels, layer takes " +
             std::to_string(l.in_channels));
  if (!l.delay.empty()) fail("dense forward", "", "axonal delays are not supported");
  if (l.neuron.discretisation == Discretisation::FIR)
    return forward_impl<float>(l, ts, in, l.srm_kernel, l.ref_kernel);
  // IIR: the untruncated continuous kernels over the whole window, in double.
  std::vector<double> eps(size_t(in.T)), nu(size_t(in.T));
  for (int i = 0; i < in.T; ++i) {
    eps[i] = srm_kernel_value(l.neuron, ts, i);
    nu[i] = refractory_kernel_value(l.neuron, ts, i);
  }
  return forward_impl<double>(l, ts, in, eps, nu);
}

DenseTensor dense_concat_channels(const DenseTensor& a, const DenseTensor& b) {
  if (a.T != b.T || a.H != b.H || a.W != b.W)
    fail("dense forward", "",
         "cannot concatenate [" + std::to_string(a.T) + ", " + std::to_string(a.H) + ", " +
             std::to_string(a.W) + "] and [" + std::to_string(b.T) + ", " + std::to_string(b.H) +
             ", " + std::to_string(b.W) + "] spikes on the channels");
  DenseTensor c(a.T, a.C + b.C, a.H, a.W);
  const size_t fa = a.frame_size(), fb = b.frame_size();
  for (int t = 0; t < a.T; ++t) {
    std::copy_n(&a.v[size_t(t) * fa], fa, &c.v[size_t(t) * (fa + fb)]);
    std::copy_n(&b.v[size_t(t) * fb], fb, &c.v[size_t(t) * (fa + fb) + fa]);
  }
  return c;
}

DenseTensor dense_network_input(const ModelSpec& m, const DenseTensor& in) {
  if (!m.has_skips()) return in;
  const auto [h, w] = m.fitted_input_size(in.H, in.W);
  m.check_input_size(h, w, m.name);
  DenseTensor p(in.T, in.C, h, w);
  for (int t = 0; t < in.T; ++t)
    for (int c = 0; c < in.C; ++c)
      for (int y = 0; y < in.H; ++y)
        std::copy_n(&in.v[in.index(t, c, y, 0)], in.W, &p.v[p.index(t, c, y, 0)]);
  return p;
}

DenseTensor dense_layer_input(const ModelSpec& m, size_t k, const DenseTensor& net_input,
                              const std::vector<DenseLayerOutput>& outs) {
  if (k == 0) return net_input;
  const int skip = m.layers[k].skip_from;
  if (skip < 0) return outs[k - 1].spikes;
  return dense_concat_channels(outs[k - 1].spikes, outs[size_t(skip)].spikes);
}

std::vector<DenseLayerOutput> dense_forward(const ModelSpec& m, const DenseTensor& input) {
  const DenseTensor net_input = dense_network_input(m, input);
  std::vector<DenseLayerOutput> outs;
  outs.reserve(m.layers.size());
  for (size_t k = 0; k < m.layers.size(); ++k) {
    const LayerSpec& l = m.layers[k];
    if (l.skip_from >= 0)
      outs.push_back(
          dense_layer_forward(l, m.time_step_ms, dense_layer_input(m, k, net_input, outs)));
    else  // no copy
      outs.push_back(
          dense_layer_forward(l, m.time_step_ms, k == 0 ? net_input : outs[k - 1].spikes));
  }
  if (m.output_gate_steps > 0) dense_output_gate(m.output_gate_steps, input, outs.back().spikes);
  return outs;
}

void dense_output_gate(int steps, const DenseTensor& input, DenseTensor& spikes) {
  // Literally: for each output spike, look back over the K steps for an input event at its
  // pixel (output pixel (y, x) = input pixel (y, x); beyond the input, none).
  for (int t = 0; t < spikes.T; ++t)
    for (int y = 0; y < spikes.H; ++y)
      for (int x = 0; x < spikes.W; ++x) {
        bool event = false;
        if (y < input.H && x < input.W)
          for (int u = std::max(0, t - steps + 1); u <= t && u < input.T && !event; ++u)
            for (int c = 0; c < input.C; ++c) event = event || input.at(u, c, y, x) != 0.f;
        if (!event)
          for (int c = 0; c < spikes.C; ++c) spikes.at(t, c, y, x) = 0.f;
      }
}

}  // namespace spikems
