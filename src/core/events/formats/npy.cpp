#include "core/events/formats/npy.h"

#include <algorithm>
#include <cctype>
#include <cerrno>

#include "core/events/formats/zip.h"
#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"

namespace spikems {

namespace npy_detail {
char numeric_kind(const std::string& descr) {
  if (descr.size() >= 3) {
    char k = descr[1];
    if (k == 'f' || k == 'i' || k == 'u' || k == 'b') return k;
  }
  throw Error("npy element type '" + descr + "' is not numeric");
}
}  // namespace npy_detail

int64_t NpyArray::numel() const {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

size_t NpyArray::itemsize() const {
  if (descr.size() < 3 || !std::isdigit(static_cast<unsigned char>(descr[2]))) return 0;
  size_t n = size_t(std::stoul(descr.substr(2)));
  return descr[1] == 'U' ? 4 * n : n;
}

std::vector<std::string> NpyArray::to_strings() const {
  if (descr.size() < 3 || (descr[1] != 'U' && descr[1] != 'S'))
    throw Error("npy element type '" + descr + "' is not a string type");
  const size_t item = itemsize(), n = size_t(numel());
  if (data.size() != n * item) throw Error("npy string array: data size does not match shape");
  std::vector<std::string> out(n);
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* e = data.data() + i * item;
    std::string& s = out[i];
    if (descr[1] == 'S') {
      for (size_t k = 0; k < item && e[k]; ++k) s.push_back(char(e[k]));
      continue;
    }
    for (size_t k = 0; k < item; k += 4) {  // UTF-32LE to UTF-8, NUL-padded
      uint32_t c = load_le32(e + k);
      if (c == 0) break;
      if (c < 0x80) {
        s.push_back(char(c));
      } else if (c < 0x800) {
        s.push_back(char(0xC0 | (c >> 6)));
        s.push_back(char(0x80 | (c & 0x3F)));
      } else if (c < 0x10000) {
        s.push_back(char(0xE0 | (c >> 12)));
        s.push_back(char(0x80 | ((c >> 6) & 0x3F)));
        s.push_back(char(0x80 | (c & 0x3F)));
      } else {
        s.push_back(char(0xF0 | ((c >> 18) & 0x07)));
        s.push_back(char(0x80 | ((c >> 12) & 0x3F)));
        s.push_back(char(0x80 | ((c >> 6) & 0x3F)));
        s.push_back(char(0x80 | (c & 0x3F)));
      }
    }
  }
  return out;
}

namespace {

constexpr char kMagic[] = "\x93NUMPY";

// The header is a Python dict literal such as
//   {'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }
// This parser accepts exactly the value kinds numpy writes there.
struct HeaderParser {
  const std::string& s;
  size_t i = 0;
  const std::string& src;
  uint64_t base;  // byte offset of the header text, for error positions

