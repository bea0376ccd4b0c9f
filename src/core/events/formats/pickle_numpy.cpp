#include "core/events/formats/pickle_numpy.h"

#include <bit>

namespace spikems::pickle_numpy {

namespace {

struct Allowed {
  std::string_view module, name;
  Name what;
};

// The whole allow-list. Adding a line here lets pickles name one more thing: every name must be
// one that pickle.cpp interprets itself (REDUCE and BUILD accept only the layouts above).
constexpr Allowed kAllowed[] = {
    {"numpy.core.multiarray", "_reconstruct", Name::Reconstruct},
    {"numpy._core.multiarray", "_reconstruct", Name::Reconstruct},  // numpy 2
    {"numpy", "ndarray", Name::Ndarray},
    {"numpy", "dtype", Name::Dtype},
};

struct Numeric {
  std::string_view descr;  // byte order + type string
  size_t size;
  Scalar::Kind kind;
  bool is_signed;
};

constexpr Numeric kNumeric[] = {
    {"<f8", 8, Scalar::Float, true}, {"<f4", 4, Scalar::Float, true},
    {"<i8", 8, Scalar::Int, true},   {"<i4", 4, Scalar::Int, true},
    {"<u2", 2, Scalar::Int, false},  {"|u1", 1, Scalar::Int, false},
    {"|b1", 1, Scalar::Bool, false},
};

uint64_t load_le(const uint8_t* p, size_t n) {
  uint64_t v = 0;
  for (size_t k = n; k-- > 0;) v = (v << 8) | p[k];
  return v;
}

Scalar decode_one(const Numeric& t, const uint8_t* p) {
  const uint64_t raw = load_le(p, t.size);
  Scalar s;
  s.kind = t.kind;
  if (t.kind == Scalar::Bool) {
    s.i = raw != 0;
  } else if (t.kind == Scalar::Float) {
    s.f = t.size == 8 ? std::bit_cast<double>(raw) : double(std::bit_cast<float>(uint32_t(raw)));
  } else if (t.is_signed && t.size == 4) {
    s.i = int32_t(uint32_t(raw));
  } else {
    s.i = int64_t(raw);  // i8 as two's complement; u2 and u1 are small
  }
  return s;
}

}  // namespace

std::optional<Name> allowed_name(std::string_view module, std::string_view name) {
  for (const auto& a : kAllowed)
    if (a.module == module && a.name == name) return a.what;
  return std::nullopt;
}

const char* name_text(Name n) {
  switch (n) {
    case Name::Reconstruct:
      return "numpy.core.multiarray._reconstruct";
    case Name::Ndarray:
      return "numpy.ndarray";
    case Name::Dtype:
      return "numpy.dtype";
  }
  return "?";
}

std::optional<uint64_t> element_count(const std::vector<int64_t>& shape, uint64_t limit) {
  if (shape.size() > kMaxDims) return std::nullopt;
  for (int64_t d : shape)
    if (d == 0) return 0;
  uint64_t count = 1;
  for (int64_t d : shape) {
    if (d < 0 || uint64_t(d) > limit / count) return std::nullopt;
    count *= uint64_t(d);
  }
  return count;
}

std::string shape_text(const std::vector<int64_t>& shape) {
  std::string s = "(";
  for (size_t k = 0; k < shape.size(); ++k) s += (k ? ", " : "") + std::to_string(shape[k]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

bool is_object_type(std::string_view type) {
  return type == "O8" || type == "O4";
}

std::string decode_numeric(char order, std::string_view type, std::string_view bytes,
                           const std::vector<int64_t>& shape, uint64_t count, bool fortran,
                           std::vector<Scalar>& out) {
  if (order == 0) return "numpy.dtype '" + std::string(type) + "' has no state (BUILD)";
  const std::string descr = order + std::string(type);
  const Numeric* t = nullptr;
  for (const auto& n : kNumeric)
    if (n.descr == descr) t = &n;
  if (!t)
    return "numpy dtype '" + descr +
           "' is not decoded (accepted: object 'O8'/'O4' and '<f8' '<f4' '<i8' '<i4' '<u2' "
           "'|u1' '|b1')";
  if (bytes.size() / t->size != count || bytes.size() % t->size != 0)
    return "numpy array of shape " + shape_text(shape) + " and dtype '" + descr + "' needs " +
           std::to_string(count) + " x " + std::to_string(t->size) + " bytes, its data has " +
           std::to_string(bytes.size());
  const auto* p = reinterpret_cast<const uint8_t*>(bytes.data());
  out.clear();
  out.reserve(size_t(count));
  if (!fortran || shape.size() < 2) {
    for (uint64_t k = 0; k < count; ++k) out.push_back(decode_one(*t, p + k * t->size));
    return "";
  }
  // Row-major walk over a column-major buffer: element (i0, i1, ...) is at sum(ik * stride_k)
  // with stride_0 = 1, stride_k = stride_{k-1} * shape[k-1].
  const size_t nd = shape.size();
  std::vector<uint64_t> stride(nd, 1), index(nd, 0);
  for (size_t k = 1; k < nd; ++k) stride[k] = stride[k - 1] * uint64_t(shape[k - 1]);
  uint64_t at = 0;
  for (uint64_t e = 0; e < count; ++e) {
    out.push_back(decode_one(*t, p + at * t->size));
    for (size_t k = nd; k-- > 0;) {  // next row-major index, last dimension fastest
      at += stride[k];
      if (++index[k] < uint64_t(shape[k])) break;
      at -= stride[k] * index[k];
      index[k] = 0;
    }
  }
  return "";
}

}  // namespace spikems::pickle_numpy
