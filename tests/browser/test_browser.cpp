// The pages spikems writes, opened in a real browser: headless Chromium (Debian's `chromium`)
// loads `spikems eval`'s report.html and scripts/demo's index.html, dumps the DOM after the
// load event and takes a screenshot. A page passes when its tables are there, the page's own
// image check (core/viz/html_report.cpp) says every image decoded, the console stayed silent
// and the screenshot is not blank. Skips, saying why, where chromium is not installed.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/test_paths.h"
#include "common/tiny_models.h"
#include "core/model/model_file.h"
#include "core/viz/image.h"

namespace spikems {
namespace {

namespace fs = std::filesystem;
using test::run_command;

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// The chromium executable, or "" where it is not installed.
std::string chromium() {
  std::string out;
  if (run_command("command -v chromium", &out) != 0) return "";
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

#define REQUIRE_CHROMIUM()                                                                  \
  if (chromium().empty())                                                                   \
  GTEST_SKIP() << "chromium is not installed (Debian 12: apt-get install chromium, or run " \
                  "scripts/setup): the pages are not checked in a browser"

struct Rendered {
  std::string dom;       // the DOM after the load event
  std::string console;   // the page's console messages (script errors included), one a line
  double pixel_std = 0;  // standard deviation of the screenshot's grey levels (0: blank)
  std::string problems;  // why chromium did not give a DOM or a screenshot
};

// Loads `page` twice in headless Chromium: once for the DOM and the console, once for a
// screenshot of width x height pixels.
Rendered render(const std::string& page, const std::string& work, int width = 1200,
                int height = 1600) {
  fs::create_directories(work);
  const std::string base = quoted(chromium()) +
                           " --headless --disable-gpu --no-sandbox --no-first-run"
                           " --user-data-dir=" +
                           quoted(work + "/profile");
  const std::string url = quoted("file://" + fs::absolute(page).string());
  const std::string dom = work + "/dom.html", log = work + "/chromium.log",
                    shot = work + "/screenshot.png";
  Rendered r;
  std::string out;
  // Console messages are logged as "...:INFO:CONSOLE...] "text", source: ..." on stderr.
  if (run_command("( " + base + " --enable-logging=stderr --v=0 --dump-dom " + url + " > " +
                      quoted(dom) + " 2> " + quoted(log) + " )",
                  &out) != 0)
    r.problems += "chromium --dump-dom failed: " + out + slurp(log);
  r.dom = slurp(dom);
  std::istringstream lines(slurp(log));
  for (std::string l; std::getline(lines, l);)
    if (l.find(":CONSOLE") != std::string::npos) r.console += l + "\n";
  if (run_command(base + " --hide-scrollbars --window-size=" + std::to_string(width) + "," +
                      std::to_string(height) + " --screenshot=" + quoted(shot) + " " + url,
                  &out) != 0 ||
      !fs::exists(shot)) {
    r.problems += "chromium --screenshot failed: " + out;
    return r;
  }
  const Image img = read_png_rgb(shot);
  double sum = 0, sum2 = 0;
  const double n = double(img.width) * double(img.height);
  for (size_t i = 0; i < img.rgb.size(); i += 3) {
    const double g = (double(img.rgb[i]) + img.rgb[i + 1] + img.rgb[i + 2]) / 3;
    sum += g;
    sum2 += g * g;
  }
  r.pixel_std = n > 0 ? std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n))) : 0;
  return r;
}

