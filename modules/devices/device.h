#pragma once
// The host side of a device: an owned plugin instance with its resolved entry
// points. The real-time calls (read, write, feed) are noexcept and forward
// straight to the plugin.

#include "devices/plugin_api.h"

#include <memory>
#include <stdexcept>
#include <string>

namespace palpa::devices {

/// Bad plugin, bad options or a device that cannot start. The message names
/// the plugin (file or name) and what is wrong.
class DeviceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The entry points of one plugin (all required except feed).
struct PluginApi {
  palpa_device_interface_fn interface = nullptr;
  palpa_device_options_fn options = nullptr;
  palpa_device_create_fn create = nullptr;
  palpa_device_destroy_fn destroy = nullptr;
  palpa_device_spec_fn spec = nullptr;
  palpa_device_start_fn start = nullptr;
  palpa_device_stop_fn stop = nullptr;
  palpa_device_read_fn read = nullptr;
  palpa_device_write_fn write = nullptr;
  palpa_device_message_fn message = nullptr;
  palpa_device_feed_fn feed = nullptr;  ///< optional: host-fed devices (mouse)
};

/// One device instance. Move-only; destroying it stops and destroys the
/// plugin instance. Keeps its plugin library loaded while alive.
class Device {
 public:
  Device() = default;
  /// Creates an instance through `api` with `options`; `label` names it in
  /// messages (e.g. "falcon"). `library` keeps the code loaded (may be null
  /// for entry points compiled into the program). Throws DeviceError with
  /// the plugin's own message when creation fails.
  Device(std::shared_ptr<void> library, const PluginApi& api, const std::string& options, std::string label);
  ~Device();
  Device(Device&& other) noexcept;
  Device& operator=(Device&& other) noexcept;
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  explicit operator bool() const { return handle_ != nullptr; }
  const std::string& label() const { return label_; }
  /// The device's capabilities (read once at creation).
  const PalpaDeviceSpec& spec() const { return spec_; }

  /// Opens the hardware. Throws DeviceError with the plugin's message.
  void start();
  /// Commands zero force and releases the hardware (idempotent).
  void stop();
  /// stop() then start(): reconnects after an unplug.
  void restart();
  bool started() const { return started_; }

  /// Real-time: the latest sample. Returns false when the plugin failed.
  bool read(PalpaDeviceSample& sample) noexcept { return api_.read(handle_, &sample) == PALPA_DEVICE_OK; }
  /// Real-time: replaces the force command (false for devices without force output).
  bool write(const PalpaForceCommand& command) noexcept {
    return api_.write(handle_, &command) == PALPA_DEVICE_OK;
  }
  /// True when the host feeds samples itself (the `mouse` plugin).
  bool can_feed() const { return api_.feed != nullptr; }
  /// Real-time, lock-free: hands the next sample to a host-fed device; false
  /// when the device is not host-fed.
  bool feed(const PalpaDeviceSample& sample) noexcept {
    return api_.feed != nullptr && api_.feed(handle_, &sample) == PALPA_DEVICE_OK;
  }

  /// The plugin's one-line state ("running", "homing: ...", "unplugged").
  std::string message() const;

 private:
  void reset() noexcept;

  std::shared_ptr<void> library_;
  PluginApi api_{};
  PalpaDevice* handle_ = nullptr;
  PalpaDeviceSpec spec_{};
  std::string label_;
  bool started_ = false;
};

}  // namespace palpa::devices
