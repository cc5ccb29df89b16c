#include "devices/device.h"

#include <utility>

namespace palpa::devices {

// Creates the plugin instance and reads its specification once.
Device::Device(std::shared_ptr<void> library, const PluginApi& api, const std::string& options, std::string label)
    : library_(std::move(library)), api_(api), label_(std::move(label)) {
  char error[1024] = {0};
  handle_ = api_.create(options.c_str(), error, sizeof error);
  if (handle_ == nullptr) {
    std::string msg = error[0] ? error : label_ + ": the plugin refused to create a device (no reason given)";
    throw DeviceError(msg);
  }
  if (api_.spec(handle_, &spec_) != PALPA_DEVICE_OK) {
    api_.destroy(handle_);
    handle_ = nullptr;
    throw DeviceError(label_ + ": the plugin did not report its specification");
  }
  spec_.name[sizeof spec_.name - 1] = '\0';
}

Device::~Device() { reset(); }

Device::Device(Device&& other) noexcept { *this = std::move(other); }

// Moves ownership of the instance; the moved-from device is empty.
Device& Device::operator=(Device&& other) noexcept {
  if (this == &other) return *this;
  reset();
  library_ = std::move(other.library_);
  api_ = other.api_;
  handle_ = std::exchange(other.handle_, nullptr);
  spec_ = other.spec_;
  label_ = std::move(other.label_);
  started_ = std::exchange(other.started_, false);
  return *this;
}

// Stops (zero force first, inside the plugin) and destroys the instance.
void Device::reset() noexcept {
  if (handle_ == nullptr) return;
  if (started_) api_.stop(handle_);
  api_.destroy(handle_);
  handle_ = nullptr;
  started_ = false;
}

void Device::start() {
  if (handle_ == nullptr) throw DeviceError("device is empty (moved from)");
  if (started_) return;
  char error[1024] = {0};
  if (api_.start(handle_, error, sizeof error) != PALPA_DEVICE_OK) {
    std::string msg = error[0] ? error : label_ + ": failed to start (no reason given)";
    throw DeviceError(msg);
  }
  started_ = true;
}

void Device::stop() {
  if (handle_ == nullptr || !started_) return;
  api_.stop(handle_);
  started_ = false;
}

void Device::restart() {
  stop();
  start();
}

std::string Device::message() const {
  if (handle_ == nullptr) return "no device";
  char buf[512] = {0};
  api_.message(handle_, buf, sizeof buf);
  buf[sizeof buf - 1] = '\0';
  return buf;
}

}  // namespace palpa::devices
