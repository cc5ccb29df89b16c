// The `falcon` device: a Novint Falcon over libusb (protocol in
// falcon_protocol.h, kinematics in falcon_kinematics.h).
//
// The Falcon needs its firmware uploaded after every power-up. That firmware
// is Novint's and is not shipped with Palpa: the user points the plugin at
// the file from Novint's driver package with firmware=PATH. Without it the
// plugin still works with a Falcon whose firmware is already loaded, and
// says clearly what is missing otherwise.
//
// After start the device homes: the LED is red and forces stay off until the
// user has moved the grip through its range and all three encoders report
// homed; then the LED turns green. An I/O thread exchanges one command and
// one status packet per cycle; force commands come from the haptic loop
// through a triple buffer and are converted to motor torques with the
// Jacobian transpose at the current position. A command older than its
// expiry (the loop's watchdog) is replaced by zero force. A USB error or an
// unplug sets PALPA_STATUS_FAULT until the device is restarted.
//
// Options:
//   firmware=PATH     firmware file to upload when the Falcon has none
//   index=0           which Falcon when several are connected
//   max_force=8.9     N, the force limit declared to the host (Falcon: about 2 lbf)
//   max_stiffness=1500  N/m, declared stable stiffness
//   motor_limit=10000   largest motor command magnitude (all three scaled together)

#include "core/triple_buffer.h"
#include "devices/plugin_support.h"
#include "falcon_kinematics.h"
#include "falcon_protocol.h"

#include <libusb.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

namespace {

using namespace palpa::devices::plugin;
namespace fc = palpa::plugins::falcon;

constexpr unsigned kControlTimeoutMs = 1000;
constexpr unsigned kIoTimeoutMs = 100;

// The options: the form's fields and the parser's defaults and ranges.
constexpr PalpaDeviceOption kOptions[] = {
    option_file("firmware", 0u,
                "Novint's firmware file (not shipped), uploaded when the Falcon has none loaded; "
                "empty works with a Falcon whose firmware is already loaded."),
    option_int("index", "", 0, 15, "0", "Which Falcon, when several are connected (0: the first)."),
    option_double("max_force", "N", 0.01, 50.0, "8.9", "The force limit declared to the host (a Falcon gives about 9 N)."),
    option_double("max_stiffness", "N/m", 1.0, 1e5, "1500", "The stiffness the device renders stably."),
    option_double("motor_limit", "", 1.0, 32767.0, "10000",
                  "The largest motor command magnitude (all three motors are scaled together)."),
};

std::string usb_error(int rc) { return libusb_error_name(rc); }

class FalconDevice final : public DeviceImpl {
 public:
  explicit FalconDevice(const Options& o) {
    firmware_ = o.text("firmware");
    index_ = static_cast<int>(o.integer("index"));
    max_force_ = o.number("max_force");
    max_stiffness_ = o.number("max_stiffness");
    motor_limit_ = o.number("motor_limit");
  }
  ~FalconDevice() override { stop(); }

  PalpaDeviceSpec spec() const override {
    PalpaDeviceSpec s{};
    set_spec_name(s, "Novint Falcon");
    s.position_dof = 3;
    s.force_dof = 3;
    const double lo[3] = {-0.06, -0.06, 0.075}, hi[3] = {0.06, 0.06, 0.175};
    for (int i = 0; i < 3; ++i) {
      s.workspace_min[i] = lo[i];
      s.workspace_max[i] = hi[i];
    }
    s.max_force = max_force_;
    s.max_stiffness = max_stiffness_;
    s.max_damping = 5.0;
    s.nominal_rate = 1000;
    s.button_count = 4;
    return s;
  }

