// Column and packed BLOB formats (internal_codec.h).

#include "record/internal_codec.h"

#include <openssl/evp.h>
#include <zlib.h>

namespace palpa::record::internal {

namespace {

// XOR or subtract each element with the previous one (as unsigned words),
// then shuffle: plane k holds byte k of every element.
std::vector<std::uint8_t> transform(const std::uint8_t* in, std::size_t count, std::size_t width, Codec codec) {
  std::vector<std::uint8_t> out(count * width);
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < count; ++i) {
    std::uint64_t v = 0;
    std::memcpy(&v, in + i * width, width);
    const std::uint64_t d = codec == Codec::XorFloat ? (v ^ prev) : (v - prev);
    prev = v;
    for (std::size_t k = 0; k < width; ++k) out[k * count + i] = static_cast<std::uint8_t>(d >> (8 * k));
  }
  return out;
}

void untransform(const std::uint8_t* in, std::size_t count, std::size_t width, Codec codec, std::uint8_t* out) {
  const std::uint64_t mask = width == 8 ? ~std::uint64_t{0} : ((std::uint64_t{1} << (8 * width)) - 1);
  std::uint64_t prev = 0;
  for (std::size_t i = 0; i < count; ++i) {
    std::uint64_t d = 0;
    for (std::size_t k = 0; k < width; ++k) d |= static_cast<std::uint64_t>(in[k * count + i]) << (8 * k);
    const std::uint64_t v = (codec == Codec::XorFloat ? (d ^ prev) : (d + prev)) & mask;
    prev = v;
    std::memcpy(out + i * width, &v, width);
  }
}

std::vector<std::uint8_t> deflate_bytes(const std::uint8_t* p, std::size_t n) {
  uLongf size = compressBound(static_cast<uLong>(n));
  std::vector<std::uint8_t> out(size);
  if (compress2(out.data(), &size, p, static_cast<uLong>(n), 1) != Z_OK) throw std::runtime_error("deflate failed");
  out.resize(size);
  return out;
}

void inflate_bytes(const std::uint8_t* p, std::size_t n, std::uint8_t* out, std::size_t expected, const char* what) {
  uLongf size = static_cast<uLongf>(expected);
  const int rc = uncompress(out, &size, p, static_cast<uLong>(n));
  if (rc != Z_OK || size != expected)
    throw DecodeError(std::string(what) + " does not inflate (" + (rc == Z_OK ? "wrong size" : zError(rc)) + ")");
}

void put_u32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) b[at + k] = static_cast<std::uint8_t>(v >> (8 * k));
}
std::uint32_t get_u32(const std::uint8_t* p) {
  return p[0] | (std::uint32_t{p[1]} << 8) | (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[3]} << 24);
}

}  // namespace

std::vector<std::uint8_t> encode_column(const void* data, std::size_t count, std::size_t width, Codec codec) {
  std::vector<std::uint8_t> out(6);
  out[1] = static_cast<std::uint8_t>(width);
  put_u32(out, 2, static_cast<std::uint32_t>(count));
  const auto* in = static_cast<const std::uint8_t*>(data);
  if (codec != Codec::Raw && count > 0) {
    const auto t = transform(in, count, width, codec);
    const auto z = deflate_bytes(t.data(), t.size());
    if (z.size() < count * width) {
      out[0] = static_cast<std::uint8_t>(codec);
      out.insert(out.end(), z.begin(), z.end());
      return out;
    }
  }
  out[0] = static_cast<std::uint8_t>(Codec::Raw);
  out.insert(out.end(), in, in + count * width);
  return out;
}

std::vector<std::uint8_t> same_as_position_column(std::size_t count, std::size_t width) {
  std::vector<std::uint8_t> out(6);
  out[0] = static_cast<std::uint8_t>(Codec::SameAsPosition);
  out[1] = static_cast<std::uint8_t>(width);
  put_u32(out, 2, static_cast<std::uint32_t>(count));
  return out;
}

bool is_same_as_position(std::span<const std::uint8_t> blob) {
  return blob.size() == 6 && blob[0] == static_cast<std::uint8_t>(Codec::SameAsPosition);
}

namespace {
// zlib's deflate cannot pack more than 1032 bytes into one, plus a few bytes of stream framing.
constexpr std::uint64_t kMaxInflateRatio = 1032;
constexpr std::uint64_t kInflateSlack = 64;
}  // namespace

bool column_can_hold(std::size_t blob_bytes, std::size_t count, std::size_t width) {
  if (width == 0 || count > (std::uint64_t(1) << 40) / width) return false;
  return std::uint64_t(count) * width <= kMaxInflateRatio * blob_bytes + kInflateSlack;
}

void decode_column(std::span<const std::uint8_t> blob, std::size_t expected_count, std::size_t width, void* out) {
  if (blob.size() < 6) throw DecodeError("column of " + std::to_string(blob.size()) + " bytes has no header");
  const auto codec = static_cast<Codec>(blob[0]);
  if (blob[1] != width)
    throw DecodeError("column has " + std::to_string(blob[1]) + "-byte elements, expected " + std::to_string(width));
  const std::uint32_t count = get_u32(blob.data() + 2);
  if (count != expected_count)
    throw DecodeError("column has " + std::to_string(count) + " elements, expected " + std::to_string(expected_count));
  const std::size_t bytes = count * width;
  auto* o = static_cast<std::uint8_t*>(out);
  if (codec == Codec::Raw) {
    if (blob.size() - 6 != bytes) throw DecodeError("raw column has " + std::to_string(blob.size() - 6) + " bytes, expected " + std::to_string(bytes));
    if (bytes) std::memcpy(o, blob.data() + 6, bytes);
  } else if (codec == Codec::XorFloat || codec == Codec::DeltaInt) {
    std::vector<std::uint8_t> t(bytes);
    inflate_bytes(blob.data() + 6, blob.size() - 6, t.data(), bytes, "column");
    untransform(t.data(), count, width, codec, o);
  } else {
    throw DecodeError("column has unknown codec " + std::to_string(blob[0]));
  }
}

std::vector<std::uint8_t> pack(const std::vector<std::uint8_t>& bytes, std::uint32_t magic) {
  std::vector<std::uint8_t> out(8);
  put_u32(out, 0, magic);
  put_u32(out, 4, static_cast<std::uint32_t>(bytes.size()));
  const auto z = deflate_bytes(bytes.data(), bytes.size());
  out.insert(out.end(), z.begin(), z.end());
  return out;
}

std::vector<std::uint8_t> unpack(std::span<const std::uint8_t> blob, std::uint32_t magic, const char* what) {
  if (blob.size() < 8 || get_u32(blob.data()) != magic) throw DecodeError(std::string(what) + " has no valid header");
  const std::uint32_t n = get_u32(blob.data() + 4);
  if (n > (1u << 31) || n > kMaxInflateRatio * (blob.size() - 8) + kInflateSlack)
    throw DecodeError(std::string(what) + " claims " + std::to_string(n) + " bytes from " + std::to_string(blob.size() - 8) +
                      " deflated bytes");
  std::vector<std::uint8_t> out(n);
  inflate_bytes(blob.data() + 8, blob.size() - 8, out.data(), n, what);
  return out;
}

std::string sha256_hex(const void* data, std::size_t n) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_Digest(data, n, md, &len, EVP_sha256(), nullptr);
  static const char* hex = "0123456789abcdef";
  std::string s;
  for (unsigned i = 0; i < len; ++i) {
    s += hex[md[i] >> 4];
    s += hex[md[i] & 15];
  }
  return s;
}

}  // namespace palpa::record::internal