  [[noreturn]] void bad(const std::string& why) {
    fail_at_byte(src, base + i, "malformed .npy header: " + why + " in \"" + s + "\"");
  }
  void ws() {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
  }
  bool eat(char c) {
    ws();
    if (i < s.size() && s[i] == c) {
      ++i;
      return true;
    }
    return false;
  }
  void expect(char c) {
    if (!eat(c)) bad(std::string("expected '") + c + "'");
  }
  std::string str() {
    ws();
    if (i >= s.size() || (s[i] != '\'' && s[i] != '"')) bad("expected a string");
    char q = s[i++];
    size_t j = s.find(q, i);
    if (j == std::string::npos) bad("unterminated string");
    std::string r = s.substr(i, j - i);
    i = j + 1;
    return r;
  }
  bool boolean() {
    ws();
    if (s.compare(i, 4, "True") == 0) return i += 4, true;
    if (s.compare(i, 5, "False") == 0) return i += 5, false;
    bad("expected True or False");
  }
  std::vector<int64_t> tuple() {
    expect('(');
    std::vector<int64_t> r;
    while (!eat(')')) {
      ws();
      size_t st = i;
      while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
      if (i == st || i - st > 15) bad("expected a non-negative dimension below 1e15");
      r.push_back(std::stoll(s.substr(st, i - st)));
      if (r.size() > 32) bad("more than 32 dimensions");
      if (!eat(',')) {
        expect(')');
        break;
      }
    }
    return r;
  }
};

// Swaps every element of `data` in place (big-endian input).
void byteswap(std::vector<uint8_t>& data, size_t item) {
  for (size_t k = 0; k + item <= data.size(); k += item) std::reverse(&data[k], &data[k + item]);
}

// Fortran order (first index fastest) to C order (last index fastest).
std::vector<uint8_t> fortran_to_c(const std::vector<uint8_t>& in, const std::vector<int64_t>& shape,
                                  size_t item) {
  const size_t nd = shape.size();
  std::vector<uint8_t> out(in.size());
  std::vector<int64_t> fstride(nd), idx(nd, 0);
  int64_t st = 1;
  for (size_t k = 0; k < nd; ++k) fstride[k] = st, st *= shape[k];
  const size_t n = in.size() / item;
  int64_t src = 0;
  for (size_t o = 0; o < n; ++o) {
    std::memcpy(&out[o * item], &in[size_t(src) * item], item);
    for (size_t k = nd; k-- > 0;) {  // C-order odometer, tracking the Fortran offset
      if (++idx[k] < shape[k]) {
        src += fstride[k];
        break;
      }
      src -= fstride[k] * (shape[k] - 1);
      idx[k] = 0;
    }
  }
  return out;
}

}  // namespace

namespace {
// Parses and validates everything; the payload goes to `owned` (moved, its header erased)
// when given, else it is copied from data.
NpyArray parse_npy_impl(const uint8_t* data, size_t n, const std::string& source,
                        std::vector<uint8_t>* owned) {
  if (n < 10 || std::memcmp(data, kMagic, 6) != 0)
    fail_at_byte(source, 0, "not a NumPy .npy array: wrong magic bytes");
  const int major = data[6];
  if (major < 1 || major > 3)
    fail_at_byte(source, 6,
                 "unsupported .npy format version " + std::to_string(major) + "." +
                     std::to_string(data[7]) + " (1, 2 and 3 are known)");
  size_t hstart = major == 1 ? 10 : 12;
  if (n < hstart) fail_at_byte(source, n, ".npy header is truncated");
  uint64_t hlen = major == 1 ? load_le16(data + 8) : load_le32(data + 8);
  if (hlen > n - hstart)
    fail_at_byte(source, 8,
                 ".npy header length " + std::to_string(hlen) + " runs past the " +
                     std::to_string(n) + "-byte file (truncated?)");
  std::string header(reinterpret_cast<const char*>(data + hstart), hlen);
  HeaderParser hp{header, 0, source, hstart};
  NpyArray a;
  bool have_descr = false, have_order = false, have_shape = false;
  hp.expect('{');
  while (!hp.eat('}')) {
    std::string key = hp.str();
    hp.expect(':');
    hp.ws();
    if (key == "descr") {
      if (hp.i < header.size() && header[hp.i] == '[')
        fail_at_byte(source, hstart,
                     "structured (record) dtypes are not supported; save each field as its own "
                     "array (np.savez(t=..., x=..., ...))");
      a.descr = hp.str();
      have_descr = true;
    } else if (key == "fortran_order") {
      a.fortran_order = hp.boolean();
      have_order = true;
    } else if (key == "shape") {
      a.shape = hp.tuple();
      have_shape = true;
    } else {
      hp.bad("unknown key '" + key + "'");
    }
    if (!hp.eat(',')) {
      hp.expect('}');
      break;
    }
  }
  if (!have_descr || !have_order || !have_shape)
    hp.bad("missing 'descr', 'fortran_order' or 'shape'");

  // Validate and normalise the element type.
  const std::string& d = a.descr;
  if (d.find('O') != std::string::npos)
    fail_at_byte(source, hstart,
                 "array holds pickled Python objects (dtype '" + d +
                     "'); spikems does not unpickle data: store it as numeric arrays");
  if (d.size() < 3 || std::string("<>|=").find(d[0]) == std::string::npos)
    fail_at_byte(source, hstart, "unsupported .npy dtype '" + d + "'");
  const char kind = d[1];
  std::string digits = d.substr(2);
  if (digits.empty() || digits.size() > 6 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(c); }))
    fail_at_byte(source, hstart, "unsupported .npy dtype '" + d + "'");
  const int count = std::stoi(digits);
  const bool ok =
      (kind == 'f' && (count == 2 || count == 4 || count == 8)) ||
      ((kind == 'i' || kind == 'u') && (count == 1 || count == 2 || count == 4 || count == 8)) ||
      (kind == 'b' && count == 1) || ((kind == 'U' || kind == 'S') && count >= 1);
  if (!ok)
    fail_at_byte(source, hstart,
                 "unsupported .npy dtype '" + d +
                     "' (supported: float16/32/64, int8..64, uint8..64, bool, fixed strings)");
  // 'U' holds count UTF-32 code units; swap unit by unit.
  const int size = kind == 'U' ? 4 * count : count;
  const int swap_unit = kind == 'U' ? 4 : kind == 'S' ? 1 : count;
  const bool big = d[0] == '>' && swap_unit > 1;
  a.descr = std::string(swap_unit == 1 ? "|" : "<") + kind + digits;

  // Shape against payload, without overflow.
  uint64_t numel = 1;
  for (int64_t dim : a.shape)
    if (__builtin_mul_overflow(numel, uint64_t(dim), &numel))
      fail_at_byte(source, hstart, "absurd .npy shape (element count overflows)");
  uint64_t bytes;
  if (__builtin_mul_overflow(numel, uint64_t(size), &bytes))
    fail_at_byte(source, hstart, "absurd .npy shape (byte count overflows)");
  const uint64_t payload = n - hstart - hlen;
  if (bytes != payload)
    fail_at_byte(source, hstart + hlen,
                 "shape needs " + std::to_string(bytes) + " data bytes but the file holds " +
                     std::to_string(payload) + (bytes > payload ? " (truncated?)" : ""));
  if (owned) {
    owned->erase(owned->begin(), owned->begin() + int64_t(hstart + hlen));
    a.data = std::move(*owned);
  } else {
    a.data.assign(data + hstart + hlen, data + n);
  }
  if (big) byteswap(a.data, size_t(swap_unit));
  if (a.fortran_order) {
    if (a.shape.size() > 1) a.data = fortran_to_c(a.data, a.shape, size_t(size));
    a.fortran_order = false;
  }
  return a;
}
}  // namespace

