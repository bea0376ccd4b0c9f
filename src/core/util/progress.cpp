#include "core/util/progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace spikems {

std::string human_count(double v) {
  const char* suffix[] = {"", " k", " M", " G", " T"};
  int i = 0;
  while (std::fabs(v) >= 1000.0 && i < 4) {
    v /= 1000.0;
    ++i;
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, i == 0 ? "%.0f%s" : "%.2f%s", v, suffix[i]);
  return buf;
}

std::string human_duration(double s) {
  char buf[64];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.1fs", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%dm%02ds", int(s) / 60, int(s) % 60);
  else
    std::snprintf(buf, sizeof buf, "%dh%02dm", int(s) / 3600, (int(s) / 60) % 60);
  return buf;
}

ProgressBar::ProgressBar(std::string label, uint64_t total, std::string unit, bool enabled)
    : label_(std::move(label)), unit_(std::move(unit)), total_(total), enabled_(enabled) {
  start_ = last_draw_ = std::chrono::steady_clock::now();
  if (const char* p = std::getenv("SPIKEMS_PROGRESS_PREFIX"); p && *p)
    label_ = std::string(p) + " " + label_;
  if (const char* a = std::getenv("SPIKEMS_PROGRESS_AFTER_S"); a && *a) after_s_ = std::atof(a);
}

ProgressBar::~ProgressBar() {
  if (!finished_) finish();
}

void ProgressBar::update(uint64_t done) {
  done_ = done;
  if (!enabled_) return;
  auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < std::chrono::milliseconds(100) && done_ < total_) return;
  last_draw_ = now;
  draw(false);
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  if (enabled_) draw(true);
}

void ProgressBar::draw(bool final) {
  double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  double rate = el > 0 ? double(done_) / el : 0.0;
  double frac = total_ ? std::min(1.0, double(done_) / double(total_)) : 0.0;
  double eta = rate > 0 && total_ >= done_ ? double(total_ - done_) / rate : -1;
  const int width = 30;
  int fill = int(frac * width);
  std::string bar(size_t(fill), '#');
  bar += std::string(size_t(width - fill), '.');
  bool tty = isatty(fileno(stderr));
  // On a terminal the line is redrawn in place; in logs only the final line is written.
  if (!tty && !final) return;
  const std::string recipe =
      !final && after_s_ >= 0 && eta >= 0 ? " recipe ETA " + human_duration(eta + after_s_) : "";
  std::fprintf(stderr, "%s%s [%s] %5.1f%% %s/%s %s %s/s %s %s%s%s%s%s", tty ? "\r" : "",
               label_.c_str(), bar.c_str(), frac * 100, human_count(double(done_)).c_str(),
               human_count(double(total_)).c_str(), unit_.c_str(), human_count(rate).c_str(),
               final ? "in" : "ETA", human_duration(final ? el : eta).c_str(), recipe.c_str(),
               status_.empty() ? "" : "  ", status_.c_str(), final ? "\n" : "   ");
  std::fflush(stderr);
}

}  // namespace spikems
