#include "core/viz/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/util/atomic_file.h"
#include "core/util/error.h"

namespace spikems {

namespace {

const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                          "#9467bd", "#8c564b", "#e377c2", "#17becf"};

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string color_of(const PlotSeries& s, size_t i) {
  return s.color.empty() ? kPalette[i % 8] : xml_escape(s.color);
}

void check_series(const std::vector<PlotSeries>& series, bool need_x) {
  for (const auto& s : series) {
    if (need_x && s.x.size() != s.y.size())
      fail("plot", "series '" + s.label + "'", "x and y have different lengths");
    if (!s.err.empty() && s.err.size() != s.y.size())
      fail("plot", "series '" + s.label + "'", "err and y have different lengths");
    for (const auto* v : {&s.x, &s.y, &s.err})
      for (double d : *v)
        if (!std::isfinite(d)) fail("plot", "series '" + s.label + "'", "value is not finite");
  }
}

// Plot frame: margins, scales, axes, title, legend.
struct Frame {
  double left = 70, right = 20, top = 40, bottom = 55;
  double w, h, x0, x1, y0, y1;
  double px(double x) const { return left + (x - x0) / (x1 - x0) * (w - left - right); }
  double py(double y) const { return h - bottom - (y - y0) / (y1 - y0) * (h - top - bottom); }
};

void widen(double& lo, double& hi) {
  if (!(hi > lo)) {
    double d = std::fabs(lo) > 0 ? std::fabs(lo) * 0.1 : 1;
    lo -= d;
    hi += d;
  }
}

void header(std::ostringstream& o, const PlotOptions& opt) {
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << opt.width << "\" height=\""
    << opt.height << "\" viewBox=\"0 0 " << opt.width << " " << opt.height
    << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
    << "<rect x=\"0\" y=\"0\" width=\"" << opt.width << "\" height=\"" << opt.height
    << "\" fill=\"white\"/>\n";
  if (!opt.title.empty())
    o << "<text x=\"" << opt.width / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
      << xml_escape(opt.title) << "</text>\n";
}

void y_axis(std::ostringstream& o, const Frame& f, const PlotOptions& opt,
            const std::vector<double>& ticks) {
  o << "<g class=\"y-axis\">\n";
  o << "<line x1=\"" << f.left << "\" y1=\"" << f.top << "\" x2=\"" << f.left << "\" y2=\""
    << f.h - f.bottom << "\" stroke=\"black\"/>\n";
  for (double t : ticks) {
    double y = f.py(t);
    o << "<line x1=\"" << f.left - 4 << "\" y1=\"" << y << "\" x2=\"" << f.w - f.right << "\" y2=\""
      << y << "\" stroke=\"#ddd\"/>\n"
      << "<text x=\"" << f.left - 7 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">" << num(t)
      << "</text>\n";
  }
  if (!opt.y_label.empty())
    o << "<text transform=\"translate(16," << (f.top + f.h - f.bottom) / 2
      << ") rotate(-90)\" text-anchor=\"middle\">" << xml_escape(opt.y_label) << "</text>\n";
  o << "</g>\n";
}

void x_label(std::ostringstream& o, const Frame& f, const PlotOptions& opt) {
  o << "<line x1=\"" << f.left << "\" y1=\"" << f.h - f.bottom << "\" x2=\"" << f.w - f.right
    << "\" y2=\"" << f.h - f.bottom << "\" stroke=\"black\"/>\n";
  if (!opt.x_label.empty())
    o << "<text x=\"" << (f.left + f.w - f.right) / 2 << "\" y=\"" << f.h - 12
      << "\" text-anchor=\"middle\">" << xml_escape(opt.x_label) << "</text>\n";
}

void legend(std::ostringstream& o, const Frame& f, const std::vector<PlotSeries>& series) {
  o << "<g class=\"legend\">\n";
  // Right-aligned by the longest label (~7 px per character at 12 px sans-serif), so that long
  // model file names stay inside the picture; at least 150 px as before.
  size_t longest = 0;
  for (const auto& s : series) longest = std::max(longest, s.label.size());
  const double x = f.w - f.right - std::max(150.0, 17.0 + 7.0 * double(longest));
  for (size_t i = 0; i < series.size(); ++i) {
    double y = f.top + 6 + double(i) * 16;
    o << "<rect x=\"" << x << "\" y=\"" << y - 8 << "\" width=\"12\" height=\"10\" fill=\""
      << color_of(series[i], i) << "\"/>\n"
      << "<text x=\"" << x + 17 << "\" y=\"" << y + 1 << "\">" << xml_escape(series[i].label)
      << "</text>\n";
  }
  o << "</g>\n";
}

void y_range(const std::vector<PlotSeries>& series, const PlotOptions& opt, bool include_zero,
             double& lo, double& hi) {
  lo = INFINITY;
  hi = -INFINITY;
  for (const auto& s : series)
    for (size_t i = 0; i < s.y.size(); ++i) {
      double e = s.err.empty() ? 0 : std::fabs(s.err[i]);
      lo = std::min(lo, s.y[i] - e);
      hi = std::max(hi, s.y[i] + e);
    }
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  if (include_zero) lo = std::min(lo, 0.0), hi = std::max(hi, 0.0);
  if (opt.y_min) lo = *opt.y_min;
  if (opt.y_max) hi = *opt.y_max;
  widen(lo, hi);
}

}  // namespace

