#include "core/runtime/streaming_layer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/util/error.h"

namespace spikems {

StreamingLayer::StreamingLayer(const LayerSpec& l, int hin, int win)
    : cin_(l.in_channels),
      hin_(hin),
      win_(win),
      cout_(l.out_channels),
      hout_(l.output_size(hin)),
      wout_(l.output_size(win)),
      k_(l.kernel),
      theta_(l.neuron.theta) {
  if (hout_ <= 0 || wout_ <= 0) fail("runtime", "", "input too small for the layer");
  if (!l.delay.empty())
    fail("runtime", "", "axonal delays are not supported by the streaming runtime");
  const int k = k_, s = l.stride, p = l.padding;
  wlocal_.resize(size_t(cin_) * k * k * cout_);
  for (int ci = 0; ci < cin_; ++ci)
    for (int ky = 0; ky < k; ++ky)
      for (int kx = 0; kx < k; ++kx)
        for (int co = 0; co < cout_; ++co) {
          size_t src = l.kind == LayerKind::Conv ? ((size_t(co) * cin_ + ci) * k + ky) * k + kx
                                                 : ((size_t(ci) * cout_ + co) * k + ky) * k + kx;
          wlocal_[((size_t(ci) * k + ky) * k + kx) * cout_ + co] = l.weight[src];
        }
  // Which outputs an input row reaches through tap ky:
  //   conv:  s*o - p + ky = i  ->  o = (i + p - ky) / s when divisible
  //   convT: o = s*i - p + ky
  auto taps = [&](int n_in, int n_out, std::vector<int32_t>& begin,
                  std::vector<std::pair<int32_t, int32_t>>& list) {
    begin.assign(size_t(n_in) + 1, 0);
    for (int i = 0; i < n_in; ++i) {
      begin[i] = int32_t(list.size());
      for (int kk = 0; kk < k; ++kk) {
        int o;
        if (l.kind == LayerKind::Conv) {
          int num = i + p - kk;
          if (num < 0 || num % s != 0) continue;
          o = num / s;
        } else {
          o = s * i - p + kk;
        }
        if (o >= 0 && o < n_out) list.push_back({o, kk});
      }
    }
    begin[n_in] = int32_t(list.size());
  };
  taps(hin_, hout_, row_begin_, row_taps_);
  taps(win_, wout_, col_begin_, col_taps_);
  drive_.assign(size_t(hout_) * wout_ * cout_, 0.f);
  touched_step_.assign(size_t(hout_) * wout_, -1);
}

void StreamingLayer::drive(int64_t t, const uint32_t* spikes, size_t n) {
  touched_.clear();
  const int C = cout_, k = k_;
  for (size_t i = 0; i < n; ++i) {
    const uint32_t pos = spikes[i] / uint32_t(cin_);
    const int ci = int(spikes[i] % uint32_t(cin_));
    const int y = int(pos / uint32_t(win_)), x = int(pos % uint32_t(win_));
    for (int ry = row_begin_[y]; ry < row_begin_[y + 1]; ++ry) {
      const auto [oy, ky] = row_taps_[ry];
      for (int rx = col_begin_[x]; rx < col_begin_[x + 1]; ++rx) {
        const auto [ox, kx] = col_taps_[rx];
        const uint32_t op = uint32_t(oy) * uint32_t(wout_) + uint32_t(ox);
        float* d = &drive_[size_t(op) * C];
        if (touched_step_[op] != t) {
          touched_step_[op] = t;
          touched_.push_back(op);
          std::memset(d, 0, sizeof(float) * C);
        }
        const float* w = &wlocal_[((size_t(ci) * k + ky) * k + kx) * C];
        for (int c = 0; c < C; ++c) d[c] += w[c];
        synops_ += uint64_t(C);
      }
    }
  }
  integrate(t);
}

namespace {

int ring_size(size_t n) {
  int w = 1;
  while (size_t(w) < n) w <<= 1;
  return w;
}

class FirStreamingLayer final : public StreamingLayer {
 public:
  FirStreamingLayer(const LayerSpec& l, int hin, int win)
      : StreamingLayer(l, hin, win), eps_(l.srm_kernel), nu_(l.ref_kernel) {
    if (eps_.empty()) eps_.push_back(0.f);
    if (nu_.empty()) nu_.push_back(0.f);
    W_ = ring_size(std::max(eps_.size(), nu_.size()));
    mask_ = W_ - 1;
    const size_t npos = size_t(hout_) * wout_;
    ring_.assign(npos * W_ * cout_, 0.f);
    horizon_.assign(npos, std::numeric_limits<int64_t>::min() / 2);
    next_.assign(npos, -1);
    wheel_.resize(W_);
  }

