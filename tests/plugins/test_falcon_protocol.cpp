// Falcon packets on byte vectors: the documented layout, round trips, every
// malformed packet, FTDI status stripping and reassembly of split, garbled
// streams.

#include "falcon_protocol.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace palpa::plugins::falcon {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes bytes(const std::array<std::uint8_t, kPacketSize>& a) { return {a.begin(), a.end()}; }

TEST(FalconPacket, CommandLayoutByHand) {
  Command c;
  c.motor = {0x1234, -1, 0};
  c.leds = kLedRed | kLedGreen;
  c.homing = true;
  // 0x1234 -> nibbles 4,3,2,1 -> 'E','D','C','B'; -1 -> 'P' x4; 0 -> 'A' x4;
  // flags 0x8 | 0x2 | 0x1 = 0xb -> 'L'; byte 14 'A'.
  const Bytes expected = {'<', 'E', 'D', 'C', 'B', 'P', 'P', 'P', 'P', 'A', 'A', 'A', 'A', 'L', 'A', '>'};
  EXPECT_EQ(bytes(encode_command(c)), expected);
}

TEST(FalconPacket, StatusLayoutByHand) {
  // Encoders 1, -2, 0x7fff; buttons 0b0101; motors 1 and 3 homed.
  const Bytes packet = {'<', 'B', 'A', 'A', 'A', 'O', 'P', 'P', 'P', 'P', 'P', 'P', 'H',
                        static_cast<std::uint8_t>(0x41 + ((0b101 << 4) | 0b0101)), 'A', '>'};
  Status s;
  ASSERT_EQ(decode_status(packet, s), PacketError::None);
  EXPECT_EQ(s.encoder, (std::array<std::int16_t, 3>{1, -2, 0x7fff}));
  EXPECT_EQ(s.buttons, 0b0101);
  EXPECT_EQ(s.homed, 0b101);
}

TEST(FalconPacket, RoundTripsOverRandomValues) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> v(-32768, 32767), b(0, 15), h(0, 7);
  for (int i = 0; i < 10000; ++i) {
    Command c;
    c.motor = {static_cast<std::int16_t>(v(rng)), static_cast<std::int16_t>(v(rng)), static_cast<std::int16_t>(v(rng))};
    c.leds = static_cast<std::uint8_t>(b(rng) & 0xe);
    c.homing = (i & 1) != 0;
    Command c2;
    ASSERT_EQ(decode_command(bytes(encode_command(c)), c2), PacketError::None);
    EXPECT_EQ(c2, c);
    Status s;
    s.encoder = {static_cast<std::int16_t>(v(rng)), static_cast<std::int16_t>(v(rng)), static_cast<std::int16_t>(v(rng))};
    s.buttons = static_cast<std::uint8_t>(b(rng));
    s.homed = static_cast<std::uint8_t>(h(rng));
    Status s2;
    ASSERT_EQ(decode_status(bytes(encode_status(s)), s2), PacketError::None);
    EXPECT_EQ(s2, s);
  }
}

TEST(FalconPacket, EveryMalformedPacketIsRefusedWithItsReason) {
  const Bytes good = bytes(encode_status(Status{{100, -200, 300}, 7, 9}));
  Status s;
  auto with = [&](std::size_t i, std::uint8_t value) {
    Bytes b = good;
    b[i] = value;
    return b;
  };
  EXPECT_EQ(decode_status(Bytes{}, s), PacketError::WrongLength);
  EXPECT_EQ(decode_status(Bytes(good.begin(), good.end() - 1), s), PacketError::WrongLength);
  Bytes longer = good;
  longer.push_back('>');
  EXPECT_EQ(decode_status(longer, s), PacketError::WrongLength);
  EXPECT_EQ(decode_status(with(0, '['), s), PacketError::BadStart);
  EXPECT_EQ(decode_status(with(15, ']'), s), PacketError::BadEnd);
  for (std::size_t i = 1; i <= 12; ++i) {
    EXPECT_EQ(decode_status(with(i, 0x40), s), PacketError::BadNibble) << i;  // just below 'A'
    EXPECT_EQ(decode_status(with(i, 0x51), s), PacketError::BadNibble) << i;  // just above 'P'
    EXPECT_EQ(decode_status(with(i, '<'), s), PacketError::BadNibble) << i;
  }
  EXPECT_EQ(decode_status(with(13, 0x40), s), PacketError::BadFlags);
  EXPECT_EQ(decode_status(with(13, 0x41 + 0x80), s), PacketError::BadFlags);
  EXPECT_EQ(decode_status(with(14, 0x20), s), PacketError::BadNibble);
  // Commands: the same frame rules, and byte 14 must be 'A'.
  const Bytes cmd = bytes(encode_command(Command{}));
  Command c;
  Bytes b = cmd;
  b[14] = 'B';
  EXPECT_EQ(decode_command(b, c), PacketError::BadFlags);
  b = cmd;
  b[0] = 'x';
  EXPECT_EQ(decode_command(b, c), PacketError::BadStart);
  EXPECT_STREQ(to_string(PacketError::BadNibble), "packet byte outside 'A'..'P'");
}

