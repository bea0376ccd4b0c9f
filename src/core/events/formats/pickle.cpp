#include "core/events/formats/pickle.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/events/formats/pickle_numpy.h"
#include "core/events/formats/zip.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

struct OpName {
  uint8_t code;
  const char* name;
};

// Every opcode of protocols 0-5 (pickletools.opcodes), for messages.
// clang-format off
constexpr OpName kOpNames[] = {
    {'I', "INT"}, {'J', "BININT"}, {'K', "BININT1"}, {'M', "BININT2"}, {'L', "LONG"},
    {0x8a, "LONG1"}, {0x8b, "LONG4"}, {'S', "STRING"}, {'T', "BINSTRING"},
    {'U', "SHORT_BINSTRING"}, {'B', "BINBYTES"}, {'C', "SHORT_BINBYTES"}, {0x8e, "BINBYTES8"},
    {0x96, "BYTEARRAY8"}, {0x97, "NEXT_BUFFER"}, {0x98, "READONLY_BUFFER"}, {'N', "NONE"},
    {0x88, "NEWTRUE"}, {0x89, "NEWFALSE"}, {'V', "UNICODE"}, {0x8c, "SHORT_BINUNICODE"},
    {'X', "BINUNICODE"}, {0x8d, "BINUNICODE8"}, {'F', "FLOAT"}, {'G', "BINFLOAT"},
    {']', "EMPTY_LIST"}, {'a', "APPEND"}, {'e', "APPENDS"}, {'l', "LIST"}, {')', "EMPTY_TUPLE"},
    {'t', "TUPLE"}, {0x85, "TUPLE1"}, {0x86, "TUPLE2"}, {0x87, "TUPLE3"}, {'}', "EMPTY_DICT"},
    {'d', "DICT"}, {'s', "SETITEM"}, {'u', "SETITEMS"}, {0x8f, "EMPTY_SET"}, {0x90, "ADDITEMS"},
    {0x91, "FROZENSET"}, {'0', "POP"}, {'2', "DUP"}, {'(', "MARK"}, {'1', "POP_MARK"},
    {'g', "GET"}, {'h', "BINGET"}, {'j', "LONG_BINGET"}, {'p', "PUT"}, {'q', "BINPUT"},
    {'r', "LONG_BINPUT"}, {0x94, "MEMOIZE"}, {0x82, "EXT1"}, {0x83, "EXT2"}, {0x84, "EXT4"},
    {'c', "GLOBAL"}, {0x93, "STACK_GLOBAL"}, {'R', "REDUCE"}, {'b', "BUILD"}, {'i', "INST"},
    {'o', "OBJ"}, {0x81, "NEWOBJ"}, {0x92, "NEWOBJ_EX"}, {0x80, "PROTO"}, {'.', "STOP"},
    {0x95, "FRAME"}, {'P', "PERSID"}, {'Q', "BINPERSID"},
};
// clang-format on

std::string op_name(uint8_t code) {
  for (const auto& o : kOpNames)
    if (o.code == code) return o.name;
  char hex[8];
  std::snprintf(hex, sizeof hex, "0x%02x", code);
  return hex;
}

// Why an opcode is refused, or nullptr for the plain-data ones. GLOBAL, STACK_GLOBAL, REDUCE and
// BUILD are accepted only in numpy's array layout (Unpickler::numpy_op).
const char* refusal(uint8_t code) {
  switch (code) {
    case 'c':
    case 0x93:
    case 'R':
    case 'b':
    case 'i':
    case 'o':
    case 0x81:
    case 0x92:
    case 0x82:
    case 0x83:
    case 0x84:
      return "calls Python code";
    case 'P':
    case 'Q':
      return "needs the pickler's persistent-id resolver";
    case 0x97:
    case 0x98:
      return "needs out-of-band buffers";
    default:
      return nullptr;
  }
}

void append_utf8(std::string& out, uint32_t cp) {
  if (cp < 0x80) {
    out += char(cp);
  } else if (cp < 0x800) {
    out += char(0xC0 | (cp >> 6));
    out += char(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += char(0xE0 | (cp >> 12));
    out += char(0x80 | ((cp >> 6) & 0x3F));
    out += char(0x80 | (cp & 0x3F));
  } else {
    out += char(0xF0 | (cp >> 18));
    out += char(0x80 | ((cp >> 12) & 0x3F));
    out += char(0x80 | ((cp >> 6) & 0x3F));
    out += char(0x80 | (cp & 0x3F));
  }
}

bool is_scalar_value(uint32_t cp) {
  return cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF);
}

