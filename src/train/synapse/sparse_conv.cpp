#include "train/synapse/sparse_conv.h"

#include <ATen/Dispatch.h>
#include <ATen/Parallel.h>

#include <array>
#include <vector>

#include "core/util/error.h"
#include "train/neuron/psp.h"

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

// For every input coordinate, the (output coordinate, kernel tap) pairs it reaches:
//   conv:             in = out * stride - pad + tap
//   transposed conv:  out = in * stride - pad + tap
struct Taps {
  std::vector<std::array<int32_t, 2>> pairs;  // (out, tap)
  std::vector<int32_t> begin;                 // pairs of input i: [begin[i], begin[i+1])
};

Taps make_taps(int64_t in, int64_t out, int64_t k, int64_t stride, int64_t pad, bool transposed) {
  Taps t;
  t.begin.push_back(0);
  for (int64_t i = 0; i < in; ++i) {
    for (int64_t tap = 0; tap < k; ++tap) {
      int64_t o;
      if (transposed) {
        o = i * stride - pad + tap;
      } else {
        const int64_t num = i + pad - tap;
        if (num < 0 || num % stride != 0) continue;
        o = num / stride;
      }
      if (o >= 0 && o < out) t.pairs.push_back({int32_t(o), int32_t(tap)});
    }
    t.begin.push_back(int32_t(t.pairs.size()));
  }
  return t;
}

// The frames are dealt to the chunks round-robin: activity changes over time (the warm-up), so
// contiguous ranges of time steps would load the threads unevenly.
int64_t chunk_count(int64_t frames) {
  return std::max<int64_t>(1, std::min<int64_t>(frames, at::get_num_threads()));
}

// Nonzero entries of each frame of x [F, M]: flat index within the frame and value; frame f owns
// [offsets[f], offsets[f+1]).
template <typename S>
void find_nonzeros(const S* x, int64_t F, int64_t M, std::vector<int64_t>& offsets,
                   std::vector<int32_t>& index, std::vector<S>& value) {
  offsets.assign(size_t(F + 1), 0);
  at::parallel_for(0, F, 1, [&](int64_t f0, int64_t f1) {
    for (int64_t f = f0; f < f1; ++f) {
      const S* xr = x + f * M;
      int64_t n = 0;
      for (int64_t m = 0; m < M; ++m) n += xr[m] != S(0);
      offsets[size_t(f + 1)] = n;
    }
  });
  for (int64_t f = 0; f < F; ++f) offsets[size_t(f + 1)] += offsets[size_t(f)];
  index.resize(size_t(offsets[size_t(F)]));
  value.resize(index.size());
  at::parallel_for(0, F, 1, [&](int64_t f0, int64_t f1) {
    for (int64_t f = f0; f < f1; ++f) {
      const S* xr = x + f * M;
      int64_t o = offsets[size_t(f)];
      for (int64_t m = 0; m < M; ++m)
        if (xr[m] != S(0)) {
          index[size_t(o)] = int32_t(m);
          value[size_t(o++)] = xr[m];
        }
    }
  });
}

// out[f] (channels last) += v * wt[ci, ky, kx, :] for every nonzero (ci, y, x, v) of frame f.
template <typename S>
void scatter(const int64_t* offsets, const int32_t* index, const S* value, const S* wt, S* out,
             int64_t F, const Frame& g, const Taps& rows, const Taps& cols) {
  const int64_t nchunks = chunk_count(F), hw = g.h * g.w, co = g.co;
  at::parallel_for(0, nchunks, 1, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c)
      for (int64_t f = c; f < F; f += nchunks) {
        S* of = out + f * g.ho * g.wo * co;
        for (int64_t n = offsets[f]; n < offsets[f + 1]; ++n) {
          const int64_t m = index[n], ci = m / hw, y = (m % hw) / g.w, x = m % g.w;
          const S v = value[n];
          for (int32_t r = rows.begin[size_t(y)]; r < rows.begin[size_t(y + 1)]; ++r) {
            const auto [oy, ky] = rows.pairs[size_t(r)];
            for (int32_t q = cols.begin[size_t(x)]; q < cols.begin[size_t(x + 1)]; ++q) {
              const auto [ox, kx] = cols.pairs[size_t(q)];
              S* __restrict o = of + (int64_t(oy) * g.wo + ox) * co;
              const S* __restrict w = wt + ((ci * g.k + ky) * g.k + kx) * co;
              for (int64_t j = 0; j < co; ++j) o[j] += v * w[j];
            }
          }
        }
      }
  });
}