std::string xml_escape(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      case '\'':
        o += "&#39;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::vector<double> nice_ticks(double lo, double hi, int target) {
  widen(lo, hi);
  double raw = (hi - lo) / std::max(1, target);
  double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  std::vector<double> t;
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step)
    t.push_back(std::fabs(v) < step * 1e-9 ? 0.0 : v);
  return t;
}

std::string svg_line_plot(const std::vector<PlotSeries>& series, const PlotOptions& opt) {
  check_series(series, true);
  Frame f;
  f.w = opt.width;
  f.h = opt.height;
  f.x0 = INFINITY;
  f.x1 = -INFINITY;
  for (const auto& s : series)
    for (double x : s.x) f.x0 = std::min(f.x0, x), f.x1 = std::max(f.x1, x);
  if (!std::isfinite(f.x0)) f.x0 = 0, f.x1 = 1;
  widen(f.x0, f.x1);
  y_range(series, opt, false, f.y0, f.y1);
  auto yt = nice_ticks(f.y0, f.y1);
  f.y0 = std::min(f.y0, yt.front());
  f.y1 = std::max(f.y1, yt.back());
  std::ostringstream o;
  header(o, opt);
  y_axis(o, f, opt, yt);
  o << "<g class=\"x-axis\">\n";
  for (double t : nice_ticks(f.x0, f.x1)) {
    if (t < f.x0 - 1e-12 || t > f.x1 + 1e-12) continue;
    double x = f.px(t);
    o << "<line x1=\"" << x << "\" y1=\"" << f.h - f.bottom << "\" x2=\"" << x << "\" y2=\""
      << f.h - f.bottom + 4 << "\" stroke=\"black\"/>\n"
      << "<text x=\"" << x << "\" y=\"" << f.h - f.bottom + 17 << "\" text-anchor=\"middle\">"
      << num(t) << "</text>\n";
  }
  x_label(o, f, opt);
  o << "</g>\n";
  for (size_t i = 0; i < series.size(); ++i) {
    const auto& s = series[i];
    std::string c = color_of(s, i);
    o << "<g class=\"series\" data-label=\"" << xml_escape(s.label) << "\">\n";
    if (s.x.size() > 1) {
      o << "<polyline fill=\"none\" stroke=\"" << c << "\" stroke-width=\"2\" points=\"";
      for (size_t k = 0; k < s.x.size(); ++k)
        o << (k ? " " : "") << f.px(s.x[k]) << "," << f.py(s.y[k]);
      o << "\"/>\n";
    }
    for (size_t k = 0; k < s.x.size(); ++k) {
      double x = f.px(s.x[k]), y = f.py(s.y[k]);
      if (!s.err.empty())
        o << "<line x1=\"" << x << "\" y1=\"" << f.py(s.y[k] - s.err[k]) << "\" x2=\"" << x
          << "\" y2=\"" << f.py(s.y[k] + s.err[k]) << "\" stroke=\"" << c << "\"/>\n";
      o << "<circle cx=\"" << x << "\" cy=\"" << y << "\" r=\"3\" fill=\"" << c << "\"><title>"
        << xml_escape(s.label) << ": x=" << num(s.x[k]) << ", y=" << num(s.y[k])
        << (s.err.empty() ? "" : " +/- " + num(s.err[k])) << "</title></circle>\n";
    }
    o << "</g>\n";
  }
  legend(o, f, series);
  o << "</svg>\n";
  return o.str();
}

