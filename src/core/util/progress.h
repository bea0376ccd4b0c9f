// A progress bar on stderr with rate and ETA, for every long command. Redraws at most
// 10 times a second; prints a final line on finish(). Quiet when disabled.
// Inside a recipe (`spikems train --recipe`) the runner sets SPIKEMS_PROGRESS_PREFIX (e.g.
// "[3/6 student]"), put before the label, and SPIKEMS_PROGRESS_AFTER_S, the seconds the stages
// after this one are expected to take: the bar then also shows "recipe ETA <its ETA + them>".
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace spikems {

class ProgressBar {
 public:
  ProgressBar(std::string label, uint64_t total, std::string unit = "it", bool enabled = true);
  ~ProgressBar();
  void update(uint64_t done);  // absolute progress
  void add(uint64_t n) { update(done_ + n); }
  void finish();
  // Text shown after the rate and ETA (e.g. "loss 0.31 IoU 42 %"), redrawn with the bar.
  void set_status(std::string s) { status_ = std::move(s); }

 private:
  void draw(bool final);
  std::string label_, unit_, status_;
  double after_s_ = -1;  // SPIKEMS_PROGRESS_AFTER_S; < 0: none
  uint64_t total_, done_ = 0;
  bool enabled_, finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

// "1.23 M", "456 k": numbers people can read at a glance.
std::string human_count(double v);
std::string human_duration(double seconds);

}  // namespace spikems
