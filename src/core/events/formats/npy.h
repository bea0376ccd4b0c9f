// NumPy .npy arrays and .npz archives (a ZIP of .npy files), read and written without Python.
//
// Format: https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html
// Supported element types: f4, f8 (and f2 kept as raw bytes), i1..i8, u1..u8, b1, and
// fixed-length strings 'U'/'S' (to_strings()), in any byte order (big-endian input is byte-swapped
// on load, so `data` is always little-endian). Object arrays ('|O', pickled Python objects) and
// structured dtypes are rejected with a clear error. Fortran-ordered arrays are transposed on load
// into C order (fortran_order is then false).
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "core/events/formats/zip.h"
#include "core/util/error.h"

namespace spikems {

struct NpyArray {
  std::string descr;  // numpy dtype descr, e.g. "<f4", "<i8", "|u1", "<u2", "|b1"
  std::vector<int64_t> shape;
  bool fortran_order = false;
  std::vector<uint8_t> data;  // raw little-endian element bytes, C order

  int64_t numel() const;
  size_t itemsize() const;  // bytes per element
  // Converts every element of a numeric array (f4, f8, i1..i8, u1..u8, b1) to T with a C++
  // static_cast; throws Error for other element types.
  template <typename T>
  std::vector<T> to() const;
  // Elements of a fixed-length string array ('<U', '|S'), trailing NULs removed, as UTF-8.
  std::vector<std::string> to_strings() const;
  template <typename T>
  static NpyArray from(const std::vector<T>& v, std::vector<int64_t> shape);
};

NpyArray parse_npy(const uint8_t* data, size_t n, const std::string& source);
NpyArray read_npy(const std::string& path);
std::vector<uint8_t> serialize_npy(const NpyArray& a);
// The magic, version, header length and header dict of a C-order array of that dtype and shape,
// padded so that the data that follows starts on a 64-byte boundary (128 bytes for any 1-D
// array).
std::vector<uint8_t> npy_header(const std::string& descr, const std::vector<int64_t>& shape);
// npy_header()'s size for any 1-D array: writers that stream a column reserve it and write the
// header once the length is known.
inline constexpr size_t kNpyHeader1d = 128;
void write_npy(const std::string& path, const NpyArray& a);  // atomic

// Keys are the member names without ".npy".
std::map<std::string, NpyArray> read_npz(const std::string& path);
std::map<std::string, NpyArray> parse_npz(const uint8_t* data, size_t n, const std::string& source);
// An npz archive opened once, arrays decoded on demand: lets a reader skip members it cannot
// or need not decode (e.g. EV-IMO's pickled `meta`). A file is read member by member (libzip
// reads its central directory, then only the members asked for); the memory constructor does
// not copy: the caller keeps `data` alive.
class NpzFile {
 public:
  explicit NpzFile(const std::string& path);
  NpzFile(const uint8_t* data, size_t n, std::string source);
  ~NpzFile();
  NpzFile(const NpzFile&) = delete;
  NpzFile& operator=(const NpzFile&) = delete;
  const std::vector<std::string>& keys() const { return keys_; }  // archive order
  bool has(const std::string& key) const;
  NpyArray get(const std::string& key) const;  // errors name "<file>:<key>"
  const std::string& source() const { return source_; }

