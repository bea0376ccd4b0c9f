#include "core/eval/ann_scorer.h"

#include "core/eval/window_scorer.h"
#include "core/events/binning.h"
#include "core/runtime/ann2d_network.h"
#include "core/runtime/ann_features.h"
#include "core/util/error.h"

namespace spikems {

SequenceScore score_ann_sequence(const ModelSpec& model, const LabelledSequence& seq,
                                 const std::vector<int64_t>& windows_us,
                                 const SequenceScoreOptions& opt) {
  const Ann2dForward net(model);
  const int64_t step = time_step_us(model);
  check_windows(windows_us, step, "model '" + model.name + "'");
  const EventStream& ev = seq.events;
  const auto [n, t0, end] = scored_span(seq, opt.max_us);
  SequenceScore r = empty_score(seq, windows_us);
  if (ev.empty()) return r;
  const EventStream scored = ev.slice_index(0, n);
  BinningConfig bc;
  bc.step_us = step;
  const int H = ev.sensor.height, W = ev.sensor.width;
  const size_t plane = size_t(H) * size_t(W);
  uint64_t done = 0;
  for (size_t li = 0; li < windows_us.size(); ++li) {
    const int64_t L = windows_us[li];
    WindowScorer scorer(ev.sensor, {L});
    scorer.add_events(scored);
    PredictionFrame f;
    f.width = W;
    f.height = H;
    for (int64_t k = 0; t0 + (k + 1) * L <= end; ++k) {
      const int64_t a = t0 + k * L;
      const SpikeTensor s = bin_events(scored, a, L, bc);
      const std::vector<float> logit = net.forward(ann_features(s.data.data(), s.T, H, W), H, W);
      f.foreground.assign(plane, 0);
      for (int t = 0; t < s.T; ++t)
        for (size_t i = 0; i < 2 * plane; ++i)
          if (s.data[size_t(t) * 2 * plane + i] && logit[i % plane] > 0)
            f.foreground[i % plane] = 1;
      f.t0_us = a;
      f.t1_us = a + L;
      f.index = int(k);
      scorer.add_frame(f);
      const auto [b, e] = scored.time_range(a, a + L);
      done += e - b;
      if (opt.progress && !opt.progress(done / windows_us.size())) {
        r.complete = false;
        r.scores.assign(windows_us.size(), WindowScores{});
        return r;
      }
    }
    scorer.finish(end);
    r.scores[li] = scorer.scores().front();
  }
  r.events = n;
  r.span_us = end - t0;
  return r;
}

}  // namespace spikems