size_t count(const std::string& s, const std::string& what) {
  size_t n = 0;
  for (size_t p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

// A non-blank page: a white page with a few lines of text already has a grey-level standard
// deviation of a few units; one with tables, plots and pictures has tens.
constexpr double kMinPixelStd = 4.0;

// What every page must show: every image decoded (the page's own check ran after the load
// event), no console message, a screenshot that is not blank.
void expect_rendered(const Rendered& r, const std::string& page, size_t min_images) {
  ASSERT_TRUE(r.problems.empty()) << page << ": " << r.problems;
  EXPECT_NE(r.dom.find("data-images-ok=\"true\""), std::string::npos)
      << page << ": an image did not load (or the check did not run)";
  const size_t at = r.dom.find("data-images=\"");
  ASSERT_NE(at, std::string::npos) << page;
  EXPECT_GE(std::stoul(r.dom.substr(at + 13)), min_images) << page;
  EXPECT_EQ(r.console, "") << page << ": console messages";
  EXPECT_GT(r.pixel_std, kMinPixelStd) << page << ": the screenshot looks blank";
}

class Browser : public ::testing::Test {
 protected:
  void SetUp() override {
    REQUIRE_CHROMIUM();
    dir_ = test::scratch_dir();
  }
  std::string dir_;
};

// The checks themselves fail where they should: a missing image, a console error, a blank page.
TEST_F(Browser, ChecksCatchBrokenImagesConsoleErrorsAndBlankPages) {
  const std::string page = dir_ + "/broken.html";
  std::ofstream(page) << "<!DOCTYPE html><html><body><h1>broken</h1><img src=\"missing.png\"/>"
                         "<script>console.error('boom');"
                         "window.addEventListener('load', function () {"
                         " var ok = Array.prototype.every.call(document.images, function (i) {"
                         " return i.complete ? i.naturalWidth !== 0 : false; });"
                         " document.body.setAttribute('data-images-ok', String(ok)); });"
                         "</script></body></html>";
  const Rendered r = render(page, dir_ + "/broken");
  ASSERT_TRUE(r.problems.empty()) << r.problems;
  EXPECT_NE(r.dom.find("data-images-ok=\"false\""), std::string::npos) << r.dom;
  EXPECT_NE(r.console.find("boom"), std::string::npos) << r.console;

  const std::string blank = dir_ + "/blank.html";
  std::ofstream(blank) << "<!DOCTYPE html><html><body></body></html>";
  EXPECT_LT(render(blank, dir_ + "/blank").pixel_std, 0.5);
}

// `spikems eval --out` on a tiny simulated dataset with a hand-built model and the baseline.
TEST_F(Browser, EvalReportRenders) {
  const std::string bin = test::spikems_binary();
  std::string out;
  ASSERT_EQ(run_command(bin + " simulate --preset tiny --sequences 2 --duration 0.2s --out " +
                            quoted(dir_ + "/tiny") + " --no-progress",
                        &out),
            0)
      << out;
  save_model(dir_ + "/pass_all.safetensors",
             test::pointwise_model({1.f, 0.f, 0.f, 1.f}, "pass-all"));
  ASSERT_EQ(run_command(bin + " eval --quiet --model " + quoted(dir_ + "/pass_all.safetensors") +
                            " --baseline all-events --data " + quoted(dir_ + "/tiny") +
                            " --split all --windows 10,20,100 --out " + quoted(dir_ + "/eval"),
                        &out),
            0)
      << out;
  const std::string page = dir_ + "/eval/report.html";
  const Rendered r = render(page, dir_ + "/chromium");
  // Three plots (IoU by window, by size band, per sequence) and 3 windows for each of the 2
  // sequences.
  expect_rendered(r, page, 3 + 2 * 3);
  EXPECT_EQ(count(r.dom, "<table"), 3u);  // the summary, size-band and per-sequence tables
  EXPECT_NE(r.dom.find("<th>IoU % (mean ± std)</th>"), std::string::npos);
  EXPECT_NE(r.dom.find("<td>pass_all.safetensors</td>"), std::string::npos);
  EXPECT_NE(r.dom.find("<td>baseline:all-events</td>"), std::string::npos);
}

// scripts/demo's page and the report it links, made by the demo itself with the built binary.
TEST_F(Browser, DemoPageAndItsReportRender) {
  const std::string demo = dir_ + "/demo";
  std::string out;
  ASSERT_EQ(run_command("cd " + quoted(test::source_dir()) +
                            " && SPIKEMS_BIN=" + quoted(test::spikems_binary()) +
                            " OUT=" + quoted(demo) + " scripts/demo",
                        &out),
            0)
      << out;
  const Rendered index = render(demo + "/index.html", dir_ + "/chromium_index");
  expect_rendered(index, demo + "/index.html", 1 + 3);  // events.png and 3 windows at least
  // input | truth | prediction of the shipped model, no bare prediction frames.
  EXPECT_GE(count(index.dom, "<img src=\"windows/"), 3u);
  EXPECT_EQ(count(index.dom, "masks/"), 0u);
  EXPECT_NE(index.dom.find("href=\"eval/report.html\""), std::string::npos)
      << "index.html does not link the evaluation report";
  // One score table: a row per model and the baseline, the authors' EV-IMO model where
  // ../shared holds it; the speed.
  EXPECT_EQ(count(index.dom, "<table"), 1u);
  EXPECT_NE(index.dom.find("<table id=\"scores\">"), std::string::npos);
  const bool evimo =
      fs::exists(fs::path(test::source_dir()) / "../shared/reference/spikems-evimo/weights.npz");
  EXPECT_EQ(count(index.dom, "<tr><td>"), evimo ? 4u : 3u);
  for (const char* row :
       {"default (shipped)", "fast (--model fast)", "every event moving (baseline)"})
    EXPECT_NE(index.dom.find(std::string("<tr><td>") + row + "</td>"), std::string::npos) << row;
  if (evimo) {
    EXPECT_NE(index.dom.find("<tr><td>EV-IMO (the authors' model)</td>"), std::string::npos);
  }
  EXPECT_NE(index.dom.find("events/s"), std::string::npos) << "index.html gives no speed";
  const Rendered report = render(demo + "/eval/report.html", dir_ + "/chromium_report");
  expect_rendered(report, demo + "/eval/report.html", 3);
  EXPECT_EQ(count(report.dom, "<table"), 3u);  // summary, size bands, per sequence
}

}  // namespace
}  // namespace spikems
