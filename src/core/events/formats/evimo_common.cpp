#include "core/events/formats/evimo_common.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "core/events/formats/pickle.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {

namespace {

class PyLiteral {
 public:
  PyLiteral(const std::string& s, const std::string& src) : s_(s), src_(src) {}
  nlohmann::json parse() {
    auto v = value(0);
    ws();
    if (i_ != s_.size()) bad("unexpected text after the value");
    return v;
  }

 private:
  [[noreturn]] void bad(const std::string& why) {
    fail_at_byte(src_, i_, "cannot parse Python literal: " + why);
  }
  void ws() {
    while (i_ < s_.size()) {
      if (std::isspace(static_cast<unsigned char>(s_[i_])))
        ++i_;
      else if (s_[i_] == '#')
        while (i_ < s_.size() && s_[i_] != '\n') ++i_;
      else
        break;
    }
  }
  bool eat(char c) {
    ws();
    if (i_ < s_.size() && s_[i_] == c) return ++i_, true;
    return false;
  }
  bool word(const char* w) {
    size_t n = std::strlen(w);
    if (s_.compare(i_, n, w) == 0 &&
        (i_ + n == s_.size() || !std::isalnum(static_cast<unsigned char>(s_[i_ + n])))) {
      i_ += n;
      return true;
    }
    return false;
  }
  nlohmann::json value(int depth) {
    if (depth > 64) bad("nesting deeper than 64");
    ws();
    if (i_ >= s_.size()) bad("unexpected end");
    char c = s_[i_];
    if (c == '{') {
      ++i_;
      nlohmann::json o = nlohmann::json::object();
      while (!eat('}')) {
        auto k = value(depth + 1);
        if (!eat(':')) bad("expected ':'");
        std::string key = k.is_string() ? k.get<std::string>() : k.dump();
        o[key] = value(depth + 1);
        if (!eat(',')) {
          if (!eat('}')) bad("expected ',' or '}'");
          break;
        }
      }
      return o;
    }
    if (c == '[' || c == '(') {
      char close = c == '[' ? ']' : ')';
      ++i_;
      nlohmann::json a = nlohmann::json::array();
      while (!eat(close)) {
        a.push_back(value(depth + 1));
        if (!eat(',')) {
          if (!eat(close)) bad(std::string("expected ',' or '") + close + "'");
          break;
        }
      }
      return a;
    }
    if (c == '\'' || c == '"') {
      ++i_;
      std::string out;
      while (i_ < s_.size() && s_[i_] != c) {
        if (s_[i_] == '\\' && i_ + 1 < s_.size()) {
          char e = s_[++i_];
          out += e == 'n' ? '\n' : e == 't' ? '\t' : e;
        } else {
          out += s_[i_];
        }
        ++i_;
      }
      if (i_ >= s_.size()) bad("unterminated string");
      ++i_;
      return out;
    }
    if (word("True")) return true;
    if (word("False")) return false;
    if (word("None")) return nullptr;
    if (word("nan")) return nullptr;
    // A number: integer if it has no '.', 'e' or "inf".
    size_t st = i_;
    while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '.' ||
                              s_[i_] == '-' || s_[i_] == '+'))
      ++i_;
    std::string_view tok(s_.data() + st, i_ - st);
    if (tok.empty()) bad(std::string("unexpected character '") + c + "'");
    const char* b = tok.data() + (tok.front() == '+');
    const char* e = tok.data() + tok.size();
    if (tok.find_first_of(".eE") == std::string_view::npos) {
      int64_t v;
      auto r = std::from_chars(b, e, v);
      if (r.ec == std::errc() && r.ptr == e) return v;
    }
    double d;
    auto r = std::from_chars(b, e, d);
    if (r.ec != std::errc() || r.ptr != e) bad("bad number '" + std::string(tok) + "'");
    return d;
  }
  const std::string& s_;
  const std::string& src_;
  size_t i_ = 0;
};

}  // namespace

nlohmann::json parse_python_literal(const std::string& text, const std::string& source) {
  return PyLiteral(text, source).parse();
}

