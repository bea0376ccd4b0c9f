// The documentation is tested: every `spikems ...` example in README.md and docs/cli.md parses
// with the built program (SPIKEMS_PARSE_ONLY=1: option names, types and ranges are checked,
// nothing runs), every script README.md names exists, and every relative link in README.md,
// CHANGELOG.md, models/ and docs/ resolves, anchors included.
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/test_paths.h"

namespace fs = std::filesystem;
using spikems::test::run_command;
using spikems::test::source_dir;

namespace {

struct Line {
  std::string file;
  int number;  // 1-based
  std::string text;
};

std::vector<std::string> read_lines(const fs::path& p) {
  std::ifstream in(p);
  EXPECT_TRUE(in.good()) << "cannot read " << p;
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

// Lines inside fenced code blocks (```), with shell continuations (trailing '\') joined.
std::vector<Line> code_lines(const fs::path& p) {
  std::vector<Line> out;
  bool in_code = false;
  std::string pending;
  int pending_line = 0;
  int n = 0;
  for (const auto& l : read_lines(p)) {
    ++n;
    if (l.rfind("```", 0) == 0) {
      in_code = !in_code;
      continue;
    }
    if (!in_code) continue;
    if (pending.empty()) pending_line = n;
    if (!l.empty() && l.back() == '\\') {
      pending += l.substr(0, l.size() - 1) + " ";
      continue;
    }
    out.push_back({p.filename().string(), pending_line, pending + l});
    pending.clear();
  }
  return out;
}

// Splits a shell line at |, &&, || and ; outside quotes, after dropping a trailing "# comment".
std::vector<std::string> shell_segments(const std::string& line) {
  std::vector<std::string> segs;
  std::string cur;
  char quote = 0;
  for (size_t i = 0; i < line.size(); ++i) {
    char c = line[i];
    if (quote) {
      if (c == quote) quote = 0;
      cur += c;
      continue;
    }
    if (c == '\'' || c == '"') {
      quote = c;
      cur += c;
    } else if (c == '#' && (i == 0 || std::isspace(static_cast<unsigned char>(line[i - 1])))) {
      break;
    } else if (c == '|' || c == ';' || (c == '&' && i + 1 < line.size() && line[i + 1] == '&')) {
      if (i + 1 < line.size() && line[i + 1] == c) ++i;
      segs.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  segs.push_back(cur);
  return segs;
}

// The arguments after `spikems` in a segment (leading VAR=value assignments skipped), or
// nullopt where the segment runs something else.
std::optional<std::string> spikems_args(const std::string& seg) {
  static const std::regex re(R"(^\s*(?:[A-Z_][A-Z0-9_]*=\S*\s+)*spikems(\s.*)?$)");
  std::smatch m;
  if (!std::regex_match(seg, m, re)) return std::nullopt;
  return m[1].str();
}

struct Example {
  Line where;
  std::string args;
};

std::vector<Example> examples_in(const fs::path& p) {
  std::vector<Example> out;
  for (const auto& l : code_lines(p))
    for (const auto& seg : shell_segments(l.text))
      if (auto a = spikems_args(seg)) out.push_back({l, *a});
  return out;
}

bool is_torch_command(const std::string& args) {
  std::istringstream s(args);
  std::string cmd;
  s >> cmd;
  return cmd == "train" || cmd == "forward";
}

// Runs `spikems ARGS` in parse-only mode from an empty folder; returns exit status and output.
int parse_only(const std::string& args, const std::string& cwd, std::string* out) {
  return run_command("cd '" + cwd + "' && SPIKEMS_PARSE_ONLY=1 '" +
                         spikems::test::spikems_binary() + "' " + args + " </dev/null",
                     out);
}

void check_examples(const fs::path& doc, size_t at_least) {
  auto ex = examples_in(doc);
  ASSERT_GE(ex.size(), at_least) << doc << ": fewer `spikems` examples than expected; is the "
                                 << "extraction broken?";
  std::string cwd = spikems::test::scratch_dir();
  int checked = 0;
  for (const auto& e : ex) {
    if (e.args.find("...") != std::string::npos) continue;  // an elided command line
    if (!SPIKEMS_TEST_WITH_TRAIN && is_torch_command(e.args)) continue;
    std::string out;
    int rc = parse_only(e.args, cwd, &out);
    EXPECT_EQ(rc, 0) << e.where.file << ":" << e.where.number << ": `spikems" << e.args
                     << "` does not parse:\n"
                     << out;
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

// GitHub's heading anchors: lower case, punctuation dropped, spaces to '-'; repeats get -1, -2.
std::set<std::string> anchors_of(const fs::path& md) {
  std::set<std::string> out;
  std::map<std::string, int> seen;
  bool in_code = false;
  for (const auto& l : read_lines(md)) {
    if (l.rfind("```", 0) == 0) in_code = !in_code;
    if (in_code || l.empty() || l[0] != '#') continue;
    size_t i = l.find_first_not_of('#');
    if (i == std::string::npos || l[i] != ' ') continue;
    std::string slug;
    for (char c : l.substr(i + 1)) {
      unsigned char u = static_cast<unsigned char>(c);
      if (std::isalnum(u) || c == '-' || c == '_' || u >= 0x80)
        slug += static_cast<char>(std::tolower(u));
      else if (c == ' ')
        slug += '-';
    }
    int k = seen[slug]++;
    out.insert(k == 0 ? slug : slug + "-" + std::to_string(k));
  }
  return out;
}

// Markdown links and images outside code: [text](target) and ![alt](target).
std::vector<std::pair<int, std::string>> links_in(const fs::path& md) {
  static const std::regex link(R"(\]\(([^()\s]+)(?:\s+"[^"]*")?\))");
  std::vector<std::pair<int, std::string>> out;
  bool in_code = false;
  int n = 0;
  for (auto l : read_lines(md)) {
    ++n;
    if (l.rfind("```", 0) == 0) {
      in_code = !in_code;
      continue;
    }
    if (in_code) continue;
    l = std::regex_replace(l, std::regex("`[^`]*`"), "");  // inline code is not a link
    for (std::sregex_iterator it(l.begin(), l.end(), link), end; it != end; ++it)
      out.push_back({n, (*it)[1].str()});
  }
  return out;
}

std::vector<fs::path> documentation_files() {
  fs::path root = source_dir();
  std::vector<fs::path> files{root / "README.md", root / "CHANGELOG.md"};
  for (const char* dir : {"docs", "models"}) {
    if (!fs::exists(root / dir)) continue;
    for (const auto& e : fs::recursive_directory_iterator(root / dir))
      if (e.path().extension() == ".md") files.push_back(e.path());
  }
  return files;
}

}  // namespace

TEST(DocsExamples, ReadmeCommandsParse) {
  check_examples(fs::path(source_dir()) / "README.md", 5);
}

TEST(DocsExamples, CliReferenceCommandsParse) {
  check_examples(fs::path(source_dir()) / "docs" / "cli.md", 20);
}

// The check itself can fail: a misspelt option, a bad value and an unknown command are refused.
TEST(DocsExamples, ParseOnlyRefusesBadCommandLines) {
  std::string cwd = spikems::test::scratch_dir(), out;
  EXPECT_NE(parse_only("segment --input x.raw --inptu y", cwd, &out), 0) << out;
  EXPECT_NE(parse_only("render x.raw --window", cwd, &out), 0) << out;
  EXPECT_NE(parse_only("segmnet --input x.raw", cwd, &out), 0) << out;
  EXPECT_EQ(parse_only("segment --input x.raw --out labels.txt", cwd, &out), 0) << out;
  EXPECT_FALSE(fs::exists(fs::path(cwd) / "labels.txt")) << "parse-only mode ran the command";
}

TEST(DocsExamples, ReadmeScriptsExist) {
  int n = 0;
  for (const auto& l : code_lines(fs::path(source_dir()) / "README.md")) {
    for (const auto& seg : shell_segments(l.text)) {
      static const std::regex re(R"(^\s*(?:[A-Z_][A-Z0-9_]*=\S*\s+)*(scripts/\S+))");
      std::smatch m;
      if (!std::regex_search(seg, m, re)) continue;
      fs::path p = fs::path(source_dir()) / m[1].str();
      EXPECT_TRUE(fs::exists(p) &&
                  (fs::status(p).permissions() & fs::perms::owner_exec) != fs::perms::none)
          << "README.md:" << l.number << ": " << m[1] << " is not an executable file";
      ++n;
    }
  }
  EXPECT_GE(n, 2) << "README.md should name its Quickstart scripts";
}

TEST(DocsExamples, VersionIsTheProjectVersion) {
  std::string out;
  ASSERT_EQ(run_command("'" + spikems::test::spikems_binary() + "' --version", &out), 0) << out;
  EXPECT_EQ(out, "spikems " SPIKEMS_PROJECT_VERSION "\n");
}

TEST(DocsLinks, RelativeLinksResolve) {
  int checked = 0;
  for (const auto& md : documentation_files()) {
    if (!fs::exists(md)) {
      ADD_FAILURE() << md << " is missing";
      continue;
    }
    for (const auto& [line, target] : links_in(md)) {
      if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
      std::string path = target, anchor;
      if (auto h = target.find('#'); h != std::string::npos) {
        path = target.substr(0, h);
        anchor = target.substr(h + 1);
      }
      fs::path dest = path.empty() ? md : md.parent_path() / path;
      ++checked;
      if (!fs::exists(dest)) {
        ADD_FAILURE() << md << ":" << line << ": link target " << target << " does not exist";
        continue;
      }
      if (!anchor.empty() && dest.extension() == ".md") {
        auto anchors = anchors_of(dest);
        EXPECT_TRUE(anchors.count(anchor))
            << md << ":" << line << ": no heading for #" << anchor << " in " << dest;
      }
    }
  }
  EXPECT_GT(checked, 20) << "fewer links than the docs index alone holds";
}
