// The igtl device's stream decoder on byte vectors: 64-bit body sizes against
// the per-type maximum, refused header versions named, resynchronisation
// after a bad header (counted), orthonormal rotations and positions inside
// the workspace, each with its exact message.

#include "igtl_decoder.h"

#include <gtest/gtest.h>
#include <igtlPositionMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_util.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace palpa::plugins::igtl {
namespace {

using Bytes = std::vector<std::uint8_t>;

// A packed TRANSFORM: rotation r (row-major 3x3) and translation t.
Bytes transform(const float r[9], float x, float y, float z, const char* name = "Tracker") {
  ::igtl::TransformMessage::Pointer m = ::igtl::TransformMessage::New();
  m->SetDeviceName(name);
  ::igtl::Matrix4x4 t;
  ::igtl::IdentityMatrix(t);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t[i][j] = r[3 * i + j];
  t[0][3] = x;
  t[1][3] = y;
  t[2][3] = z;
  m->SetMatrix(t);
  m->Pack();
  const auto* p = static_cast<const std::uint8_t*>(m->GetPackPointer());
  return Bytes(p, p + m->GetPackSize());
}

const float kIdentity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

Bytes identity_at(float x) { return transform(kIdentity, x, 0, 0); }

// Overwrites the header's big-endian body size (bytes 42..49) or version (0..1).
void set_body_size(Bytes& m, std::uint64_t size) {
  for (int k = 0; k < 8; ++k) m[42 + k] = static_cast<std::uint8_t>(size >> (56 - 8 * k));
}
void set_version(Bytes& m, std::uint16_t v) {
  m[0] = static_cast<std::uint8_t>(v >> 8);
  m[1] = static_cast<std::uint8_t>(v);
}

struct Stream {
  std::vector<Pose> poses;
  Decoder decoder;
  explicit Stream(DecoderOptions o = {}) : decoder(o) {}
  void feed(const Bytes& b) { decoder.feed(b.data(), b.size(), poses); }
};

DecoderOptions metres() {
  DecoderOptions o;
  o.unit_scale = 1.0;
  return o;
}

TEST(IgtlDecoder, AcceptsAPoseInMillimetres) {
  Stream r;
  r.feed(identity_at(10));
  ASSERT_EQ(r.poses.size(), 1u);
  EXPECT_NEAR(r.poses[0].position[0], 0.010, 1e-9);
  EXPECT_EQ(r.poses[0].orientation[0], 1.0);
  EXPECT_EQ(r.decoder.bad_messages(), 0u);
  EXPECT_EQ(r.decoder.last_problem(), "");
}

// A body size of 2^32 + 48 used to be truncated to 48 and the next 48 bytes taken as a pose.
TEST(IgtlDecoder, SixtyFourBitBodySizesAreCheckedAgainstTheTypesMaximum) {
  for (const std::uint64_t size : {(std::uint64_t(1) << 32) + 48, std::uint64_t(1) << 63}) {
    SCOPED_TRACE(size);
    Stream r(metres());
    Bytes bad = identity_at(0.5f);
    set_body_size(bad, size);
    r.feed(bad);
    EXPECT_TRUE(r.poses.empty());
    EXPECT_EQ(r.decoder.bad_messages(), 1u);
    EXPECT_EQ(r.decoder.resynchronisations(), 1u);
    EXPECT_EQ(r.decoder.last_problem(), "refused a TRANSFORM message with a body of " + std::to_string(size) +
                                            " bytes (a TRANSFORM of header version 1 has at most 48)");
    // The next good message is found again and counted.
    r.feed(identity_at(0.25f));
    ASSERT_EQ(r.poses.size(), 1u);
    EXPECT_EQ(r.poses[0].position[0], 0.25);
    EXPECT_EQ(r.decoder.skipped_bytes(), 58u + 48u);
    EXPECT_EQ(r.decoder.last_problem(), "refused a TRANSFORM message with a body of " + std::to_string(size) +
                                            " bytes (a TRANSFORM of header version 1 has at most 48)"
                                            "; resynchronised after skipping 106 bytes");
  }
}

TEST(IgtlDecoder, OtherHeaderVersionsAreRefusedByNumberAndSkipped) {
  Stream r(metres());
  Bytes v3 = identity_at(0.1f);
  set_version(v3, 3);
  r.feed(v3);
  r.feed(identity_at(0.2f));
  ASSERT_EQ(r.poses.size(), 1u);
  EXPECT_EQ(r.poses[0].position[0], 0.2f);
  EXPECT_EQ(r.decoder.bad_messages(), 1u);
  EXPECT_EQ(r.decoder.resynchronisations(), 0u);
  EXPECT_EQ(r.decoder.last_problem(), "refused a TRANSFORM message of header version 3 (this bridge reads versions 1 and 2)");
}

TEST(IgtlDecoder, GarbageBetweenMessagesIsSkippedAndCounted) {
  Stream r(metres());
  Bytes stream = identity_at(0.1f);
  const Bytes garbage = {0xde, 0xad, 0xbe, 0xef, 0, 1, 2, 3};
  stream.insert(stream.end(), garbage.begin(), garbage.end());
  const Bytes next = identity_at(0.3f);
  stream.insert(stream.end(), next.begin(), next.end());
  // Byte by byte, as a slow network would deliver it.
  for (std::uint8_t b : stream) r.feed(Bytes{b});
  ASSERT_EQ(r.poses.size(), 2u);
  EXPECT_EQ(r.poses[1].position[0], 0.3f);
  EXPECT_EQ(r.decoder.bad_messages(), 1u);
  EXPECT_EQ(r.decoder.skipped_bytes(), 8u);
  EXPECT_EQ(r.decoder.last_problem(),
            "refused a header whose type or device name is not a name; resynchronised after skipping 8 bytes");
}

TEST(IgtlDecoder, PosesOutsideTheWorkspaceAndBadRotationsAreRefused) {
  const float zero[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  const float mirror[9] = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
  const float sheared[9] = {1, 0.5f, 0, 0, 1, 0, 0, 0, 1};
  struct Case {
    const char* name;
    Bytes message;
    const char* expected;
  } cases[] = {
      {"1e27 m", transform(kIdentity, 1e27f, 0, 0),
       "refused a TRANSFORM message: its position (1e+27, 0, 0) m is outside the workspace (|x|, |y|, |z| <= 1 m)"},
      {"1.5 m", transform(kIdentity, 0, 0, -1.5f),
       "refused a TRANSFORM message: its position (0, 0, -1.5) m is outside the workspace (|x|, |y|, |z| <= 1 m)"},
      {"all-zero rotation", transform(zero, 0, 0, 0),
       "refused a TRANSFORM message: its rotation is not orthonormal (|R^T R - I| = 1, det R = 0)"},
      {"mirror", transform(mirror, 0, 0, 0),
       "refused a TRANSFORM message: its rotation is not orthonormal (|R^T R - I| = 0, det R = -1)"},
      {"shear", transform(sheared, 0, 0, 0),
       "refused a TRANSFORM message: its rotation is not orthonormal (|R^T R - I| = 0.5, det R = 1)"},
      {"nan", transform(kIdentity, std::nanf(""), 0, 0), "refused a TRANSFORM message: it holds a number that is not finite"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Stream r(metres());
    r.feed(c.message);
    EXPECT_TRUE(r.poses.empty());
    EXPECT_EQ(r.decoder.bad_messages(), 1u);
    EXPECT_EQ(r.decoder.last_problem(), c.expected);
  }
}

TEST(IgtlDecoder, PositionQuaternionsMustBeUnit) {
  ::igtl::PositionMessage::Pointer m = ::igtl::PositionMessage::New();
  m->SetDeviceName("Tracker");
  m->SetPosition(1.f, 2.f, 3.f);
  m->SetQuaternion(0.f, 0.f, 0.f, 0.f);
  m->Pack();
  const auto* p = static_cast<const std::uint8_t*>(m->GetPackPointer());
  Stream r;
  r.feed(Bytes(p, p + m->GetPackSize()));
  EXPECT_TRUE(r.poses.empty());
  EXPECT_EQ(r.decoder.last_problem(), "refused a POSITION message: its quaternion has norm 0, not 1");
}

// Header version 2 (protocol 3): the content sits between an extended header and metadata.
TEST(IgtlDecoder, HeaderVersionTwoIsRead) {
  Bytes v1 = identity_at(0.4f);
  Bytes body(v1.begin() + kHeaderSize, v1.end());
  Bytes ext = {0, 12, 0, 0, 0, 0, 0, 0, 0, 0, 0, 7};  // 12-byte extended header, no metadata, id 7
  Bytes m(v1.begin(), v1.begin() + kHeaderSize);
  m.insert(m.end(), ext.begin(), ext.end());
  m.insert(m.end(), body.begin(), body.end());
  set_version(m, 2);
  set_body_size(m, ext.size() + body.size());
  const std::uint64_t crc = crc64(m.data() + kHeaderSize, ext.size() + body.size(), 0);
  for (int k = 0; k < 8; ++k) m[50 + k] = static_cast<std::uint8_t>(crc >> (56 - 8 * k));
  Stream r(metres());
  r.feed(m);
  ASSERT_EQ(r.poses.size(), 1u) << r.decoder.last_problem();
  EXPECT_EQ(r.poses[0].position[0], 0.4f);
}

}  // namespace
}  // namespace palpa::plugins::igtl