  void fire(int64_t t, std::vector<uint32_t>& out) override {
    auto& bucket = wheel_[t & mask_];
    const int C = cout_;
    const int R = int(nu_.size());
    for (size_t i = 0; i < bucket.size(); ++i) {
      const uint32_t pos = bucket[i];
      if (next_[pos] != t) continue;  // rescheduled since
      const float* u = slot(pos, t);
      for (int c = 0; c < C; ++c) {
        if (!(u[c] >= theta_)) continue;
        out.push_back(pos * uint32_t(C) + uint32_t(c));
        ++spikes_;
        if (R > 1) {
          extend(pos, t, t + R - 1);
          for (int j = 1; j < R; ++j) slot(pos, t + j)[c] += nu_[j];
        }
      }
      next_[pos] = -1;
      schedule(pos, next_crossing(pos, t + 1));
    }
    bucket.clear();
  }

  float potential(int64_t t, uint32_t neuron) const override {
    const uint32_t pos = neuron / uint32_t(cout_);
    if (t > horizon_[pos]) return 0.f;
    return ring_[(size_t(pos) * W_ + (t & mask_)) * cout_ + neuron % uint32_t(cout_)];
  }

  size_t busy_positions() const override {
    size_t n = 0;
    for (const auto& b : wheel_) n += b.size();
    return n;
  }

 protected:
  void integrate(int64_t t) override {
    const int C = cout_, K = int(eps_.size());
    for (uint32_t pos : touched_) {
      const float* d = &drive_[size_t(pos) * C];
      int64_t cross = -1;
      if (K > 1) {
        extend(pos, t, t + K - 1);
        // Scatter and look for the first slot reaching theta in the same pass.
        for (int k = 1; k < K; ++k) {
          float* u = slot(pos, t + k);
          const float e = eps_[k];
          float m = -std::numeric_limits<float>::infinity();
          for (int c = 0; c < C; ++c) {
            u[c] += d[c] * e;
            m = std::max(m, u[c]);
          }
          if (m >= theta_) {
            cross = t + k;
            break;
          }
        }
        if (cross >= 0) {  // finish the scatter past the crossing
          for (int k = int(cross - t) + 1; k < K; ++k) {
            float* u = slot(pos, t + k);
            const float e = eps_[k];
            for (int c = 0; c < C; ++c) u[c] += d[c] * e;
          }
        } else {
          cross = next_crossing(pos, t + K);  // slots beyond the kernel (long refractory)
        }
      } else {
        cross = next_crossing(pos, t + 1);
      }
      schedule(pos, cross);
    }
  }

 private:
  float* slot(uint32_t pos, int64_t step) {
    return &ring_[(size_t(pos) * W_ + (step & mask_)) * cout_];
  }
  const float* slot(uint32_t pos, int64_t step) const {
    return &ring_[(size_t(pos) * W_ + (step & mask_)) * cout_];
  }
  // Makes the slots of steps (t, upto] valid: the ones past the horizon hold stale values.
  void extend(uint32_t pos, int64_t t, int64_t upto) {
    int64_t& h = horizon_[pos];
    if (upto <= h) return;
    for (int64_t s = std::max(h, t) + 1; s <= upto; ++s)
      std::memset(slot(pos, s), 0, sizeof(float) * cout_);
    h = upto;
  }
  int64_t next_crossing(uint32_t pos, int64_t from) const {
    const int C = cout_;
    for (int64_t s = from; s <= horizon_[pos]; ++s) {
      const float* u = slot(pos, s);
      float m = u[0];
      for (int c = 1; c < C; ++c) m = std::max(m, u[c]);
      if (m >= theta_) return s;
    }
    return -1;
  }
  void schedule(uint32_t pos, int64_t s) {
    if (s == next_[pos]) return;
    next_[pos] = s;
    if (s >= 0) wheel_[s & mask_].push_back(pos);
  }

