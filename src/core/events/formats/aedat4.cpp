// iniVation AEDAT 4.0. Layout (docs.inivation.com, "AEDAT 4.0 file format"):
//   "#!AER-DAT4.0\r\n", int32 size + IOHeader FlatBuffer (compression, dataTablePosition,
//   infoNode = XML describing the streams), then packets: int32 stream id, int32 size, payload.
//   A payload (compressed as a whole with LZ4 frame or zstd, or not at all) is a size-prefixed
//   EventPacket FlatBuffer: a vector of 16-byte structs {int64 t; int16 x; int16 y; bool on}.
// The FlatBuffers are read with flatc-generated code (schemas aedat4_*.fbs) after the
// generated Verifier has checked every offset, size and alignment in them.
// Only the first event stream is read; packets of other streams (IMU, triggers, frames, a
// second camera) are skipped.
#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <memory>

#include "aedat4_events_generated.h"
#include "aedat4_ioheader_generated.h"
#include "core/events/formats/aedat4_common.h"
#include "core/events/formats/camera_reader.h"
#include "core/events/formats/camera_writers.h"
#include "core/util/error.h"

namespace spikems {

namespace {

// Value of <attr key="KEY" ...>VALUE</attr> in `xml`, or "".
std::string attr_value(std::string_view xml, const std::string& key) {
  std::string pat = "key=\"" + key + "\"";
  size_t k = xml.find(pat);
  if (k == std::string::npos) return "";
  size_t gt = xml.find('>', k);
  if (gt == std::string::npos) return "";
  size_t lt = xml.find('<', gt);
  if (lt == std::string::npos) return "";
  return std::string(xml.substr(gt + 1, lt - gt - 1));
}

// The root of the size-prefixed FlatBuffer in buf[0, size) after verification, or nullptr when
// it fails. Writers differ in what they align to: dv-processing aligns from the size prefix,
// others (the DAVIS346 clip of neuromorphicsystems/aedat's test data, as trimmed in
// shiba24/event-vision-library) from the bytes after it, so an 8-byte field sits 4 bytes off
// for the other convention. The prefix's convention is tried first; when it fails verification
// or `aligned(root)` is false, the second is verified on an aligned copy of the buffer without
// its prefix (`unprefixed`, which then holds the data that root points into). A root that
// verifies but is aligned in neither is returned for the caller to refuse.
template <typename T, typename Aligned>
const T* verified_root(const uint8_t* buf, size_t size, std::vector<uint8_t>& unprefixed,
                       Aligned aligned) {
  const T* found = nullptr;
  flatbuffers::Verifier prefixed(buf, size);
  if (prefixed.VerifySizePrefixedBuffer<T>(nullptr)) {
    found = flatbuffers::GetSizePrefixedRoot<T>(buf);
    if (aligned(found)) return found;
  }
  unprefixed.assign(buf + 4, buf + size);  // heap memory: aligned for any scalar
  flatbuffers::Verifier plain(unprefixed.data(), unprefixed.size());
  if (plain.VerifyBuffer<T>(nullptr)) return flatbuffers::GetRoot<T>(unprefixed.data());
  return found;
}

}  // namespace

std::vector<Aedat4Stream> parse_aedat4_info(std::string_view xml) {
  // Each stream is a node whose path ends in "/outInfo/<id>/"; its attributes (and those of
  // its "info" child) run until the next stream node.
  struct Start {
    size_t pos;
    int id;
  };
  std::vector<Start> starts;
  const std::string pat = "path=\"";
  for (size_t p = xml.find(pat); p != std::string::npos; p = xml.find(pat, p + 1)) {
    size_t b = p + pat.size();
    size_t e = xml.find('"', b);
    if (e == std::string::npos) break;
    std::string_view path = xml.substr(b, e - b);
    size_t oi = path.rfind("/outInfo/");
    if (oi == std::string::npos) continue;
    std::string_view rest = path.substr(oi + 9);
    if (rest.size() < 2 || rest.back() != '/') continue;
    rest.remove_suffix(1);
    if (rest.size() > 9 || rest.find_first_not_of("0123456789") != std::string::npos) continue;
    starts.push_back({p, std::stoi(std::string(rest))});
  }
  std::vector<Aedat4Stream> out;
  for (size_t i = 0; i < starts.size(); ++i) {
    size_t end = i + 1 < starts.size() ? starts[i + 1].pos : xml.size();
    std::string_view seg = xml.substr(starts[i].pos, end - starts[i].pos);
    Aedat4Stream s;
    s.id = starts[i].id;
    s.type = attr_value(seg, "typeIdentifier");
    s.sensor.width = std::atoi(attr_value(seg, "sizeX").c_str());
    s.sensor.height = std::atoi(attr_value(seg, "sizeY").c_str());
    if (s.sensor.width <= 0 || s.sensor.height <= 0 || s.sensor.width > 65535 ||
        s.sensor.height > 65535)
      s.sensor = {};
    out.push_back(s);
  }
  return out;
}

void aedat4_decompress(int compression, const uint8_t* src, size_t n, std::vector<uint8_t>& dst,
                       const std::string& source, uint64_t offset) {
  const size_t kMax = size_t(1) << 30;  // a packet larger than 1 GiB decompressed is corrupt
  dst.clear();
  if (compression == kAedatNone) {
    dst.assign(src, src + n);
    return;
  }
  if (compression == kAedatLz4 || compression == kAedatLz4High) {
    LZ4F_dctx* ctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION)))
      fail_at_byte(source, offset, "cannot create an LZ4 decompression context");
    std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> guard(
        ctx, LZ4F_freeDecompressionContext);
    size_t in = 0, out = 0, ret = 1;
    dst.resize(std::max<size_t>(n * 4, 4096));
    while (in < n) {
      if (out == dst.size()) {
        if (dst.size() >= kMax) fail_at_byte(source, offset, "LZ4 packet decompresses past 1 GiB");
        dst.resize(dst.size() * 2);
      }
      size_t src_size = n - in, dst_size = dst.size() - out;
      ret = LZ4F_decompress(ctx, dst.data() + out, &dst_size, src + in, &src_size, nullptr);
      if (LZ4F_isError(ret))
        fail_at_byte(source, offset, std::string("corrupt LZ4 packet: ") + LZ4F_getErrorName(ret));
      in += src_size;
      out += dst_size;
      if (ret == 0) break;  // frame complete
      if (src_size == 0 && dst_size == 0 && out < dst.size())
        fail_at_byte(source, offset, "corrupt LZ4 packet: decoder makes no progress");
    }
    // Flush what the decoder still holds once the input is consumed.
    while (ret != 0) {
      if (out == dst.size()) {
        if (dst.size() >= kMax) fail_at_byte(source, offset, "LZ4 packet decompresses past 1 GiB");
        dst.resize(dst.size() * 2);
      }
      size_t src_size = 0, dst_size = dst.size() - out;
      ret = LZ4F_decompress(ctx, dst.data() + out, &dst_size, nullptr, &src_size, nullptr);
      if (LZ4F_isError(ret))
        fail_at_byte(source, offset, std::string("corrupt LZ4 packet: ") + LZ4F_getErrorName(ret));
      out += dst_size;
      if (dst_size == 0 && ret != 0)
        fail_at_byte(source, offset, "LZ4 packet is truncated (the frame does not end)");
    }
    dst.resize(out);
    return;
  }
  if (compression == kAedatZstd || compression == kAedatZstdHigh) {
    std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> ctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
    if (!ctx) fail_at_byte(source, offset, "cannot create a zstd decompression context");
    ZSTD_inBuffer in{src, n, 0};
    size_t out = 0, ret = 1;
    dst.resize(std::max<size_t>(n * 4, 4096));
    while (true) {
      if (out == dst.size()) {
        if (dst.size() >= kMax) fail_at_byte(source, offset, "zstd packet decompresses past 1 GiB");
        dst.resize(dst.size() * 2);
      }
      ZSTD_outBuffer ob{dst.data() + out, dst.size() - out, 0};
      ret = ZSTD_decompressStream(ctx.get(), &ob, &in);
      if (ZSTD_isError(ret))
        fail_at_byte(source, offset, std::string("corrupt zstd packet: ") + ZSTD_getErrorName(ret));
      out += ob.pos;
      if (ret == 0 && in.pos == in.size) break;
      if (in.pos == in.size && ob.pos < ob.size)
        fail_at_byte(source, offset, "zstd packet is truncated (the frame does not end)");
    }
    dst.resize(out);
    return;
  }
  fail_at_byte(source, offset, "unknown compression type " + std::to_string(compression));
}