  // Open, configure the FTDI chip, upload firmware if needed, start I/O.
  void start() override {
    if (handle_ != nullptr) return;
    int rc = libusb_init(&ctx_);
    if (rc != 0) throw PluginError("falcon: libusb could not be initialised: " + usb_error(rc));
    try {
      open_device();
      set_normal_mode();
      if (!firmware_answers()) {
        if (firmware_.empty())
          throw PluginError(
              "falcon: the Falcon has no firmware loaded and no firmware file is configured; set "
              "firmware=/path/to/the firmware file from Novint's driver package (Palpa does not ship it)");
        upload_firmware(read_firmware_file());
        set_normal_mode();
        if (!firmware_answers())
          throw PluginError("falcon: the firmware was uploaded but the Falcon does not answer");
      }
    } catch (...) {
      close_device();
      throw;
    }
    {
      std::lock_guard<std::mutex> lock(message_mutex_);
      error_.clear();
    }
    PalpaForceCommand zero{};
    commands_.write(zero);
    PalpaDeviceSample s = empty_sample();
    s.status = PALPA_STATUS_NOT_READY;
    samples_.write(s);
    homed_.store(false);
    stop_.store(false);
    running_.store(true);
    thread_ = std::thread([this] { io_main(); });
  }

  void stop() override {
    if (handle_ == nullptr) return;
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
    close_device();
    running_.store(false);
  }

  void read(PalpaDeviceSample& s) noexcept override {
    if (!running_.load(std::memory_order_acquire)) {
      s = empty_sample();
      return;
    }
    s = samples_.latest();
  }

  int write(const PalpaForceCommand& c) noexcept override {
    commands_.write(c);
    return PALPA_DEVICE_OK;
  }

  std::string message() const override {
    std::lock_guard<std::mutex> lock(message_mutex_);
    if (!error_.empty()) return error_;
    if (!running_.load()) return "falcon: stopped";
    if (!homed_.load()) return "falcon: homing: move the grip all the way in and out until the LED turns green";
    return "falcon: running";
  }

 private:
  // ---- USB helpers (control thread or I/O thread, never both) ----

  void open_device() {
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx_, &list);
    if (n < 0) throw PluginError("falcon: cannot list USB devices: " + usb_error(static_cast<int>(n)));
    libusb_device* found = nullptr;
    int seen = 0;
    for (ssize_t i = 0; i < n && found == nullptr; ++i) {
      libusb_device_descriptor d{};
      if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
      if (d.idVendor == fc::kVendorId && d.idProduct == fc::kProductId && seen++ == index_) found = list[i];
    }
    int rc = found ? libusb_open(found, &handle_) : LIBUSB_ERROR_NOT_FOUND;
    libusb_free_device_list(list, 1);
    if (found == nullptr)
      throw PluginError(index_ == 0 ? "falcon: no Novint Falcon found (USB 0403:cb48)"
                                    : "falcon: Falcon number " + std::to_string(index_) + " not found (" +
                                          std::to_string(seen) + " connected)");
    if (rc != 0) {
      handle_ = nullptr;
      throw PluginError("falcon: cannot open the Falcon: " + usb_error(rc) +
                        " (check the permissions of /dev/bus/usb or the udev rule)");
    }
    libusb_set_auto_detach_kernel_driver(handle_, 1);
    rc = libusb_claim_interface(handle_, 0);
    if (rc != 0) throw PluginError("falcon: cannot claim the Falcon's interface: " + usb_error(rc));
  }

  void close_device() {
    if (handle_ != nullptr) {
      libusb_release_interface(handle_, 0);
      libusb_close(handle_);
      handle_ = nullptr;
    }
    if (ctx_ != nullptr) {
      libusb_exit(ctx_);
      ctx_ = nullptr;
    }
  }

  void control(std::uint8_t request, std::uint16_t value, const char* what) {
    const int rc = libusb_control_transfer(handle_, fc::kFtdiRequestType, request, value, 0, nullptr, 0,
                                           kControlTimeoutMs);
    if (rc < 0) throw PluginError(std::string("falcon: cannot ") + what + ": " + usb_error(rc));
  }

