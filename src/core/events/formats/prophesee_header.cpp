#include "core/events/formats/prophesee_header.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>

#include "core/events/formats/camera_reader.h"
#include "core/util/error.h"

namespace spikems {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Sensor sizes of Prophesee sensor generations, for headers that name only the plugin.
SensorSize size_from_generation(const std::string& text) {
  std::string s = lower(text);
  if (s.find("genx320") != std::string::npos) return {320, 320};
  if (s.find("imx636") != std::string::npos || s.find("imx646") != std::string::npos ||
      s.find("gen41") != std::string::npos || s.find("gen4.1") != std::string::npos ||
      s.find("gen4") != std::string::npos)
    return {1280, 720};
  if (s.find("gen31") != std::string::npos || s.find("gen3.1") != std::string::npos ||
      s.find("gen3") != std::string::npos)
    return {640, 480};
  return {};
}

}  // namespace

std::string PropheseeHeader::get(const std::string& key) const {
  std::string k = lower(key);
  for (const auto& [name, value] : fields)
    if (lower(name) == k) return value;
  return "";
}

PropheseeHeader parse_prophesee_header(const std::vector<std::string>& lines,
                                       const std::string& source) {
  PropheseeHeader h;
  for (const auto& line : lines) {
    std::string body = trim(line.substr(1));  // drop the '%'
    size_t sp = body.find_first_of(" \t");
    std::string key = sp == std::string::npos ? body : body.substr(0, sp);
    std::string value = sp == std::string::npos ? "" : trim(body.substr(sp));
    h.fields.emplace_back(key, value);
  }
  std::string format = h.get("format");
  if (!format.empty()) {
    // "EVT3;height=720;width=1280"
    std::string f = lower(format);
    if (f.rfind("evt3", 0) == 0)
      h.evt = "3.0";
    else if (f.rfind("evt21", 0) == 0)
      h.evt = "2.1";
    else if (f.rfind("evt2", 0) == 0)
      h.evt = "2.0";
    auto num = [&](const std::string& k) {
      size_t p = f.find(k + "=");
      return p == std::string::npos ? 0L : std::strtol(f.c_str() + p + k.size() + 1, nullptr, 10);
    };
    long w = num("width"), ht = num("height");
    if (w > 0 && ht > 0 && w <= 65535 && ht <= 65535) h.sensor = {int(w), int(ht)};
  }
  std::string evt = h.get("evt");
  if (!evt.empty()) h.evt = evt;
  if (!h.sensor.known()) h.sensor = parse_geometry(h.get("geometry"));
  if (!h.sensor.known()) {
    long w = std::strtol(h.get("width").c_str(), nullptr, 10);
    long ht = std::strtol(h.get("height").c_str(), nullptr, 10);
    if (w > 0 && ht > 0 && w <= 65535 && ht <= 65535) h.sensor = {int(w), int(ht)};
  }
  if (!h.sensor.known()) {
    for (const char* k : {"sensor_generation", "plugin_name", "camera_integrator_name"}) {
      h.sensor = size_from_generation(h.get(k));
      if (h.sensor.known()) break;
    }
  }
  std::string off = h.get("spikems_time_offset_us");
  if (!off.empty()) {
    char* end = nullptr;
    long long v = std::strtoll(off.c_str(), &end, 10);
    if (end == off.c_str() || v < 0)
      fail(source, "header", "bad spikems_time_offset_us value '" + off + "'");
    h.time_offset_us = v;
  }
  return h;
}

std::string prophesee_header_text(const std::vector<uint8_t>& head) {
  std::string text;
  size_t i = 0;
  while (i < head.size() && head[i] == '%') {
    size_t j = i;
    while (j < head.size() && head[j] != '\n') ++j;
    text.append(reinterpret_cast<const char*>(head.data() + i), j - i);
    text.push_back('\n');
    i = j + 1;
  }
  return lower(text);
}

}  // namespace spikems
