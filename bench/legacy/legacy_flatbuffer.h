// The hand-written FlatBuffers reader that the flatc-generated code replaced, kept only so
// bench_formats_libs can compare both in one process; not part of any shipped target.
// A small, bounds-checked reader and a minimal builder for the few FlatBuffers tables of
// AEDAT 4.0 (IOHeader, EventPacket). Every offset read from the buffer is checked against its
// size before use, so a corrupt file raises spikems::Error and never reads out of bounds.
// Wire format: flatbuffers.dev, "FlatBuffers internals" (little-endian; a table starts with
// an int32 back-offset to its vtable; the vtable lists uint16 field offsets).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace spikems::legacy {

class FlatView {
 public:
  // `source` and `base_offset` (file offset of data[0]) are used in error messages.
  FlatView(const uint8_t* data, size_t size, std::string source, uint64_t base_offset)
      : d_(data), n_(size), source_(std::move(source)), base_(base_offset) {}

  // Position of the root table; checks the 4-byte file identifier when one is given.
  size_t root(const char* identifier = nullptr) const;
  // Position of field `id` inside the table at `table`, or 0 when the field is absent.
  // `bytes` is the size the field must have inside the buffer.
  size_t field(size_t table, int id, size_t bytes) const;
  int32_t i32(size_t table, int id, int32_t def) const;
  int64_t i64(size_t table, int id, int64_t def) const;
  std::string_view string(size_t table, int id) const;  // empty when absent
  struct Vector {
    size_t pos = 0;    // position of the first element
    size_t count = 0;  // number of elements
  };
  // A vector of `elem_size`-byte elements (structs or scalars); count 0 when absent.
  Vector vector(size_t table, int id, size_t elem_size) const;
  const uint8_t* data() const { return d_; }
  size_t size() const { return n_; }
  [[noreturn]] void bad(size_t pos, const std::string& what) const;

 private:
  uint32_t u32(size_t pos) const;
  const uint8_t* d_;
  size_t n_;
  std::string source_;
  uint64_t base_;
};

// Appends little-endian values and lays out one table at a time, front to back.
class FlatBuilder {
 public:
  std::vector<uint8_t> buf;
  void pad_to(size_t align, size_t from = 0);  // zero-pads so that (size - from) % align == 0
  size_t put_u16(uint16_t v);
  size_t put_u32(uint32_t v);
  size_t put_u64(uint64_t v);
  void set_u32(size_t pos, uint32_t v);
  void put_bytes(const void* p, size_t n);
};

}  // namespace spikems::legacy