NpyArray parse_npy(const uint8_t* data, size_t n, const std::string& source) {
  return parse_npy_impl(data, n, source, nullptr);
}

NpyArray read_npy(const std::string& path) {
  auto bytes = read_file_bytes(path);
  return parse_npy(bytes.data(), bytes.size(), path);
}

std::vector<uint8_t> npy_header(const std::string& descr, const std::vector<int64_t>& dims) {
  std::string shape = "(";
  for (size_t k = 0; k < dims.size(); ++k) shape += (k ? ", " : "") + std::to_string(dims[k]);
  if (dims.size() == 1) shape += ",";
  shape += ")";
  std::string h = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  // Pad with spaces so that the data starts on a 64-byte boundary; the header ends with '\n'.
  size_t pre = h.size() + 1 < 65536 - 64 ? 10 : 12;
  size_t total = pre + h.size() + 1;
  h.append((64 - total % 64) % 64, ' ');
  h += '\n';
  std::vector<uint8_t> out(pre + h.size());
  std::memcpy(out.data(), kMagic, 6);
  out[6] = pre == 10 ? 1 : 2;
  out[7] = 0;
  if (pre == 10)
    store_le16(out.data() + 8, uint16_t(h.size()));
  else
    store_le32(out.data() + 8, uint32_t(h.size()));
  std::memcpy(out.data() + pre, h.data(), h.size());
  return out;
}

namespace {
std::vector<uint8_t> npy_header(const NpyArray& a) {
  if (a.fortran_order) throw Error("serialize_npy: only C-order arrays are written");
  if (a.itemsize() == 0 || uint64_t(a.numel()) * a.itemsize() != a.data.size())
    throw Error("serialize_npy: " + std::to_string(a.data.size()) +
                " data bytes do not match dtype '" + a.descr + "' and the shape");
  return spikems::npy_header(a.descr, a.shape);
}
}  // namespace

std::vector<uint8_t> serialize_npy(const NpyArray& a) {
  std::vector<uint8_t> out = npy_header(a);
  out.insert(out.end(), a.data.begin(), a.data.end());
  return out;
}

void write_npy(const std::string& path, const NpyArray& a) {
  auto bytes = serialize_npy(a);
  AtomicFile f(path);
  f.write(bytes.data(), bytes.size());
  f.commit();
}

NpzFile::NpzFile(const std::string& path)
    : source_(path), zip_(std::make_unique<ZipArchive>(path)) {
  index();
}

NpzFile::~NpzFile() = default;

NpzFile::NpzFile(const uint8_t* data, size_t n, std::string source)
    : source_(std::move(source)), zip_(std::make_unique<ZipArchive>(data, n, source_)) {
  index();
}

void NpzFile::index() {
  for (const auto& e : zip_->entries()) {
    std::string key = e.name;
    if (key.size() > 4 && key.compare(key.size() - 4, 4, ".npy") == 0)
      key.resize(key.size() - 4);
    else
      continue;  // not an array (numpy's savez writes only .npy members)
    keys_.push_back(key);
    entries_.emplace(key, e);
  }
}

bool NpzFile::has(const std::string& key) const {
  return entries_.count(key) > 0;
}

NpyArray NpzFile::get(const std::string& key) const {
  auto it = entries_.find(key);
  if (it == entries_.end()) {
    std::string known;
    for (const auto& k : keys_) known += (known.empty() ? "" : ", ") + k;
    fail(source_, "", "npz archive has no array '" + key + "' (it has: " + known + ")");
  }
  auto raw = zip_->read(it->second);
  return parse_npy_impl(raw.data(), raw.size(), source_ + ":" + key, &raw);
}

std::map<std::string, NpyArray> parse_npz(const uint8_t* data, size_t n,
                                          const std::string& source) {
  NpzFile f(data, n, source);
  std::map<std::string, NpyArray> out;
  for (const auto& k : f.keys()) out.emplace(k, f.get(k));
  return out;
}

std::map<std::string, NpyArray> read_npz(const std::string& path) {
  NpzFile f(path);
  std::map<std::string, NpyArray> out;
  for (const auto& k : f.keys()) out.emplace(k, f.get(k));
  return out;
}

void write_npz(const std::string& path, const std::map<std::string, NpyArray>& arrays,
               bool compress, int level) {
  // Each member is its npy header followed by the array's own bytes: nothing is copied
  // before libzip reads it.
  std::vector<std::vector<uint8_t>> headers;
  headers.reserve(arrays.size());
  AtomicFile f(path);
  ZipWriter zip(f, compress, level);
  for (const auto& [key, a] : arrays) {
    headers.push_back(npy_header(a));
    zip.add(key + ".npy", {headers.back(), a.data});
  }
  zip.finish();
  f.commit();
}

}  // namespace spikems
