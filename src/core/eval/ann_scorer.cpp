#include "core/eval/ann_scorer.h"

#include <algorithm>
#include <exception>

#include "core/eval/kalman_filter.h"
#include "core/eval/window_scorer.h"
#include "core/events/binning.h"
#include "core/runtime/ann2d_network.h"
#include "core/runtime/ann_features.h"
#include "core/util/error.h"
#include "core/util/parallel.h"

namespace spikems {

SequenceScore score_ann_sequence(const ModelSpec& model, const LabelledSequence& seq,
                                 const std::vector<int64_t>& windows_us,
                                 const SequenceScoreOptions& opt) {
  const Ann2dForward net(model);
  const int64_t step = time_step_us(model);
  const std::string who = "model '" + model.name + "'";
  check_windows(windows_us, step, who);
  if (!opt.kalman_us.empty()) check_windows(opt.kalman_us, step, who + " (--kalman)");
  const EventStream& ev = seq.events;
  const auto [n, t0, end] = scored_span(seq, opt.max_us);
  SequenceScore r = empty_score(seq, windows_us, opt.kalman_us);
  if (ev.empty()) return r;
  const EventStream scored = ev.slice_index(0, n);
  BinningConfig bc;
  bc.step_us = step;
  const int H = ev.sensor.height, W = ev.sensor.width;
  const size_t plane = size_t(H) * size_t(W);
  // Each length on its own (the ANN's prediction for a window is one frame of that window's
  // events): the plain lengths, then the Kalman-filtered ones.
  const size_t runs = windows_us.size() + opt.kalman_us.size();
  uint64_t done = 0;
  for (size_t li = 0; li < runs; ++li) {
    const bool plain = li < windows_us.size();
    const int64_t L = plain ? windows_us[li] : opt.kalman_us[li - windows_us.size()];
    std::vector<FilteredLength> filtered;
    if (!plain) filtered.push_back({L, std::make_shared<KalmanWindowFilter>(W, H, opt.kalman)});
    WindowScorer scorer(ev.sensor, {L}, filtered);
    if (plain && L == opt.capture_window_us && !opt.capture_windows.empty())
      scorer.capture(opt.capture_window_us, opt.capture_windows);
    scorer.gate_by_events(opt.gate_events);
    scorer.use_boxes(opt.boxes);
    scorer.track_moving_share(opt.moving_share);
    scorer.min_moving_share(opt.min_moving_share);
    scorer.group_windows(opt.group_windows);
    EventTally tally(t0, L);
    scorer.add_events(scored);
    PredictionFrame f;
    f.width = W;
    f.height = H;
    // Windows are independent frames: their forward passes run `opt.threads` at a time, and
    // the results go to the scorer in window order (the same scores as one thread).
    const int64_t count = (end - t0) / L;
    const int64_t chunk = std::max(1, opt.threads) * 2;
    std::vector<std::vector<float>> feats(static_cast<size_t>(chunk)), logits(feats.size());
    for (int64_t k0 = 0; k0 < count; k0 += chunk) {
      const int64_t k1 = std::min(count, k0 + chunk);
      std::vector<std::exception_ptr> errors(feats.size());
      parallel_chunks(int(k1 - k0), opt.threads, [&](int, int j0, int j1) {
        for (int j = j0; j < j1; ++j) try {
            // The window's frame, then its past frames (newest first), each of length L; those
            // before the first event are empty, as a camera just switched on gives.
            std::vector<float>& f = feats[size_t(j)];
            f.clear();
            for (int h = 0; h <= model.ann_history; ++h) {
              const SpikeTensor s = bin_events(scored, t0 + (k0 + j - h) * L, L, bc);
              const std::vector<float> one = ann_features(s.data.data(), s.T, H, W);
              f.insert(f.end(), one.begin(), one.end());
            }
            logits[size_t(j)] = net.forward(feats[size_t(j)], H, W);
          } catch (...) {
            errors[size_t(j)] = std::current_exception();
          }
      });
      for (const auto& e : errors)
        if (e) std::rethrow_exception(e);
      for (int64_t k = k0; k < k1; ++k) {
        const std::vector<float>& feat = feats[size_t(k - k0)];
        const std::vector<float>& logit = logits[size_t(k - k0)];
        const int64_t a = t0 + k * L;
        // Channels 0 and 1 are log(1 + spike count): > 0 where the pixel had events.
        f.foreground.assign(plane, 0);
        for (size_t i = 0; i < plane; ++i)
          f.foreground[i] = (feat[i] > 0 || feat[plane + i] > 0) && logit[i] > 0;
        f.t0_us = a;
        f.t1_us = a + L;
        f.index = int(k);
        scorer.add_frame(f);
        const auto [b, e] = scored.time_range(a, a + L);
        if (plain)
          for (size_t i = b; i < e; ++i)
            tally.add(scored.t[i], scored.label[i] != 0,
                      logit[size_t(scored.y[i]) * size_t(W) + scored.x[i]] > 0);
        done += e - b;
        if (opt.progress && !opt.progress(done / runs)) {
          r.complete = false;
          r.scores.assign(r.scores.size(), WindowScores{});
          return r;
        }
      }
    }
    scorer.finish(end);
    r.scores[li] = scorer.scores().back();  // a filtered scorer holds plain, then filtered
    if (plain) {
      r.events_pr[li] = tally.per_length({L}, end).front();
      if (L == opt.capture_window_us) r.captured = scorer.captured();
    }
  }
  r.events = n;
  r.span_us = end - t0;
  return r;
}

}  // namespace spikems
