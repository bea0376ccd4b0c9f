#include "core/model/safetensors.h"

#include <algorithm>
#include <cstring>
#include <nlohmann/json.hpp>

#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {

int64_t StTensor::numel() const {
  int64_t n = 1;
  for (auto d : shape) n *= d;
  return n;
}

SafeTensors parse_safetensors(const std::vector<uint8_t>& bytes, const std::string& source) {
  if (bytes.size() < 8) fail_at_byte(source, 0, "file is truncated: no safetensors header length");
  uint64_t hlen = load_le64(bytes.data());
  if (hlen > 100'000'000 || 8 + hlen > bytes.size())
    fail_at_byte(source, 0,
                 "header length " + std::to_string(hlen) +
                     " does not fit in the file (not a safetensors model, or truncated)");
  nlohmann::json h;
  try {
    h = nlohmann::json::parse(bytes.begin() + 8, bytes.begin() + 8 + long(hlen));
  } catch (const std::exception& e) {
    fail_at_byte(source, 8, std::string("header is not valid JSON: ") + e.what());
  }
  if (!h.is_object()) fail_at_byte(source, 8, "header is not a JSON object");
  SafeTensors st;
  const uint64_t data_start = 8 + hlen, data_len = bytes.size() - data_start;
  std::vector<std::pair<uint64_t, uint64_t>> ranges;
  for (auto it = h.begin(); it != h.end(); ++it) {
    if (it.key() == "__metadata__") {
      if (!it->is_object()) fail_at_byte(source, 8, "__metadata__ is not an object");
      for (auto m = it->begin(); m != it->end(); ++m) {
        if (!m->is_string())
          fail_at_byte(source, 8, "metadata value '" + m.key() + "' is not a string");
        st.metadata[m.key()] = m->get<std::string>();
      }
      continue;
    }
    const auto& d = *it;
    const std::string where = "tensor '" + it.key() + "'";
    if (!d.is_object() || !d.contains("dtype") || !d.contains("shape") ||
        !d.contains("data_offsets"))
      fail_at_byte(source, 8, where + " lacks dtype, shape or data_offsets");
    StTensor t;
    try {
      t.dtype = d["dtype"].get<std::string>();
      t.shape = d["shape"].get<std::vector<int64_t>>();
      auto off = d["data_offsets"].get<std::vector<uint64_t>>();
      if (off.size() != 2 || off[0] > off[1] || off[1] > data_len)
        fail_at_byte(source, 8, where + " has data offsets outside the file");
      if (t.dtype != "F32" && t.dtype != "I32")
        fail_at_byte(source, 8, where + " has dtype " + t.dtype + " (spikems reads F32 and I32)");
      int64_t n = 1;
      for (auto s : t.shape) {
        if (s < 0 || s > (int64_t(1) << 31))
          fail_at_byte(source, 8, where + " has an absurd shape");
        n *= s;
        if (n > (int64_t(1) << 34)) fail_at_byte(source, 8, where + " has an absurd shape");
      }
      if (uint64_t(n) * 4 != off[1] - off[0])
        fail_at_byte(source, data_start + off[0],
                     where + ": " + std::to_string(off[1] - off[0]) + " bytes for " +
                         std::to_string(n) + " elements of 4 bytes");
      ranges.push_back({off[0], off[1]});
      const uint8_t* p = bytes.data() + data_start + off[0];
      if (t.dtype == "F32") {
        t.f32.resize(size_t(n));
        std::memcpy(t.f32.data(), p, size_t(n) * 4);
      } else {
        t.i32.resize(size_t(n));
        std::memcpy(t.i32.data(), p, size_t(n) * 4);
      }
    } catch (const nlohmann::json::exception& e) {
      fail_at_byte(source, 8, where + ": " + e.what());
    }
    st.tensors[it.key()] = std::move(t);
  }
  std::sort(ranges.begin(), ranges.end());
  for (size_t i = 1; i < ranges.size(); ++i)
    if (ranges[i].first < ranges[i - 1].second)
      fail_at_byte(source, data_start + ranges[i].first, "tensor data ranges overlap");
  return st;
}

SafeTensors read_safetensors(const std::string& path) {
  return parse_safetensors(read_file_bytes(path), path);
}

std::vector<uint8_t> serialize_safetensors(const SafeTensors& st) {
  nlohmann::json h = nlohmann::json::object();
  if (!st.metadata.empty()) h["__metadata__"] = st.metadata;
  uint64_t off = 0;
  for (const auto& [name, t] : st.tensors) {
    uint64_t n = uint64_t(t.numel()) * 4;
    h[name] = {{"dtype", t.dtype}, {"shape", t.shape}, {"data_offsets", {off, off + n}}};
    off += n;
  }
  std::string hs = h.dump();
  while ((8 + hs.size()) % 8) hs.push_back(' ');  // keeps tensor data 8-byte aligned
  std::vector<uint8_t> out(8 + hs.size() + off);
  store_le64(out.data(), hs.size());
  std::memcpy(out.data() + 8, hs.data(), hs.size());
  uint8_t* p = out.data() + 8 + hs.size();
  for (const auto& [name, t] : st.tensors) {
    size_t n = size_t(t.numel()) * 4;
    if ((t.dtype == "F32" ? t.f32.size() : t.i32.size()) * 4 != n)
      throw Error("tensor '" + name + "': data size does not match its shape");
    std::memcpy(p, t.dtype == "F32" ? static_cast<const void*>(t.f32.data()) : t.i32.data(), n);
    p += n;
  }
  return out;
}

void write_safetensors(const std::string& path, const SafeTensors& st) {
  auto bytes = serialize_safetensors(st);
  AtomicFile f(path);
  f.write(bytes.data(), bytes.size());
  f.commit();
}

}  // namespace spikems