std::string svg_bar_plot(const std::vector<std::string>& categories,
                         const std::vector<PlotSeries>& series, const PlotOptions& opt) {
  check_series(series, false);
  for (const auto& s : series)
    if (s.y.size() != categories.size())
      fail("plot", "series '" + s.label + "'", "needs one value per category");
  Frame f;
  f.w = opt.width;
  f.h = opt.height;
  f.x0 = 0;
  f.x1 = double(std::max<size_t>(categories.size(), 1));
  y_range(series, opt, true, f.y0, f.y1);
  auto yt = nice_ticks(f.y0, f.y1);
  f.y0 = std::min(f.y0, yt.front());
  f.y1 = std::max(f.y1, yt.back());
  std::ostringstream o;
  header(o, opt);
  y_axis(o, f, opt, yt);
  o << "<g class=\"x-axis\">\n";
  for (size_t j = 0; j < categories.size(); ++j)
    o << "<text x=\"" << f.px(double(j) + 0.5) << "\" y=\"" << f.h - f.bottom + 17
      << "\" text-anchor=\"middle\">" << xml_escape(categories[j]) << "</text>\n";
  x_label(o, f, opt);
  o << "</g>\n";
  double group = f.px(1) - f.px(0);
  double bw = group * 0.8 / double(std::max<size_t>(series.size(), 1));
  for (size_t i = 0; i < series.size(); ++i) {
    const auto& s = series[i];
    std::string c = color_of(s, i);
    o << "<g class=\"series\" data-label=\"" << xml_escape(s.label) << "\">\n";
    for (size_t j = 0; j < s.y.size(); ++j) {
      double x = f.px(double(j)) + group * 0.1 + bw * double(i);
      double ya = f.py(std::max(s.y[j], 0.0)), yb = f.py(std::min(s.y[j], 0.0));
      o << "<rect x=\"" << x << "\" y=\"" << ya << "\" width=\"" << bw << "\" height=\"" << yb - ya
        << "\" fill=\"" << c << "\"><title>" << xml_escape(s.label) << " / "
        << xml_escape(categories[j]) << ": " << num(s.y[j])
        << (s.err.empty() ? "" : " +/- " + num(s.err[j])) << "</title></rect>\n";
      if (!s.err.empty())
        o << "<line x1=\"" << x + bw / 2 << "\" y1=\"" << f.py(s.y[j] - s.err[j]) << "\" x2=\""
          << x + bw / 2 << "\" y2=\"" << f.py(s.y[j] + s.err[j]) << "\" stroke=\"black\"/>\n";
    }
    o << "</g>\n";
  }
  legend(o, f, series);
  o << "</svg>\n";
  return o.str();
}

void write_svg(const std::string& path, const std::string& svg) {
  write_file_atomic(path, svg);
}

}  // namespace spikems