 private:
  void index();
  std::string source_;
  std::unique_ptr<ZipArchive> zip_;
  std::vector<std::string> keys_;
  std::map<std::string, ZipEntry> entries_;
};

// Atomic; compress = deflate (np.savez_compressed) at `level` (1 fastest .. 9 smallest), else
// stored (np.savez).
void write_npz(const std::string& path, const std::map<std::string, NpyArray>& arrays,
               bool compress, int level = 6);

// The descr numpy uses for a C++ element type ("<f4" for float, ...).
template <typename T>
constexpr const char* npy_descr_of() {
  if constexpr (std::is_same_v<T, bool>)
    return "|b1";
  else if constexpr (std::is_same_v<T, float>)
    return "<f4";
  else if constexpr (std::is_same_v<T, double>)
    return "<f8";
  else if constexpr (std::is_same_v<T, int8_t>)
    return "|i1";
  else if constexpr (std::is_same_v<T, uint8_t>)
    return "|u1";
  else if constexpr (std::is_same_v<T, int16_t>)
    return "<i2";
  else if constexpr (std::is_same_v<T, uint16_t>)
    return "<u2";
  else if constexpr (std::is_same_v<T, int32_t>)
    return "<i4";
  else if constexpr (std::is_same_v<T, uint32_t>)
    return "<u4";
  else if constexpr (std::is_same_v<T, int64_t>)
    return "<i8";
  else if constexpr (std::is_same_v<T, uint64_t>)
    return "<u8";
  else
    static_assert(sizeof(T) == 0, "no numpy dtype for this type");
}

namespace npy_detail {
// Element kind of a descr: 'f', 'i', 'u', 'b' (validated), or throws.
char numeric_kind(const std::string& descr);
template <typename S, typename T>
void convert(const uint8_t* src, size_t n, T* dst) {
  for (size_t i = 0; i < n; ++i) {
    S v;
    std::memcpy(&v, src + i * sizeof(S), sizeof(S));  // data is little-endian, as is the host
    dst[i] = static_cast<T>(v);
  }
}
}  // namespace npy_detail

template <typename T>
std::vector<T> NpyArray::to() const {
  static_assert(std::endian::native == std::endian::little, "spikems assumes a little-endian host");
  const char kind = npy_detail::numeric_kind(descr);
  const size_t n = size_t(numel()), sz = itemsize();
  if (data.size() != n * sz)
    throw Error("npy array of " + descr + ": " + std::to_string(data.size()) +
                " data bytes do not match its shape");
  std::vector<T> out(n);
  const uint8_t* s = data.data();
  using namespace npy_detail;
  if (kind == 'f' && sz == 4)
    convert<float>(s, n, out.data());
  else if (kind == 'f' && sz == 8)
    convert<double>(s, n, out.data());
  else if (kind == 'i' && sz == 1)
    convert<int8_t>(s, n, out.data());
  else if (kind == 'i' && sz == 2)
    convert<int16_t>(s, n, out.data());
  else if (kind == 'i' && sz == 4)
    convert<int32_t>(s, n, out.data());
  else if (kind == 'i' && sz == 8)
    convert<int64_t>(s, n, out.data());
  else if (kind == 'u' && sz == 1)
    convert<uint8_t>(s, n, out.data());
  else if (kind == 'u' && sz == 2)
    convert<uint16_t>(s, n, out.data());
  else if (kind == 'u' && sz == 4)
    convert<uint32_t>(s, n, out.data());
  else if (kind == 'u' && sz == 8)
    convert<uint64_t>(s, n, out.data());
  else if (kind == 'b' && sz == 1)
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<T>(s[i] != 0);
  else
    throw Error("npy element type '" + descr + "' cannot be converted to numbers");
  return out;
}

template <typename T>
NpyArray NpyArray::from(const std::vector<T>& v, std::vector<int64_t> shape) {
  NpyArray a;
  a.descr = npy_descr_of<T>();
  a.shape = std::move(shape);
  if (a.numel() != int64_t(v.size()))
    throw Error("NpyArray::from: shape holds " + std::to_string(a.numel()) + " elements, vector " +
                std::to_string(v.size()));
  a.data.resize(v.size() * sizeof(T));
  if constexpr (std::is_same_v<T, bool>) {
    for (size_t i = 0; i < v.size(); ++i) a.data[i] = v[i] ? 1 : 0;
  } else if (!v.empty()) {
    std::memcpy(a.data.data(), v.data(), a.data.size());
  }
  return a;
}

}  // namespace spikems
