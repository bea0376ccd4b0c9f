// A progress bar on stderr with rate and ETA, for every long command. Redraws at most
// 10 times a second; prints a final line on finish(). Quiet when disabled.
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
  uint64_t total_, done_ = 0;
  bool enabled_, finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

// "1.23 M", "456 k": numbers people can read at a glance.
std::string human_count(double v);
std::string human_duration(double seconds);

}  // namespace spikems
