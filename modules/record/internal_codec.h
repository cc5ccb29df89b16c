#pragma once
// Internal: the byte formats of the session file's BLOBs (docs/RECORDING.md).
//
// A column BLOB holds `count` fixed-width elements (width 1, 4 or 8 bytes):
//   byte 0      codec: 0 raw, 1 XOR-delta + byte shuffle + deflate (floating
//               point), 2 subtract-delta + byte shuffle + deflate (integers)
//   byte 1      element width in bytes
//   bytes 2..5  count (little-endian u32)
//   then        the payload (raw: count * width bytes; else a zlib stream
//               that inflates to count * width bytes)
// A packed BLOB (snapshots, material maps, command payloads) is a zlib
// stream of a Writer's bytes behind a 4-byte magic and the inflated size.
// Every decoder checks every length and throws DecodeError, never reads
// out of bounds.

#include "record/format.h"

#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace palpa::record::internal {


enum class Codec : std::uint8_t { Raw = 0, XorFloat = 1, DeltaInt = 2, SameAsPosition = 3 };

/// Encodes `count` elements of `width` bytes at `data`.
std::vector<std::uint8_t> encode_column(const void* data, std::size_t count, std::size_t width, Codec codec);
/// A column that repeats the position column (the world position under an
/// identity mapping): the header alone.
std::vector<std::uint8_t> same_as_position_column(std::size_t count, std::size_t width);
/// True when `blob` is such a column.
bool is_same_as_position(std::span<const std::uint8_t> blob);
/// Whether a column BLOB of `blob_bytes` bytes can hold `count` elements of
/// `width` bytes at all (raw, or deflated at zlib's largest ratio, 1032:1),
/// so a reader never sizes a buffer from a count its BLOB cannot fill.
bool column_can_hold(std::size_t blob_bytes, std::size_t count, std::size_t width);
/// Decodes a column BLOB of `expected_count` elements of `width` bytes into `out`
/// (count * width bytes). Throws DecodeError naming what is wrong.
void decode_column(std::span<const std::uint8_t> blob, std::size_t expected_count, std::size_t width, void* out);

/// zlib around a byte string, with a magic and the inflated size.
std::vector<std::uint8_t> pack(const std::vector<std::uint8_t>& bytes, std::uint32_t magic);
std::vector<std::uint8_t> unpack(std::span<const std::uint8_t> blob, std::uint32_t magic, const char* what);

/// Little byte writer / bounds-checked reader for the packed formats.
class Writer {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_destructible_v<T>);
    put_bytes(&v, sizeof(T));
  }
  void put_bytes(const void* p, std::size_t n) {
    const std::size_t at = bytes_.size();
    bytes_.resize(at + n);
    if (n) std::memcpy(bytes_.data() + at, p, n);
  }
  template <class T>
  void put_vector(const std::vector<T>& v) {
    put<std::uint64_t>(v.size());
    if (!v.empty()) put_bytes(v.data(), v.size() * sizeof(T));
  }
  void put_string(const std::string& s) {
    put<std::uint64_t>(s.size());
    put_bytes(s.data(), s.size());
  }
  std::vector<std::uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

class Reader {
 public:
  Reader(std::span<const std::uint8_t> b, const char* what) : b_(b), what_(what) {}
  template <class T>
  T get() {
    static_assert(std::is_trivially_destructible_v<T>);
    T v;
    get_bytes(&v, sizeof(T));
    return v;
  }
  void get_bytes(void* p, std::size_t n) {
    if (n > b_.size() - at_) throw DecodeError(std::string(what_) + " ends early");
    std::memcpy(p, b_.data() + at_, n);
    at_ += n;
  }
  template <class T>
  std::vector<T> get_vector(std::size_t max_count) {
    const auto n = get<std::uint64_t>();
    if (n > max_count || n * sizeof(T) > b_.size() - at_)
      throw DecodeError(std::string(what_) + " has a bad length (" + std::to_string(n) + ")");
    std::vector<T> v(n);
    if (n) get_bytes(v.data(), n * sizeof(T));
    return v;
  }
  std::string get_string() {
    const auto n = get<std::uint64_t>();
    if (n > b_.size() - at_) throw DecodeError(std::string(what_) + " has a bad string length");
    std::string s(reinterpret_cast<const char*>(b_.data() + at_), n);
    at_ += n;
    return s;
  }
  bool done() const { return at_ == b_.size(); }
  /// Bytes not read yet.
  std::size_t left() const { return b_.size() - at_; }

 private:
  std::span<const std::uint8_t> b_;
  const char* what_;
  std::size_t at_ = 0;
};

/// SHA-256 of bytes, lower-case hex.
std::string sha256_hex(const void* data, std::size_t n);

}  // namespace palpa::record::internal
