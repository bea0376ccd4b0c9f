#include "core/sim/event_generator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/util/parallel.h"

namespace spikems::sim {

EventGenerator::EventGenerator(int width, int height, const NoiseParams& p, uint64_t seed)
    : w_(width), h_(height), p_(p), rng_(seed) {
  px_ = draw_pixel_params(width, height, p, rng_);
}

void EventGenerator::reset(const float* L, const uint16_t* ids, int64_t t_us) {
  const size_t n = size_t(w_) * size_t(h_);
  last_L_.assign(L, L + n);
  last_id_.assign(ids, ids + n);
  ref_.assign(L, L + n);
  if (p_.random_initial_reference) {
    std::uniform_real_distribution<float> U(0.f, 1.f);
    for (size_t i = 0; i < n; ++i) {
      const float lo = p_.balanced_initial_reference ? -px_.c_off[i] : 0.f;
      ref_[i] = L[i] - (lo + U(rng_) * (px_.c_on[i] - lo));
    }
  }
  last_event_us_.assign(n, std::numeric_limits<int64_t>::min() / 2);
  t_us_ = t_us;
}

float EventGenerator::step(const float* L, const uint16_t* ids, int64_t t1, EventStream& out,
                           int threads) {
  const int64_t t0 = t_us_;
  const double dt_s = double(t1 - t0) * 1e-6;
  // Reference drift this step: leak_hz ON events per second at the nominal ON threshold.
  const float leak = float(p_.leak_hz * p_.c_on() * dt_s);
  const bool lowpass = p_.photoreceptor_cutoff_hz > 0;
  const double w = dt_s * 2 * 3.141592653589793 * p_.photoreceptor_cutoff_hz;  // dt / tau
  const float alpha = lowpass ? float(1 - std::exp(-w)) : 1.f;
  // Light-dependent bandwidth: dt / tau scales with (I + floor) / (1 + floor), I from the input.
  const bool by_light = lowpass && p_.photoreceptor_light_dependent;
  const float w_scaled = float(w / (1 + kIntensityFloor)), eps = float(p_.log_eps),
              floor_i = float(kIntensityFloor);
  const int64_t refr = p_.refractory_us;
  const int chunks = std::max(1, threads);
  std::vector<std::vector<Event>> part(static_cast<size_t>(chunks));
  std::vector<float> part_max(size_t(chunks), 0.f);

  parallel_chunks(h_, threads, [&](int k, int y_begin, int y_end) {
    auto& ev = part[size_t(k)];
    float mx = 0;
    for (int y = y_begin; y < y_end; ++y) {
      for (int x = 0; x < w_; ++x) {
        const size_t i = size_t(y) * size_t(w_) + size_t(x);
        float a_i = alpha;
        if (by_light)
          a_i = 1.f - std::exp(-w_scaled * (std::max(std::exp(L[i]) - eps, 0.f) + floor_i));
        const float L0 = last_L_[i], L1 = L0 + a_i * (L[i] - L0);
        mx = std::max(mx, std::fabs(L1 - L0));
        const float ref_end = ref_[i] - leak;
        const float a = L0 - ref_[i], b = L1 - ref_end;
        const float con = px_.c_on[i], coff = px_.c_off[i];
        int n = 0;
        float level = 0;
        uint8_t pol = 1;
        if (b >= con) {
          n = int(std::floor(b / con));
          level = con;
        } else if (b <= -coff) {
          n = int(std::floor(-b / coff));
          level = -coff;
          pol = 0;
        }
        if (n == 0) {
          ref_[i] = ref_end;
        } else {
          const uint16_t id0 = last_id_[i], id1 = ids[i];
          const float inv = 1.f / (b - a);
          for (int j = 1; j <= n; ++j) {
            float s = std::clamp((level * j - a) * inv, 0.f, 1.f);
            int64_t t = t0 + int64_t(std::llround(double(s) * double(t1 - t0)));
            if (t - last_event_us_[i] < refr) continue;
            last_event_us_[i] = t;
            uint16_t lbl = (id0 && id1) ? (s < 0.5f ? id0 : id1) : uint16_t(id0 | id1);
            ev.push_back(Event{t, uint16_t(x), uint16_t(y), pol, lbl});
          }
          ref_[i] = ref_end + level * float(n);
        }
        last_L_[i] = L1;
        last_id_[i] = ids[i];
      }
    }
    part_max[size_t(k)] = mx;
  });

  std::vector<Event> all;
  size_t total = 0;
  for (auto& v : part) total += v.size();
  all.reserve(total);
  for (auto& v : part) all.insert(all.end(), v.begin(), v.end());
  // Noise comes from this sequence's own generator, after the pixel pass: deterministic.
  EventStream noise;
  add_poisson_noise(w_, h_, p_, px_, t0, t1, rng_, noise, L);
  for (size_t k = 0; k < noise.size(); ++k) all.push_back(noise[k]);
  std::stable_sort(all.begin(), all.end(),
                   [](const Event& u, const Event& v) { return u.t < v.t; });
  for (const auto& e : all) out.push_back(e.t, e.x, e.y, e.p, e.label);
  t_us_ = t1;
  return *std::max_element(part_max.begin(), part_max.end());
}

}  // namespace spikems::sim
