// The evaluation report (`spikems eval --out DIR`): SVG plots and DIR/report.html, one page
// with the tables of results.h, the plots and, per sequence, a few windows as one PNG each:
// input events | ground truth | each model's prediction. Files: docs/evaluation.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/eval/metrics.h"
#include "core/eval/results.h"
#include "core/viz/image.h"

namespace spikems {

// One window of one sequence as every run (models, then baselines) saw it, captured while
// scoring (WindowScorer::capture): P and G exactly as scored.
struct ExampleWindow {
  int64_t t0_us = 0, t1_us = 0;  // from the sequence's first event
  int width = 0, height = 0;
  Image events;                                 // the window's input events (ON red, OFF blue)
  std::vector<uint8_t> truth;                   // G
  std::vector<std::vector<uint8_t>> predicted;  // P, one per run
  std::vector<MaskCounts> counts;               // one per run
};

struct SequenceExamples {
  std::string name;  // as SequenceResult::name
  std::vector<ExampleWindow> windows;
};

struct EvalExamples {
  int64_t window_us = 0;  // the length of the windows shown
  // Indexed like ModelResult::datasets; sequences in order, the first few of each dataset.
  std::vector<std::vector<SequenceExamples>> datasets;
};

// The window length shown: 20 ms where it is scored, else the scored length nearest to it.
int64_t example_window_length(const std::vector<int64_t>& windows_us);

// One picture per example window: input events | ground truth (dark grey) | per run the
// prediction against the truth (green: predicted moving pixel, orange: predicted but not
// moving, blue: moving pixel missed), each panel framed, enlarged to about 256 pixels wide.
Image example_image(const ExampleWindow& w);

// DIR/plots/*.svg, DIR/windows/*.png and DIR/report.html (the folder is created; each file is
// written atomically). Returns the report's path.
std::string write_report(const EvalResults& r, const EvalExamples& ex, const std::string& dir);

}  // namespace spikems
