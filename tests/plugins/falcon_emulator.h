#pragma once
// An emulated Novint Falcon behind umockdev: a programmable ioctl handler
// that answers the usbdevfs requests libusb makes (claim, control and bulk
// URBs, reaping, discarding) like the Falcon's FTDI chip and firmware:
//   - the loader: handshake at 9600 baud, upload echo at 140000 baud, the
//     firmware accepted when the uploaded bytes equal the expected image;
//   - the firmware: one 16-byte status packet per command packet;
//   - a physical model: the end effector (mass, held by the user's hand, a
//     spring to a target the test moves) pushed by the motor torques of the
//     commands; the Cartesian force of a torque comes from virtual work on
//     finite differences of the inverse kinematics, not from the plugin's
//     analytic Jacobian;
//   - homing: each encoder reports an unknown offset until, in homing mode,
//     its arm passes the index angle (35 degrees);
//   - unplug: every later request fails with ENODEV.

#include "falcon_kinematics.h"
#include "falcon_protocol.h"

#include <umockdev.h>

#include <deque>
#include <mutex>
#include <vector>

namespace palpa::test {

class FalconEmulator {
 public:
  FalconEmulator();
  ~FalconEmulator();
  FalconEmulator(const FalconEmulator&) = delete;
  FalconEmulator& operator=(const FalconEmulator&) = delete;

  /// The handler to attach to the device node.
  UMockdevIoctlBase* handler() const { return handler_; }

  /// The firmware image the loader expects; when empty, the firmware counts
  /// as loaded from the start (as after a previous session).
  void expect_firmware(std::vector<std::uint8_t> image);
  /// Echo a wrong byte at this upload position (to test the check).
  void corrupt_echo_at(std::size_t index);

  /// Where the user's hand pulls the grip (device frame, m).
  void set_hand(const palpa::plugins::falcon::Vec3& target);
  void set_buttons(std::uint8_t buttons);
  /// From now on every request fails with ENODEV.
  void unplug();

  // Observations (thread-safe copies).
  bool firmware_loaded() const;
  palpa::plugins::falcon::Vec3 position() const;
  std::uint8_t homed() const;
  std::uint64_t command_packets() const;
  palpa::plugins::falcon::Command last_command() const;
  /// Largest |motor command| seen while not homed (must stay 0).
  int max_motor_before_homing() const;

 private:
  struct Urb {
    UMockdevIoctlData* urb = nullptr;
    UMockdevIoctlData* buffer = nullptr;
    double submitted = 0;
  };

  static gboolean on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self);
  gboolean handle(UMockdevIoctlClient* client);
  void control(std::uint8_t request_type, std::uint8_t request, std::uint16_t value);
  void bulk_out(const std::uint8_t* data, std::size_t n);
  void command_packet(const palpa::plugins::falcon::Command& c);
  void advance(double now);
  bool ready(const Urb& u, double now) const;
  void complete_in(Urb& u);

  UMockdevIoctlBase* handler_ = nullptr;
  mutable std::mutex mutex_;
  std::deque<Urb> pending_;
  std::deque<Urb> discarded_;

  // FTDI and loader state.
  std::uint16_t baud_ = 0x4138;
  unsigned latency_ms_ = 16;
  bool unplugged_ = false;
  std::vector<std::uint8_t> expected_firmware_;
  std::vector<std::uint8_t> uploaded_;
  bool uploading_ = false;
  bool firmware_loaded_ = false;
  std::size_t corrupt_at_ = static_cast<std::size_t>(-1);
  std::deque<std::uint8_t> in_;  // bytes waiting for bulk IN

  // Firmware and physics.
  palpa::plugins::falcon::Kinematics kin_;
  std::vector<std::uint8_t> out_stream_;  // command bytes not yet framed
  palpa::plugins::falcon::Command command_;
  palpa::plugins::falcon::Vec3 p_{0, 0, 0.11}, v_{0, 0, 0}, hand_{0, 0, 0.11};
  double last_time_ = 0;
  std::uint8_t buttons_ = 0;
  std::uint8_t homed_ = 0;
  std::array<int, 3> offset_{517, -733, 311};  // encoder offsets until homed
  std::array<int, 3> last_true_{0, 0, 0};
  bool have_true_ = false;
  std::uint64_t packets_ = 0;
  int max_motor_unhomed_ = 0;
};

}  // namespace palpa::test
