// Sequential byte input for binary readers, from a file or from memory (fuzzing, tests).
// Tracks the absolute offset so that every error can name the byte where it happened.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace spikems {

class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Reads up to n bytes; returns the count (0 at the end).
  virtual size_t read_some(void* dst, size_t n) = 0;
  // Total size if known (files), else UINT64_MAX.
  virtual uint64_t size() const = 0;
  virtual void seek(uint64_t offset) = 0;
  uint64_t offset() const { return offset_; }
  const std::string& name() const { return name_; }

  // Reads exactly n bytes or throws "truncated" naming `what` and the offset.
  void read_exact(void* dst, size_t n, const char* what);
  // Reads one '\n'-terminated line (without the terminator); false at the end.
  // Lines longer than max_len are an error (binary data mistaken for text).
  bool read_line(std::string& line, size_t max_len = 1 << 20);
  // Peeks at the first bytes without moving (only valid at offset 0 before any read).
  std::vector<uint8_t> head(size_t n);

 protected:
  uint64_t offset_ = 0;
  std::string name_;
};

std::unique_ptr<ByteSource> open_file_source(const std::string& path);
std::unique_ptr<ByteSource> open_memory_source(const uint8_t* data, size_t n,
                                               std::string name = "<memory>");

// Standard input as a source named "<stdin>": size unknown (UINT64_MAX); seeking back is
// possible only within the first 64 KiB (enough for head() and format detection).
std::unique_ptr<ByteSource> open_stdin_source();

// Whole-file helpers.
std::vector<uint8_t> read_file_bytes(const std::string& path);

// Little/big-endian loads that do not care about alignment.
inline uint16_t load_le16(const uint8_t* p) {
  return uint16_t(p[0] | (p[1] << 8));
}
inline uint32_t load_le32(const uint8_t* p) {
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}
inline uint64_t load_le64(const uint8_t* p) {
  return uint64_t(load_le32(p)) | (uint64_t(load_le32(p + 4)) << 32);
}
inline uint16_t load_be16(const uint8_t* p) {
  return uint16_t((p[0] << 8) | p[1]);
}
inline uint32_t load_be32(const uint8_t* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}
inline void store_le16(uint8_t* p, uint16_t v) {
  p[0] = uint8_t(v);
  p[1] = uint8_t(v >> 8);
}
inline void store_le32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i));
}
inline void store_le64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i));
}

}  // namespace spikems
