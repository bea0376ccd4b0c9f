// Thin helpers over the HDF5 C API: owned handles, errors as spikems::Error naming the file
// and the object, 1-D extendible datasets (chunked, shuffle + deflate), range reads.
#pragma once

#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

namespace spikems {

// An owned hid_t, closed with the right H5*close for its type.
class H5Handle {
 public:
  H5Handle() = default;
  explicit H5Handle(hid_t id) : id_(id) {}
  ~H5Handle() { reset(); }
  H5Handle(H5Handle&& o) noexcept : id_(o.id_) { o.id_ = -1; }
  H5Handle& operator=(H5Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_;
      o.id_ = -1;
    }
    return *this;
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  void reset();
  // reset() that reports whether HDF5's close succeeded (a file's close writes what is left of
  // its metadata, and can fail on a full disk).
  bool close();

 private:
  hid_t id_ = -1;
};

// Silences HDF5's own error printing once per process (errors are reported as exceptions).
void h5_quiet();
bool h5_is_hdf5(const std::string& path);  // signature check, no exception
H5Handle h5_open_read(const std::string& path);
bool h5_exists(hid_t file, const std::string& path);  // "/a/b/c", every level checked
H5Handle h5_open_dataset(hid_t file, const std::string& path, const std::string& src);
// Element count of a dataset, which must be 1-D (or, with allow_nd, its shape).
uint64_t h5_length_1d(hid_t dset, const std::string& src, const std::string& name);
// The columns GROUP/t, x, y, p of an event table (DSEC and spikems-h5 share this layout),
// checked to be 1-D and of one length.
struct H5EventColumns {
  H5Handle t, x, y, p;
  uint64_t n = 0;
};
H5EventColumns h5_open_event_columns(hid_t file, const std::string& group, const std::string& src);
std::vector<uint64_t> h5_shape(hid_t dset);
// Reads elements [offset, offset+n) of a 1-D dataset, converting to the memory type.
void h5_read_range(hid_t dset, hid_t mem_type, uint64_t offset, uint64_t n, void* out,
                   const std::string& src, const std::string& name);
void h5_read_all(hid_t dset, hid_t mem_type, void* out, const std::string& src,
                 const std::string& name);

// Creation.
H5Handle h5_create_file(const std::string& path);
H5Handle h5_create_group(hid_t parent, const std::string& name, const std::string& src);
// 1-D dataset of unlimited length, chunked (chunk elements), shuffle + deflate(level) when
// level > 0.
H5Handle h5_create_extendible(hid_t parent, const std::string& name, hid_t file_type,
                              uint64_t chunk, int level, const std::string& src);
void h5_append(hid_t dset, hid_t mem_type, const void* data, uint64_t n, uint64_t& length,
               const std::string& src, const std::string& name);
// Fixed-shape dataset written at once; chunk dims (empty: contiguous).
void h5_write_array(hid_t parent, const std::string& name, hid_t file_type, hid_t mem_type,
                    const std::vector<uint64_t>& shape, const void* data,
                    const std::vector<uint64_t>& chunk, int level, const std::string& src);

// Attributes on an object.
void h5_set_attr_int(hid_t obj, const std::string& name, int64_t v, const std::string& src);
void h5_set_attr_string(hid_t obj, const std::string& name, const std::string& v,
                        const std::string& src);
bool h5_get_attr_int(hid_t obj, const std::string& name, int64_t& v);
bool h5_get_attr_string(hid_t obj, const std::string& name, std::string& v);

}  // namespace spikems
