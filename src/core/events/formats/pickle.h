// A restricted unpickler: reads Python pickles (protocols 0-5) that hold only plain data (and
// numpy arrays, interpreted here), and refuses everything that would make Python import or call
// code. Written from the opcode
// descriptions in CPython's Lib/pickletools.py.
//
// Accepted: None, True/False, ints (INT, BININT*, LONG, LONG1/LONG4 within int64), floats
// (FLOAT, BINFLOAT), str (STRING, BINSTRING, SHORT_BINSTRING, UNICODE, BINUNICODE,
// SHORT_BINUNICODE, BINUNICODE8), bytes/bytearray (BINBYTES, SHORT_BINBYTES, BINBYTES8,
// BYTEARRAY8), tuples, lists, dicts, sets/frozensets, the memo (PUT/BINPUT/LONG_BINPUT/MEMOIZE,
// GET/BINGET/LONG_BINGET), MARK, POP, POP_MARK, DUP, PROTO, FRAME, STOP; and numpy arrays in the
// layout ndarray.__reduce__ writes (pickle_numpy.h), which is how np.save / np.savez store an
// object array such as np.savez(meta=dict)'s: GLOBAL/STACK_GLOBAL of exactly
// numpy.core.multiarray._reconstruct, numpy._core.multiarray._reconstruct, numpy.ndarray and
// numpy.dtype; REDUCE only as _reconstruct(ndarray, shape, bytes) and dtype(str, bool, bool);
// BUILD only on what those made. Nothing is imported or called: these names are markers that
// this code interprets. An object array ('O8'/'O4') becomes its one element when 0-d, else
// nested lists of its elements (row-major); a numeric one ('<f8' '<f4' '<i8' '<i4' '<u2' '|u1'
// '|b1') nested lists of numbers (bools for '|b1'); other dtypes are refused.
// Refused with an Error naming the opcode: GLOBAL and STACK_GLOBAL of any other name, REDUCE and
// BUILD in any other layout, INST, OBJ, NEWOBJ, NEWOBJ_EX, EXT1/2/4 (they import or call Python
// code), PERSID, BINPERSID, NEXT_BUFFER, READONLY_BUFFER (they need the pickler's out-of-band
// state) and unknown bytes. Consequences: protocols 0-2 write bytes and sets through REDUCE, so
// those are refused there, including a numpy array pickled by Python 3 with protocol 2, whose
// b'b' is _codecs.encode('b', 'latin1') (older numpy's np.save used protocol 2, later ones 3,
// numpy 2 uses 4; Python 2's protocol 2 writes a str and is accepted); numpy scalars
// (np.float64(1.5) is numpy.core.multiarray.scalar) are refused.
//
// Result, as nlohmann::json (the type parse_python_literal in evimo_common.h returns, so the same
// code reads meta.txt and a pickled meta): None -> null, bool, int -> int64, float -> double
// (NaN/inf kept), str -> string (UTF-8), bytes/bytearray -> json binary (no subtype), tuple,
// list, set, frozenset -> array (in pickle order), dict -> object whose keys are str keys as
// they are and other keys as their JSON text (1 -> "1", (1, 2) -> "[1,2]"), as
// parse_python_literal does; keys that collide keep the last value.
// Shared sub-objects (the memo) are copied into each place they appear; a container holding
// itself, nesting deeper than kPickleMaxDepth or expanding to more than kPickleMaxValues values
// (a numpy array's elements and nested lists count too) is an Error, as are truncated input,
// stack underflow, a missing MARK, a bad memo index and lengths past the end. Bytes after STOP are
// ignored, as Python does.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace spikems {

constexpr int kPickleMaxDepth = 1000;
constexpr uint64_t kPickleMaxValues = uint64_t(1) << 24;

// Decodes one pickle. Errors read "<source>: at byte <base_offset + offset>: <reason>".
nlohmann::json unpickle(const uint8_t* data, size_t n, const std::string& source,
                        uint64_t base_offset = 0);

// The Python object np.savez stored as `key` in an npz archive: the member `key`.npy is an npy
// of dtype '|O' whose data is a pickle (a member that is a bare pickle is accepted too). Only that
// member is read. Errors name "<npz_path>:<key>" and the byte within the member.
nlohmann::json unpickle_npz_member(const std::string& npz_path, const std::string& key);

}  // namespace spikems
