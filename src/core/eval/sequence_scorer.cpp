#include "core/eval/sequence_scorer.h"

#include <algorithm>
#include <cmath>

#include "core/eval/kalman_filter.h"
#include "core/eval/window_scorer.h"
#include "core/events/event_ops.h"
#include "core/model/model_scale.h"
#include "core/runtime/segmenter.h"
#include "core/util/error.h"

namespace spikems {

int64_t time_step_us(const ModelSpec& model) {
  return std::max<int64_t>(1, std::llround(model.time_step_ms * 1000.0));
}

namespace {
std::string ms_text(int64_t us) {
  char b[32];
  std::snprintf(b, sizeof b, "%g ms", double(us) / 1000.0);
  return b;
}
}  // namespace

void check_windows(const std::vector<int64_t>& windows_us, int64_t step_us,
                   const std::string& source) {
  if (windows_us.empty()) fail(source, "", "no window length given");
  for (int64_t w : windows_us) {
    if (w <= 0) fail(source, "", "window " + ms_text(w) + ": a window length must be positive");
    if (w % step_us != 0)
      fail(source, "",
           "window " + ms_text(w) + " is not a multiple of the model's time step (" +
               ms_text(step_us) + "): use whole steps, e.g. " +
               ms_text(std::max<int64_t>(1, (w + step_us / 2) / step_us) * step_us));
  }
}

ScoredSpan scored_span(const LabelledSequence& seq, int64_t max_us) {
  const EventStream& ev = seq.events;
  if (!ev.empty() && !ev.has_labels())
    fail(seq.name, "", "no labels: scoring needs per-event labels (1 = moving object)");
  ScoredSpan s;
  if (ev.empty()) return s;
  s.t0 = ev.t_first();
  s.n = ev.size();
  s.end = ev.t_last() + 1;
  if (max_us > 0 && ev.t_last() >= s.t0 + max_us) {
    s.n = ev.time_range(s.t0, s.t0 + max_us).second;
    s.end = s.t0 + max_us;
  }
  return s;
}

SequenceScore empty_score(const LabelledSequence& seq, const std::vector<int64_t>& windows_us,
                          const std::vector<int64_t>& kalman_us) {
  SequenceScore r;
  r.name = seq.name;
  r.windows_us = windows_us;
  r.kalman_us = kalman_us;
  r.scores.resize(windows_us.size() + kalman_us.size());
  r.events_pr.resize(windows_us.size());
  return r;
}

std::vector<int64_t> example_windows(const LabelledSequence& seq, int64_t window_us, int count,
                                     int64_t max_us) {
  if (window_us <= 0 || count <= 0) return {};
  const auto [n, t0, end] = scored_span(seq, max_us);
  const int64_t complete = (end - t0) / window_us;
  std::vector<int64_t> moving;  // windows with a moving-object event, ascending
  const EventStream& ev = seq.events;
  for (size_t i = 0; i < n; ++i) {
    if (ev.label[i] == 0) continue;
    const int64_t k = (ev.t[i] - t0) / window_us;
    if (k >= complete) break;
    if (moving.empty() || moving.back() != k) moving.push_back(k);
  }
  if (moving.size() <= size_t(count)) return moving;
  // The middle of each of `count` equal shares of the list.
  std::vector<int64_t> pick;
  for (int i = 0; i < count; ++i)
    pick.push_back(moving[(2 * size_t(i) + 1) * moving.size() / (2 * size_t(count))]);
  return pick;
}

std::vector<FilteredLength> kalman_lengths(SensorSize sensor, const SequenceScoreOptions& opt) {
  std::vector<FilteredLength> out;
  for (int64_t w : opt.kalman_us)
    out.push_back(
        {w, std::make_shared<KalmanWindowFilter>(sensor.width, sensor.height, opt.kalman)});
  return out;
}

SequenceScore score_sequence(const ModelSpec& model, const LabelledSequence& seq,
                             const std::vector<int64_t>& windows_us,
                             const SequenceScoreOptions& opt) {
  const EventStream& ev = seq.events;
  check_windows(windows_us, time_step_us(model), "model '" + model.name + "'");
  if (!opt.kalman_us.empty())
    check_windows(opt.kalman_us, time_step_us(model), "model '" + model.name + "' (--kalman)");
  const auto [n, t0, end] = scored_span(seq, opt.max_us);
  SequenceScore r = empty_score(seq, windows_us, opt.kalman_us);
  if (ev.empty()) return r;

  // A downsampled network is scored on its own grid: G from the events at its pixels (as
  // `spikems eval` of the data converted with `convert --downsample N`); the event precision
  // and recall stay per original event.
  const int ds =
      resolve_downsample(model, ev.sensor.width, ev.sensor.height, opt.downsample, seq.name);
  BinningConfig geo;
  geo.downsample = ds;
  r.downsample = ds;
  const auto [gh, gw] = binned_size(ev.sensor, geo);
  const SensorSize grid{gw, gh};
  if (ds > 1 && opt.boxes)
    fail(seq.name, "",
         "box ground truth is scored on the sensor's grid, but the model runs it downsampled " +
             std::to_string(ds) +
             "x (its training grid is smaller): give --downsample 1, or convert the recording "
             "with `spikems convert --downsample N` and scale the boxes");
  WindowScorer scorer(grid, windows_us, kalman_lengths(grid, opt));
  if (!opt.capture_windows.empty()) scorer.capture(opt.capture_window_us, opt.capture_windows);
  scorer.gate_by_events(opt.gate_events);
  scorer.use_boxes(opt.boxes);
  scorer.track_moving_share(opt.moving_share);
  scorer.min_moving_share(opt.min_moving_share);
  scorer.group_windows(opt.group_windows);
  EventTally tally(t0, scorer.frame_us());
  SegmenterOptions so;
  so.mask_window_us = scorer.frame_us();
  so.threads = opt.threads;
  so.block_steps = std::max(1, opt.block_steps);
  so.label_tolerance_steps = std::max(0, opt.label_tolerance_steps);
  so.downsample = ds;
  Segmenter seg(model, ev.sensor, so, seq.name);
  size_t labelled = 0;  // the runtime labels every event, in input order
  auto drain = [&] {
    for (const auto& f : seg.frames()) scorer.add_frame(f);
    seg.frames().clear();
    const EventStream& l = seg.labelled();
    if (labelled + l.size() > n)
      fail(seq.name, "", "internal error: the runtime labelled more events than it was given");
    for (size_t i = 0; i < l.size(); ++i, ++labelled)
      tally.add(ev.t[labelled], ev.label[labelled] != 0, l.label[i] != 0);
    seg.labelled().clear();
  };
  // Chunks bound the frames waiting in the segmenter (one sensor-sized frame per frame_us).
  constexpr size_t kChunk = 4096;
  for (size_t b = 0; b < n; b += kChunk) {
    const EventStream chunk = ev.slice_index(b, std::min(n, b + kChunk));
    // Before the frames the chunk gives (window_scorer.h).
    scorer.add_events(ds > 1 ? remap_events(chunk, geo) : chunk);
    seg.push(chunk);
    drain();
    r.events += chunk.size();
    if (opt.progress && !opt.progress(r.events)) {
      r.complete = false;
      r.scores.assign(windows_us.size(), WindowScores{});
      return r;
    }
  }
  seg.finish();
  drain();
  if (labelled != n)
    fail(seq.name, "",
         "internal error: the runtime labelled " + std::to_string(labelled) + " of " +
             std::to_string(n) + " events");
  scorer.finish(end);
  r.span_us = end - t0;
  r.scores = scorer.scores();
  r.captured = scorer.captured();
  r.events_pr = tally.per_length(windows_us, end);
  return r;
}

}  // namespace spikems