  std::vector<float> eps_, nu_;
  int W_ = 1;
  int64_t mask_ = 0;
  std::vector<float> ring_;                   // [pos][slot][c]: future potential
  std::vector<int64_t> horizon_;              // last step whose slot is valid
  std::vector<int64_t> next_;                 // step at which the position reaches theta (-1: none)
  std::vector<std::vector<uint32_t>> wheel_;  // positions to visit, by step mod W
};

// Powers of a constant for integer exponents: a table for short gaps, pow() beyond.
class Powers {
 public:
  explicit Powers(double a) : a_(a) {
    tab_.resize(256);
    for (size_t i = 0; i < tab_.size(); ++i) tab_[i] = std::pow(a, double(i));
  }
  double operator()(int64_t n) const {
    return n < int64_t(tab_.size()) ? tab_[size_t(n)] : std::pow(a_, double(n));
  }

 private:
  double a_;
  std::vector<double> tab_;
};

class IirStreamingLayer final : public StreamingLayer {
 public:
  IirStreamingLayer(const LayerSpec& l, double ts, int hin, int win)
      : StreamingLayer(l, hin, win),
        a_(std::exp(-ts / double(l.neuron.tau_s))),
        ar_(std::exp(-ts / double(l.neuron.tau_r))),
        pa_(a_),
        par_(ar_),
        slayer_ref_(l.neuron.refractory == RefractoryShape::Slayer) {
    cs_ = std::exp(1.0) * ts / double(l.neuron.tau_s);
    const double mult = -double(l.neuron.scale_ref) * double(l.neuron.theta);
    cref_ = slayer_ref_ ? mult * std::exp(1.0) * ts / double(l.neuron.tau_r) : mult;
    inv_ar_ = 1.0 / ar_;
    n_peak_ = -1.0 / std::log(a_);
    const size_t npos = size_t(hout_) * wout_, n = npos * cout_;
    a1_.assign(n, 0.f);
    b0_.assign(n, 0.f);
    r1_.assign(n, 0.f);
    r0_.assign(n, 0.f);
    u_eval_.assign(n, 0.f);
    last_.assign(npos, 0);
    eval_step_.assign(npos, -1);
    active_flag_.assign(npos, 0);
  }

  void fire(int64_t t, std::vector<uint32_t>& out) override {
    const int C = cout_;
    size_t keep = 0;
    for (size_t i = 0; i < active_.size(); ++i) {
      const uint32_t pos = active_[i];
      advance(pos, t);
      const size_t b = size_t(pos) * C;
      float* ue = &u_eval_[b];
      bool spiked = false;
      for (int c = 0; c < C; ++c) {
        const float u = potential_now(b + c);
        ue[c] = u;
        if (u >= theta_) {
          out.push_back(pos * uint32_t(C) + uint32_t(c));
          ++spikes_;
          // The spike's refractory response starts at t+1.
          if (slayer_ref_)
            r0_[b + c] += 1.f;
          else
            r0_[b + c] += float(inv_ar_);
          spiked = true;
        }
      }
      (void)spiked;
      eval_step_[pos] = t;
      if (can_reach_theta(pos))
        active_[keep++] = pos;
      else
        active_flag_[pos] = 0;
    }
    active_.resize(keep);
  }

  float potential(int64_t t, uint32_t neuron) const override {
    const uint32_t pos = neuron / uint32_t(cout_);
    if (eval_step_[pos] == t) return u_eval_[neuron];
    const int64_t d = t - last_[pos];
    const double g = pa_(d);
    const double a1 = g * (double(a1_[neuron]) + double(d) * b0_[neuron]);
    double ref;
    if (slayer_ref_) {
      const double gr = par_(d);
      ref = cref_ * gr * (double(r1_[neuron]) + double(d) * r0_[neuron]);
    } else {
      ref = cref_ * par_(d) * r0_[neuron];
    }
    return float(cs_ * a1 + ref);
  }

  size_t busy_positions() const override { return active_.size(); }

