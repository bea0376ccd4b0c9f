// The numpy part of the restricted unpickler (pickle.h): an explicit allow-list of the numpy
// names a pickle may use, and what they mean as data. Nothing here imports or calls anything:
// the unpickler recognises the names and builds the value itself.
//
// np.save / np.savez store an object array (np.savez(meta=dict) stores a 0-d object array) as
// pickle.dump(array) (protocol 2 in old numpy, then 3, 4 from numpy 2), and ndarray.__reduce__
// writes
//   GLOBAL numpy.core.multiarray._reconstruct       (numpy 2: numpy._core.multiarray._reconstruct)
//   (GLOBAL numpy.ndarray, (0,), b'b') REDUCE       -> an array under construction
//   (1, shape, DTYPE, is_fortran, data) BUILD       -> the array
// with DTYPE = GLOBAL numpy.dtype ('O8', False, True) REDUCE (3, '|', None, None, None, -1, -1,
// 63) BUILD (older numpy writes 0, 1 for False, True). `data` is the list of the elements in
// row-major order for an object dtype, else the raw bytes (column-major when is_fortran).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace spikems::pickle_numpy {

enum class Name : uint8_t { Reconstruct, Ndarray, Dtype };

// The allow-list: which numpy name `module`.`name` is, or nullopt for every other name.
//   numpy.core.multiarray._reconstruct, numpy._core.multiarray._reconstruct -> Reconstruct
//   numpy.ndarray -> Ndarray, numpy.dtype -> Dtype
std::optional<Name> allowed_name(std::string_view module, std::string_view name);

// "numpy.ndarray", ..., for messages.
const char* name_text(Name n);

constexpr size_t kMaxDims = 64;  // numpy 2's NPY_MAXDIMS

// The number of elements of an array of `shape`, or nullopt when it has more than kMaxDims
// dimensions or more than `limit` elements. Dimensions must be >= 0.
std::optional<uint64_t> element_count(const std::vector<int64_t>& shape, uint64_t limit);

// "(2, 3)", "()", "(4,)".
std::string shape_text(const std::vector<int64_t>& shape);

// An object dtype ("O8", or "O4" from a 32-bit numpy): the array's data is a list.
bool is_object_type(std::string_view type);

struct Scalar {
  enum Kind : uint8_t { Bool, Int, Float } kind = Int;
  int64_t i = 0;
  double f = 0;
};

// Decodes a numeric array's data: `count` elements of `shape` whose dtype has the type string
// `type` (the dtype REDUCE's "f8", ...) and byte order `order` (its BUILD state's '<' or '|';
// 0 when there was no BUILD). Accepted: '<f8' '<f4' '<i8' '<i4' '<u2' '|u1' '|b1'. The values
// come out row-major (the bytes are column-major when `fortran`). Returns "" or why the data is
// refused.
std::string decode_numeric(char order, std::string_view type, std::string_view bytes,
                           const std::vector<int64_t>& shape, uint64_t count, bool fortran,
                           std::vector<Scalar>& out);

}  // namespace spikems::pickle_numpy
