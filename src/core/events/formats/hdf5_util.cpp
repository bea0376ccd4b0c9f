#include "core/events/formats/hdf5_util.h"

#include <cstdio>
#include <cstring>
#include <mutex>
#include <utility>

#include "core/util/error.h"

namespace spikems {

bool H5Handle::close() {
  if (id_ < 0 || H5Iget_type(id_) != H5I_FILE) {
    reset();
    return true;
  }
  return H5Fclose(std::exchange(id_, -1)) >= 0;
}

void H5Handle::reset() {
  if (id_ < 0) return;
  switch (H5Iget_type(id_)) {
    case H5I_FILE:
      H5Fclose(id_);
      break;
    case H5I_GROUP:
      H5Gclose(id_);
      break;
    case H5I_DATASET:
      H5Dclose(id_);
      break;
    case H5I_DATASPACE:
      H5Sclose(id_);
      break;
    case H5I_DATATYPE:
      H5Tclose(id_);
      break;
    case H5I_ATTR:
      H5Aclose(id_);
      break;
    case H5I_GENPROP_LST:
      H5Pclose(id_);
      break;
    default:
      break;
  }
  id_ = -1;
}

void h5_quiet() {
  static std::once_flag once;
  std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

bool h5_is_hdf5(const std::string& path) {
  h5_quiet();
  return H5Fis_hdf5(path.c_str()) > 0;
}

H5Handle h5_open_read(const std::string& path) {
  h5_quiet();
  if (!h5_is_hdf5(path)) fail(path, "", "not an HDF5 file (signature missing, or truncated)");
  H5Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!f.valid()) fail(path, "", "HDF5 library cannot open the file (corrupt or truncated?)");
  return f;
}

bool h5_exists(hid_t file, const std::string& path) {
  size_t pos = 1;
  while (pos <= path.size()) {
    size_t next = path.find('/', pos);
    if (next == std::string::npos) next = path.size();
    std::string prefix = path.substr(0, next);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    pos = next + 1;
  }
  return true;
}

H5Handle h5_open_dataset(hid_t file, const std::string& path, const std::string& src) {
  if (!h5_exists(file, path)) fail(src, "", "HDF5 dataset '" + path + "' is missing");
  H5Handle d(H5Dopen2(file, path.c_str(), H5P_DEFAULT));
  if (!d.valid()) fail(src, "", "cannot open HDF5 dataset '" + path + "'");
  return d;
}

std::vector<uint64_t> h5_shape(hid_t dset) {
  H5Handle sp(H5Dget_space(dset));
  int nd = H5Sget_simple_extent_ndims(sp.get());
  if (nd < 0) return {};
  std::vector<hsize_t> dims(static_cast<size_t>(nd));
  H5Sget_simple_extent_dims(sp.get(), dims.data(), nullptr);
  return std::vector<uint64_t>(dims.begin(), dims.end());
}

uint64_t h5_length_1d(hid_t dset, const std::string& src, const std::string& name) {
  auto s = h5_shape(dset);
  if (s.size() != 1)
    fail(src, "dataset '" + name + "'",
         "expected a 1-D array, found " + std::to_string(s.size()) + "-D");
  return s[0];
}

void h5_read_range(hid_t dset, hid_t mem_type, uint64_t offset, uint64_t n, void* out,
                   const std::string& src, const std::string& name) {
  if (n == 0) return;
  H5Handle fs(H5Dget_space(dset));
  hsize_t len = 0;
  H5Sget_simple_extent_dims(fs.get(), &len, nullptr);
  if (offset > len || n > len - offset)
    fail(src, "dataset '" + name + "'", "read past its end (" + std::to_string(len) + " elements)");
  hsize_t off = offset, cnt = n;
  H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, &off, nullptr, &cnt, nullptr);
  H5Handle ms(H5Screate_simple(1, &cnt, nullptr));
  if (H5Dread(dset, mem_type, ms.get(), fs.get(), H5P_DEFAULT, out) < 0)
    fail(src,
         "dataset '" + name + "' elements " + std::to_string(offset) + ".." +
             std::to_string(offset + n),
         "HDF5 read failed (corrupt chunk, missing filter or wrong type)");
}