// Strict UTF-8 (no overlong forms, surrogates or values past U+10FFFF), so that the JSON
// built from it can always be dumped.
bool valid_utf8(std::string_view s) {
  for (size_t k = 0; k < s.size();) {
    const uint8_t c = uint8_t(s[k]);
    size_t len = c < 0x80             ? 1
                 : (c & 0xE0) == 0xC0 ? 2
                 : (c & 0xF0) == 0xE0 ? 3
                 : (c & 0xF8) == 0xF0 ? 4
                                      : 0;
    if (len == 0 || s.size() - k < len) return false;
    if (len == 1) {
      ++k;
      continue;
    }
    uint32_t cp = c & (0x7F >> len);
    for (size_t j = 1; j < len; ++j) {
      const uint8_t d = uint8_t(s[k + j]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    const uint32_t min = len == 2 ? 0x80 : len == 3 ? 0x800 : 0x10000;
    if (cp < min || !is_scalar_value(cp)) return false;
    k += len;
  }
  return true;
}

// Python 2 str bytes, decoded as Latin-1 (what numpy does for old pickles).
std::string latin1_to_utf8(std::string_view s) {
  std::string out;
  for (char c : s) append_utf8(out, uint8_t(c));
  return out;
}

std::optional<uint32_t> hex_value(std::string_view s) {
  uint32_t v = 0;
  auto r = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// The UNICODE opcode's raw-unicode-escape text: Latin-1 bytes, except that an odd run of
// backslashes before 'u'/'U' starts a \uXXXX / \UXXXXXXXX escape.
std::optional<std::string> raw_unicode_escape(std::string_view s) {
  std::string out;
  for (size_t k = 0; k < s.size();) {
    if (s[k] != '\\') {
      append_utf8(out, uint8_t(s[k++]));
      continue;
    }
    size_t run = 0;
    for (; k < s.size() && s[k] == '\\'; ++k) ++run;
    out.append(run, '\\');
    if (run % 2 == 0 || k == s.size() || (s[k] != 'u' && s[k] != 'U')) continue;
    out.pop_back();
    const size_t digits = s[k] == 'u' ? 4 : 8;
    ++k;
    if (s.size() - k < digits) return std::nullopt;
    auto cp = hex_value(s.substr(k, digits));
    if (!cp || !is_scalar_value(*cp)) return std::nullopt;
    append_utf8(out, *cp);
    k += digits;
  }
  return out;
}

// The STRING opcode's argument: a quoted Python 2 str literal, escapes as codecs.escape_decode.
std::optional<std::string> escape_decode(std::string_view s) {
  std::string out;
  for (size_t k = 0; k < s.size(); ++k) {
    if (s[k] != '\\') {
      out += s[k];
      continue;
    }
    if (++k == s.size()) return std::nullopt;  // a trailing backslash
    const char e = s[k];
    static constexpr std::string_view kFrom = "ntrabfv\\'\"", kTo = "\n\t\r\a\b\f\v\\'\"";
    if (auto at = kFrom.find(e); at != std::string_view::npos) {
      out += kTo[at];
    } else if (e == 'x') {
      auto v = k + 2 < s.size() ? hex_value(s.substr(k + 1, 2)) : std::nullopt;
      if (!v) return std::nullopt;
      out += char(*v);
      k += 2;
    } else if (e >= '0' && e <= '7') {
      unsigned v = 0;
      size_t j = k;
      for (; j < s.size() && j < k + 3 && s[j] >= '0' && s[j] <= '7'; ++j) v = v * 8 + (s[j] - '0');
      out += char(v & 0xFF);
      k = j - 1;
    } else if (e != '\n') {  // unknown escapes stay as written
      out += '\\';
      out += e;
    }
  }
  return out;
}

// Tuple and the kinds after it are containers. NpName, NpDtype and NpArray come from numpy's
// array layout only (pickle_numpy.h): an allow-listed name (i = pickle_numpy::Name), a dtype
// (s = its type string, i = its byte order once BUILD gave it, else 0) and an array (i = 1 once
// BUILD made it; items = {its value}).
enum class Kind : uint8_t {
  None,
  Bool,
  Int,
  Float,
  Str,
  Bytes,
  Tuple,
  List,
  Dict,
  Set,
  NpName,
  NpDtype,
  NpArray
};

const char* kind_name(Kind k) {
  static constexpr const char* kNames[] = {
      "None", "bool", "int", "float",      "str",         "bytes",      "tuple",
      "list", "dict", "set", "numpy name", "numpy.dtype", "numpy array"};
  return kNames[int(k)];
}

// One decoded object. Containers refer to other nodes by index, so that memo references and
// later APPENDs to a memoised list behave as Python's shared references do.
struct Node {
  explicit Node(Kind k = Kind::None, int64_t v = 0) : kind(k), i(v) {}
  Kind kind;
  int64_t i;  // Bool, Int
  double f = 0;
  std::string s;                // Str (UTF-8) or Bytes
  std::vector<uint32_t> items;  // containers; a dict's as key, value, key, value, ...
  uint64_t at = 0;              // offset of the opcode that made it, for errors
};

class Unpickler {
 public:
  Unpickler(const uint8_t* data, size_t n, const std::string& source, uint64_t base)
      : d_(data), n_(n), src_(source), base_(base) {}

  nlohmann::json run() {
    for (;;) {
      if (pos_ >= n_)
        fail_at_byte(src_, base_ + n_, "truncated pickle: it ends without a STOP opcode");
      op_at_ = pos_;
      op_ = d_[pos_++];
      if (op_ == '.') break;
      if (numpy_op()) continue;
      if (refusal(op_)) refuse();
      if (!(scalar_op() || string_op() || container_op() || stack_op()))
        bad("unknown pickle opcode " + op_name(op_) + " (not a pickle, or corrupt)");
    }
    if (!marks_.empty() || stack_.size() != 1)
      bad("malformed pickle: STOP with " + std::to_string(stack_.size()) + " values and " +
          std::to_string(marks_.size()) + " MARKs on the stack (expected one value)");
    state_.assign(nodes_.size(), kUnseen);
    size_.assign(nodes_.size(), 0);
    height_.assign(nodes_.size(), 0);
    check(stack_[0], 0);
    return to_json(stack_[0]);
  }

 private:
  [[noreturn]] void bad(const std::string& why) const { fail_at_byte(src_, base_ + op_at_, why); }
  [[noreturn]] void bad_node(const Node& nd, const std::string& why) const {
    fail_at_byte(src_, base_ + nd.at, why);
  }
  [[noreturn]] void refuse() const {
    bad("refused pickle opcode " + op_name(op_) + " (" + refusal(op_) +
        "): only plain containers, strings and numbers are accepted");
  }

  // ---- input
  const uint8_t* take(uint64_t len) {
    if (len > n_ - pos_)
      bad("truncated pickle: " + op_name(op_) + " needs " + std::to_string(len) + " bytes, only " +
          std::to_string(n_ - pos_) + " are left");
    const uint8_t* p = d_ + pos_;
    pos_ += size_t(len);
    return p;
  }
  std::string_view text(uint64_t len) { return {reinterpret_cast<const char*>(take(len)), len}; }
  uint64_t uint_le(int bytes) {
    const uint8_t* p = take(uint64_t(bytes));
    uint64_t v = 0;
    for (int k = bytes - 1; k >= 0; --k) v = (v << 8) | p[k];
    return v;
  }
  uint64_t uint_be8() {  // BINFLOAT is big-endian
    const uint8_t* p = take(8);
    uint64_t v = 0;
    for (int k = 0; k < 8; ++k) v = (v << 8) | p[k];
    return v;
  }
  uint64_t length4_signed() {  // BINSTRING and LONG4 store a signed length
    const int32_t len = int32_t(uint32_t(uint_le(4)));
    if (len < 0) bad(op_name(op_) + " has a negative length " + std::to_string(len));
    return uint64_t(len);
  }
  std::string_view line() {
    const void* nl = std::memchr(d_ + pos_, '\n', n_ - pos_);
    if (!nl) bad("truncated pickle: " + op_name(op_) + "'s text argument has no end of line");
    const size_t len = size_t(static_cast<const uint8_t*>(nl) - (d_ + pos_));
    std::string_view s(reinterpret_cast<const char*>(d_ + pos_), len);
    pos_ += len + 1;
    return s;
  }
  std::string shown(std::string_view s) const {
    return "'" + std::string(s.substr(0, 40)) + (s.size() > 40 ? "...'" : "'");
  }
  int64_t parse_int(std::string_view s) {
    if (!s.empty() && s[0] == '+') s.remove_prefix(1);
    int64_t v = 0;
    auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    if (r.ec == std::errc::result_out_of_range)
      bad("integer " + shown(s) + " does not fit in 64 bits");
    if (r.ec != std::errc() || r.ptr != s.data() + s.size() || s.empty())
      bad("bad integer " + shown(s) + " in " + op_name(op_));
    return v;
  }
  uint64_t parse_index(std::string_view s) {
    uint64_t v = 0;
    auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    if (r.ec != std::errc() || r.ptr != s.data() + s.size() || s.empty())
      bad("bad memo index " + shown(s) + " in " + op_name(op_));
    return v;
  }
  // LONG1/LONG4: little-endian two's complement of any length; only int64 values fit.
  int64_t decode_long(const uint8_t* p, uint64_t len) {
    if (len == 0) return 0;
    const bool neg = p[len - 1] & 0x80;
    if (len > 8) {
      bool fits = bool(p[7] & 0x80) == neg;
      for (uint64_t k = 8; k < len && fits; ++k) fits = p[k] == (neg ? 0xFF : 0x00);
      if (!fits) bad("integer of " + std::to_string(len) + " bytes does not fit in 64 bits");
    }
    const size_t m = size_t(std::min<uint64_t>(len, 8));
    uint64_t v = 0;
    for (size_t k = 0; k < m; ++k) v |= uint64_t(p[k]) << (8 * k);
    if (neg && m < 8) v |= ~uint64_t(0) << (8 * m);
    return int64_t(v);
  }

  // ---- stack
  uint32_t add_node(Node nd) {
    if (nodes_.size() >= kPickleMaxValues)
      bad("pickle holds more than " + std::to_string(kPickleMaxValues) + " values");
    nd.at = op_at_;
    nodes_.push_back(std::move(nd));
    return uint32_t(nodes_.size() - 1);
  }
  void push_new(Node nd) { stack_.push_back(add_node(std::move(nd))); }
  void push_new(Kind k, int64_t i = 0) { push_new(Node{k, i}); }
  void push_str(std::string s, Kind k = Kind::Str) {
    Node nd{k};
    nd.s = std::move(s);
    push_new(std::move(nd));
  }
  size_t floor() const { return marks_.empty() ? 0 : marks_.back(); }
  void need_values(size_t count) {
    if (stack_.size() - floor() < count)
      bad("stack underflow: " + op_name(op_) + " needs " + std::to_string(count) + " value" +
          (count > 1 ? "s" : "") + (marks_.empty() ? "" : " above the last MARK"));
  }
  uint32_t pop() {
    need_values(1);
    uint32_t v = stack_.back();
    stack_.pop_back();
    return v;
  }
  uint32_t top() {
    need_values(1);
    return stack_.back();
  }
  std::vector<uint32_t> pop_mark() {
    if (marks_.empty()) bad(op_name(op_) + " without a MARK before it");
    std::vector<uint32_t> items(stack_.begin() + std::ptrdiff_t(marks_.back()), stack_.end());
    stack_.resize(marks_.back());
    marks_.pop_back();
    return items;
  }
  std::vector<uint32_t> pop_pairs() {
    auto items = pop_mark();
    if (items.size() % 2) bad(op_name(op_) + " with an odd number of keys and values");
    return items;
  }
  void new_container(Kind k, std::vector<uint32_t> items = {}) {
    Node nd{k};
    nd.items = std::move(items);
    push_new(std::move(nd));
  }
  // APPEND(S), SETITEM(S), ADDITEMS: the container just below the items must be of kind k.
  void add_to(Kind k, const std::vector<uint32_t>& items) {
    Node& c = nodes_[top()];
    if (c.kind != k)
      bad(op_name(op_) + " needs a " + kind_name(k) + " below its items (found " +
          kind_name(c.kind) + ")");
    c.items.insert(c.items.end(), items.begin(), items.end());
  }
  void memo_put(uint64_t index) { memo_[index] = top(); }
  void memo_get(uint64_t index) {
    auto it = memo_.find(index);
    if (it == memo_.end())
      bad(op_name(op_) + " of memo entry " + std::to_string(index) + ", which was never stored");
    stack_.push_back(it->second);
  }

  // ---- opcodes, by group; each returns false for opcodes not its own
  bool scalar_op() {
    switch (op_) {
      case 'N':
        push_new(Kind::None);
        break;
      case 0x88:
        push_new(Kind::Bool, 1);
        break;
      case 0x89:
        push_new(Kind::Bool, 0);
        break;
      case 'I':
        int_line(line());
        break;
      case 'L':
        long_line(line());
        break;
      case 'J':
        push_new(Kind::Int, int32_t(uint32_t(uint_le(4))));
        break;
      case 'K':
        push_new(Kind::Int, int64_t(uint_le(1)));
        break;
      case 'M':
        push_new(Kind::Int, int64_t(uint_le(2)));
        break;
      case 0x8a:
        long_bytes(uint_le(1));
        break;
      case 0x8b:
        long_bytes(length4_signed());
        break;
      case 'F':
        float_line(line());
        break;
      case 'G':
        push_float(std::bit_cast<double>(uint_be8()));
        break;
      default:
        return false;
    }
    return true;
  }
  void int_line(std::string_view s) {  // protocol 0 writes True/False as INT 01/00
    if (s == "01" || s == "00")
      push_new(Kind::Bool, s == "01");
    else
      push_new(Kind::Int, parse_int(s));
  }
  void long_line(std::string_view s) {
    if (!s.empty() && s.back() == 'L') s.remove_suffix(1);
    push_new(Kind::Int, parse_int(s));
  }
  void long_bytes(uint64_t len) {
    const uint8_t* p = take(len);
    push_new(Kind::Int, decode_long(p, len));
  }
  void float_line(std::string_view s) {
    double v = 0;
    auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    if (r.ec != std::errc() || r.ptr != s.data() + s.size() || s.empty())
      bad("bad float " + shown(s) + " in FLOAT");
    push_float(v);
  }
  void push_float(double v) {
    Node nd{Kind::Float};
    nd.f = v;
    push_new(std::move(nd));
  }

  bool string_op() {
    switch (op_) {
      case 'S':
        quoted_string(line());
        break;
      case 'T':
        push_str(latin1_to_utf8(text(length4_signed())));
        break;
      case 'U':
        push_str(latin1_to_utf8(text(uint_le(1))));
        break;
      case 'V':
        unicode_line(line());
        break;
      case 'X':
        utf8_string(uint_le(4));
        break;
      case 0x8c:
        utf8_string(uint_le(1));
        break;
      case 0x8d:
        utf8_string(uint_le(8));
        break;
      case 'B':
        push_str(std::string(text(uint_le(4))), Kind::Bytes);
        break;
      case 'C':
        push_str(std::string(text(uint_le(1))), Kind::Bytes);
        break;
      case 0x8e:
      case 0x96:
        push_str(std::string(text(uint_le(8))), Kind::Bytes);
        break;
      default:
        return false;
    }
    return true;
  }
  void quoted_string(std::string_view s) {
    if (s.size() < 2 || s.front() != s.back() || (s.front() != '\'' && s.front() != '"'))
      bad("the STRING opcode's argument is not quoted");
    auto v = escape_decode(s.substr(1, s.size() - 2));
    if (!v) bad("bad escape in STRING " + shown(s));
    push_str(latin1_to_utf8(*v));
  }
  void unicode_line(std::string_view s) {
    auto v = raw_unicode_escape(s);
    if (!v) bad("bad \\u escape in UNICODE " + shown(s));
    push_str(std::move(*v));
  }
  void utf8_string(uint64_t len) {
    std::string_view s = text(len);
    if (!valid_utf8(s)) bad(op_name(op_) + " string is not valid UTF-8");
    push_str(std::string(s));
  }

  bool container_op() {
    switch (op_) {
      case ')':
        new_container(Kind::Tuple);
        break;
      case ']':
        new_container(Kind::List);
        break;
      case '}':
        new_container(Kind::Dict);
        break;
      case 0x8f:
        new_container(Kind::Set);
        break;
      case 't':
        new_container(Kind::Tuple, pop_mark());
        break;
      case 'l':
        new_container(Kind::List, pop_mark());
        break;
      case 0x91:
        new_container(Kind::Set, pop_mark());
        break;
      case 'd':
        new_container(Kind::Dict, pop_pairs());
        break;
      case 0x85:
      case 0x86:
      case 0x87:
        small_tuple(size_t(op_ - 0x84));
        break;
      case 'a':
        add_to(Kind::List, {pop()});
        break;
      case 'e':
        add_to(Kind::List, pop_mark());
        break;
      case 's':
        set_item();
        break;
      case 'u':
        add_to(Kind::Dict, pop_pairs());
        break;
      case 0x90:
        add_to(Kind::Set, pop_mark());
        break;
      default:
        return false;
    }
    return true;
  }
  void small_tuple(size_t count) {
    need_values(count);
    std::vector<uint32_t> items(stack_.end() - std::ptrdiff_t(count), stack_.end());
    stack_.resize(stack_.size() - count);
    new_container(Kind::Tuple, std::move(items));
  }
  void set_item() {
    need_values(3);  // dict, key, value
    const uint32_t v = pop(), k = pop();
    add_to(Kind::Dict, {k, v});
  }

  bool stack_op() {
    switch (op_) {
      case '(':
        mark();
        break;
      case '0':
        pop_value_or_mark();
        break;
      case '1':
        pop_mark();
        break;
      case '2':
        stack_.push_back(top());
        break;
      case 'p':
        memo_put(parse_index(line()));
        break;
      case 'q':
        memo_put(uint_le(1));
        break;
      case 'r':
        memo_put(uint_le(4));
        break;
      case 0x94:
        memo_put(memo_.size());
        break;
      case 'g':
        memo_get(parse_index(line()));
        break;
      case 'h':
        memo_get(uint_le(1));
        break;
      case 'j':
        memo_get(uint_le(4));
        break;
      case 0x80:
        protocol(uint_le(1));
        break;
      case 0x95:
        frame(uint_le(8));
        break;
      default:
        return false;
    }
    return true;
  }
  void mark() {
    if (marks_.size() >= size_t(kPickleMaxDepth))
      bad("more than " + std::to_string(kPickleMaxDepth) + " nested MARKs");
    marks_.push_back(stack_.size());
  }
  void pop_value_or_mark() {  // as Python: POP on an empty frame drops the MARK itself
    if (stack_.size() > floor())
      stack_.pop_back();
    else if (!marks_.empty())
      marks_.pop_back();
    else
      need_values(1);
  }
  void protocol(uint64_t v) {
    if (v > 5) bad("unsupported pickle protocol " + std::to_string(v) + " (0 to 5 are known)");
  }
  void frame(uint64_t len) {  // frames only group opcodes for buffered reading
    if (len > n_ - pos_)
      bad("truncated pickle: FRAME declares " + std::to_string(len) + " bytes, only " +
          std::to_string(n_ - pos_) + " are left");
  }

  // ---- numpy's array layout (see pickle_numpy.h), the only use of GLOBAL, STACK_GLOBAL, REDUCE
  // and BUILD that is accepted. The allow-listed names become NpName values, REDUCE of
  // _reconstruct(ndarray, shape, b'b') an NpArray under construction, REDUCE of
  // dtype(str, bool, bool) an NpDtype, and BUILD fills those two in. Nothing is imported or
  // called. Anything else is refused: another name or callable as before any of this existed,
  // the wrong arguments or state with a message saying what numpy writes.
  bool numpy_op() {
    switch (op_) {
      case 'c':
        global_line();
        break;
      case 0x93:
        stack_global();
        break;
      case 'R':
        reduce();
        break;
      case 'b':
        build();
        break;
      default:
        return false;
    }
    return true;
  }
  [[noreturn]] void refuse_numpy(const std::string& why) const {
    bad("refused pickle opcode " + op_name(op_) + ": " + why);
  }
  void push_name(pickle_numpy::Name name) { push_new(Node{Kind::NpName, int64_t(name)}); }
  // GLOBAL's "module\nname\n", consumed only when it is an allowed name.
  void global_line() {
    std::string_view rest(reinterpret_cast<const char*>(d_ + pos_), n_ - pos_);
    const size_t a = rest.find('\n');
    const size_t b = a == std::string_view::npos ? a : rest.find('\n', a + 1);
    if (b != std::string_view::npos)
      if (auto name =
              pickle_numpy::allowed_name(rest.substr(0, a), rest.substr(a + 1, b - a - 1))) {
        pos_ += b + 1;
        push_name(*name);
        return;
      }
    refuse();
  }
  void stack_global() {
    if (stack_.size() - floor() >= 2) {
      const Node& module = nodes_[stack_[stack_.size() - 2]];
      const Node& name = nodes_[stack_.back()];
      if (module.kind == Kind::Str && name.kind == Kind::Str)
        if (auto which = pickle_numpy::allowed_name(module.s, name.s)) {
          stack_.resize(stack_.size() - 2);
          push_name(*which);
          return;
        }
    }
    refuse();
  }
  const Node& item(const Node& tuple, size_t k) const { return nodes_[tuple.items[k]]; }
  bool is_name(const Node& nd, pickle_numpy::Name name) const {
    return nd.kind == Kind::NpName && nd.i == int64_t(name);
  }
  bool is_flag(const Node& nd) const {  // numpy writes False/True, older ones 0/1
    return nd.kind == Kind::Bool || (nd.kind == Kind::Int && (nd.i == 0 || nd.i == 1));
  }
  // A shape: a tuple of at most kMaxDims ints >= 0.
  std::optional<std::vector<int64_t>> shape_of(const Node& nd) const {
    if (nd.kind != Kind::Tuple || nd.items.size() > pickle_numpy::kMaxDims) return std::nullopt;
    std::vector<int64_t> shape;
    for (uint32_t k : nd.items) {
      if (nodes_[k].kind != Kind::Int || nodes_[k].i < 0) return std::nullopt;
      shape.push_back(nodes_[k].i);
    }
    return shape;
  }
  // "numpy.ndarray", "int", "(numpy.ndarray, tuple, bytes)", for messages.
  std::string describe(const Node& nd, bool open_tuple = true) const {
    if (nd.kind == Kind::NpName) return pickle_numpy::name_text(pickle_numpy::Name(nd.i));
    if (nd.kind != Kind::Tuple || !open_tuple) return kind_name(nd.kind);
    std::string s = "(";
    for (size_t k = 0; k < nd.items.size() && k < 9; ++k)
      s += (k ? ", " : "") + describe(item(nd, k), false);
    return s + (nd.items.size() > 9 ? ", ...)" : nd.items.size() == 1 ? ",)" : ")");
  }

  void reduce() {
    if (stack_.size() - floor() < 2 || nodes_[stack_[stack_.size() - 2]].kind != Kind::NpName)
      refuse();
    const uint32_t args_at = pop(), fn_at = pop();
    const auto fn = pickle_numpy::Name(nodes_[fn_at].i);
    const Node& args = nodes_[args_at];
    const bool three = args.kind == Kind::Tuple && args.items.size() == 3;
    using pickle_numpy::Name;
    if (fn == Name::Reconstruct && three && is_name(item(args, 0), Name::Ndarray) &&
        shape_of(item(args, 1)) &&
        (item(args, 2).kind == Kind::Bytes || item(args, 2).kind == Kind::Str)) {
      push_new(Node{Kind::NpArray, 0});
      return;
    }
    if (fn == Name::Dtype && three && item(args, 0).kind == Kind::Str && is_flag(item(args, 1)) &&
        is_flag(item(args, 2))) {
      Node nd{Kind::NpDtype, 0};
      nd.s = item(args, 0).s;
      push_new(std::move(nd));
      return;
    }
    refuse_numpy(std::string(pickle_numpy::name_text(fn)) + " called with " + describe(args) +
                 "; only numpy.core.multiarray._reconstruct(numpy.ndarray, shape tuple, bytes) "
                 "and numpy.dtype(str, bool, bool) are accepted");
  }

  void build() {
    if (stack_.size() - floor() < 2) refuse();
    const uint32_t target = stack_[stack_.size() - 2];
    const Kind kind = nodes_[target].kind;
    if (kind != Kind::NpDtype && kind != Kind::NpArray) refuse();
    const uint32_t state = pop();
    if (nodes_[target].i != 0) refuse_numpy(std::string(kind_name(kind)) + " given a state twice");
    if (kind == Kind::NpDtype)
      build_dtype(nodes_[target], nodes_[state]);
    else
      build_array(target, nodes_[state]);
  }
  // numpy writes (version, byte order, subarray, names, fields, elsize, alignment, flags
  // [, metadata]): the byte order is kept, the rest is ignored (only the type strings that
  // pickle_numpy accepts are ever used, and none of them has fields or a subarray).
  void build_dtype(Node& dtype, const Node& st) {
    const bool ok = st.kind == Kind::Tuple && st.items.size() >= 2 &&
                    item(st, 0).kind == Kind::Int && item(st, 1).kind == Kind::Str &&
                    item(st, 1).s.size() == 1 &&
                    std::string_view("<>|").find(item(st, 1).s[0]) != std::string_view::npos;
    if (!ok)
      refuse_numpy("numpy.dtype state " + describe(st) +
                   " is not (version, '<' '>' or '|', ...) as numpy writes it");
    dtype.i = item(st, 1).s[0];
  }
  // numpy writes (1, shape, dtype, is_fortran, data).
  void build_array(uint32_t target, const Node& st) {
    std::optional<std::vector<int64_t>> shape;
    const bool ok = st.kind == Kind::Tuple && st.items.size() == 5 &&
                    item(st, 0).kind == Kind::Int && item(st, 0).i == 1 &&
                    (shape = shape_of(item(st, 1))) && item(st, 2).kind == Kind::NpDtype &&
                    is_flag(item(st, 3));
    if (!ok)
      refuse_numpy("numpy array state " + describe(st) +
                   " is not (1, shape tuple, numpy.dtype, bool, data) as numpy writes it");
    // st, dtype and data are not used once add_node() may have moved the nodes.
    const Node& dtype = item(st, 2);
    const Node& data = item(st, 4);
    const bool fortran = item(st, 3).i != 0;
    if (dtype.i == 0) refuse_numpy("numpy.dtype '" + dtype.s + "' has no state (BUILD)");
    const auto count = pickle_numpy::element_count(*shape, kPickleMaxValues);
    if (!count)
      refuse_numpy("numpy array of shape " + pickle_numpy::shape_text(*shape) + " has more than " +
                   std::to_string(kPickleMaxValues) + " elements");
    std::vector<uint32_t> flat;
    if (pickle_numpy::is_object_type(dtype.s)) {
      if (data.kind != Kind::List || data.items.size() != *count)
        refuse_numpy("a numpy object array of shape " + pickle_numpy::shape_text(*shape) +
                     " needs a list of " + std::to_string(*count) + " items, its data is a " +
                     kind_name(data.kind) +
                     (data.kind == Kind::List ? " of " + std::to_string(data.items.size()) : ""));
      flat = data.items;  // numpy copies the items out here: later APPENDs do not reach it
    } else {
      if (data.kind != Kind::Bytes)
        refuse_numpy("a numeric numpy array's data must be bytes, not " +
                     std::string(kind_name(data.kind)));
      std::vector<pickle_numpy::Scalar> values;
      const std::string why = pickle_numpy::decode_numeric(char(dtype.i), dtype.s, data.s, *shape,
                                                           *count, fortran, values);
      if (!why.empty()) refuse_numpy(why);
      flat.reserve(values.size());
      for (const auto& v : values) {
        using S = pickle_numpy::Scalar;
        Node nd{v.kind == S::Bool ? Kind::Bool : v.kind == S::Int ? Kind::Int : Kind::Float, v.i};
        nd.f = v.f;
        flat.push_back(add_node(std::move(nd)));
      }
    }
    const uint32_t value = nest(*shape, *count, std::move(flat));
    nodes_[target].items = {value};
    nodes_[target].i = 1;
  }
  // Nests row-major elements into lists by `shape`; a 0-d array is its one element.
  uint32_t nest(const std::vector<int64_t>& shape, uint64_t count, std::vector<uint32_t> level) {
    if (shape.empty()) return level.at(0);
    // Lists made: 1 + shape[0] + shape[0] * shape[1] + ... At most ndim per element, except for
    // an empty array, whose outer dimensions could otherwise ask for any number of empty lists.
    uint64_t lists = 0, groups = 1;
    for (size_t d = 0; d < shape.size(); ++d) {
      lists += groups;
      if (d + 1 < shape.size())  // saturating at kPickleMaxValues + 1
        groups = uint64_t(shape[d]) > kPickleMaxValues / groups ? kPickleMaxValues + 1
                                                                : groups * uint64_t(shape[d]);
    }
    if (lists > shape.size() * count + 4096 || lists > kPickleMaxValues)
      refuse_numpy("numpy array of shape " + pickle_numpy::shape_text(shape) +
                   " would need more than " + std::to_string(shape.size() * count + 4096) +
                   " nested lists");
    for (size_t d = shape.size(); d-- > 0;) {
      const size_t len = size_t(shape[d]);
      uint64_t outer = 1;
      for (size_t k = 0; k < d; ++k) outer *= uint64_t(shape[k]);
      std::vector<uint32_t> next;
      next.reserve(size_t(outer));
      for (uint64_t g = 0; g < outer; ++g) {
        Node nd{Kind::List};
        const auto from = level.begin() + std::ptrdiff_t(g * len);
        nd.items.assign(from, from + std::ptrdiff_t(len));
        next.push_back(add_node(std::move(nd)));
      }
      level = std::move(next);
    }
    return level[0];
  }

  // ---- result
  bool is_container(Kind k) const { return k >= Kind::Tuple; }

  // Walks the object graph before anything is copied: refuses a container that holds itself,
  // nesting deeper than kPickleMaxDepth, and a result (shared objects copied at each place they
  // appear) of more than kPickleMaxValues values, so that a small pickle cannot make a huge
  // result. Recursion stays within the depth limit. Returns the node's size in values. A numpy
  // name, a lone dtype or an array that BUILD never filled in is refused here, where it is part
  // of the result; a built array counts as a container of its value.
  uint64_t check(uint32_t i, int depth) {
    const Node& nd = nodes_[i];
    if (!is_container(nd.kind)) return 1;
    if (nd.kind == Kind::NpName)
      bad_node(nd, "refused " + std::string(pickle_numpy::name_text(pickle_numpy::Name(nd.i))) +
                       " as a value: numpy names are only accepted to rebuild an array");
    if (nd.kind == Kind::NpDtype)
      bad_node(nd, "refused numpy.dtype('" + nd.s + "') as a value: only an array's dtype");
    if (nd.kind == Kind::NpArray && nd.i == 0)
      bad_node(nd, "refused numpy array without its state: _reconstruct's REDUCE has no BUILD");
    if (state_[i] == kVisiting)
      bad_node(nd, "a " + std::string(kind_name(nd.kind)) + " contains itself");
    if (depth >= kPickleMaxDepth || (state_[i] == kDone && depth + height_[i] > kPickleMaxDepth))
      bad_node(nd, "containers nested deeper than " + std::to_string(kPickleMaxDepth));
    if (state_[i] == kDone) return size_[i];
    state_[i] = kVisiting;
    uint64_t size = 1;
    int height = 1;
    for (uint32_t c : nd.items) {
      size = std::min(size + check(c, depth + 1), kPickleMaxValues + 1);
      height = std::max(height, height_[c] + 1);
    }
    if (size > kPickleMaxValues)
      bad_node(nd, "pickle expands to more than " + std::to_string(kPickleMaxValues) +
                       " values (objects shared through the memo are copied)");
    state_[i] = kDone;
    size_[i] = size;
    height_[i] = height;
    return size;
  }

  nlohmann::json to_json(uint32_t i) const {
    const Node& nd = nodes_[i];
    switch (nd.kind) {
      case Kind::None:
        return nullptr;
      case Kind::Bool:
        return nd.i != 0;
      case Kind::Int:
        return nd.i;
      case Kind::Float:
        return nd.f;
      case Kind::Str:
        return nd.s;
      case Kind::Bytes:
        return nlohmann::json::binary(std::vector<uint8_t>(nd.s.begin(), nd.s.end()));
      case Kind::NpArray:  // check() let through only built arrays
        return to_json(nd.items.at(0));
      default:
        break;
    }
    if (nd.kind != Kind::Dict) {
      nlohmann::json out = nlohmann::json::array();
      for (uint32_t item : nd.items) out.push_back(to_json(item));
      return out;
    }
    nlohmann::json out = nlohmann::json::object();
    for (size_t k = 0; k + 1 < nd.items.size(); k += 2) {
      nlohmann::json key = to_json(nd.items[k]);
      out[key.is_string() ? key.get<std::string>() : key.dump()] = to_json(nd.items[k + 1]);
    }
    return out;
  }

  const uint8_t* d_;
  size_t n_;
  const std::string& src_;
  uint64_t base_;
  size_t pos_ = 0, op_at_ = 0;
  uint8_t op_ = 0;
  std::vector<Node> nodes_;
  std::vector<uint32_t> stack_;
  std::vector<size_t> marks_;  // stack sizes at each open MARK
  std::unordered_map<uint64_t, uint32_t> memo_;
  enum : uint8_t { kUnseen, kVisiting, kDone };
  std::vector<uint8_t> state_;  // check(): per node
  std::vector<uint64_t> size_;
  std::vector<int> height_;  // levels of containers, counting the node itself
};

// Where the pickle starts in an npy member of dtype '|O' (0 for a bare pickle).
size_t npy_object_payload(const std::vector<uint8_t>& b, const std::string& src) {
  static constexpr uint8_t kMagic[] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
  if (b.size() < sizeof kMagic || std::memcmp(b.data(), kMagic, sizeof kMagic) != 0) return 0;
  if (b.size() < 10) fail_at_byte(src, b.size(), "truncated npy header");
  const uint8_t major = b[6];
  if (major < 1 || major > 3)
    fail_at_byte(src, 6, "unsupported npy version " + std::to_string(major));
  const size_t len_size = major == 1 ? 2 : 4;
  if (b.size() < 8 + len_size) fail_at_byte(src, b.size(), "truncated npy header");
  const uint64_t header_len = len_size == 2 ? load_le16(&b[8]) : load_le32(&b[8]);
  const uint64_t start = 8 + len_size + header_len;
  if (start > b.size()) fail_at_byte(src, b.size(), "truncated npy header");
  std::string_view header(reinterpret_cast<const char*>(&b[8 + len_size]), size_t(header_len));
  if (header.find("'|O'") == std::string_view::npos)
    fail_at_byte(src, 8 + len_size, "not a pickled object array (dtype '|O')");
  return size_t(start);
}

}  // namespace

nlohmann::json unpickle(const uint8_t* data, size_t n, const std::string& source,
                        uint64_t base_offset) {
  return Unpickler(data, n, source, base_offset).run();
}

nlohmann::json unpickle_npz_member(const std::string& npz_path, const std::string& key) {
  const std::string member = key + ".npy";
  // libzip reads the central directory and this member only (EV-IMO npz files hold
  // gigabytes of depth and masks beside a small meta).
  ZipArchive zip(npz_path);
  const ZipEntry* e = zip.find(member);
  if (!e) fail(npz_path, "", "npz archive has no member '" + member + "'");
  const auto bytes = zip.read(*e);
  const std::string src = npz_path + ":" + key;
  const size_t start = npy_object_payload(bytes, src);
  return unpickle(bytes.data() + start, bytes.size() - start, src, start);
}

}  // namespace spikems
