// Small, dependency-free SVG charts for reports: line plots (with optional error bars) and
// grouped bar plots, each with a title, axes with ticks, axis labels and a legend.
// Every data point carries a <title> tooltip with its value, so the numbers stay readable.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace spikems {

struct PlotSeries {
  std::string label;
  std::vector<double> x;  // line plots only (bar plots use categories)
  std::vector<double> y;
  std::vector<double> err;  // optional +/- error per point (e.g. a standard deviation)
  std::string color;        // CSS colour; empty: taken from the palette
};

struct PlotOptions {
  std::string title, x_label, y_label;
  int width = 640, height = 400;
  std::optional<double> y_min, y_max;  // default: from the data (y_min includes 0 for bars)
};

// Throws spikems::Error when a series' x, y and err lengths disagree or a value is not finite.
std::string svg_line_plot(const std::vector<PlotSeries>& series, const PlotOptions& opt);
// One group of bars per category; series[i].y[j] is the bar of series i in category j.
std::string svg_bar_plot(const std::vector<std::string>& categories,
                         const std::vector<PlotSeries>& series, const PlotOptions& opt);
// Writes SVG text atomically.
void write_svg(const std::string& path, const std::string& svg);

// "Nice" axis ticks (steps of 1, 2 or 5 x 10^k) covering [lo, hi], about `target` of them.
std::vector<double> nice_ticks(double lo, double hi, int target = 6);
// Escapes &, <, >, " and ' for XML/HTML text and attributes.
std::string xml_escape(const std::string& s);

}  // namespace spikems
