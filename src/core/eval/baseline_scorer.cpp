#include "core/eval/baseline_scorer.h"

#include <algorithm>

#include "core/eval/window_scorer.h"
#include "core/util/error.h"

namespace spikems {

SequenceScore score_all_events(const LabelledSequence& seq, const std::vector<int64_t>& windows_us,
                               const SequenceScoreOptions& opt) {
  const EventStream& ev = seq.events;
  check_windows(windows_us, 1, "baseline '" + std::string(kAllEventsBaseline) + "'");
  const auto [n, t0, end] = scored_span(seq, opt.max_us);
  SequenceScore r = empty_score(seq, windows_us, opt.kalman_us);
  if (ev.empty()) return r;

  WindowScorer scorer(ev.sensor, windows_us, kalman_lengths(ev.sensor, opt));
  if (!opt.capture_windows.empty()) scorer.capture(opt.capture_window_us, opt.capture_windows);
  scorer.gate_by_events(opt.gate_events);
  scorer.use_boxes(opt.boxes);
  scorer.track_moving_share(opt.moving_share);
  scorer.min_moving_share(opt.min_moving_share);
  scorer.group_windows(opt.group_windows);
  EventTally tally(t0, scorer.frame_us());  // every event predicted moving
  const int64_t F = scorer.frame_us();
  PredictionFrame f;
  f.width = ev.sensor.width;
  f.height = ev.sensor.height;
  f.foreground.assign(size_t(f.width) * size_t(f.height), 0);
  int64_t cur = 0;                    // the frame being filled: [t0 + cur F, t0 + (cur + 1) F)
  auto emit_until = [&](int64_t j) {  // frames before j are complete
    for (; cur < j; ++cur) {
      f.t0_us = t0 + cur * F;
      f.t1_us = f.t0_us + F;
      f.index = int(cur);
      scorer.add_frame(f);
      std::fill(f.foreground.begin(), f.foreground.end(), 0);
    }
  };
  constexpr size_t kChunk = 4096;
  for (size_t b = 0; b < n; b += kChunk) {
    const size_t e = std::min(n, b + kChunk);
    scorer.add_events(ev.slice_index(b, e));  // validates pixels and time order
    for (size_t i = b; i < e; ++i) {
      emit_until((ev.t[i] - t0) / F);
      if (ev.x[i] >= f.width || ev.y[i] >= f.height)
        fail(seq.name, "event " + std::to_string(i), "pixel outside the sensor");
      f.foreground[size_t(ev.y[i]) * size_t(f.width) + ev.x[i]] = 1;
      tally.add(ev.t[i], ev.label[i] != 0, true);
    }
    r.events += e - b;
    if (opt.progress && !opt.progress(r.events)) {
      r.complete = false;
      r.scores.assign(windows_us.size(), WindowScores{});
      return r;
    }
  }
  emit_until((end - t0 + F - 1) / F);
  scorer.finish(end);
  r.span_us = end - t0;
  r.scores = scorer.scores();
  r.captured = scorer.captured();
  r.events_pr = tally.per_length(windows_us, end);
  return r;
}

}  // namespace spikems