  void bulk_out(const std::uint8_t* data, int size, const char* what) {
    int done = 0;
    const int rc = libusb_bulk_transfer(handle_, fc::kEndpointOut, const_cast<std::uint8_t*>(data), size, &done,
                                        kControlTimeoutMs);
    if (rc != 0 || done != size)
      throw PluginError(std::string("falcon: cannot send ") + what + ": " + (rc ? usb_error(rc) : "short write"));
  }

  // One bulk IN transfer; payload (FTDI status bytes removed) appended to `out`.
  int bulk_in(std::vector<std::uint8_t>& out, unsigned timeout_ms) {
    std::uint8_t buf[fc::kUsbPacketSize];
    int got = 0;
    const int rc = libusb_bulk_transfer(handle_, fc::kEndpointIn, buf, sizeof buf, &got, timeout_ms);
    if (rc != 0 && rc != LIBUSB_ERROR_TIMEOUT) return rc;
    std::uint8_t payload[fc::kUsbPacketSize];
    const std::size_t n = fc::strip_ftdi_status(std::span<const std::uint8_t>(buf, static_cast<std::size_t>(got)),
                                                payload);
    out.insert(out.end(), payload, payload + n);
    return 0;
  }

  void purge() {
    control(fc::kFtdiReset, fc::kFtdiPurgeRx, "purge the receive buffer");
    control(fc::kFtdiReset, fc::kFtdiPurgeTx, "purge the transmit buffer");
  }

  void set_normal_mode() {
    control(fc::kFtdiLatency, 1, "set the latency timer");
    control(fc::kFtdiBaudRate, fc::kBaudNormal, "set the baud rate");
    purge();
  }

  // Sends idle command packets and watches for a valid status packet.
  bool firmware_answers() {
    fc::StatusFramer framer;
    fc::Command idle;
    idle.leds = fc::kLedRed;
    idle.homing = true;
    const auto packet = fc::encode_command(idle);
    for (int attempt = 0; attempt < 5; ++attempt) {
      bulk_out(packet.data(), static_cast<int>(packet.size()), "a command packet");
      std::vector<std::uint8_t> bytes;
      for (int k = 0; k < 3; ++k) {
        const int rc = bulk_in(bytes, 20);
        if (rc != 0) throw PluginError("falcon: cannot read from the Falcon: " + usb_error(rc));
      }
      framer.push(bytes);
      fc::Status st;
      if (framer.next(st)) return true;
    }
    return false;
  }

  std::vector<std::uint8_t> read_firmware_file() const {
    std::error_code ec;
    if (!std::filesystem::exists(firmware_, ec))
      throw PluginError("falcon: firmware file '" + firmware_ + "' does not exist");
    std::ifstream f(firmware_, std::ios::binary);
    if (!f) throw PluginError("falcon: cannot read firmware file '" + firmware_ + "'");
    std::vector<std::uint8_t> data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (data.empty()) throw PluginError("falcon: firmware file '" + firmware_ + "' is empty");
    if (data.size() > (1u << 20))
      throw PluginError("falcon: firmware file '" + firmware_ + "' is larger than 1 MiB; is it the right file?");
    return data;
  }