std::vector<EvimoFrameInfo> evimo_frames_from_meta(const nlohmann::json& meta,
                                                   const std::string& source) {
  if (!meta.is_object() || !meta.contains("frames") || !meta["frames"].is_array())
    fail(source, "", "EV-IMO meta has no 'frames' list");
  std::vector<EvimoFrameInfo> out;
  for (size_t i = 0; i < meta["frames"].size(); ++i) {
    const auto& f = meta["frames"][i];
    if (!f.is_object() || !f.contains("ts") || !f["ts"].is_number())
      fail(source, "frame " + std::to_string(i), "EV-IMO meta frame has no numeric 'ts'");
    double ts = f["ts"].get<double>();
    if (!std::isfinite(ts) || std::fabs(ts) > 9e12)
      fail(source, "frame " + std::to_string(i), "frame timestamp is not finite");
    EvimoFrameInfo fi;
    fi.t_us = std::llround(ts * 1e6);
    if (f.contains("id") && f["id"].is_number_integer()) fi.id = f["id"].get<int64_t>();
    if (f.contains("gt_frame") && f["gt_frame"].is_string()) fi.gt_frame = f["gt_frame"];
    out.push_back(fi);
  }
  return out;
}

SensorSize evimo_sensor(const ReadOptions& opt, const EventStream& ev, int mask_w, int mask_h) {
  if (opt.sensor.known()) return opt.sensor;
  if (mask_w > 0 && mask_h > 0) return {mask_w, mask_h};
  if (ev.empty()) return {346, 260};
  int mx = *std::max_element(ev.x.begin(), ev.x.end());
  int my = *std::max_element(ev.y.begin(), ev.y.end());
  for (SensorSize s : {SensorSize{240, 180}, SensorSize{346, 260}, SensorSize{640, 480}})
    if (mx < s.width && my < s.height) return s;
  return {mx + 1, my + 1};
}

CameraIntrinsics evimo_intrinsics(const NpyArray& K, const NpyArray* D, const std::string& src) {
  if (K.numel() != 9) fail(src, "array 'K'", "expected a 3x3 camera matrix");
  auto k = K.to<double>();
  CameraIntrinsics c;
  c.fx = k[0];
  c.fy = k[4];
  c.cx = k[2];
  c.cy = k[5];
  if (D) c.distortion = D->to<double>();
  return c;
}

std::vector<int64_t> evimo_mask_times(const std::string& npz_path, bool has_meta,
                                      const std::string& meta_txt, size_t count,
                                      const EventStream& ev, const std::string& mask_name,
                                      nlohmann::json& info) {
  // The times a meta dict's 'frames' list gives, which must describe every mask frame.
  auto listed = [&](const nlohmann::json& meta, const std::string& src) {
    auto frames = evimo_frames_from_meta(meta, src);
    if (frames.size() != count)
      fail(src, "",
           std::to_string(frames.size()) + " frames listed, " + mask_name + " has " +
               std::to_string(count));
    std::vector<int64_t> times;
    for (const auto& f : frames) times.push_back(f.t_us);
    return times;
  };
  if (has_meta) {
    try {
      auto times = listed(unpickle_npz_member(npz_path, "meta"), npz_path + ":meta");
      info["mask_times"] = "meta";
      return times;
    } catch (const Error& e) {
      info["meta_error"] = e.what();
    }
  }
  std::error_code ec;
  if (!meta_txt.empty() && std::filesystem::is_regular_file(meta_txt, ec)) {
    auto bytes = read_file_bytes(meta_txt);
    info["mask_times"] = "meta.txt";
    return listed(parse_python_literal(std::string(bytes.begin(), bytes.end()), meta_txt),
                  meta_txt);
  }
  std::vector<int64_t> times;
  for (size_t i = 0; i < count; ++i)
    times.push_back(ev.empty()
                        ? 0
                        : ev.t_first() + std::llround((double(i) + 0.5) * double(ev.duration_us()) /
                                                      double(count)));
  info["mask_times"] = "uniform-estimate";
  return times;
}

}  // namespace spikems
