#include "core/viz/html_report.h"

#include <algorithm>

#include "core/util/atomic_file.h"
#include "core/util/error.h"
#include "core/viz/svg_plot.h"

namespace spikems {

namespace {
// After the load event (every image loaded or failed), marks <body> with the number of images
// and whether all of them decoded: data-images-ok="true" lets a headless browser's dumped DOM
// prove that the page rendered (tests/browser). No <, > or & so the page stays well-formed XML.
constexpr const char* kImageCheck =
    "<script>\nwindow.addEventListener('load', function () {\n"
    "  var imgs = Array.prototype.slice.call(document.images);\n"
    "  var ok = imgs.every(function (i) { return i.complete ? i.naturalWidth !== 0 : false; });\n"
    "  document.body.setAttribute('data-images', String(imgs.length));\n"
    "  document.body.setAttribute('data-images-ok', ok ? 'true' : 'false');\n"
    "});\n</script>\n";
}  // namespace

HtmlReport::HtmlReport(std::string title) : title_(std::move(title)) {
  body_ += "<h1>" + xml_escape(title_) + "</h1>\n";
}

void HtmlReport::heading(const std::string& text, int level) {
  level = std::clamp(level, 1, 6);
  std::string tag = "h" + std::to_string(level);
  body_ += "<" + tag + ">" + xml_escape(text) + "</" + tag + ">\n";
}

void HtmlReport::paragraph(const std::string& text) {
  body_ += "<p>" + xml_escape(text) + "</p>\n";
}

void HtmlReport::code(const std::string& text) {
  body_ += "<pre>" + xml_escape(text) + "</pre>\n";
}

void HtmlReport::table(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows,
                       const std::string& caption) {
  size_t cols = header.size();
  for (const auto& r : rows) cols = std::max(cols, r.size());
  body_ += "<table>\n";
  if (!caption.empty()) body_ += "<caption>" + xml_escape(caption) + "</caption>\n";
  if (!header.empty()) {
    body_ += "<thead><tr>";
    for (size_t c = 0; c < cols; ++c)
      body_ += "<th>" + (c < header.size() ? xml_escape(header[c]) : std::string()) + "</th>";
    body_ += "</tr></thead>\n";
  }
  body_ += "<tbody>\n";
  for (const auto& r : rows) {
    body_ += "<tr>";
    for (size_t c = 0; c < cols; ++c)
      body_ += "<td>" + (c < r.size() ? xml_escape(r[c]) : std::string()) + "</td>";
    body_ += "</tr>\n";
  }
  body_ += "</tbody>\n</table>\n";
}

void HtmlReport::image(const std::string& relative_path, const std::string& caption, int width) {
  body_ += "<figure><img src=\"" + xml_escape(relative_path) + "\" alt=\"" +
           xml_escape(caption.empty() ? relative_path : caption) + "\"" +
           (width > 0 ? " width=\"" + std::to_string(width) + "\"" : std::string()) + "/>";
  if (!caption.empty()) body_ += "<figcaption>" + xml_escape(caption) + "</figcaption>";
  body_ += "</figure>\n";
}

void HtmlReport::svg(const std::string& svg_text) {
  // Drop an XML declaration if the SVG came from a file.
  std::string s = svg_text;
  if (s.rfind("<?xml", 0) == 0) s.erase(0, s.find("?>") + 2);
  body_ += "<div class=\"plot\">" + s + "</div>\n";
}

std::string HtmlReport::str() const {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>" +
         xml_escape(title_) +
         "</title>\n<style>\nbody { font-family: sans-serif; max-width: 1100px; margin: 2em auto; "
         "}\ntable { border-collapse: collapse; margin: 1em 0; }\nth, td { border: 1px solid "
         "#bbb; padding: 3px 8px; text-align: right; }\nth { background: #eee; }\nfigure { "
         "display: inline-block; margin: 0.5em; }\nimg { image-rendering: pixelated; }\npre { "
         "background: #f4f4f4; padding: 0.5em; }\n</style>\n</head>\n<body>\n" +
         body_ + kImageCheck + "</body>\n</html>\n";
}

void HtmlReport::write(const std::string& path) const {
  write_file_atomic(path, str());
}

}  // namespace spikems
