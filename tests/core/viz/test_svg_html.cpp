// SVG plots and HTML reports: well-formed markup that carries the plotted values.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "common/test_paths.h"
#include "core/util/error.h"
#include "core/viz/html_report.h"
#include "core/viz/svg_plot.h"

using namespace spikems;

namespace {

// A strict little XML checker: tags balance, attributes are quoted, entities are known.
// Returns "" when well-formed, else what is wrong.
std::string check_xml(const std::string& s) {
  std::vector<std::string> stack;
  size_t i = 0;
  while (i < s.size()) {
    if (s[i] == '&') {
      size_t e = s.find(';', i);
      if (e == std::string::npos) return "bare & at " + std::to_string(i);
      std::string ent = s.substr(i + 1, e - i - 1);
      if (ent != "amp" && ent != "lt" && ent != "gt" && ent != "quot" && ent != "#39")
        return "unknown entity &" + ent + ";";
      i = e + 1;
      continue;
    }
    if (s[i] == '>') return "stray > at " + std::to_string(i);
    if (s[i] != '<') {
      ++i;
      continue;
    }
    if (s.compare(i, 4, "<!--") == 0) {
      i = s.find("-->", i) + 3;
      continue;
    }
    if (s.compare(i, 2, "<!") == 0 || s.compare(i, 2, "<?") == 0) {
      i = s.find('>', i) + 1;
      continue;
    }
    size_t e = i + 1;
    char quote = 0;
    while (e < s.size() && (quote || s[e] != '>')) {
      if (quote && s[e] == quote)
        quote = 0;
      else if (!quote && (s[e] == '"' || s[e] == '\''))
        quote = s[e];
      else if (!quote && s[e] == '<')
        return "< inside a tag at " + std::to_string(e);
      ++e;
    }
    if (e >= s.size()) return "unterminated tag";
    std::string tag = s.substr(i + 1, e - i - 1);
    if (tag.empty()) return "empty tag";
    if (tag[0] == '/') {
      std::string name = tag.substr(1);
      if (stack.empty() || stack.back() != name) return "mismatched </" + name + ">";
      stack.pop_back();
    } else if (tag.back() != '/') {
      std::string name = tag.substr(0, tag.find_first_of(" \n\t"));
      if (name == "meta" || name == "img" || name == "br") return "unclosed void element " + name;
      stack.push_back(name);
    }
    i = e + 1;
  }
  return stack.empty() ? "" : "unclosed <" + stack.back() + ">";
}

}  // namespace

TEST(Xml, CheckerCatchesBrokenMarkup) {
  EXPECT_EQ(check_xml("<a><b x=\"1\"/></a>"), "");
  EXPECT_NE(check_xml("<a><b></a>"), "");
  EXPECT_NE(check_xml("<a>x & y</a>"), "");
  EXPECT_NE(check_xml("<a>"), "");
}

TEST(SvgPlot, LinePlotIsWellFormedAndCarriesValues) {
  PlotSeries iou{"IoU <raw>", {1, 2, 5, 10}, {0.2, 0.35, 0.5, 0.61}, {0.01, 0.02, 0.03, 0.04}, ""};
  PlotSeries kf{"Kalman", {1, 2, 5, 10}, {0.3, 0.4, 0.55, 0.62}, {}, "#000000"};
  PlotOptions opt;
  opt.title = "IoU vs window & step";
  opt.x_label = "window (ms)";
  opt.y_label = "IoU";
  std::string svg = svg_line_plot({iou, kf}, opt);
  EXPECT_EQ(check_xml(svg), "") << svg;
  EXPECT_NE(svg.find("IoU vs window &amp; step"), std::string::npos);
  EXPECT_NE(svg.find("IoU &lt;raw&gt;"), std::string::npos);  // legend, escaped
  EXPECT_NE(svg.find("x=5, y=0.5 +/- 0.03"), std::string::npos);
  EXPECT_NE(svg.find("Kalman: x=10, y=0.62"), std::string::npos);
  EXPECT_NE(svg.find("window (ms)"), std::string::npos);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);
  EXPECT_NE(svg.find("#000000"), std::string::npos);
  std::string path = test::scratch_dir() + "/p.svg";
  write_svg(path, svg);
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), svg);
}

TEST(SvgPlot, BarPlotAndErrors) {
  std::string svg = svg_bar_plot(
      {"boxes", "floor"}, {{"SpikeMS", {}, {61, 60}, {}, ""}, {"ours", {}, {63.5, -2}, {1, 1}, ""}},
      PlotOptions{"IoU", "", "%", 500, 300, {}, {}});
  EXPECT_EQ(check_xml(svg), "") << svg;
  EXPECT_NE(svg.find("SpikeMS / boxes: 61"), std::string::npos);
  EXPECT_NE(svg.find("ours / floor: -2 +/- 1"), std::string::npos);
  EXPECT_NE(svg.find(">boxes</text>"), std::string::npos);
  EXPECT_THROW(svg_bar_plot({"a"}, {{"s", {}, {1, 2}, {}, ""}}, {}), Error);
  EXPECT_THROW(svg_line_plot({{"s", {1}, {NAN}, {}, ""}}, {}), Error);
  EXPECT_THROW(svg_line_plot({{"s", {1, 2}, {1}, {}, ""}}, {}), Error);
  // Empty input still gives a valid document.
  EXPECT_EQ(check_xml(svg_line_plot({}, {})), "");
}

TEST(SvgPlot, NiceTicks) {
  auto t = nice_ticks(0, 1, 5);
  std::vector<double> want{0, 0.2, 0.4, 0.6, 0.8, 1.0};
  ASSERT_EQ(t.size(), want.size());
  for (size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], want[i], 1e-12);
  auto u = nice_ticks(3, 97, 6);  // step 20: 20, 40, 60, 80
  std::vector<double> want_u{20, 40, 60, 80};
  EXPECT_EQ(u, want_u);
  EXPECT_FALSE(nice_ticks(5, 5).empty());
}

TEST(HtmlReport, WellFormedWithTablesImagesAndSvg) {
  HtmlReport r("Run <1>");
  r.heading("Scores");
  r.paragraph("IoU & detection rate");
  r.table({"sequence", "IoU", "DR"}, {{"boxes", "0.61", "0.65"}, {"floor", "0.60"}}, "per seq");
  r.image("frames/w0001.png", "window 1", 346);
  r.svg("<?xml version=\"1.0\"?>" + svg_line_plot({{"a", {0, 1}, {0, 1}, {}, ""}}, {}));
  r.code("spikems eval --model m.spikems");
  std::string html = r.str();
  EXPECT_EQ(check_xml(html), "") << html;
  EXPECT_NE(html.find("<title>Run &lt;1&gt;</title>"), std::string::npos);
  EXPECT_NE(html.find("<td>boxes</td><td>0.61</td><td>0.65</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>floor</td><td>0.60</td><td></td>"), std::string::npos);  // padded
  EXPECT_NE(html.find("src=\"frames/w0001.png\""), std::string::npos);
  EXPECT_NE(html.find("IoU &amp; detection rate"), std::string::npos);
  EXPECT_EQ(html.find("<?xml"), std::string::npos);
  // The script that tells a headless browser (tests/browser) that every image loaded.
  EXPECT_NE(html.find("setAttribute('data-images-ok'"), std::string::npos);
  std::string path = test::scratch_dir() + "/r.html";
  r.write(path);
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), html);
}
