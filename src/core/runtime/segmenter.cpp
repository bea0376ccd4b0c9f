#include "core/runtime/segmenter.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <utility>

#include "core/util/error.h"

namespace spikems {

namespace {
// Another step is another model (core/model/time_step.h: its time constants move with it).
int64_t model_step_us(const ModelSpec& m) {
  return std::max<int64_t>(1, std::llround(m.time_step_ms * 1000.0));
}

// s: the grid the network sees (the sensor, or the sensor downsampled by 2^shift).
const ModelSpec& checked(const ModelSpec& m, SensorSize s, int shift, const std::string& src) {
  if (!s.known()) fail(src, "", "the sensor size is unknown; give it with --width and --height");
  if (m.input_width > 0 && m.input_height > 0 &&
      (m.input_width != s.width || m.input_height != s.height))
    fail(src, "",
         "the model '" + m.name + "' was made for a " + std::to_string(m.input_width) + "x" +
             std::to_string(m.input_height) + " sensor but the events come from a " +
             std::to_string(s.width) + "x" + std::to_string(s.height) +
             (shift > 0 ? " grid (the sensor downsampled " + std::to_string(1 << shift) + "x)"
                        : std::string(" sensor")) +
             "; use a model for this sensor (or crop/resize the events first)");
  return m;
}
int downsample_shift(int f, const std::string& src) {
  if (f != 1 && f != 2 && f != 4 && f != 8)
    fail(src, "", "the downsampling factor must be 1, 2, 4 or 8, not " + std::to_string(f));
  return std::countr_zero(unsigned(f));
}

SensorSize downsampled(SensorSize s, int shift) {
  const int f = 1 << shift;
  return {(s.width + f - 1) / f, (s.height + f - 1) / f};
}
}  // namespace

Segmenter::Segmenter(const ModelSpec& m, SensorSize sensor, SegmenterOptions opt,
                     std::string source)
    : source_(std::move(source)),
      sensor_(sensor),
      ds_shift_(downsample_shift(opt.downsample, source_)),
      net_sensor_(downsampled(sensor, ds_shift_)),
      step_us_(model_step_us(m)),
      opt_(opt),
      net_(checked(m, net_sensor_, ds_shift_, source_), net_sensor_.height, net_sensor_.width,
           opt.whole_network),
      labeller_(net_sensor_, net_.out_height(), net_.out_width(), net_.out_channels(),
                net_.latency_steps() + std::max(0, opt.label_tolerance_steps), ds_shift_) {
  net_.set_threads(opt.threads);
  input_bits_.assign((size_t(net_sensor_.width) * net_sensor_.height * 2 + 63) / 64, 0);
  input_words_.assign((input_bits_.size() + 63) / 64, 0);
  labelled_.sensor = sensor;
  labelled_.add_zero_labels();
}

void Segmenter::end_step() {
  // The input in neuron order (a bitmap, not the events' order): the first layer's scatter
  // then walks its state forward instead of jumping around the sensor.
  // Only the words marked in input_words_ are read (a few hundred of thousands, at 1 M ev/s).
  std::vector<std::vector<uint32_t>>& set = inputs_[set_];
  if (set.size() <= queued_) set.resize(queued_ + 1);
  std::vector<uint32_t>& input = set[queued_];
  input.clear();
  if (input_count_ > 0)
    for (size_t s = 0; s < input_words_.size(); ++s) {
      for (uint64_t sm = input_words_[s]; sm != 0; sm &= sm - 1) {
        const size_t w = s * 64 + size_t(std::countr_zero(sm));
        for (uint64_t m = input_bits_[w]; m != 0; m &= m - 1)
          input.push_back(uint32_t(w * 64 + size_t(std::countr_zero(m))));
        input_bits_[w] = 0;
      }
      input_words_[s] = 0;
    }
  input_count_ = 0;
  if (masks_) mask_counts_.push_back(std::exchange(step_events_, 0));
  ++queued_;
  ++cur_step_;
  if (queued_ >= size_t(std::max(1, opt_.block_steps))) run_block();
}

void Segmenter::run_block() {
  const auto t0 = std::chrono::steady_clock::now();
  size_t ready;
  if (net_.block_running() || net_.pipelined(queued_)) {
    // With threads: the block started last time finishes (this thread takes its share of
    // the layers), this one starts, and the binning of the next block and the labels of the
    // finished one run beside it.
    ready = net_.finish_block();
    if (queued_ > 0 || net_.in_flight()) {
      net_.start_block(inputs_[set_].data(), queued_);
      set_ ^= 1;
    }
  } else {
    ready = net_.step_block(inputs_[set_].data(), queued_);
  }
  queued_ = 0;
  net_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  deliver(ready);
}

void Segmenter::deliver(size_t ready) {
  for (size_t j = 0; j < ready; ++j) {
    const int64_t s = out_step_++;
    const std::vector<uint32_t>& out = net_.block_output(j);
    if (masks_) {
      // The step's events, then its spikes, then the frames that end with it (as they came).
      for (uint32_t n = mask_counts_.front(); n > 0; --n) {
        const uint32_t px = mask_events_.front();
        mask_events_.pop_front();
        masks_->add_event(int(px % uint32_t(net_sensor_.width)),
                          int(px / uint32_t(net_sensor_.width)));
      }
      mask_counts_.pop_front();
      masks_->add_spikes(origin_ + s * step_us_, out);
    }
    labeller_.on_step(s, out, labelled_);
    if (masks_) masks_->close_until(origin_ + (s + 1) * step_us_, frames_);
  }
}

void Segmenter::push(const EventStream& c) {
  if (finished_) fail(source_, "", "events pushed after the end of the stream");
  // The bitmap words of events a few ahead are requested early: events land anywhere on
  // the sensor, and the network's state has evicted the bitmap from the cache by now.
  constexpr size_t kAhead = 16;
  // The network's pixel grid (the sensor's, or downsampled: pixel (x >> s, y >> s)).
  const uint32_t width = uint32_t(net_sensor_.width), height = uint32_t(net_sensor_.height);
  const int sh = ds_shift_;
  auto word_of = [&](size_t i) {
    const uint32_t x = std::min<uint32_t>(uint32_t(c.x[i]) >> sh, width - 1),
                   y = std::min<uint32_t>(uint32_t(c.y[i]) >> sh, height - 1);
    return (y * width + x) >> 5;  // 2 bits (polarities) per pixel, 64 per word
  };
  for (size_t i = 0; i < std::min(c.size(), kAhead); ++i)
    __builtin_prefetch(&input_bits_[word_of(i)], 1);
  labeller_.reserve(c.size());
  for (size_t i = 0; i < c.size(); ++i) {
    if (i + kAhead < c.size()) __builtin_prefetch(&input_bits_[word_of(i + kAhead)], 1);
    const uint64_t idx = events_in_ + i;
    const int64_t t = c.t[i];
    if (c.x[i] >= sensor_.width || c.y[i] >= sensor_.height)
      fail_at_event(source_, idx,
                    "pixel (" + std::to_string(c.x[i]) + ", " + std::to_string(c.y[i]) +
                        ") is outside the " + std::to_string(sensor_.width) + "x" +
                        std::to_string(sensor_.height) + " sensor");
    if (c.p[i] > 1) fail_at_event(source_, idx, "polarity must be 0 or 1");
    if (!started_) {
      started_ = true;
      origin_ = last_t_ = t;
      if (opt_.mask_window_us > 0)
        masks_.emplace(net_sensor_, net_.out_height(), net_.out_width(), net_.out_channels(),
                       origin_, opt_.mask_window_us, 1 << ds_shift_);
    }
    if (t < last_t_)
      fail_at_event(source_, idx,
                    "time goes back from " + std::to_string(last_t_) + " us to " +
                        std::to_string(t) + " us; sort the stream first (e.g. --sort)");
    last_t_ = t;
    // The event's step without a division per event: steps end at origin + k * step_us.
    while (t >= origin_ + (cur_step_ + 1) * step_us_) end_step();
    const int64_t step = cur_step_;
    const uint32_t nx = uint32_t(c.x[i]) >> sh, ny = uint32_t(c.y[i]) >> sh;
    const uint32_t n = (ny * width + nx) * 2u + c.p[i];
    uint64_t& word = input_bits_[n >> 6];
    const uint64_t bit = uint64_t(1) << (n & 63);
    input_count_ += (word & bit) == 0;
    word |= bit;
    input_words_[n >> 12] |= uint64_t(1) << ((n >> 6) & 63);
    labeller_.push_reserved(t, c.x[i], c.y[i], c.p[i], step);
    if (masks_) {
      mask_events_.push_back(ny * width + nx);
      ++step_events_;
    }
  }
  events_in_ += c.size();
}

void Segmenter::finish() {
  if (finished_) return;
  finished_ = true;
  if (!started_) return;
  // The current step, then enough empty steps to decide every queued event.
  const int64_t end = cur_step_ + labeller_.window_steps();
  while (cur_step_ <= end) end_step();
  run_block();
  while (net_.block_running()) run_block();  // the pipeline's last blocks (threads)
  if (masks_) masks_->flush(frames_);
}

int default_block_steps(double step_ms, int threads) {
  const double span_ms = threads > 1 ? 20.0 : 40.0;
  if (!(step_ms > 0)) return 16;
  return int(std::clamp(std::lround(span_ms / step_ms), 1L, 16L));
}

}  // namespace spikems
