// The ESIM / v2e event model. Each pixel keeps a reference log intensity; between two rendered
// samples its log intensity L is taken as linear in time, and every crossing of reference + C_on
// (or - C_off) gives an event at the linearly interpolated time, after which the reference
// moves by that threshold. Leak moves the reference down at leak_hz * C per second (ON events
// at about leak_hz in a static scene); crossings within the refractory period after an
// emitted event are dropped (the reference still moves, as the pixel resets).
//
// With photoreceptor_cutoff_hz > 0, L first passes a first-order low-pass filter (exact
// exponential update per step, time constant 1 / (2 pi f_c)), which spreads the events of a
// sharp edge over a few ms as the finite bandwidth of a real pixel does (v2e). With
// photoreceptor_light_dependent the cutoff of each pixel scales with its input intensity,
// f_c (I + I_floor) / (1 + I_floor), I = exp(L) - log_eps, I_floor = 20/255 (v2e): dark pixels
// respond later. ON and OFF thresholds differ with threshold_asymmetry (sensor_noise.h).
//
// Labels: the event takes the object id the pixel shows in the sample nearer to the crossing
// time; when one of the two samples shows background (0) and the other an object, the object's
// id (the change at a pixel that an object enters or leaves is caused by that object). Noise
// events (shot, hot pixels) are labelled 0.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "core/events/event_stream.h"
#include "core/sim/sensor_noise.h"

namespace spikems::sim {

class EventGenerator {
 public:
  EventGenerator(int width, int height, const NoiseParams& p, uint64_t seed);

  // First sample: sets the references (random reset state when the params ask for it).
  void reset(const float* log_intensity, const uint16_t* ids, int64_t t_us);
  // Next sample at t_us > previous: appends the events of the interval, sorted by time
  // (ties keep row-major pixel order, then noise), to out (which must carry labels).
  // Returns max |dL| over the pixels, for the adaptive time step.
  float step(const float* log_intensity, const uint16_t* ids, int64_t t_us, EventStream& out,
             int threads = 1);

  int64_t time_us() const { return t_us_; }
  const PixelParams& pixel_params() const { return px_; }

 private:
  int w_, h_;
  NoiseParams p_;
  std::mt19937_64 rng_;
  PixelParams px_;
  std::vector<float> ref_, last_L_;
  std::vector<uint16_t> last_id_;
  std::vector<int64_t> last_event_us_;
  int64_t t_us_ = 0;
};

}  // namespace spikems::sim
