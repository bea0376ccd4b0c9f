// A self-contained HTML report page, built piece by piece: headings, paragraphs, tables,
// images by relative path and inline SVG charts. The output is well-formed XHTML-style markup
// (every element closed), so it can be checked and parsed by simple tools. A small script marks
// <body data-images-ok="true"> once every image has loaded (false if one failed).
#pragma once

#include <string>
#include <vector>

namespace spikems {

class HtmlReport {
 public:
  explicit HtmlReport(std::string title);
  void heading(const std::string& text, int level = 2);  // level 1..6
  void paragraph(const std::string& text);
  // Preformatted text (commands, logs).
  void code(const std::string& text);
  // A table; rows shorter than the header are padded with empty cells.
  void table(const std::vector<std::string>& header,
             const std::vector<std::vector<std::string>>& rows, const std::string& caption = "");
  // An image by path relative to the report (not embedded), with an optional caption.
  void image(const std::string& relative_path, const std::string& caption = "", int width = 0);
  // An SVG document inserted inline (e.g. from svg_line_plot).
  void svg(const std::string& svg_text);
  std::string str() const;
  void write(const std::string& path) const;  // atomic

 private:
  std::string title_;
  std::string body_;
};

}  // namespace spikems