void h5_read_all(hid_t dset, hid_t mem_type, void* out, const std::string& src,
                 const std::string& name) {
  if (H5Dread(dset, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out) < 0)
    fail(src, "dataset '" + name + "'", "HDF5 read failed (corrupt data or wrong type)");
}

H5EventColumns h5_open_event_columns(hid_t file, const std::string& group, const std::string& src) {
  H5EventColumns c;
  c.t = h5_open_dataset(file, group + "/t", src);
  c.x = h5_open_dataset(file, group + "/x", src);
  c.y = h5_open_dataset(file, group + "/y", src);
  c.p = h5_open_dataset(file, group + "/p", src);
  c.n = h5_length_1d(c.t.get(), src, group + "/t");
  for (auto* d : {&c.x, &c.y, &c.p})
    if (h5_length_1d(d->get(), src, group) != c.n)
      fail(src, "", "event datasets " + group + "/{t,x,y,p} have different lengths");
  return c;
}

H5Handle h5_create_file(const std::string& path) {
  h5_quiet();
  // No object modification times: the same recording gives the same bytes (the simulator
  // promises this).
  H5Handle fcpl(H5Pcreate(H5P_FILE_CREATE));
  H5Pset_obj_track_times(fcpl.get(), false);
  H5Handle f(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl.get(), H5P_DEFAULT));
  if (!f.valid()) fail(path, "", "cannot create HDF5 file");
  return f;
}

H5Handle h5_create_group(hid_t parent, const std::string& name, const std::string& src) {
  H5Handle gcpl(H5Pcreate(H5P_GROUP_CREATE));
  H5Pset_obj_track_times(gcpl.get(), false);
  H5Handle g(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT));
  if (!g.valid()) fail(src, "", "cannot create HDF5 group '" + name + "'");
  return g;
}

namespace {
void set_filters(hid_t dcpl, int level) {
  if (level > 0) {
    H5Pset_shuffle(dcpl);
    H5Pset_deflate(dcpl, unsigned(level));
  }
}
}  // namespace

