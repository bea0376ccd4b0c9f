#include "legacy/legacy_flatbuffer.h"

#include <cstring>

#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems::legacy {

void FlatView::bad(size_t pos, const std::string& what) const {
  fail_at_byte(source_, base_ + pos, "corrupt FlatBuffers data: " + what);
}

uint32_t FlatView::u32(size_t pos) const {
  if (pos > n_ || n_ - pos < 4) bad(pos, "offset points past the end of the buffer");
  return load_le32(d_ + pos);
}

size_t FlatView::root(const char* identifier) const {
  if (n_ < 8) bad(0, "buffer of " + std::to_string(n_) + " bytes is too small for a root table");
  if (identifier && std::memcmp(d_ + 4, identifier, 4) != 0)
    bad(4, std::string("file identifier is not '") + identifier + "'");
  size_t r = u32(0);
  if (r < 4 || r > n_ - 4) bad(0, "root table offset " + std::to_string(r) + " is out of range");
  return r;
}

size_t FlatView::field(size_t table, int id, size_t bytes) const {
  int32_t soff = int32_t(u32(table));
  int64_t vt = int64_t(table) - soff;
  if (vt < 0 || vt > int64_t(n_) - 4) bad(table, "vtable offset is out of range");
  size_t vtable = size_t(vt);
  uint16_t vt_size = load_le16(d_ + vtable);
  uint16_t tbl_size = load_le16(d_ + vtable + 2);
  if (vt_size < 4 || (vt_size & 1) || vtable + vt_size > n_) bad(vtable, "bad vtable size");
  if (table + tbl_size > n_) bad(table, "table extends past the end of the buffer");
  size_t slot = 4 + 2 * size_t(id);
  if (slot + 2 > vt_size) return 0;
  uint16_t off = load_le16(d_ + vtable + slot);
  if (off == 0) return 0;
  if (off < 4 || size_t(off) + bytes > tbl_size) bad(vtable + slot, "field lies outside its table");
  return table + off;
}

int32_t FlatView::i32(size_t table, int id, int32_t def) const {
  size_t f = field(table, id, 4);
  return f ? int32_t(load_le32(d_ + f)) : def;
}

int64_t FlatView::i64(size_t table, int id, int64_t def) const {
  size_t f = field(table, id, 8);
  return f ? int64_t(load_le64(d_ + f)) : def;
}

std::string_view FlatView::string(size_t table, int id) const {
  Vector v = vector(table, id, 1);
  return std::string_view(reinterpret_cast<const char*>(d_ + v.pos), v.count);
}

FlatView::Vector FlatView::vector(size_t table, int id, size_t elem_size) const {
  size_t f = field(table, id, 4);
  if (!f) return {};
  uint64_t vec = uint64_t(f) + u32(f);
  if (vec > n_ || n_ - vec < 4) bad(f, "vector offset is out of range");
  uint64_t count = load_le32(d_ + vec);
  uint64_t avail = n_ - vec - 4;
  if (count > avail / elem_size)
    bad(vec, "vector of " + std::to_string(count) + " elements of " + std::to_string(elem_size) +
                 " bytes does not fit in the buffer");
  return {size_t(vec + 4), size_t(count)};
}

void FlatBuilder::pad_to(size_t align, size_t from) {
  while ((buf.size() - from) % align) buf.push_back(0);
}
size_t FlatBuilder::put_u16(uint16_t v) {
  size_t p = buf.size();
  buf.resize(p + 2);
  store_le16(buf.data() + p, v);
  return p;
}
size_t FlatBuilder::put_u32(uint32_t v) {
  size_t p = buf.size();
  buf.resize(p + 4);
  store_le32(buf.data() + p, v);
  return p;
}
size_t FlatBuilder::put_u64(uint64_t v) {
  size_t p = buf.size();
  buf.resize(p + 8);
  store_le64(buf.data() + p, v);
  return p;
}
void FlatBuilder::set_u32(size_t pos, uint32_t v) {
  store_le32(buf.data() + pos, v);
}
void FlatBuilder::put_bytes(const void* p, size_t n) {
  const auto* b = static_cast<const uint8_t*>(p);
  buf.insert(buf.end(), b, b + n);
}

}  // namespace spikems::legacy
