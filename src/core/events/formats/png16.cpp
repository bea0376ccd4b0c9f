#include "core/events/formats/png16.h"

#include <png.h>

#include <csetjmp>
#include <cstring>

#include "core/util/atomic_file.h"
#include "core/util/byte_source.h"
#include "core/util/error.h"

namespace spikems {
namespace {

// libpng reports errors by longjmp; the functions below hold no C++ objects with destructors
// between setjmp and the libpng calls, and copy the message out for the caller to throw.
struct Ctx {
  const uint8_t* d = nullptr;
  size_t n = 0, pos = 0;
  char msg[256] = {};
};

void on_error(png_structp p, png_const_charp m) {
  auto* c = static_cast<Ctx*>(png_get_error_ptr(p));
  std::snprintf(c->msg, sizeof c->msg, "%s", m);
  longjmp(png_jmpbuf(p), 1);
}
void on_warning(png_structp, png_const_charp) {}
void on_read(png_structp p, png_bytep out, png_size_t len) {
  auto* c = static_cast<Ctx*>(png_get_io_ptr(p));
  if (len > c->n - c->pos) png_error(p, "PNG data is truncated");
  std::memcpy(out, c->d + c->pos, len);
  c->pos += len;
}

struct Header {
  png_uint_32 w = 0, h = 0;
  int depth = 0, color = 0, channels = 0;
};

// Returns false with ctx.msg set on error. When rows is null only the header is read.
bool run_decode(Ctx& ctx, Header& hd, uint16_t* out) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &ctx, on_error, on_warning);
  if (!png) return std::snprintf(ctx.msg, sizeof ctx.msg, "out of memory"), false;
  png_infop info = png_create_info_struct(png);
  png_bytep* volatile rows = nullptr;  // volatile: read after longjmp
  if (!info || setjmp(png_jmpbuf(png))) {
    std::free(rows);
    png_destroy_read_struct(&png, &info, nullptr);
    if (!ctx.msg[0]) std::snprintf(ctx.msg, sizeof ctx.msg, "libpng error");
    return false;
  }
  png_set_read_fn(png, &ctx, on_read);
  png_set_user_limits(png, 1u << 15, 1u << 15);
  png_read_info(png, info);
  hd.w = png_get_image_width(png, info);
  hd.h = png_get_image_height(png, info);
  hd.depth = png_get_bit_depth(png, info);
  hd.color = png_get_color_type(png, info);
  if (hd.color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (hd.color == PNG_COLOR_TYPE_GRAY && hd.depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (hd.depth == 16) png_set_swap(png);  // file is big-endian, host little-endian
  png_read_update_info(png, info);
  hd.channels = png_get_channels(png, info);
  const int depth_now = png_get_bit_depth(png, info);
  if (out) {
    const size_t row_bytes = png_get_rowbytes(png, info);
    rows = static_cast<png_bytep*>(std::malloc(sizeof(png_bytep) * hd.h));
    if (!rows) png_error(png, "out of memory");
    uint8_t* base = reinterpret_cast<uint8_t*>(out);
    // 8-bit rows are read into the second half of each 16-bit row and widened in place.
    const size_t out_row = size_t(hd.w) * size_t(hd.channels) * 2;
    for (png_uint_32 y = 0; y < hd.h; ++y)
      rows[y] = base + y * out_row + (depth_now == 8 ? out_row - row_bytes : 0);
    png_read_image(png, rows);
    if (depth_now == 8)
      for (png_uint_32 y = 0; y < hd.h; ++y) {
        uint8_t* src = rows[y];
        uint16_t* dst = out + size_t(y) * size_t(hd.w) * size_t(hd.channels);
        for (size_t i = 0; i < size_t(hd.w) * size_t(hd.channels); ++i) dst[i] = src[i];
      }
    png_read_end(png, nullptr);
  }
  std::free(rows);
  png_destroy_read_struct(&png, &info, nullptr);
  hd.depth = depth_now;
  return true;
}

void on_write(png_structp p, png_bytep d, png_size_t len) {
  auto* v = static_cast<std::vector<uint8_t>*>(png_get_io_ptr(p));
  v->insert(v->end(), d, d + len);
}
void on_flush(png_structp) {}

bool run_encode(Ctx& ctx, const Image16& img, std::vector<uint8_t>* out, png_bytep* rows) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &ctx, on_error, on_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  static const int kColor[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGB_ALPHA};
  png_set_write_fn(png, out, on_write, on_flush);
  png_set_IHDR(png, info, png_uint_32(img.width), png_uint_32(img.height), 16, kColor[img.channels],
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

Image16 decode_png16(const uint8_t* data, size_t n, const std::string& source) {
  static const uint8_t kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (n < 8 || std::memcmp(data, kSig, 8) != 0)
    fail_at_byte(source, 0, "not a PNG image: wrong magic bytes");
  Ctx ctx;
  ctx.d = data;
  ctx.n = n;
  Header hd;
  if (!run_decode(ctx, hd, nullptr)) fail(source, "", std::string("bad PNG: ") + ctx.msg);
  Image16 img;
  img.width = int(hd.w);
  img.height = int(hd.h);
  img.channels = hd.channels;
  img.bit_depth = hd.depth;
  img.data.resize(size_t(hd.w) * hd.h * size_t(hd.channels));
  Ctx ctx2;
  ctx2.d = data;
  ctx2.n = n;
  if (!run_decode(ctx2, hd, img.data.data())) fail(source, "", std::string("bad PNG: ") + ctx2.msg);
  return img;
}

Image16 read_png16(const std::string& path) {
  auto bytes = read_file_bytes(path);
  return decode_png16(bytes.data(), bytes.size(), path);
}

std::vector<uint8_t> encode_png16(const Image16& img) {
  if (img.channels < 1 || img.channels > 4 || img.width <= 0 || img.height <= 0 ||
      img.data.size() != size_t(img.width) * size_t(img.height) * size_t(img.channels))
    throw Error("encode_png16: image size and data do not agree");
  std::vector<png_bytep> rows(size_t(img.height));
  for (int y = 0; y < img.height; ++y)
    rows[size_t(y)] =
        reinterpret_cast<png_bytep>(const_cast<uint16_t*>(img.data.data()) +
                                    size_t(y) * size_t(img.width) * size_t(img.channels));
  std::vector<uint8_t> out;
  Ctx ctx;
  if (!run_encode(ctx, img, &out, rows.data()))
    throw Error(std::string("PNG encoding failed: ") + ctx.msg);
  return out;
}

void write_png16(const std::string& path, const Image16& img) {
  auto bytes = encode_png16(img);
  AtomicFile f(path);
  f.write(bytes.data(), bytes.size());
  f.commit();
}

}  // namespace spikems