TEST(FalconPacket, FtdiStatusBytesAreStrippedPerUsbPacket) {
  Bytes transfer = {0x31, 0x60, 1, 2, 3};
  std::uint8_t out[256];
  EXPECT_EQ(strip_ftdi_status(transfer, out), 3u);
  EXPECT_EQ(Bytes(out, out + 3), (Bytes{1, 2, 3}));
  EXPECT_EQ(strip_ftdi_status(Bytes{0x31, 0x60}, out), 0u);  // status only
  EXPECT_EQ(strip_ftdi_status(Bytes{0x31}, out), 0u);
  // 100 bytes = one full 64-byte USB packet + 36: two status pairs.
  Bytes big(100);
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<std::uint8_t>(i);
  ASSERT_EQ(strip_ftdi_status(big, out), 96u);
  EXPECT_EQ(out[0], 2);
  EXPECT_EQ(out[61], 63);
  EXPECT_EQ(out[62], 66);  // bytes 64 and 65 were the second status pair
}

TEST(FalconFramer, ReassemblesSplitPacketsAndSkipsGarbage) {
  const Status a{{1, 2, 3}, 1, 2}, b{{-4, 5, -6}, 7, 15};
  Bytes stream = {'x', '<', 'A', '>'};                   // garbage and a fake start
  const Bytes pa = bytes(encode_status(a)), pb = bytes(encode_status(b));
  stream.insert(stream.end(), pa.begin(), pa.end());
  stream.insert(stream.end(), {'<', 'Z', 'Z'});          // a broken packet start
  stream.insert(stream.end(), pb.begin(), pb.end());
  // Feed in awkward pieces.
  StatusFramer f;
  std::vector<Status> got;
  for (std::size_t i = 0; i < stream.size(); i += 5) {
    f.push(std::span<const std::uint8_t>(stream.data() + i, std::min<std::size_t>(5, stream.size() - i)));
    Status s;
    while (f.next(s)) got.push_back(s);
  }
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0], a);
  EXPECT_EQ(got[1], b);
  EXPECT_EQ(f.discarded(), 4u + 3u);
  EXPECT_EQ(f.buffered(), 0u);
}

TEST(FalconFramer, PacketWithACorruptedByteIsDropped) {
  Bytes p = bytes(encode_status(Status{{9, 9, 9}, 0, 0}));
  p[6] = 0x00;
  const Bytes good = bytes(encode_status(Status{{1, 1, 1}, 0, 0}));
  p.insert(p.end(), good.begin(), good.end());
  StatusFramer f;
  f.push(p);
  Status s;
  ASSERT_TRUE(f.next(s));
  EXPECT_EQ(s.encoder[0], 1);
  EXPECT_FALSE(f.next(s));
}

TEST(FalconFramer, BoundedBufferDropsTheOldestBytes) {
  StatusFramer f;
  const Bytes junk(1000, 'q');
  f.push(junk);
  EXPECT_EQ(f.buffered(), 256u);
  Status s;
  EXPECT_FALSE(f.next(s));
  EXPECT_EQ(f.buffered(), 0u);
}

}  // namespace
}  // namespace palpa::plugins::falcon