// dwt[ci, ky, kx, :] = sum over nonzeros (f, ci, y, x, v) and their taps of v * grad[f, oy, ox, :]
// (grad channels last). One accumulator per chunk, summed in chunk order.
template <typename S>
void gather_weight_grad(const int64_t* offsets, const int32_t* index, const S* value,
                        const S* grad, S* dwt, int64_t F, const Frame& g, const Taps& rows,
                        const Taps& cols) {
  const int64_t nchunks = chunk_count(F), hw = g.h * g.w, co = g.co;
  const int64_t wsize = g.ci * g.k * g.k * co;
  std::vector<S> acc(size_t(nchunks * wsize), S(0));
  at::parallel_for(0, nchunks, 1, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      S* dw = acc.data() + c * wsize;
      for (int64_t f = c; f < F; f += nchunks) {
        const S* gf = grad + f * g.ho * g.wo * co;
        for (int64_t n = offsets[f]; n < offsets[f + 1]; ++n) {
          const int64_t m = index[n], ci = m / hw, y = (m % hw) / g.w, x = m % g.w;
          const S v = value[n];
          for (int32_t r = rows.begin[size_t(y)]; r < rows.begin[size_t(y + 1)]; ++r) {
            const auto [oy, ky] = rows.pairs[size_t(r)];
            for (int32_t q = cols.begin[size_t(x)]; q < cols.begin[size_t(x + 1)]; ++q) {
              const auto [ox, kx] = cols.pairs[size_t(q)];
              const S* __restrict gr = gf + (int64_t(oy) * g.wo + ox) * co;
              S* __restrict w = dw + ((ci * g.k + ky) * g.k + kx) * co;
              for (int64_t j = 0; j < co; ++j) w[j] += v * gr[j];
            }
          }
        }
      }
    }
  });
  for (int64_t i = 0; i < wsize; ++i) {
    S sum = S(0);
    for (int64_t c = 0; c < nchunks; ++c) sum += acc[size_t(c * wsize + i)];
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
  ctx->saved_data["dims"] = std::vector<int64_t>{l.T,  l.B,  f.ci, f.h,     f.w,       f.co,
                                                 f.ho, f.wo, f.k,  l.stride, l.pad, l.out_pad,
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
    torch::Tensor c = torch::zeros({l.T, l.B, g.ho, g.wo, g.co}, s.options());
    AT_DISPATCH_FLOATING_TYPES(s.scalar_type(), "sparse_synapse_forward", [&] {
      std::vector<int64_t> off;
      std::vector<int32_t> idx;
      std::vector<scalar_t> val;
      find_nonzeros<scalar_t>(s.data_ptr<scalar_t>(), F, M, off, idx, val);
      std::copy(off.begin(), off.end(), offsets.data_ptr<int64_t>());
      index = torch::from_blob(idx.data(), {int64_t(idx.size())}, torch::kInt32).clone();
      value = torch::from_blob(val.data(), {int64_t(val.size())}, s.scalar_type()).clone();
      scatter<scalar_t>(off.data(), idx.data(), val.data(), wt.data_ptr<scalar_t>(),
                        c.data_ptr<scalar_t>(), F, g, taps.rows, taps.cols);
    });
    // The filter is per neuron, so it runs on the channels-last layout as well.
    torch::Tensor u = apply_temporal_kernel_cpu(c.view({l.T, -1}), eps, ts, false);
    u = u.view({l.T, l.B, g.ho, g.wo, g.co}).permute({0, 1, 4, 2, 3}).contiguous();
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
    // dL/d(W (*) s) = eps^T * dL/du.
    torch::Tensor gc = apply_temporal_kernel_cpu(gu.view({l.T, -1}), eps, ts, true)
                           .view({F, g.co, g.ho, g.wo});
    torch::Tensor gw, gs;
    if (ctx->needs_input_grad(1)) {
      const torch::Tensor gcl = gc.permute({0, 2, 3, 1}).contiguous();
      torch::Tensor dwt = torch::empty({g.ci, g.k, g.k, g.co}, value.options());
      const TapTables taps(l);
      AT_DISPATCH_FLOATING_TYPES(value.scalar_type(), "sparse_synapse_weight_grad", [&] {
        gather_weight_grad<scalar_t>(offsets.data_ptr<int64_t>(), index.data_ptr<int32_t>(),
                                     value.data_ptr<scalar_t>(), gcl.data_ptr<scalar_t>(),
                                     dwt.data_ptr<scalar_t>(), F, g, taps.rows, taps.cols);
      });
      gw = taps_to_weight(dwt, l.transposed);
    }
    if (ctx->needs_input_grad(0)) {
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

bool use_sparse_path(KernelPath path, const torch::Tensor& s) {
  if (path == KernelPath::Dense) return false;
  const bool supported = s.device().is_cpu() && s.dim() == 5 &&
                         (s.scalar_type() == torch::kFloat || s.scalar_type() == torch::kDouble);
  if (path == KernelPath::Sparse) return supported;
  return supported && nonzero_density(s) <= kSparseDensityThreshold;
}

}  // namespace spikems::train