namespace {

const std::string kMagic = "#!AER-DAT4.0";

class Aedat4Reader final : public CameraReader {
 public:
  explicit Aedat4Reader(std::unique_ptr<ByteSource> src) : in_(std::move(src)) {
    uint8_t magic[14];
    in_.read_exact(magic, 14, "the AEDAT 4.0 signature");
    if (std::memcmp(magic, "#!AER-DAT4.0\r\n", 14) != 0)
      fail_at_byte(in_.name(), 0, "not an AEDAT 4.0 file (signature '#!AER-DAT4.0\\r\\n' missing)");
    uint8_t sz[4];
    in_.read_exact(sz, 4, "the IOHeader size");
    int32_t hsize = int32_t(load_le32(sz));
    if (hsize < 8 || hsize > (16 << 20) || uint64_t(hsize) > in_.remaining())
      fail_at_byte(in_.name(), 14,
                   "IOHeader size " + std::to_string(hsize) +
                       " is absurd (negative, tiny, over 16 MiB or past the end of the file)");
    // Kept with its size prefix: FlatBuffers aligns (and verifies alignment) from there.
    std::vector<uint8_t> hdr(size_t(hsize) + 4);
    store_le32(hdr.data(), uint32_t(hsize));
    uint64_t hoff = in_.offset();
    in_.read_exact(hdr.data() + 4, size_t(hsize), "the IOHeader");
    std::vector<uint8_t> unprefixed;
    const aedat4::IOHeader* h = verified_root<aedat4::IOHeader>(
        hdr.data(), hdr.size(), unprefixed, [](const aedat4::IOHeader*) { return true; });
    if (!h)
      fail_at_byte(in_.name(), hoff,
                   "corrupt FlatBuffers data: the IOHeader fails verification (an offset, size "
                   "or alignment points outside its " +
                       std::to_string(hsize) + " bytes)");
    compression_ = int(h->compression());
    if (compression_ < kAedatNone || compression_ > kAedatZstdHigh)
      fail_at_byte(in_.name(), hoff, "unknown compression type " + std::to_string(compression_));
    int64_t dtp = h->data_table_position();
    packets_end_ = dtp >= 0 ? uint64_t(dtp) : UINT64_MAX;
    const std::string_view info = h->info_node() ? h->info_node()->string_view() : "";
    // The first event stream only: a second one (stereo rig) is another camera, whose
    // events would interleave out of time order and in another coordinate frame.
    for (const auto& s : parse_aedat4_info(info)) {
      if (s.type != "EVTS" || !event_streams_.empty()) continue;
      event_streams_.push_back(s.id);
      sensor_ = s.sensor;
    }
    if (event_streams_.empty())
      fail_at_byte(in_.name(), hoff,
                   "the header's infoNode declares no event stream (typeIdentifier EVTS): the "
                   "file holds no polarity events");
  }
  std::string format_name() const override { return "aedat4"; }

