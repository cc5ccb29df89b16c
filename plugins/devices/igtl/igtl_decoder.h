#pragma once
// The OpenIGTLink byte stream of the `igtl` device, decoded by our own code
// so that every field is checked before it is trusted: the 58-byte header
// (big-endian: u16 version, char type[12], char device[20], u64 timestamp,
// u64 body size, u64 CRC-64 of the body) and the TRANSFORM and POSITION
// bodies the bridge uses.
//
// - Header versions 1 (OpenIGTLink protocols 1 and 2) and 2 (protocol 3: an
//   extended header and metadata around the content) are read; any other is
//   refused by number and its message skipped when its size is plausible.
// - The 64-bit body size is checked against the most its type can have
//   (kMaxTransformBody, kMaxPositionBody, kMaxOtherBody, plus the metadata of
//   version 2) before any byte of the body is waited for or stored.
// - After a header that cannot be trusted the decoder resynchronises: it
//   skips byte by byte to the next plausible header, counting what it skipped.
// - A pose is kept only with a matching CRC, a finite position inside the
//   workspace cube (after the unit) and an orthonormal rotation (TRANSFORM:
//   |R^T R - I| <= kRotationTolerance and det R > 0) or a unit quaternion
//   (POSITION: | |q| - 1 | <= kRotationTolerance).
// Not real-time: it runs on the plugin's I/O thread and may allocate.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace palpa::plugins::igtl {

inline constexpr std::size_t kHeaderSize = 58;
inline constexpr std::uint64_t kMaxTransformBody = 48;   ///< 12 float32
inline constexpr std::uint64_t kMaxPositionBody = 28;    ///< 3 + 4 float32
inline constexpr std::uint64_t kMaxOtherBody = 1 << 20;  ///< any other type, skipped unread
inline constexpr std::uint64_t kMaxMetadata = 1 << 16;   ///< version 2: extended header and metadata
inline constexpr double kRotationTolerance = 1e-2;

struct DecoderOptions {
  double unit_scale = 1e-3;   ///< m per unit of the incoming positions (mm: 1e-3)
  std::string device_filter;  ///< accept poses only from this device name (empty: any)
  double workspace = 1.0;     ///< m: positions must satisfy |x|, |y|, |z| <= workspace
};

/// One accepted pose: position in m, unit quaternion w, x, y, z.
struct Pose {
  double position[3] = {0, 0, 0};
  double orientation[4] = {1, 0, 0, 0};
};

class Decoder {
 public:
  explicit Decoder(DecoderOptions options);

  /// Appends received bytes and decodes every complete message; accepted
  /// poses are appended to `poses`. Never throws on any input.
  void feed(const std::uint8_t* data, std::size_t size, std::vector<Pose>& poses);

  /// Forgets buffered bytes (a new peer); the counts stay.
  void reset();

  std::uint64_t messages() const { return messages_; }          ///< complete messages, good or bad
  std::uint64_t bad_messages() const { return bad_; }           ///< refused messages and headers
  std::uint64_t resynchronisations() const { return resyncs_; } ///< times the stream was searched for a header
  std::uint64_t skipped_bytes() const { return skipped_; }      ///< bytes dropped while resynchronising
  std::size_t buffered() const { return in_.size(); }           ///< bytes of an incomplete message
  /// The latest problem, e.g. "refused a TRANSFORM message: its CRC does not
  /// match its body"; empty while there has been none.
  const std::string& last_problem() const { return problem_; }

 private:
  enum class Header { ok, incomplete, bad };
  Header check_header(std::size_t at, std::string* why) const;
  void handle(const std::string& type, const std::string& name, const std::uint8_t* body, std::uint64_t size,
              std::uint64_t crc, int version, std::vector<Pose>& poses);
  void refuse(const std::string& why);
  void resynchronise();

  DecoderOptions options_;
  std::vector<std::uint8_t> in_;
  std::uint64_t messages_ = 0, bad_ = 0, resyncs_ = 0, skipped_ = 0, search_skipped_ = 0;
  bool searching_ = false;
  std::string problem_;
};

}  // namespace palpa::plugins::igtl
