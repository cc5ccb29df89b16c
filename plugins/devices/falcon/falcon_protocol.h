#pragma once
// The Novint Falcon's USB protocol (facts as documented in libnifalcon's
// sources; this is our own code).
//
// Transport: an FTDI USB-serial chip, USB 0403:cb48, bulk OUT endpoint 0x02,
// bulk IN endpoint 0x81. Every bulk IN transfer starts with two FTDI modem
// status bytes (again at the start of every 64-byte USB packet). The chip is
// configured with FTDI vendor control requests (bmRequestType 0x40).
//
// Firmware: the Falcon boots into a loader. At 9600 baud (divisor 0x4138),
// 8N1, no flow control, RTS low, DTR low then high, the host sends 0A 43 0D
// and the loader answers 0A 44 2C 0D (some hosts see a leading 00). Then DTR
// low, divisor 0x15 (140000 baud), the host sends 'A' and the loader echoes
// 0x41; the firmware image follows in chunks of at most 62 bytes, each byte
// echoed back. Normal mode afterwards: latency timer 1 ms, divisor 0x2,
// RX/TX purged.
//
// Normal mode: the host sends a 16-byte command packet, the firmware answers
// with a 16-byte status packet:
//   byte 0       '<'
//   bytes 1..12  three int16 values, four nibbles each, least significant
//                first; every nibble is sent as 0x41 + nibble ('A'..'P')
//                (command: motor torques; status: encoder counts)
//   byte 13      0x41 + flags. Command: LEDs (green 0x2, blue 0x4, red 0x8)
//                | homing mode 0x1. Status: low nibble = grip buttons, high
//                nibble bits 0..2 = motors 1..3 homed.
//   byte 14      0x41 (+ 0)
//   byte 15      '>'

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace palpa::plugins::falcon {

inline constexpr std::uint16_t kVendorId = 0x0403;
inline constexpr std::uint16_t kProductId = 0xcb48;
inline constexpr unsigned char kEndpointOut = 0x02;
inline constexpr unsigned char kEndpointIn = 0x81;
inline constexpr std::size_t kPacketSize = 16;
inline constexpr std::size_t kFtdiStatusBytes = 2;
inline constexpr std::size_t kUsbPacketSize = 64;
inline constexpr std::size_t kFirmwareChunk = 62;

// FTDI vendor control requests (bmRequestType 0x40) and their values.
inline constexpr std::uint8_t kFtdiRequestType = 0x40;
inline constexpr std::uint8_t kFtdiReset = 0;
inline constexpr std::uint8_t kFtdiModemControl = 1;
inline constexpr std::uint8_t kFtdiFlowControl = 2;
inline constexpr std::uint8_t kFtdiBaudRate = 3;
inline constexpr std::uint8_t kFtdiData = 4;
inline constexpr std::uint8_t kFtdiLatency = 9;
inline constexpr std::uint16_t kFtdiPurgeRx = 1;
inline constexpr std::uint16_t kFtdiPurgeTx = 2;
inline constexpr std::uint16_t kFtdiDtrHigh = 0x0101;
inline constexpr std::uint16_t kFtdiDtrLow = 0x0100;
inline constexpr std::uint16_t kFtdiRtsLow = 0x0200;
inline constexpr std::uint16_t kFtdiData8N1 = 8;
inline constexpr std::uint16_t kBaudLoaderCheck = 0x4138;  ///< 9600 baud
inline constexpr std::uint16_t kBaudLoaderUpload = 0x15;   ///< 140000 baud
inline constexpr std::uint16_t kBaudNormal = 0x2;

inline constexpr std::array<std::uint8_t, 3> kLoaderQuery{0x0a, 0x43, 0x0d};
inline constexpr std::array<std::uint8_t, 4> kLoaderReply{0x0a, 0x44, 0x2c, 0x0d};
inline constexpr std::uint8_t kLoaderStart = 0x41;

enum Led : std::uint8_t { kLedGreen = 0x2, kLedBlue = 0x4, kLedRed = 0x8 };
inline constexpr std::uint8_t kHomingModeBit = 0x1;

/// Host -> Falcon.
struct Command {
  std::array<std::int16_t, 3> motor{};  ///< motor commands (torque units)
  std::uint8_t leds = 0;                ///< Led bits
  bool homing = false;                  ///< homing mode
  friend bool operator==(const Command&, const Command&) = default;
};

/// Falcon -> host.
struct Status {
  std::array<std::int16_t, 3> encoder{};  ///< encoder counts
  std::uint8_t homed = 0;                 ///< bit i: motor i homed
  std::uint8_t buttons = 0;               ///< grip buttons, 4 bits
  friend bool operator==(const Status&, const Status&) = default;
};

enum class PacketError {
  None,
  WrongLength,  ///< not exactly 16 bytes
  BadStart,     ///< byte 0 is not '<'
  BadEnd,       ///< byte 15 is not '>'
  BadNibble,    ///< a byte 1..14 outside 'A'..'P'
  BadFlags,     ///< flag byte 13 out of range (status: above 0x41 + 0x7f; command: byte 14 not 'A')
};

const char* to_string(PacketError e);

std::array<std::uint8_t, kPacketSize> encode_command(const Command& c);
PacketError decode_command(std::span<const std::uint8_t> packet, Command& out);
std::array<std::uint8_t, kPacketSize> encode_status(const Status& s);
PacketError decode_status(std::span<const std::uint8_t> packet, Status& out);

/// Removes the two FTDI status bytes at the start of every 64-byte USB packet
/// of one bulk IN transfer; returns the payload length written to `out`
/// (which must hold transfer.size() bytes).
std::size_t strip_ftdi_status(std::span<const std::uint8_t> transfer, std::uint8_t* out);

/// Reassembles status packets from the payload byte stream (packets may be
/// split across transfers and garbage may sit between them). No allocation.
class StatusFramer {
 public:
  /// Appends payload bytes (the oldest are dropped if more than 256 pile up).
  void push(std::span<const std::uint8_t> bytes);
  /// Takes the next valid status packet; bytes that cannot start one are
  /// discarded (and counted). False when no complete packet is buffered.
  bool next(Status& out);
  std::size_t discarded() const { return discarded_; }
  std::size_t buffered() const { return size_; }

 private:
  std::array<std::uint8_t, 256> buf_{};
  std::size_t size_ = 0;
  std::size_t discarded_ = 0;
};

}  // namespace palpa::plugins::falcon