  // The loader handshake and the upload with per-byte echo check.
  void upload_firmware(const std::vector<std::uint8_t>& image) {
    purge();
    control(fc::kFtdiLatency, 16, "set the latency timer");
    control(fc::kFtdiBaudRate, fc::kBaudLoaderCheck, "set the baud rate");
    control(fc::kFtdiData, fc::kFtdiData8N1, "set the line properties");
    control(fc::kFtdiFlowControl, 0, "disable flow control");
    control(fc::kFtdiModemControl, fc::kFtdiRtsLow, "set RTS");
    control(fc::kFtdiModemControl, fc::kFtdiDtrLow, "set DTR");
    control(fc::kFtdiModemControl, fc::kFtdiDtrHigh, "set DTR");

    // Loader check: 0A 43 0D -> 0A 44 2C 0D (maybe after a 00).
    bool ok = false;
    for (int attempt = 0; attempt < 20 && !ok; ++attempt) {
      bulk_out(fc::kLoaderQuery.data(), static_cast<int>(fc::kLoaderQuery.size()), "the loader query");
      std::vector<std::uint8_t> reply;
      for (int k = 0; k < 5 && reply.size() < 5; ++k)
        if (const int rc = bulk_in(reply, 50); rc != 0)
          throw PluginError("falcon: no answer from the loader: " + usb_error(rc));
      if (!reply.empty() && reply[0] == 0x00) reply.erase(reply.begin());
      ok = reply.size() == fc::kLoaderReply.size() &&
           std::equal(reply.begin(), reply.end(), fc::kLoaderReply.begin());
    }
    if (!ok) throw PluginError("falcon: the Falcon's loader does not answer the firmware handshake");

    control(fc::kFtdiModemControl, fc::kFtdiDtrLow, "set DTR");
    control(fc::kFtdiBaudRate, fc::kBaudLoaderUpload, "set the baud rate");
    bulk_out(&fc::kLoaderStart, 1, "the upload start byte");
    std::vector<std::uint8_t> ack;
    for (int k = 0; k < 10 && ack.empty(); ++k)
      if (const int rc = bulk_in(ack, 50); rc != 0)
        throw PluginError("falcon: no answer from the loader: " + usb_error(rc));
    if (ack.size() != 1 || ack[0] != fc::kLoaderStart)
      throw PluginError("falcon: the loader did not acknowledge the upload (expected 0x41)");

    // The image in chunks; every byte comes back and must match.
    for (std::size_t pos = 0; pos < image.size(); pos += fc::kFirmwareChunk) {
      const std::size_t len = std::min(fc::kFirmwareChunk, image.size() - pos);
      bulk_out(&image[pos], static_cast<int>(len), "firmware");
      std::vector<std::uint8_t> echo;
      for (int k = 0; k < 50 && echo.size() < len; ++k)
        if (const int rc = bulk_in(echo, 50); rc != 0)
          throw PluginError("falcon: firmware upload failed at byte " + std::to_string(pos) + ": " + usb_error(rc));
      if (echo.size() < len)
        throw PluginError("falcon: firmware upload failed at byte " + std::to_string(pos + echo.size()) +
                          ": no echo from the loader");
      for (std::size_t i = 0; i < len; ++i)
        if (echo[i] != image[pos + i]) {
          char buf[160];
          std::snprintf(buf, sizeof buf, "falcon: firmware upload failed at byte %zu: echoed 0x%02x, sent 0x%02x",
                        pos + i, echo[i], image[pos + i]);
          throw PluginError(buf);
        }
    }
  }

  // ---- the I/O thread ----

  void set_error(const std::string& e) {
    std::lock_guard<std::mutex> lock(message_mutex_);
    error_ = e;
  }

  // Latches a fault: the sample says FAULT from now on.
  void fault(const std::string& e, const PalpaDeviceSample& last) {
    set_error(e);
    PalpaDeviceSample s = last;
    s.status = PALPA_STATUS_FAULT;
    s.time = monotonic_now();
    s.sequence = ++sequence_;
    samples_.write(s);
  }