 protected:
  void integrate(int64_t t) override {
    const int C = cout_;
    for (uint32_t pos : touched_) {
      advance(pos, t);
      const size_t b = size_t(pos) * C;
      const float* d = &drive_[size_t(pos) * C];
      for (int c = 0; c < C; ++c) b0_[b + c] += d[c];
      if (!active_flag_[pos] && can_reach_theta(pos)) {
        active_flag_[pos] = 1;
        active_.push_back(pos);
      }
    }
  }

 private:
  // State "as of step t": a1 = sum_{j<t} I_j (t-j) a^(t-j) (so u_psp[t] = cs*a1) and
  // b0 = sum_{j<=t} I_j a^(t-j) (this step's drive included). Without new drive, d steps on:
  // a1 <- a^d (a1 + d b0), b0 <- a^d b0. The refractory state is the same recursion fed with
  // the neuron's own spikes (SLAYER's alpha form), or for the SpikeMS form
  // r0 = sum_{j<t} s_j ar^(t-1-j) plus 1/ar for a spike at t, so that r0 <- ar^d r0.
  void advance(uint32_t pos, int64_t t) {
    const int64_t d = t - last_[pos];
    if (d <= 0) return;
    last_[pos] = t;
    const int C = cout_;
    const size_t b = size_t(pos) * C;
    const float g = float(pa_(d)), gr = float(par_(d)), fd = float(d);
    float* a1 = &a1_[b];
    float* b0 = &b0_[b];
    float* r1 = &r1_[b];
    float* r0 = &r0_[b];
    for (int c = 0; c < C; ++c) {
      a1[c] = g * (a1[c] + fd * b0[c]);
      b0[c] = g * b0[c];
    }
    if (slayer_ref_) {
      for (int c = 0; c < C; ++c) {
        r1[c] = gr * (r1[c] + fd * r0[c]);
        r0[c] = gr * r0[c];
      }
    } else {
      for (int c = 0; c < C; ++c) r0[c] = gr * r0[c];
    }
  }
  float potential_now(size_t n) const {
    const double ref = slayer_ref_ ? cref_ * r1_[n] : cref_ * r0_[n];
    return float(cs_ * a1_[n] + ref);
  }
  // Exact maximum over n >= 1 of the future psp cs * a^n (a1 + n b0) (no new drive): the
  // refractory part is never positive, so below theta means no spike until new drive.
  bool can_reach_theta(uint32_t pos) const {
    const int C = cout_;
    const size_t b = size_t(pos) * C;
    const double th = double(theta_) * (1.0 - 1e-5);  // a hair low: rounding errs on "active"
    for (int c = 0; c < C; ++c) {
      const double a1 = a1_[b + c], b0 = b0_[b + c];
      if (a1 + b0 <= 0 && b0 <= 0) continue;  // (a1 + n b0) <= 0 for every n >= 1
      auto f = [&](int64_t n) { return cs_ * pa_(n) * (a1 + double(n) * b0); };
      double m = f(1);
      if (b0 > 0) {
        const double ns = n_peak_ - a1 / b0;  // stationary point of (a1 + n b0) a^n
        if (ns > 1.0) {
          const int64_t n0 = ns < 1e9 ? int64_t(ns) : int64_t(1e9);
          m = std::max({m, f(n0), f(n0 + 1)});
        }
      }
      if (m >= th) return true;
    }
    return false;
  }

  double a_, ar_;
  Powers pa_, par_;
  bool slayer_ref_;
  double cs_ = 0, cref_ = 0, inv_ar_ = 1, n_peak_ = 0;
  std::vector<float> a1_, b0_, r1_, r0_, u_eval_;
  std::vector<int64_t> last_, eval_step_;
  std::vector<uint8_t> active_flag_;
  std::vector<uint32_t> active_;
};

}  // namespace

std::unique_ptr<StreamingLayer> StreamingLayer::create(const LayerSpec& l, double ts, int hin,
                                                       int win) {
  if (l.neuron.discretisation == Discretisation::FIR)
    return std::make_unique<FirStreamingLayer>(l, hin, win);
  return std::make_unique<IirStreamingLayer>(l, ts, hin, win);
}

}  // namespace spikems