H5Handle h5_create_extendible(hid_t parent, const std::string& name, hid_t file_type,
                              uint64_t chunk, int level, const std::string& src) {
  hsize_t dims = 0, maxdims = H5S_UNLIMITED, ch = chunk;
  H5Handle sp(H5Screate_simple(1, &dims, &maxdims));
  H5Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  H5Pset_obj_track_times(dcpl.get(), false);
  H5Pset_chunk(dcpl.get(), 1, &ch);
  set_filters(dcpl.get(), level);
  H5Handle d(
      H5Dcreate2(parent, name.c_str(), file_type, sp.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
  if (!d.valid()) fail(src, "", "cannot create HDF5 dataset '" + name + "'");
  return d;
}

void h5_append(hid_t dset, hid_t mem_type, const void* data, uint64_t n, uint64_t& length,
               const std::string& src, const std::string& name) {
  if (n == 0) return;
  hsize_t newlen = length + n;
  if (H5Dset_extent(dset, &newlen) < 0) fail(src, "", "cannot extend HDF5 dataset '" + name + "'");
  H5Handle fs(H5Dget_space(dset));
  hsize_t off = length, cnt = n;
  H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, &off, nullptr, &cnt, nullptr);
  H5Handle ms(H5Screate_simple(1, &cnt, nullptr));
  if (H5Dwrite(dset, mem_type, ms.get(), fs.get(), H5P_DEFAULT, data) < 0)
    fail(src, "", "HDF5 write to '" + name + "' failed (disk full?)");
  length = newlen;
}

void h5_write_array(hid_t parent, const std::string& name, hid_t file_type, hid_t mem_type,
                    const std::vector<uint64_t>& shape, const void* data,
                    const std::vector<uint64_t>& chunk, int level, const std::string& src) {
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  H5Handle sp(dims.empty() ? H5Screate(H5S_SCALAR)
                           : H5Screate_simple(int(dims.size()), dims.data(), nullptr));
  H5Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  H5Pset_obj_track_times(dcpl.get(), false);
  bool any_zero = false;
  for (auto d : dims) any_zero |= d == 0;
  if (!chunk.empty() && !any_zero) {
    std::vector<hsize_t> ch(chunk.begin(), chunk.end());
    H5Pset_chunk(dcpl.get(), int(ch.size()), ch.data());
    set_filters(dcpl.get(), level);
  }
  H5Handle d(
      H5Dcreate2(parent, name.c_str(), file_type, sp.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
  if (!d.valid()) fail(src, "", "cannot create HDF5 dataset '" + name + "'");
  if (!any_zero && H5Dwrite(d.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(src, "", "HDF5 write to '" + name + "' failed (disk full?)");
}

void h5_set_attr_int(hid_t obj, const std::string& name, int64_t v, const std::string& src) {
  H5Handle sp(H5Screate(H5S_SCALAR));
  H5Handle a(H5Acreate2(obj, name.c_str(), H5T_STD_I64LE, sp.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!a.valid() || H5Awrite(a.get(), H5T_NATIVE_INT64, &v) < 0)
    fail(src, "", "cannot write HDF5 attribute '" + name + "'");
}

void h5_set_attr_string(hid_t obj, const std::string& name, const std::string& v,
                        const std::string& src) {
  H5Handle t(H5Tcopy(H5T_C_S1));
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  H5Handle sp(H5Screate(H5S_SCALAR));
  H5Handle a(H5Acreate2(obj, name.c_str(), t.get(), sp.get(), H5P_DEFAULT, H5P_DEFAULT));
  const char* p = v.c_str();
  if (!a.valid() || H5Awrite(a.get(), t.get(), &p) < 0)
    fail(src, "", "cannot write HDF5 attribute '" + name + "'");
}

bool h5_get_attr_int(hid_t obj, const std::string& name, int64_t& v) {
  if (H5Aexists(obj, name.c_str()) <= 0) return false;
  H5Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT));
  H5Handle sp(H5Aget_space(a.get()));
  if (H5Sget_simple_extent_npoints(sp.get()) != 1) return false;
  H5Handle t(H5Aget_type(a.get()));
  if (H5Tget_class(t.get()) != H5T_INTEGER) return false;
  return H5Aread(a.get(), H5T_NATIVE_INT64, &v) >= 0;
}

bool h5_get_attr_string(hid_t obj, const std::string& name, std::string& v) {
  if (H5Aexists(obj, name.c_str()) <= 0) return false;
  H5Handle a(H5Aopen(obj, name.c_str(), H5P_DEFAULT));
  H5Handle t(H5Aget_type(a.get()));
  if (H5Tget_class(t.get()) != H5T_STRING) return false;
  H5Handle sp(H5Aget_space(a.get()));
  if (H5Sget_simple_extent_npoints(sp.get()) != 1) return false;
  if (H5Tis_variable_str(t.get()) > 0) {
    H5Handle mt(H5Tcopy(H5T_C_S1));
    H5Tset_size(mt.get(), H5T_VARIABLE);
    H5Tset_cset(mt.get(), H5Tget_cset(t.get()));
    char* p = nullptr;
    if (H5Aread(a.get(), mt.get(), &p) < 0 || !p) return false;
    v = p;
    H5free_memory(p);
    return true;
  }
  size_t n = H5Tget_size(t.get());
  if (n > (1u << 26)) return false;
  std::vector<char> buf(n + 1, 0);
  if (H5Aread(a.get(), t.get(), buf.data()) < 0) return false;
  v.assign(buf.data(), strnlen(buf.data(), n));
  return true;
}

}  // namespace spikems
