// Minimal safetensors reader/writer (the layout of huggingface/safetensors: an 8-byte
// little-endian header length, a JSON header naming each tensor's dtype, shape and byte
// range, then the raw little-endian data). Python users open our files with
// `safetensors.numpy.load_file`. Only F32 and I32 tensors are used by spikems.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace spikems {

struct StTensor {
  std::string dtype = "F32";  // "F32" or "I32"
  std::vector<int64_t> shape;
  std::vector<float> f32;    // when dtype == F32
  std::vector<int32_t> i32;  // when dtype == I32
  int64_t numel() const;
};

struct SafeTensors {
  std::map<std::string, StTensor> tensors;
  std::map<std::string, std::string> metadata;  // "__metadata__": string -> string
};

// Reads and validates (header size, JSON, dtypes, offsets inside the file, no overlaps,
// numel matches bytes); errors name the file and the byte offset.
SafeTensors read_safetensors(const std::string& path);
SafeTensors parse_safetensors(const std::vector<uint8_t>& bytes, const std::string& source);
// Atomic write.
void write_safetensors(const std::string& path, const SafeTensors& st);
std::vector<uint8_t> serialize_safetensors(const SafeTensors& st);

}  // namespace spikems
