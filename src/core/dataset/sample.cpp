#include "core/dataset/sample.h"

#include <algorithm>
#include <cmath>

#include "core/util/error.h"
#include "core/util/splitmix.h"

namespace spikems {

namespace {

// Uniform in [0, 1) from a 64-bit hash.
double unit(uint64_t h) {
  return double(h >> 11) * (1.0 / 9007199254740992.0);
}

double uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

int64_t uniform_int(std::mt19937_64& rng, int64_t lo, int64_t hi) {  // [lo, hi]
  return hi <= lo ? lo : std::uniform_int_distribution<int64_t>(lo, hi)(rng);
}

}  // namespace

uint64_t mix_seed(uint64_t seed, uint64_t stream, uint64_t index) {
  return splitmix64(splitmix64(splitmix64(seed) ^ stream) ^ index);
}

int sample_steps(const SampleOptions& o) {
  return int((o.warmup_us + o.step_us - 1) / o.step_us + (o.window_us + o.step_us - 1) / o.step_us);
}
int warmup_steps(const SampleOptions& o) {
  return int((o.warmup_us + o.step_us - 1) / o.step_us);
}

Sample extract_sample(const LabelledSequence& seq, const SampleSpec& s, const SampleOptions& o) {
  const EventStream& ev = seq.events;
  Sample out;
  out.T = sample_steps(o);
  out.warmup_steps = warmup_steps(o);
  out.H = s.crop_h;
  out.W = s.crop_w;
  out.centred = s.centred;
  if (out.T <= 0 || o.step_us <= 0) fail(seq.name, "", "sample: window and step must be positive");
  if (!(s.speed > 0) || !std::isfinite(s.speed))
    fail(seq.name, "", "sample: the playback speed must be positive");
  if (s.crop_w <= 0 || s.crop_h <= 0 || s.crop_x < 0 || s.crop_y < 0 ||
      s.crop_x + s.crop_w > ev.sensor.width || s.crop_y + s.crop_h > ev.sensor.height)
    fail(seq.name, "", "sample: the crop does not fit the sensor");
  const size_t plane = size_t(out.H) * size_t(out.W);
  out.input.assign(size_t(out.T) * 2 * plane, 0);
  out.fg.assign(size_t(out.T) * plane, 0);
  // At speed v a step spans v * step_us of the recording.
  const double src_step = double(o.step_us) * s.speed;
  const int64_t t_end = s.t0 + int64_t(std::ceil(double(out.T) * src_step));
  auto [b, e] = ev.time_range(s.t0, t_end);
  const bool labelled = ev.has_labels();
  for (size_t i = b; i < e; ++i) {
    int cx = int(ev.x[i]) - s.crop_x, cy = int(ev.y[i]) - s.crop_y;
    if (unsigned(cx) >= unsigned(out.W) || unsigned(cy) >= unsigned(out.H)) continue;
    int p = ev.p[i];
    if (s.keep[p] < 1.0 && unit(mix_seed(s.seed, 1, i)) >= s.keep[p]) continue;
    if (s.flip_x) cx = out.W - 1 - cx;
    if (s.flip_y) cy = out.H - 1 - cy;
    if (s.swap_polarity) p ^= 1;
    const int t = s.speed == 1 ? int((ev.t[i] - s.t0) / o.step_us)
                               : std::min(out.T - 1, int(double(ev.t[i] - s.t0) / src_step));
    out.input[out.at(t, p, cy, cx)] = 1;
    if (labelled && ev.label[i] != 0) out.fg[size_t(t) * plane + size_t(cy) * out.W + cx] = 1;
  }
  if (s.noise_hz > 0) {  // Poisson count of shot-noise events, uniform in space and time
    std::mt19937_64 rng(mix_seed(s.seed, 2, 0));
    const double mean = s.noise_hz * double(plane) * double(out.T * o.step_us) * 1e-6;
    const int64_t n = std::poisson_distribution<int64_t>(mean)(rng);
    for (int64_t k = 0; k < n; ++k) {
      const int t = int(uniform_int(rng, 0, out.T - 1));
      const int c = int(uniform_int(rng, 0, 1));
      const int y = int(uniform_int(rng, 0, out.H - 1)), x = int(uniform_int(rng, 0, out.W - 1));
      out.input[out.at(t, c, y, x)] = 1;
    }
  }
  return out;
}

namespace {

// Foreground and background event pixels of the window part of a crop.
void count_window_pixels(const EventStream& ev, int64_t w0, int64_t w1, int x0, int y0, int w,
                         int h, int& fg_px, int& bg_px) {
  std::vector<uint8_t> seen(size_t(w) * size_t(h), 0);  // bit 1 fg, bit 2 any
  auto [b, e] = ev.time_range(w0, w1);
  for (size_t i = b; i < e; ++i) {
    int cx = int(ev.x[i]) - x0, cy = int(ev.y[i]) - y0;
    if (unsigned(cx) >= unsigned(w) || unsigned(cy) >= unsigned(h)) continue;
    seen[size_t(cy) * w + cx] |= uint8_t(2 | (ev.label[i] != 0 ? 1 : 0));
  }
  fg_px = bg_px = 0;
  for (uint8_t v : seen) {
    if (v & 1)
      ++fg_px;
    else if (v)
      ++bg_px;
  }
}

}  // namespace

SampleSpec draw_sample(const std::vector<const LabelledSequence*>& seqs,
                       const std::vector<double>& weights, const SampleOptions& o,
                       std::mt19937_64& rng) {
  if (seqs.empty()) fail("dataset", "", "no sequences to draw samples from");
  SampleSpec s;
  s.sequence = std::discrete_distribution<size_t>(weights.begin(), weights.end())(rng);
  const LabelledSequence& seq = *seqs[s.sequence];
  const EventStream& ev = seq.events;
  const SensorSize sensor = ev.sensor;
  s.crop_w = o.crop > 0 ? o.crop : sensor.width;
  s.crop_h = o.crop > 0 ? o.crop : sensor.height;
  if (s.crop_w > sensor.width || s.crop_h > sensor.height)
    fail(seq.name, "",
         "the crop (" + std::to_string(o.crop) + " px) is larger than the sensor (" +
             std::to_string(sensor.width) + "x" + std::to_string(sensor.height) +
             "): lower `crop` in the config");
  // The playback speed first (drawn only when on, so that runs without it draw as before):
  // the sample then covers speed times the steps' span of the recording.
  if (!(o.speed_max >= 1)) fail(seq.name, "", "sample: speed_max must be at least 1");
  s.speed =
      o.speed_max > 1 ? std::exp(uniform(rng, -std::log(o.speed_max), std::log(o.speed_max))) : 1.0;
  const int64_t span = int64_t(std::ceil(double(sample_steps(o)) * double(o.step_us) * s.speed));
  const int64_t warm = int64_t(double(warmup_steps(o)) * double(o.step_us) * s.speed);
  const int64_t t_lo = ev.t_first(), t_hi = std::max(t_lo, ev.t_last() - span);
  const bool want_centred = uniform(rng, 0, 1) < o.centred_fraction && ev.has_labels();
  bool placed = false;
  for (int attempt = 0; want_centred && attempt < o.max_tries && !placed; ++attempt) {
    const int64_t t0 = uniform_int(rng, t_lo, t_hi);
    auto [b, e] = ev.time_range(t0 + warm, t0 + span);
    // A random foreground event of the window: sample indices until one is foreground.
    size_t pick = e;
    for (int k = 0; k < 64 && b < e; ++k) {
      size_t i = size_t(uniform_int(rng, int64_t(b), int64_t(e) - 1));
      if (ev.label[i] != 0) {
        pick = i;
        break;
      }
    }
    if (pick == e) continue;
    const double cx = ev.x[pick] + uniform(rng, -o.jitter, o.jitter);
    const double cy = ev.y[pick] + uniform(rng, -o.jitter, o.jitter);
    const int x0 = std::clamp(int(std::lround(cx)) - s.crop_w / 2, 0, sensor.width - s.crop_w);
    const int y0 = std::clamp(int(std::lround(cy)) - s.crop_h / 2, 0, sensor.height - s.crop_h);
    int fg_px = 0, bg_px = 0;
    count_window_pixels(ev, t0 + warm, t0 + span, x0, y0, s.crop_w, s.crop_h, fg_px, bg_px);
    if (fg_px < std::max(1, o.min_fg_pixels)) continue;
    if (o.max_bg_fg_ratio > 0 && double(bg_px) > o.max_bg_fg_ratio * double(fg_px)) continue;
    s.t0 = t0;
    s.crop_x = x0;
    s.crop_y = y0;
    s.centred = placed = true;
  }
  if (!placed) {
    s.t0 = uniform_int(rng, t_lo, t_hi);
    s.crop_x = int(uniform_int(rng, 0, sensor.width - s.crop_w));
    s.crop_y = int(uniform_int(rng, 0, sensor.height - s.crop_h));
  }
  s.flip_x = uniform(rng, 0, 1) < o.flip_x;
  s.flip_y = uniform(rng, 0, 1) < o.flip_y;
  s.swap_polarity = uniform(rng, 0, 1) < o.polarity_swap;
  const double drop = o.drop_max > 0 ? uniform(rng, 0, o.drop_max) : 0.0;
  for (double& k : s.keep) {
    const double scale = o.threshold_jitter > 0 ? uniform(rng, 1, 1 + o.threshold_jitter) : 1.0;
    k = (1 - drop) / scale;
  }
  s.noise_hz = o.noise_hz_max > 0 ? uniform(rng, 0, o.noise_hz_max) : 0.0;
  s.seed = rng();
  return s;
}

}  // namespace spikems
