#include "train/synapse/sparse_conv.h"

#include <ATen/Dispatch.h>
#include <ATen/Parallel.h>

#include <array>
#include <vector>

#include "core/util/error.h"
#include "core/util/simd.h"
#include "train/neuron/psp.h"
#include "train/synapse/conv_taps.h"

namespace spikems::train {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

KernelPath parse_kernel_path(const std::string& name) {
  if (name == "auto") return KernelPath::Auto;
  if (name == "sparse") return KernelPath::Sparse;
  if (name == "dense") return KernelPath::Dense;
  throw Error("unknown kernel path '" + name + "' (expected auto, sparse or dense)");
}

const char* kernel_path_name(KernelPath k) {
  return k == KernelPath::Auto ? "auto" : k == KernelPath::Sparse ? "sparse" : "dense";
}

namespace {

// Geometry of one frame: input [C_in, H, W] -> output [H_out, W_out, C_out] (channels last, so
// the weight column of one input tap is a contiguous run of C_out values: vectorised axpy).
struct Frame {
  int64_t ci, h, w, co, ho, wo, k;
};

// For every input coordinate, the (output coordinate, kernel tap) pairs it reaches (conv_taps.h).
struct Taps {
  std::vector<std::array<int32_t, 2>> pairs;  // (out, tap)
  std::vector<int32_t> begin;                 // pairs of input i: [begin[i], begin[i+1])
};

Taps make_taps(int64_t in, int64_t out, int64_t k, int64_t stride, int64_t pad, bool transposed) {
  Taps t;
  t.begin.push_back(0);
  for (int64_t i = 0; i < in; ++i) {
    for (int64_t tap = 0; tap < k; ++tap) {
      const int64_t o = tap_output(i, tap, stride, pad, transposed, out);
      if (o >= 0) t.pairs.push_back({int32_t(o), int32_t(tap)});
    }
    t.begin.push_back(int32_t(t.pairs.size()));
  }
  return t;
}

// Nonzero entries of one frame: their count, then their flat indices and values. Compiled per
// instruction set (util/simd.h): the count is a vector compare, the copy reads 16 values at a
// time and skips blocks without a nonzero.
template <typename S>
SPIKEMS_INLINE int64_t count_nonzeros(const S* x, int64_t M) {
  int64_t n = 0;
  for (int64_t m = 0; m < M; ++m) n += x[m] != S(0);
  return n;
}
template <typename S>
SPIKEMS_INLINE void copy_nonzeros(const S* x, int64_t M, int32_t* index, S* value) {
  constexpr int64_t kBlock = 16;
  int64_t o = 0, m = 0;
  for (; m + kBlock <= M; m += kBlock) {
    int any = 0;
    for (int64_t j = 0; j < kBlock; ++j) any |= x[m + j] != S(0);
    if (!any) continue;
    for (int64_t j = m; j < m + kBlock; ++j)
      if (x[j] != S(0)) {
        index[o] = int32_t(j);
        value[o++] = x[j];
      }
  }
  for (; m < M; ++m)
    if (x[m] != S(0)) {
      index[o] = int32_t(m);
      value[o++] = x[m];
    }
}
SPIKEMS_MULTIVERSION int64_t count_nonzeros_mv(const float* x, int64_t M) {
  return count_nonzeros(x, M);
}
SPIKEMS_MULTIVERSION int64_t count_nonzeros_mv(const double* x, int64_t M) {
  return count_nonzeros(x, M);
}
SPIKEMS_MULTIVERSION void copy_nonzeros_mv(const float* x, int64_t M, int32_t* index,
                                           float* value) {
  copy_nonzeros(x, M, index, value);
}
SPIKEMS_MULTIVERSION void copy_nonzeros_mv(const double* x, int64_t M, int32_t* index,
                                           double* value) {
  copy_nonzeros(x, M, index, value);
}

// Nonzero entries of each frame of x [F, M]: flat index within the frame and value; frame f owns
// [offsets[f], offsets[f+1]).
template <typename S>
void find_nonzeros(const S* x, int64_t F, int64_t M, std::vector<int64_t>& offsets,
                   std::vector<int32_t>& index, std::vector<S>& value) {
  offsets.assign(size_t(F + 1), 0);
  at::parallel_for(0, F, 1, [&](int64_t f0, int64_t f1) {
    for (int64_t f = f0; f < f1; ++f) offsets[size_t(f + 1)] = count_nonzeros_mv(x + f * M, M);
  });
  for (int64_t f = 0; f < F; ++f) offsets[size_t(f + 1)] += offsets[size_t(f)];
  index.resize(size_t(offsets[size_t(F)]));
  value.resize(index.size());
  at::parallel_for(0, F, 1, [&](int64_t f0, int64_t f1) {
    for (int64_t f = f0; f < f1; ++f)
      copy_nonzeros_mv(x + f * M, M, index.data() + offsets[size_t(f)],
                       value.data() + offsets[size_t(f)]);
  });
}

// The nonzeros of one frame and the tables that map them to output positions.
template <typename S>
struct Nonzeros {
  const int64_t* offsets;
  const int32_t* index;
  const S* value;
};

// Calls fn(v, ci, ky, kx, out_pixel) for every nonzero of frame f and every tap it reaches
// (out_pixel = oy * W_out + ox).
template <typename S, typename Fn>
SPIKEMS_INLINE void for_each_tap(const Nonzeros<S>& nz, int64_t f, const Frame& g, const Taps& rows,
                                 const Taps& cols, Fn&& fn) {
  const int64_t hw = g.h * g.w;
  for (int64_t n = nz.offsets[f]; n < nz.offsets[f + 1]; ++n) {
    const int64_t m = nz.index[n], ci = m / hw, y = (m % hw) / g.w, x = m % g.w;
    const S v = nz.value[n];
    for (int32_t r = rows.begin[size_t(y)]; r < rows.begin[size_t(y + 1)]; ++r) {
      const auto [oy, ky] = rows.pairs[size_t(r)];
      for (int32_t q = cols.begin[size_t(x)]; q < cols.begin[size_t(x + 1)]; ++q) {
        const auto [ox, kx] = cols.pairs[size_t(q)];
        fn(v, ci, ky, kx, int64_t(oy) * g.wo + ox);
      }
    }
  }
}

// Forward, fused per sample b (samples in parallel), time ascending:
//   c = scatter of frame (t, b) into a channels-last frame buffer (the weight column of a tap
//       is C_out contiguous values: a vectorised axpy), then
//   u[t, b] = Ts * (eps * c)[t], written once in the standard layout [C_out, H_out, W_out].
// IIR kernels keep their O(1) state per neuron; FIR kernels keep the last K frames of c.
// No output-sized temporaries, so no zero-fill or transpose passes over the whole tensor.
// One sample's buffers, reused across its frames (sizes set by the caller).
template <typename S>
struct SampleBuffers {
  std::vector<S> a, q, r, hist;
};

template <typename S>
SPIKEMS_INLINE void forward_sample(const Nonzeros<S>& nz, const S* wt, S* u, int64_t T, int64_t B,
                                   int64_t b, const Frame& g, const Taps& rows, const Taps& cols,
                                   const TemporalKernel& k, S scale, SampleBuffers<S>& buf) {
  const int64_t P = g.ho * g.wo, co = g.co, N = co * P;
  const bool fir = k.form == TemporalKernel::Form::FIR;
  const int64_t taps = fir ? int64_t(k.taps.size()) : 0;
  const int64_t K = fir ? std::max<int64_t>(1, std::min<int64_t>(taps, T)) : 0;
  const S a = S(k.decay), gain = S(scale * k.gain);
  std::vector<S>&cbuf = buf.a, &q = buf.q, &r = buf.r, &hist = buf.hist;
  std::fill(q.begin(), q.end(), S(0));
  std::fill(r.begin(), r.end(), S(0));
  for (int64_t t = 0; t < T; ++t) {
    const int64_t f = t * B + b;
    std::fill(cbuf.begin(), cbuf.end(), S(0));
    for_each_tap(nz, f, g, rows, cols,
                 [&](S v, int64_t ci, int64_t ky, int64_t kx, int64_t p) SPIKEMS_INLINE_LAMBDA {
                   S* __restrict o = cbuf.data() + p * co;
                   const S* __restrict w = wt + ((ci * g.k + ky) * g.k + kx) * co;
                   for (int64_t j = 0; j < co; ++j) o[j] += v * w[j];
                 });
    S* __restrict y = u + f * N;
    if (fir) {
      // hist row t % K = c[t] in the standard layout; y = scale * sum_i h[i] c[t - i].
      S* __restrict cur = hist.data() + (t % K) * N;
      for (int64_t c = 0; c < co; ++c)
        for (int64_t p = 0; p < P; ++p) cur[c * P + p] = cbuf[size_t(p * co + c)];
      for (int64_t n = 0; n < N; ++n) y[n] = S(0);
      for (int64_t i = 0; i < taps && i < K && i <= t; ++i) {
        const S h = S(k.taps[size_t(i)]);
        if (h == S(0)) continue;
        const S* __restrict xr = hist.data() + ((t - i) % K) * N;
        for (int64_t n = 0; n < N; ++n) y[n] += h * xr[n];
      }
      for (int64_t n = 0; n < N; ++n) y[n] *= scale;
    } else {
      S* __restrict qp = q.data();
      S* __restrict rp = r.data();
      for (int64_t c = 0; c < co; ++c) {
        const S* __restrict xc = cbuf.data() + c;
        S* __restrict yc = y + c * P;
        S* __restrict qc = qp + c * P;
        S* __restrict rc = rp + c * P;
        if (k.form == TemporalKernel::Form::Alpha) {
          for (int64_t p = 0; p < P; ++p) {
            rc[p] = a * (rc[p] + qc[p]);
            qc[p] = a * qc[p] + xc[p * co];
            yc[p] = gain * rc[p];
          }
        } else if (k.form == TemporalKernel::Form::AlphaLead) {
          for (int64_t p = 0; p < P; ++p) {
            qc[p] = a * qc[p] + xc[p * co];
            rc[p] = a * (rc[p] + qc[p]);
            yc[p] = gain * rc[p];
          }
        } else {  // DelayedExp
          for (int64_t p = 0; p < P; ++p) {
            yc[p] = gain * qc[p];
            qc[p] = a * qc[p] + xc[p * co];
          }
        }
      }
    }
  }
}
// Compiled per instruction set (util/simd.h): the scatter's axpy and the filter's loops are
// vector loops whose width follows the CPU (the LibTorch operations of the dense path are too).
SPIKEMS_MULTIVERSION void forward_sample_mv(const Nonzeros<float>& nz, const float* wt, float* u,
                                            int64_t T, int64_t B, int64_t b, const Frame& g,
                                            const Taps& rows, const Taps& cols,
                                            const TemporalKernel& k, float scale,
                                            SampleBuffers<float>& buf) {
  forward_sample(nz, wt, u, T, B, b, g, rows, cols, k, scale, buf);
}
SPIKEMS_MULTIVERSION void forward_sample_mv(const Nonzeros<double>& nz, const double* wt, double* u,
                                            int64_t T, int64_t B, int64_t b, const Frame& g,
                                            const Taps& rows, const Taps& cols,
                                            const TemporalKernel& k, double scale,
                                            SampleBuffers<double>& buf) {
  forward_sample(nz, wt, u, T, B, b, g, rows, cols, k, scale, buf);
}

// Forward, fused per sample b (samples in parallel), time ascending:
//   c = scatter of frame (t, b) into a channels-last frame buffer (the weight column of a tap
//       is C_out contiguous values: a vectorised axpy), then
//   u[t, b] = Ts * (eps * c)[t], written once in the standard layout [C_out, H_out, W_out].
// IIR kernels keep their O(1) state per neuron; FIR kernels keep the last K frames of c.
// No output-sized temporaries, so no zero-fill or transpose passes over the whole tensor.
template <typename S>
void forward_fused(const Nonzeros<S>& nz, const S* wt, S* u, int64_t T, int64_t B, const Frame& g,
                   const Taps& rows, const Taps& cols, const TemporalKernel& k, S scale) {
  const int64_t N = g.co * g.ho * g.wo;
  const bool fir = k.form == TemporalKernel::Form::FIR;
  const int64_t taps = fir ? int64_t(k.taps.size()) : 0;
  const int64_t K = fir ? std::max<int64_t>(1, std::min<int64_t>(taps, T)) : 0;
  at::parallel_for(0, B, 1, [&](int64_t b0, int64_t b1) {
    SampleBuffers<S> buf;
    buf.a.resize(size_t(N));
    buf.q.resize(fir ? 0 : size_t(N));
    buf.r.resize(fir ? 0 : size_t(N));
    buf.hist.resize(size_t(K * N));
    for (int64_t b = b0; b < b1; ++b)
      forward_sample_mv(nz, wt, u, T, B, b, g, rows, cols, k, scale, buf);
  });
}

// Backward, fused per sample b, time descending:
//   gc[t, b] = Ts * (eps^T * gu)[t]   (the filter run backwards; written to `gc` when the input
//                                      gradient needs it, standard layout)
//   dwt[ci, ky, kx, :] += v * gc[t, b, :, oy, ox] for the frame's nonzeros (from a channels-last
//                                      copy of the frame, so the gather is a vectorised axpy).
// One weight accumulator per sample, summed in sample order (deterministic).
template <typename S>
SPIKEMS_INLINE void backward_sample(const Nonzeros<S>& nz, const S* gu, S* gc, S* dw, int64_t T,
                                    int64_t B, int64_t b, const Frame& g, const Taps& rows,
                                    const Taps& cols, const TemporalKernel& k, S scale,
                                    SampleBuffers<S>& buf) {
  const int64_t P = g.ho * g.wo, co = g.co, N = co * P;
  const bool fir = k.form == TemporalKernel::Form::FIR;
  const int64_t K = fir ? int64_t(k.taps.size()) : 0;
  const S a = S(k.decay), gain = S(scale * k.gain);
  std::vector<S>&frame = buf.a, &cl = buf.hist, &q = buf.q, &r = buf.r;
  std::fill(q.begin(), q.end(), S(0));
  std::fill(r.begin(), r.end(), S(0));
  for (int64_t t = T - 1; t >= 0; --t) {
    const int64_t f = t * B + b;
    S* __restrict y = gc ? gc + f * N : frame.data();
    const S* __restrict x = gu + f * N;
    if (fir) {
      for (int64_t n = 0; n < N; ++n) y[n] = S(0);
      for (int64_t i = 0; i < K && t + i < T; ++i) {
        const S h = S(k.taps[size_t(i)]);
        if (h == S(0)) continue;
        const S* __restrict xr = gu + ((t + i) * B + b) * N;
        for (int64_t n = 0; n < N; ++n) y[n] += h * xr[n];
      }
      for (int64_t n = 0; n < N; ++n) y[n] *= scale;
    } else if (k.form == TemporalKernel::Form::Alpha) {
      S* __restrict rp = r.data();
      S* __restrict qp = q.data();
      for (int64_t n = 0; n < N; ++n) {
        rp[n] = a * (rp[n] + qp[n]);
        qp[n] = a * qp[n] + x[n];
        y[n] = gain * rp[n];
      }
    } else if (k.form == TemporalKernel::Form::AlphaLead) {
      S* __restrict rp = r.data();
      S* __restrict qp = q.data();
      for (int64_t n = 0; n < N; ++n) {
        qp[n] = a * qp[n] + x[n];
        rp[n] = a * (rp[n] + qp[n]);
        y[n] = gain * rp[n];
      }
    } else {
      S* __restrict qp = q.data();
      for (int64_t n = 0; n < N; ++n) {
        y[n] = gain * qp[n];
        qp[n] = a * qp[n] + x[n];
      }
    }
    if (nz.offsets[f] == nz.offsets[f + 1] || dw == nullptr) continue;
    for (int64_t c = 0; c < co; ++c)
      for (int64_t p = 0; p < P; ++p) cl[size_t(p * co + c)] = y[c * P + p];
    for_each_tap(nz, f, g, rows, cols,
                 [&](S v, int64_t ci, int64_t ky, int64_t kx, int64_t p) SPIKEMS_INLINE_LAMBDA {
                   const S* __restrict gr = cl.data() + p * co;
                   S* __restrict w = dw + ((ci * g.k + ky) * g.k + kx) * co;
                   for (int64_t j = 0; j < co; ++j) w[j] += v * gr[j];
                 });
  }
}
SPIKEMS_MULTIVERSION void backward_sample_mv(const Nonzeros<float>& nz, const float* gu, float* gc,
                                             float* dw, int64_t T, int64_t B, int64_t b,
                                             const Frame& g, const Taps& rows, const Taps& cols,
                                             const TemporalKernel& k, float scale,
                                             SampleBuffers<float>& buf) {
  backward_sample(nz, gu, gc, dw, T, B, b, g, rows, cols, k, scale, buf);
}
SPIKEMS_MULTIVERSION void backward_sample_mv(const Nonzeros<double>& nz, const double* gu,
                                             double* gc, double* dw, int64_t T, int64_t B,
                                             int64_t b, const Frame& g, const Taps& rows,
                                             const Taps& cols, const TemporalKernel& k,
                                             double scale, SampleBuffers<double>& buf) {
  backward_sample(nz, gu, gc, dw, T, B, b, g, rows, cols, k, scale, buf);
}

// Backward, fused per sample b, time descending:
//   gc[t, b] = Ts * (eps^T * gu)[t]   (the filter run backwards; written to `gc` when the input
//                                      gradient needs it, standard layout)
//   dwt[ci, ky, kx, :] += v * gc[t, b, :, oy, ox] for the frame's nonzeros (from a channels-last
//                                      copy of the frame, so the gather is a vectorised axpy).
// One weight accumulator per sample, summed in sample order (deterministic).
template <typename S>
void backward_fused(const Nonzeros<S>& nz, const S* gu, S* gc, S* dwt, int64_t T, int64_t B,
                    const Frame& g, const Taps& rows, const Taps& cols, const TemporalKernel& k,
                    S scale) {
  const int64_t N = g.co * g.ho * g.wo;
  const int64_t wsize = g.ci * g.k * g.k * g.co;
  const bool fir = k.form == TemporalKernel::Form::FIR;
  std::vector<S> acc(size_t(B * wsize), S(0));
  at::parallel_for(0, B, 1, [&](int64_t b0, int64_t b1) {
    SampleBuffers<S> buf;
    buf.a.resize(size_t(N));
    buf.hist.resize(size_t(N));
    buf.q.resize(fir ? 0 : size_t(N));
    buf.r.resize(fir ? 0 : size_t(N));
    for (int64_t b = b0; b < b1; ++b)
      backward_sample_mv(nz, gu, gc, dwt ? acc.data() + b * wsize : nullptr, T, B, b, g, rows, cols,
                         k, scale, buf);
  });
  if (dwt == nullptr) return;
  for (int64_t i = 0; i < wsize; ++i) {
    S sum = S(0);
    for (int64_t b = 0; b < B; ++b) sum += acc[size_t(b * wsize + i)];
    dwt[i] = sum;
  }
}

struct Layout {
  Frame frame;
  int64_t T, B, stride, pad, out_pad;
  bool transposed;
};

Layout layout_of(const torch::Tensor& s, const torch::Tensor& weight, const SynapseGeometry& g) {
  Layout l;
  l.T = s.size(0);
  l.B = s.size(1);
  l.transposed = g.kind == LayerKind::ConvTranspose;
  l.stride = g.stride;
  l.pad = g.padding;
  l.out_pad = g.output_padding;
  Frame& f = l.frame;
  f.ci = s.size(2);
  f.h = s.size(3);
  f.w = s.size(4);
  f.k = weight.size(2);
  f.co = l.transposed ? weight.size(1) : weight.size(0);
  const int64_t wci = l.transposed ? weight.size(0) : weight.size(1);
  TORCH_CHECK(wci == f.ci, "sparse synapse: input has ", f.ci, " channels, the weight ", wci);
  TORCH_CHECK(weight.size(3) == f.k, "sparse synapse: square kernels only");
  auto out = [&](int64_t n) {
    return l.transposed ? (n - 1) * l.stride - 2 * l.pad + f.k + l.out_pad
                        : (n + 2 * l.pad - f.k) / l.stride + 1;
  };
  f.ho = out(f.h);
  f.wo = out(f.w);
  TORCH_CHECK(f.ho > 0 && f.wo > 0, "sparse synapse: input too small for the kernel");
  return l;
}

// Weight in the layout [C_in, k, k, C_out] and back.
torch::Tensor weight_to_taps(const torch::Tensor& w, bool transposed) {
  return (transposed ? w.permute({0, 2, 3, 1}) : w.permute({1, 2, 3, 0})).contiguous();
}
torch::Tensor taps_to_weight(const torch::Tensor& wt, bool transposed) {
  return (transposed ? wt.permute({0, 3, 1, 2}) : wt.permute({3, 0, 1, 2})).contiguous();
}

void save_layout(AutogradContext* ctx, const Layout& l) {
  const Frame& f = l.frame;
  ctx->saved_data["dims"] = std::vector<int64_t>{l.T,
                                                 l.B,
                                                 f.ci,
                                                 f.h,
                                                 f.w,
                                                 f.co,
                                                 f.ho,
                                                 f.wo,
                                                 f.k,
                                                 l.stride,
                                                 l.pad,
                                                 l.out_pad,
                                                 int64_t(l.transposed)};
}
Layout load_layout(AutogradContext* ctx) {
  std::vector<int64_t> d = ctx->saved_data["dims"].toIntVector();
  Layout l;
  l.T = d[0];
  l.B = d[1];
  l.frame = {d[2], d[3], d[4], d[5], d[6], d[7], d[8]};
  l.stride = d[9];
  l.pad = d[10];
  l.out_pad = d[11];
  l.transposed = d[12] != 0;
  return l;
}

struct TapTables {
  Taps rows, cols;
  explicit TapTables(const Layout& l)
      : rows(make_taps(l.frame.h, l.frame.ho, l.frame.k, l.stride, l.pad, l.transposed)),
        cols(make_taps(l.frame.w, l.frame.wo, l.frame.k, l.stride, l.pad, l.transposed)) {}
};

class SparseSynapseFunction : public torch::autograd::Function<SparseSynapseFunction> {
 public:
  static torch::Tensor forward(AutogradContext* ctx, const torch::Tensor& s_in,
                               const torch::Tensor& weight_in, const SynapseGeometry& geom,
                               const TemporalKernel& eps, double ts) {
    const torch::Tensor s = s_in.contiguous();
    const Layout l = layout_of(s, weight_in, geom);
    const Frame& g = l.frame;
    const int64_t F = l.T * l.B, M = g.ci * g.h * g.w;
    const torch::Tensor weight = weight_in.to(s.scalar_type());
    const torch::Tensor wt = weight_to_taps(weight, l.transposed);
    const TapTables taps(l);
    torch::Tensor offsets = torch::empty({F + 1}, torch::kInt64), index, value;
    torch::Tensor u = torch::empty({l.T, l.B, g.co, g.ho, g.wo}, s.options());
    AT_DISPATCH_FLOATING_TYPES(s.scalar_type(), "sparse_synapse_forward", [&] {
      std::vector<int64_t> off;
      std::vector<int32_t> idx;
      std::vector<scalar_t> val;
      find_nonzeros<scalar_t>(s.data_ptr<scalar_t>(), F, M, off, idx, val);
      std::copy(off.begin(), off.end(), offsets.data_ptr<int64_t>());
      index = torch::from_blob(idx.data(), {int64_t(idx.size())}, torch::kInt32).clone();
      value = torch::from_blob(val.data(), {int64_t(val.size())}, s.scalar_type()).clone();
      const Nonzeros<scalar_t> nz{off.data(), idx.data(), val.data()};
      forward_fused<scalar_t>(nz, wt.data_ptr<scalar_t>(), u.data_ptr<scalar_t>(), l.T, l.B, g,
                              taps.rows, taps.cols, eps, scalar_t(ts));
    });
    ctx->save_for_backward({offsets, index, value, weight});
    save_layout(ctx, l);
    save_kernel(ctx, "eps", eps);
    ctx->saved_data["ts"] = ts;
    return u;
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const torch::Tensor &offsets = saved[0], &index = saved[1], &value = saved[2],
                        &weight = saved[3];
    const Layout l = load_layout(ctx);
    const Frame& g = l.frame;
    const TemporalKernel eps = load_kernel(ctx, "eps");
    const double ts = ctx->saved_data["ts"].toDouble();
    const int64_t F = l.T * l.B;
    torch::Tensor gu = grads[0].to(value.scalar_type()).contiguous();
    const bool need_w = ctx->needs_input_grad(1), need_s = ctx->needs_input_grad(0);
    // gc = dL/d(W (*) s) = eps^T * dL/du, kept whole only for the input gradient.
    torch::Tensor gc, dwt, gw, gs;
    if (need_s) gc = torch::empty({F, g.co, g.ho, g.wo}, value.options());
    if (need_w) dwt = torch::empty({g.ci, g.k, g.k, g.co}, value.options());
    if (need_w || need_s) {
      const TapTables taps(l);
      AT_DISPATCH_FLOATING_TYPES(value.scalar_type(), "sparse_synapse_backward", [&] {
        const Nonzeros<scalar_t> nz{offsets.data_ptr<int64_t>(), index.data_ptr<int32_t>(),
                                    value.data_ptr<scalar_t>()};
        backward_fused<scalar_t>(nz, gu.data_ptr<scalar_t>(),
                                 need_s ? gc.data_ptr<scalar_t>() : nullptr,
                                 need_w ? dwt.data_ptr<scalar_t>() : nullptr, l.T, l.B, g,
                                 taps.rows, taps.cols, eps, scalar_t(ts));
      });
    }
    if (need_w) gw = taps_to_weight(dwt, l.transposed);
    if (need_s) {
      // Every input position gets a gradient: the adjoint convolution, dense.
      if (l.transposed) {
        gs = torch::conv2d(gc, weight, {}, l.stride, l.pad);
      } else {
        auto op = [&](int64_t in, int64_t out) {
          return in - ((out - 1) * l.stride - 2 * l.pad + g.k);
        };
        gs = torch::conv_transpose2d(gc, weight, {}, l.stride, l.pad,
                                     {op(g.h, g.ho), op(g.w, g.wo)});
      }
      gs = gs.view({l.T, l.B, g.ci, g.h, g.w});
    }
    return {gs, gw, torch::Tensor(), torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

torch::Tensor sparse_synapse_psp(const torch::Tensor& s, const torch::Tensor& weight,
                                 const SynapseGeometry& g, const TemporalKernel& eps, double ts) {
  TORCH_CHECK(s.dim() == 5, "sparse synapse: input must be [T, B, C, H, W]");
  TORCH_CHECK(weight.dim() == 4, "sparse synapse: weight must be 4-D");
  TORCH_CHECK(s.device().is_cpu() && weight.device().is_cpu(), "sparse synapse: CPU tensors only");
  TORCH_CHECK(s.scalar_type() == torch::kFloat || s.scalar_type() == torch::kDouble,
              "sparse synapse: float or double input");
  // Positions are stored as int32 within one frame.
  TORCH_CHECK(s.size(2) * s.size(3) * s.size(4) < (int64_t(1) << 31),
              "sparse synapse: frame too large");
  return SparseSynapseFunction::apply(s, weight, g, eps, ts);
}

double nonzero_density(const torch::Tensor& x_in) {
  const torch::Tensor x = x_in.contiguous();
  const int64_t n = x.numel();
  if (n == 0) return 0.0;
  std::vector<int64_t> counts(size_t(at::get_num_threads()) + 1, 0);
  AT_DISPATCH_FLOATING_TYPES(x.scalar_type(), "nonzero_density", [&] {
    const scalar_t* p = x.data_ptr<scalar_t>();
    const int64_t nchunks = int64_t(counts.size());
    at::parallel_for(0, nchunks, 1, [&](int64_t c0, int64_t c1) {
      for (int64_t c = c0; c < c1; ++c) {
        const int64_t b = n * c / nchunks, e = n * (c + 1) / nchunks;
        int64_t k = 0;
        for (int64_t i = b; i < e; ++i) k += p[i] != scalar_t(0);
        counts[size_t(c)] = k;
      }
    });
  });
  int64_t total = 0;
  for (int64_t c : counts) total += c;
  return double(total) / double(n);
}

double sparse_density_threshold(const SynapseGeometry& g, int64_t out_channels) {
  if (g.kind != LayerKind::ConvTranspose) return 0.0;
  return out_channels <= 4 ? 0.05 : out_channels <= 16 ? 0.12 : out_channels <= 32 ? 0.18 : 0.30;
}

bool use_sparse_path(KernelPath path, const torch::Tensor& s, const SynapseGeometry& g,
                     int64_t out_channels) {
  if (path == KernelPath::Dense) return false;
  const bool supported = s.device().is_cpu() && s.dim() == 5 &&
                         (s.scalar_type() == torch::kFloat || s.scalar_type() == torch::kDouble);
  if (path == KernelPath::Sparse) return supported;
  const double threshold = sparse_density_threshold(g, out_channels);
  return supported && threshold > 0 && nonzero_density(s) <= threshold;
}

}  // namespace spikems::train