 protected:
  void decode(Out& o) override {
    while (o.n < o.cap) {
      if (next_ == count_ && !next_packet()) return;
      size_t k = std::min(count_ - next_, o.cap - o.n);
      const aedat4::Event* e = elems_ + next_;
      for (size_t i = 0; i < k; ++i, ++e) {
        const int16_t x = e->x(), y = e->y();
        if (x < 0 || y < 0)
          fail_at_byte(in_.name(), packet_offset_,
                       "event " + std::to_string(next_ + i) +
                           " of the packet has a negative "
                           "coordinate (" +
                           std::to_string(x) + ", " + std::to_string(y) + ")");
        o.t[o.n] = e->timestamp();
        o.x[o.n] = uint16_t(x);
        o.y[o.n] = uint16_t(y);
        o.p[o.n] = e->polarity() ? 1 : 0;
        ++o.n;
      }
      next_ += k;
    }
  }

 private:
  // Loads the next event packet; false at the end of the packets.
  bool next_packet() {
    for (;;) {
      if (in_.offset() >= packets_end_) return false;
      size_t a = in_.fill(8);
      if (a == 0) return false;
      packet_offset_ = in_.offset();
      if (a < 8)
        fail_at_byte(
            in_.name(), packet_offset_,
            "file is truncated: " + std::to_string(a) + " bytes of an 8-byte packet header");
      int32_t stream = int32_t(load_le32(in_.ptr()));
      int32_t size = int32_t(load_le32(in_.ptr() + 4));
      in_.consume(8);
      if (size <= 0 || uint64_t(size) > in_.remaining() || size > (1 << 30))
        fail_at_byte(in_.name(), packet_offset_,
                     "packet size " + std::to_string(size) + " of stream " +
                         std::to_string(stream) +
                         " is absurd (not positive, over 1 GiB or past the end of the file: "
                         "the file is truncated or corrupt)");
      if (std::find(event_streams_.begin(), event_streams_.end(), stream) == event_streams_.end()) {
        in_.skip(uint64_t(size), "a packet");
        continue;
      }
      comp_.resize(size_t(size));
      in_.read_exact(comp_.data(), comp_.size(), "a packet");
      aedat4_decompress(compression_, comp_.data(), comp_.size(), packet_, in_.name(),
                        packet_offset_);
      // A size-prefixed FlatBuffer; bytes after it are ignored.
      if (packet_.size() < 4) fail_at_byte(in_.name(), packet_offset_, "packet is too small");
      uint32_t fsize = load_le32(packet_.data());
      if (fsize > packet_.size() - 4)
        fail_at_byte(in_.name(), packet_offset_,
                     "packet FlatBuffer size " + std::to_string(fsize) + " exceeds the packet");
      // The verifier checks the vector's length field, not that its 8-byte structs are
      // 8-aligned; the accessors read them in place, so check that too (packet_ and the copy
      // are heap memory, aligned for any scalar).
      auto aligned = [](const aedat4::EventPacket* p) {
        const auto* v = p->elements();
        return !v || !v->size() ||
               reinterpret_cast<uintptr_t>(v->Get(0)) % alignof(aedat4::Event) == 0;
      };
      const aedat4::EventPacket* pk = verified_root<aedat4::EventPacket>(
          packet_.data(), size_t(fsize) + 4, unprefixed_, aligned);
      if (!pk)
        fail_at_byte(in_.name(), packet_offset_,
                     "corrupt FlatBuffers data: the EventPacket fails verification (an offset, "
                     "size or alignment points outside its " +
                         std::to_string(fsize) + " decompressed bytes)");
      if (!aligned(pk))
        fail_at_byte(in_.name(), packet_offset_,
                     "corrupt FlatBuffers data: the events vector is not 8-byte aligned");
      const auto* elements = pk->elements();
      count_ = elements ? elements->size() : 0;
      elems_ = count_ ? elements->Get(0) : nullptr;  // structs lie contiguously from here
      next_ = 0;
      if (count_ > 0) return true;
    }
  }

  BlockInput in_;
  int compression_ = kAedatNone;
  uint64_t packets_end_ = UINT64_MAX;
  std::vector<int> event_streams_;
  std::vector<uint8_t> comp_, packet_, unprefixed_;
  uint64_t packet_offset_ = 0;
  const aedat4::Event* elems_ = nullptr;
  size_t count_ = 0, next_ = 0;
};

}  // namespace

FormatInfo aedat4_format() {
  FormatInfo f;
  f.name = "aedat4";
  f.description = "iniVation AEDAT 4.0 (DV, dv-processing; LZ4/zstd packets)";
  f.extensions = {".aedat4"};
  f.detect = [](const std::vector<uint8_t>& head, const std::string& path) {
    return starts_with(head, kMagic) ? 100 : 0;
  };
  f.open_bytes = [](std::unique_ptr<ByteSource> src, const ReadOptions&) {
    return std::unique_ptr<EventReader>(std::make_unique<Aedat4Reader>(std::move(src)));
  };
  f.compresses = true;
  f.open_writer = open_aedat4_writer;
  return f;
}

}  // namespace spikems
