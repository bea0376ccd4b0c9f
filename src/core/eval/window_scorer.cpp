#include "core/eval/window_scorer.h"

#include <algorithm>
#include <numeric>
#include <string>

#include "core/util/error.h"

namespace spikems {

int64_t frame_length_us(const std::vector<int64_t>& windows_us) {
  int64_t g = 0;
  for (int64_t w : windows_us) {
    if (w <= 0) fail("window lengths", "", "a window length must be positive");
    g = std::gcd(g, w);
  }
  return g;
}

WindowScorer::WindowScorer(SensorSize sensor, std::vector<int64_t> windows_us,
                           std::vector<FilteredLength> filtered)
    : sensor_(sensor), windows_(std::move(windows_us)) {
  if (!sensor_.known()) fail("window scorer", "", "the sensor size is unknown");
  if (windows_.empty() && filtered.empty()) fail("window scorer", "", "no window length given");
  std::vector<int64_t> all = windows_;
  for (const auto& f : filtered) {
    if (!f.filter) fail("window scorer", "", "a filtered length without a filter");
    all.push_back(f.window_us);
  }
  frame_us_ = frame_length_us(all);
  for (size_t i = 0; i < all.size(); ++i) {
    PerLength l;
    l.window_us = all[i];
    l.frames_per_window = all[i] / frame_us_;
    if (i >= windows_.size()) l.filter = filtered[i - windows_.size()].filter;
    lengths_.push_back(std::move(l));
  }
  any_filter_ = !filtered.empty();
  scores_.resize(all.size());
}

void WindowScorer::use_boxes(std::shared_ptr<const BoxTruth> boxes) {
  if (have_origin_) fail("window scorer", "", "use_boxes must come before the first events");
  if (boxes) boxes->check_sensor(sensor_);
  if (boxes && min_share_ > 0)
    fail("window scorer", "", "a moving-share filter needs labelled events, not boxes");
  boxes_ = std::move(boxes);
}

void WindowScorer::track_moving_share(bool on) {
  if (have_origin_)
    fail("window scorer", "", "track_moving_share must come before the first events");
  shares_ = on;
}

void WindowScorer::min_moving_share(double fraction) {
  if (have_origin_) fail("window scorer", "", "min_moving_share must come before the first events");
  if (!(fraction >= 0 && fraction < 1))
    fail("window scorer", "", "the minimum moving share must lie in [0, 1)");
  if (fraction > 0 && boxes_)
    fail("window scorer", "", "a moving-share filter needs labelled events, not boxes");
  min_share_ = fraction;
}

void WindowScorer::group_windows(int n) {
  if (have_origin_) fail("window scorer", "", "group_windows must come before the first events");
  if (n < 1) fail("window scorer", "", "a group must hold at least one window");
  group_ = n;
}

void WindowScorer::gate_by_events(bool on) {
  if (have_origin_) fail("window scorer", "", "gate_by_events must come before the first events");
  gate_ = on;
}

std::vector<uint8_t>& WindowScorer::mask_of(std::map<int64_t, std::vector<uint8_t>>& m, int64_t k) {
  auto it = m.find(k);
  if (it != m.end()) return it->second;
  std::vector<uint8_t> mask;
  if (!pool_.empty()) {
    mask = std::move(pool_.back());
    pool_.pop_back();
  } else {
    mask.assign(size_t(sensor_.width) * size_t(sensor_.height), 0);
  }
  return m.emplace(k, std::move(mask)).first->second;
}

void WindowScorer::add_events(const EventStream& c) {
  if (c.empty() || finished_) return;
  if (!c.has_labels() && !boxes_)
    fail("window scorer", "",
         "scoring needs labelled events (label = object id, 0 = background), e.g. from "
         "`spikems simulate`");
  if (!have_origin_) {
    origin_ = last_t_ = c.t[0];
    have_origin_ = true;
  }
  for (size_t i = 0; i < c.size(); ++i) {
    const int64_t t = c.t[i];
    if (t < last_t_) fail_at_event("window scorer", events_seen_ + i, "time goes back");
    last_t_ = t;
    const bool moving = !boxes_ && c.label[i] != 0;  // with boxes, G comes from them (score)
    if ((shares_ || min_share_ > 0) && !boxes_)      // the filter needs the shares too
      for (PerLength& l : lengths_) {
        if (l.n_index < 0 || t >= l.n_end) {  // time-ordered: the window changes rarely
          l.n_index = (t - origin_) / l.window_us;
          l.n_end = origin_ + (l.n_index + 1) * l.window_us;
          l.n_counts = &l.n[l.n_index];
        }
        (*l.n_counts)[0] += 1;
        (*l.n_counts)[1] += moving;
      }
    if (!moving && !any_filter_ && !gate_) continue;
    if (c.x[i] >= sensor_.width || c.y[i] >= sensor_.height)
      fail_at_event("window scorer", events_seen_ + i, "pixel outside the sensor");
    const size_t px = size_t(c.y[i]) * size_t(sensor_.width) + c.x[i];
    if (any_filter_ || gate_)
      for (PerLength& l : lengths_)
        if (l.filter || gate_) mask_of(l.e, (t - origin_) / l.window_us)[px] = 1;
    if (!moving) continue;
    for (PerLength& l : lengths_) {
      const int64_t k = (t - origin_) / l.window_us;
      if (k != l.g_index) {  // events are time-ordered: the window changes rarely
        l.g_mask = &mask_of(l.g, k);
        l.g_index = k;
      }
      (*l.g_mask)[px] = 1;
    }
  }
  events_seen_ += c.size();
  for (size_t i = 0; i < lengths_.size(); ++i) score_ready(i);
}

void WindowScorer::add_frame(const PredictionFrame& f) {
  if (finished_) return;
  if (!have_origin_) fail("window scorer", "", "a prediction frame came before any event");
  const std::string where =
      "frame [" + std::to_string(f.t0_us) + ", " + std::to_string(f.t1_us) + ") us";
  if (f.foreground.size() != size_t(sensor_.width) * size_t(sensor_.height))
    fail("window scorer", where, "the frame does not have the sensor's size");
  if (f.t1_us - f.t0_us != frame_us_ || (f.t0_us - origin_) % frame_us_ != 0 || f.t0_us < origin_)
    fail("window scorer", where,
         "frames must be " + std::to_string(frame_us_) +
             " us long and aligned with the first event's time " + std::to_string(origin_));
  const int64_t j = (f.t0_us - origin_) / frame_us_;
  if (j < frames_done_) fail("window scorer", where, "frames must come once each, in time order");
  fg_pixels_.clear();
  for (size_t i = 0; i < f.foreground.size(); ++i)
    if (f.foreground[i]) fg_pixels_.push_back(uint32_t(i));
  if (!fg_pixels_.empty())
    for (PerLength& l : lengths_) {
      std::vector<uint8_t>& m = mask_of(l.p, j / l.frames_per_window);
      for (uint32_t px : fg_pixels_) m[px] = 1;
    }
  frames_done_ = j + 1;
  for (size_t i = 0; i < lengths_.size(); ++i) score_ready(i);
}

void WindowScorer::capture(int64_t window_us, std::vector<int64_t> indices) {
  const auto it = std::find(windows_.begin(), windows_.end(), window_us);
  if (it == windows_.end())
    fail("window scorer", "", "cannot capture windows of a length that is not scored");
  capture_length_ = size_t(it - windows_.begin());
  std::sort(indices.begin(), indices.end());
  capture_indices_ = std::move(indices);
  captured_.clear();
}

void WindowScorer::score_ready(size_t i) {
  // A window is final when all its frames have come and an event at or after its end was
  // seen (so its truth is complete and the data goes on past it).
  PerLength& l = lengths_[i];
  while ((l.next + 1) * l.frames_per_window <= frames_done_ &&
         origin_ + (l.next + 1) * l.window_us <= last_t_)
    score(i, l.next++);
}

void WindowScorer::score(size_t i, int64_t k) {
  PerLength& l = lengths_[i];
  if (boxes_) {  // G = box pixels; a window without a valid box keeps an empty G (skipped)
    const int64_t t0 = origin_ + k * l.window_us;
    boxes_->fill_window(t0, t0 + l.window_us, mask_of(l.g, k), sensor_);
  }
  auto g = l.g.find(k);
  auto p = l.p.find(k);
  if (zeros_.empty()) zeros_.assign(size_t(sensor_.width) * size_t(sensor_.height), 0);
  const std::vector<uint8_t>* pm = p != l.p.end() ? &p->second : &zeros_;  // P as scored
  MaskCounts c;  // no G: skipped by WindowScores whatever was predicted
  if (l.filter) {
    // Every window goes through the filter (it keeps state), then P as it rewrote it.
    filtered_p_ = *pm;
    auto e = l.e.find(k);
    const int64_t t0 = origin_ + k * l.window_us;
    l.filter->apply(t0, t0 + l.window_us, filtered_p_, e != l.e.end() ? e->second : zeros_);
    pm = &filtered_p_;
    if (g != l.g.end()) c = count_masks(filtered_p_, g->second);
  } else if (g != l.g.end()) {
    if (p != l.p.end() && gate_) {
      auto e = l.e.find(k);
      gated_p_.assign(p->second.size(), 0);
      if (e != l.e.end())
        for (size_t j = 0; j < gated_p_.size(); ++j) gated_p_[j] = p->second[j] & e->second[j];
      p->second.swap(gated_p_);  // the captured window shows the gated P too
    }
    c = count_masks(*pm, g->second);
  }
  double share = WindowScores::kUnknownShare;
  if (auto n = l.n.find(k); n != l.n.end() && n->second[0] > 0)  // none counted with boxes
    share = double(n->second[1]) / double(n->second[0]);
  // A window with moving events below the share asked for is left out (its G is not empty:
  // windows without moving events stay "skipped"). Kalman rows keep their filter's state,
  // which apply() above has updated already.
  const bool filtered = min_share_ > 0 && c.truth > 0 && !(share >= min_share_);
  if (group_ > 1) {
    // Windows are scored one after another (score_ready, finish), so a group is closed by its
    // last window or by finish().
    if (filtered)
      scores_[i].add_filtered();
    else if (c.truth == 0)
      scores_[i].add(c, share);  // counted as skipped
    else
      add_to_group(i, k, *pm, g->second);
    if (k % group_ == group_ - 1) close_group(i);
  } else if (filtered) {
    scores_[i].add_filtered();
  } else {
    scores_[i].add(c, share);
  }
  if (i == capture_length_ &&
      std::binary_search(capture_indices_.begin(), capture_indices_.end(), k)) {
    CapturedWindow w;
    w.index = k;
    w.t0_us = origin_ + k * l.window_us;
    w.t1_us = w.t0_us + l.window_us;
    w.width = sensor_.width;
    w.height = sensor_.height;
    const size_t px = size_t(sensor_.width) * size_t(sensor_.height);
    w.predicted = p != l.p.end() ? p->second : std::vector<uint8_t>(px, 0);
    w.truth = g != l.g.end() ? g->second : std::vector<uint8_t>(px, 0);
    w.counts = c;
    captured_.push_back(std::move(w));
  }
  auto release = [&](std::map<int64_t, std::vector<uint8_t>>& m) {
    for (auto it = m.begin(); it != m.end() && it->first <= k; it = m.erase(it)) {
      std::fill(it->second.begin(), it->second.end(), 0);
      pool_.push_back(std::move(it->second));
    }
  };
  release(l.p);
  release(l.g);
  release(l.e);
  if (l.g_index <= k) {
    l.g_index = -1;
    l.g_mask = nullptr;
  }
  l.n.erase(l.n.begin(), l.n.upper_bound(k));
  if (l.n_index <= k) {
    l.n_index = -1;
    l.n_counts = nullptr;
  }
}

void WindowScorer::add_to_group(size_t i, int64_t k, const std::vector<uint8_t>& p,
                                const std::vector<uint8_t>& g) {
  PerLength& l = lengths_[i];
  if (l.group_p.empty()) {
    l.group_p.assign(p.size(), 0);
    l.group_g.assign(g.size(), 0);
  }
  for (size_t j = 0; j < p.size(); ++j) l.group_p[j] |= p[j] != 0;
  for (size_t j = 0; j < g.size(); ++j) l.group_g[j] |= g[j] != 0;
  ++l.group_kept;
  if (auto n = l.n.find(k); n != l.n.end()) {
    l.group_n[0] += n->second[0];
    l.group_n[1] += n->second[1];
  }
}

void WindowScorer::close_group(size_t i) {
  PerLength& l = lengths_[i];
  if (l.group_kept > 0) {
    const double share = l.group_n[0] > 0 ? double(l.group_n[1]) / double(l.group_n[0])
                                          : WindowScores::kUnknownShare;
    scores_[i].add_group(count_masks(l.group_p, l.group_g), share, l.group_kept);
    std::fill(l.group_p.begin(), l.group_p.end(), 0);
    std::fill(l.group_g.begin(), l.group_g.end(), 0);
  }
  l.group_kept = 0;
  l.group_n = {0, 0};
}

void WindowScorer::finish(int64_t end_us, bool keep_partial) {
  if (finished_) return;
  finished_ = true;
  if (!have_origin_) return;
  const int64_t span = end_us - origin_;
  for (size_t i = 0; i < lengths_.size(); ++i) {
    PerLength& l = lengths_[i];
    const int64_t n = span <= 0      ? 0
                      : keep_partial ? (span + l.window_us - 1) / l.window_us
                                     : span / l.window_us;
    while (l.next < n) score(i, l.next++);
    close_group(i);  // the last group may be short (the authors' last batch is too)
    l.p.clear();
    l.g.clear();
    l.e.clear();
    l.g_mask = nullptr;
    l.n.clear();
    l.n_index = -1;
    l.n_counts = nullptr;
  }
  pool_.clear();
}

EventTally::EventTally(int64_t origin_us, int64_t frame_us) : origin_(origin_us), frame_(frame_us) {
  if (frame_us <= 0) fail("event tally", "", "the frame length must be positive");
}

void EventTally::add(int64_t t, bool truth, bool predicted) {
  if (t < origin_) fail("event tally", "", "an event before the first one");
  const size_t j = size_t((t - origin_) / frame_);
  if (j >= frames_.size()) frames_.resize(j + 1);
  frames_[j].add(truth, predicted);
}

std::vector<EventCounts> EventTally::per_length(const std::vector<int64_t>& windows_us,
                                                int64_t end_us) const {
  std::vector<EventCounts> out(windows_us.size());
  const int64_t span = end_us - origin_;
  for (size_t i = 0; i < windows_us.size(); ++i) {
    if (span <= 0) continue;
    // Frames of the whole windows: the lengths are multiples of the frame.
    const int64_t frames = span / windows_us[i] * windows_us[i] / frame_;
    for (int64_t j = 0; j < frames && size_t(j) < frames_.size(); ++j) out[i] += frames_[size_t(j)];
  }
  return out;
}

std::vector<WindowScores> score_frames(const std::vector<PredictionFrame>& frames,
                                       const EventStream& events,
                                       const std::vector<int64_t>& windows_us, int64_t end_us,
                                       bool keep_partial) {
  WindowScorer s(events.sensor, windows_us);
  s.add_events(events);
  for (const auto& f : frames) s.add_frame(f);
  s.finish(end_us, keep_partial);
  return s.scores();
}

}  // namespace spikems