  void io_main() {
    fc::Kinematics kin;
    fc::StatusFramer framer;
    PalpaDeviceSample last = empty_sample();
    last.status = PALPA_STATUS_NOT_READY;
    fc::Vec3 position(0, 0, 0.11);
    bool homed = false;
    double last_packet = monotonic_now();
    std::uint8_t buf[fc::kUsbPacketSize], payload[fc::kUsbPacketSize];

    while (!stop_.load(std::memory_order_relaxed)) {
      // Command: zero unless homed and fresh (watchdog); torques by J^T.
      const PalpaForceCommand cmd = commands_.latest();
      const double now = monotonic_now();
      fc::Command out;
      out.homing = !homed;
      out.leds = homed ? fc::kLedGreen : fc::kLedRed;
      const bool fresh = now <= cmd.time + cmd.expires_after;
      const fc::Vec3 force(cmd.force[0], cmd.force[1], cmd.force[2]);
      fc::Vec3 tau;
      if (homed && fresh && force.allFinite() && force.norm() <= max_force_ * (1 + 1e-9) &&
          kin.torques(position, force, tau)) {
        fc::Vec3 motor = -tau * fc::kTorqueScale;
        const double big = motor.cwiseAbs().maxCoeff();
        if (big > motor_limit_) motor *= motor_limit_ / big;
        for (int i = 0; i < 3; ++i) out.motor[i] = static_cast<std::int16_t>(std::lround(motor[i]));
      }
      const auto packet = fc::encode_command(out);

      // Exchange: one command out, whatever arrived back in.
      int done = 0;
      int rc = libusb_bulk_transfer(handle_, fc::kEndpointOut, const_cast<std::uint8_t*>(packet.data()),
                                    static_cast<int>(packet.size()), &done, kIoTimeoutMs);
      int got = 0;
      if (rc == 0) rc = libusb_bulk_transfer(handle_, fc::kEndpointIn, buf, sizeof buf, &got, kIoTimeoutMs);
      if (rc == LIBUSB_ERROR_TIMEOUT) rc = 0;
      if (rc != 0) {
        fault(rc == LIBUSB_ERROR_NO_DEVICE ? "falcon: unplugged; plug it back in and restart the device"
                                           : "falcon: USB error " + usb_error(rc) + "; restart the device",
              last);
        return;
      }
      const std::size_t n = fc::strip_ftdi_status(std::span<const std::uint8_t>(buf, static_cast<std::size_t>(got)),
                                                  payload);
      framer.push(std::span<const std::uint8_t>(payload, n));

      // Every complete status packet: homing, buttons, position.
      fc::Status st;
      while (framer.next(st)) {
        last_packet = monotonic_now();
        if (!homed && st.homed == 0x7) {
          homed = true;
          homed_.store(true);
        }
        fc::Vec3 angles;
        for (int i = 0; i < 3; ++i) angles[i] = fc::encoder_to_angle(st.encoder[i]);
        fc::Vec3 p = position;
        const bool solved = kin.forward(angles, p);
        if (solved) position = p;
        PalpaDeviceSample s = empty_sample();
        for (int i = 0; i < 3; ++i) s.position[i] = position[i];
        s.buttons = st.buttons;
        s.time = last_packet;
        s.sequence = ++sequence_;
        s.status = PALPA_STATUS_VALID | (homed && solved ? 0u : PALPA_STATUS_NOT_READY);
        samples_.write(s);
        last = s;
      }

      // No packets for a while: the input is stale (not yet a fault).
      if (monotonic_now() - last_packet > 0.25 && !(last.status & PALPA_STATUS_STALE)) {
        last.status |= PALPA_STATUS_STALE;
        last.sequence = ++sequence_;
        samples_.write(last);
      }
    }

    // Leaving: a zero-force packet.
    fc::Command zero;
    zero.leds = fc::kLedRed;
    const auto packet = fc::encode_command(zero);
    int done = 0;
    libusb_bulk_transfer(handle_, fc::kEndpointOut, const_cast<std::uint8_t*>(packet.data()),
                         static_cast<int>(packet.size()), &done, kIoTimeoutMs);
  }

  std::string firmware_;
  int index_ = 0;
  double max_force_ = 8.9, max_stiffness_ = 1500, motor_limit_ = 10000;
  libusb_context* ctx_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
  std::thread thread_;
  std::atomic<bool> stop_{false}, running_{false}, homed_{false};
  palpa::TripleBuffer<PalpaForceCommand> commands_;
  palpa::TripleBuffer<PalpaDeviceSample> samples_;
  std::uint64_t sequence_ = 0;  // I/O thread only
  mutable std::mutex message_mutex_;
  std::string error_;
};

std::unique_ptr<DeviceImpl> make_falcon(const Options& o) { return std::make_unique<FalconDevice>(o); }

}  // namespace

PALPA_EXPORT_DEVICE_PLUGIN("falcon", make_falcon, kOptions)
