#include "falcon_protocol.h"

#include <algorithm>
#include <cstring>

namespace palpa::plugins::falcon {

namespace {

constexpr std::uint8_t kStart = '<';
constexpr std::uint8_t kEnd = '>';
constexpr std::uint8_t kNibbleBase = 0x41;

// Three int16 as 12 nibble characters, least significant nibble first.
void put_values(const std::array<std::int16_t, 3>& v, std::uint8_t* p) {
  for (int i = 0; i < 3; ++i) {
    const auto u = static_cast<std::uint16_t>(v[i]);
    for (int k = 0; k < 4; ++k) p[4 * i + k] = static_cast<std::uint8_t>(kNibbleBase + ((u >> (4 * k)) & 0xf));
  }
}

// The frame checks shared by both directions; nibbles of bytes 1..14.
PacketError check_frame(std::span<const std::uint8_t> p, std::array<std::uint8_t, 14>& nibble) {
  if (p.size() != kPacketSize) return PacketError::WrongLength;
  if (p[0] != kStart) return PacketError::BadStart;
  if (p[15] != kEnd) return PacketError::BadEnd;
  for (int i = 1; i <= 14; ++i) {
    if (p[i] < kNibbleBase || p[i] > kNibbleBase + 15) return PacketError::BadNibble;
    nibble[i - 1] = static_cast<std::uint8_t>(p[i] - kNibbleBase);
  }
  return PacketError::None;
}

void get_values(const std::array<std::uint8_t, 14>& n, std::array<std::int16_t, 3>& v) {
  for (int i = 0; i < 3; ++i) {
    std::uint16_t u = 0;
    for (int k = 0; k < 4; ++k) u = static_cast<std::uint16_t>(u | (n[4 * i + k] << (4 * k)));
    v[i] = static_cast<std::int16_t>(u);
  }
}

}  // namespace

const char* to_string(PacketError e) {
  switch (e) {
    case PacketError::None: return "ok";
    case PacketError::WrongLength: return "packet is not 16 bytes long";
    case PacketError::BadStart: return "packet does not start with '<'";
    case PacketError::BadEnd: return "packet does not end with '>'";
    case PacketError::BadNibble: return "packet byte outside 'A'..'P'";
    case PacketError::BadFlags: return "packet flag byte out of range";
  }
  return "unknown packet error";
}

std::array<std::uint8_t, kPacketSize> encode_command(const Command& c) {
  std::array<std::uint8_t, kPacketSize> p{};
  p[0] = kStart;
  put_values(c.motor, &p[1]);
  p[13] = static_cast<std::uint8_t>(kNibbleBase + ((c.leds & (kLedGreen | kLedBlue | kLedRed)) |
                                                   (c.homing ? kHomingModeBit : 0)));
  p[14] = kNibbleBase;
  p[15] = kEnd;
  return p;
}

PacketError decode_command(std::span<const std::uint8_t> packet, Command& out) {
  std::array<std::uint8_t, 14> n{};
  if (auto e = check_frame(packet, n); e != PacketError::None) return e;
  if (n[13] != 0) return PacketError::BadFlags;
  get_values(n, out.motor);
  out.leds = n[12] & (kLedGreen | kLedBlue | kLedRed);
  out.homing = (n[12] & kHomingModeBit) != 0;
  return PacketError::None;
}

std::array<std::uint8_t, kPacketSize> encode_status(const Status& s) {
  std::array<std::uint8_t, kPacketSize> p{};
  p[0] = kStart;
  put_values(s.encoder, &p[1]);
  p[13] = static_cast<std::uint8_t>(kNibbleBase + (((s.homed & 0x7) << 4) | (s.buttons & 0xf)));
  p[14] = kNibbleBase;
  p[15] = kEnd;
  return p;
}

// Byte 13 carries 8 bits as (0x41 + value): buttons in the low nibble, homed
// motors in bits 4..6; a value above 0x7f is malformed.
PacketError decode_status(std::span<const std::uint8_t> packet, Status& out) {
  if (packet.size() != kPacketSize) return PacketError::WrongLength;
  if (packet[0] != kStart) return PacketError::BadStart;
  if (packet[15] != kEnd) return PacketError::BadEnd;
  std::array<std::uint8_t, 14> n{};
  for (int i = 1; i <= 12; ++i) {
    if (packet[i] < kNibbleBase || packet[i] > kNibbleBase + 15) return PacketError::BadNibble;
    n[i - 1] = static_cast<std::uint8_t>(packet[i] - kNibbleBase);
  }
  if (packet[13] < kNibbleBase || packet[13] > kNibbleBase + 0x7f) return PacketError::BadFlags;
  if (packet[14] < kNibbleBase || packet[14] > kNibbleBase + 15) return PacketError::BadNibble;
  const std::uint8_t flags = static_cast<std::uint8_t>(packet[13] - kNibbleBase);
  get_values(n, out.encoder);
  out.buttons = flags & 0xf;
  out.homed = (flags >> 4) & 0x7;
  return PacketError::None;
}

std::size_t strip_ftdi_status(std::span<const std::uint8_t> transfer, std::uint8_t* out) {
  std::size_t n = 0;
  for (std::size_t start = 0; start < transfer.size(); start += kUsbPacketSize) {
    const std::size_t end = std::min(transfer.size(), start + kUsbPacketSize);
    if (end - start <= kFtdiStatusBytes) continue;
    std::memcpy(out + n, transfer.data() + start + kFtdiStatusBytes, end - start - kFtdiStatusBytes);
    n += end - start - kFtdiStatusBytes;
  }
  return n;
}

void StatusFramer::push(std::span<const std::uint8_t> bytes) {
  for (std::uint8_t b : bytes) {
    if (size_ == buf_.size()) {
      // Full: drop the oldest byte.
      std::memmove(buf_.data(), buf_.data() + 1, size_ - 1);
      --size_;
      ++discarded_;
    }
    buf_[size_++] = b;
  }
}

bool StatusFramer::next(Status& out) {
  std::size_t pos = 0;
  bool found = false;
  // Slide over the buffer: a packet starts at '<' and decodes cleanly.
  while (pos < size_) {
    if (buf_[pos] != kStart) {
      ++pos;
      continue;
    }
    if (size_ - pos < kPacketSize) break;  // maybe the start of a packet still arriving
    if (decode_status(std::span<const std::uint8_t>(&buf_[pos], kPacketSize), out) == PacketError::None) {
      found = true;
      break;
    }
    ++pos;  // a '<' that does not start a valid packet
  }
  const std::size_t consumed = found ? pos + kPacketSize : pos;
  discarded_ += pos;
  std::memmove(buf_.data(), buf_.data() + consumed, size_ - consumed);
  size_ -= consumed;
  return found;
}

}  // namespace palpa::plugins::falcon
