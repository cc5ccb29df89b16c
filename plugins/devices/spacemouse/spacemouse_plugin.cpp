// The `spacemouse` device: a 3Dconnexion SpaceMouse over hidapi (hidraw) as a
// rate-controlled probe. Deflecting the cap moves the probe at a speed
// proportional to the deflection (spacemouse_reports.h); releasing it stops
// the probe. No force output.
//
// An I/O thread reads HID reports and publishes the axis state through a
// triple buffer; palpa_device_read() integrates the velocity into a position
// (real-time safe). A failed read (unplug) sets PALPA_STATUS_FAULT until the
// device is restarted.
//
// Options:
//   path=/dev/hidrawN  open this node (default: the first 3Dconnexion device found)
//   speed=0.1          m/s at full deflection
//   full_scale=350     HID value at full deflection
//   deadzone=0.05      fraction of full scale ignored around rest
//   workspace=0.1      half-size of the cube the probe stays in, m (around the start point)

#include "core/triple_buffer.h"
#include "devices/plugin_support.h"
#include "spacemouse_reports.h"

#include <hidapi.h>

#include <algorithm>
#include <atomic>
#include <cwchar>
#include <mutex>
#include <thread>

namespace {

using namespace palpa::devices::plugin;
namespace sm = palpa::plugins::spacemouse;

// The options: the form's fields and the parser's defaults and ranges.
constexpr PalpaDeviceOption kOptions[] = {
    option_string("path", "", "The hidraw node to open (e.g. /dev/hidraw3); empty: the first 3Dconnexion device found."),
    option_double("speed", "m/s", 1e-6, 10.0, "0.1", "Probe speed at full deflection of the cap."),
    option_double("full_scale", "", 1.0, 32767.0, "350", "The HID axis value at full deflection."),
    option_double("deadzone", "", 0.0, 0.9, "0.05", "Fraction of full scale ignored around rest."),
    option_double("workspace", "m", 1e-3, 10.0, "0.1", "Half-size of the cube the probe stays in, around its start point."),
};

std::string narrow(const wchar_t* w) {
  if (w == nullptr) return "unknown error";
  std::string s;
  for (; *w; ++w) s += (*w < 128) ? static_cast<char>(*w) : '?';
  return s;
}

// What the I/O thread publishes.
struct Published {
  sm::AxisState axes;
  std::uint64_t reports = 0;
  bool fault = false;
};

class SpaceMouseDevice final : public DeviceImpl {
 public:
  explicit SpaceMouseDevice(const Options& o) {
    path_ = o.text("path");
    rate_.max_speed = o.number("speed");
    rate_.full_scale = o.number("full_scale");
    rate_.deadzone = o.number("deadzone");
    half_ = o.number("workspace");
  }
  ~SpaceMouseDevice() override { stop(); }

  PalpaDeviceSpec spec() const override {
    PalpaDeviceSpec s{};
    set_spec_name(s, "3Dconnexion SpaceMouse (rate control)");
    s.position_dof = 3;
    s.force_dof = 0;
    for (int i = 0; i < 3; ++i) {
      s.workspace_min[i] = -half_;
      s.workspace_max[i] = half_;
    }
    s.nominal_rate = 125;
    s.button_count = 32;
    return s;
  }

  // Opens the device (given node or first found) and starts the reader.
  void start() override {
    if (device_ != nullptr) return;
    if (hid_init() != 0) throw PluginError("spacemouse: hidapi could not be initialised");
    std::string path = path_;
    if (path.empty()) {
      hid_device_info* list = hid_enumerate(0, 0);
      for (hid_device_info* d = list; d != nullptr; d = d->next)
        if (sm::is_spacemouse(d->vendor_id, d->product_id) && d->path) {
          path = d->path;
          break;
        }
      hid_free_enumeration(list);
      if (path.empty())
        throw PluginError(
            "spacemouse: no 3Dconnexion device found (vendor 046d or 256f); is it plugged in and is /dev/hidraw* "
            "readable?");
    }
    device_ = hid_open_path(path.c_str());
    if (device_ == nullptr)
      throw PluginError("spacemouse: cannot open " + path + ": " + narrow(hid_error(nullptr)));
    opened_path_ = path;
    published_.write(Published{});
    position_ = {0, 0, 0};
    last_read_ = monotonic_now();
    stop_.store(false);
    running_.store(true);
    thread_ = std::thread([this] { io_main(); });
  }

  void stop() override {
    if (device_ == nullptr) return;
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
    hid_close(device_);
    device_ = nullptr;
    running_.store(false);
  }

  // Real-time: integrate the rate-control velocity since the last read.
  void read(PalpaDeviceSample& s) noexcept override {
    s = empty_sample();
    if (!running_.load(std::memory_order_acquire)) return;
    const Published& p = published_.latest();
    const double now = monotonic_now();
    const double dt = std::clamp(now - last_read_, 0.0, 0.05);
    last_read_ = now;
    if (!p.fault) {
      const auto v = rate_.velocity(p.axes);
      for (int i = 0; i < 3; ++i) position_[i] = std::clamp(position_[i] + v[i] * dt, -half_, half_);
    }
    for (int i = 0; i < 3; ++i) s.position[i] = position_[i];
    s.buttons = p.axes.buttons;
    s.sequence = ++sequence_;
    s.time = now;
    s.status = p.fault ? PALPA_STATUS_FAULT : PALPA_STATUS_VALID;
  }

  std::string message() const override {
    std::lock_guard<std::mutex> lock(message_mutex_);
    if (!running_.load()) return "spacemouse: stopped";
    if (!error_.empty()) return error_;
    return "spacemouse: running on " + opened_path_;
  }

 private:
  // Reads reports until stopped or the device fails (unplug).
  void io_main() {
    Published state;
    unsigned char buf[64];
    while (!stop_.load(std::memory_order_relaxed)) {
      const int n = hid_read_timeout(device_, buf, sizeof buf, 20);
      if (n < 0) {
        {
          std::lock_guard<std::mutex> lock(message_mutex_);
          error_ = "spacemouse: reading " + opened_path_ + " failed (" + narrow(hid_error(device_)) +
                   "); unplugged? restart the device";
        }
        state.fault = true;
        state.axes = sm::AxisState{};
        published_.write(state);
        return;
      }
      if (n == 0) continue;
      if (sm::apply_report(std::span<const std::uint8_t>(buf, static_cast<std::size_t>(n)), state.axes) ==
          sm::Report::Malformed)
        continue;
      ++state.reports;
      published_.write(state);
    }
  }

  std::string path_, opened_path_;
  sm::RateControl rate_;
  double half_ = 0.1;
  hid_device* device_ = nullptr;
  std::thread thread_;
  std::atomic<bool> stop_{false}, running_{false};
  palpa::TripleBuffer<Published> published_;
  std::array<double, 3> position_{};  // reader thread only
  double last_read_ = 0;              // reader thread only
  std::uint64_t sequence_ = 0;        // reader thread only
  mutable std::mutex message_mutex_;
  std::string error_;
};

// hidapi keeps global state from hid_init() until hid_exit(); the library is
// unloaded with this plugin, so without hid_exit() that state leaked at every
// unload (LeakSanitizer, tools/asan.sh). Every device is destroyed before the
// plugin is unloaded (each Device holds the library), so this runs last.
struct HidapiLifetime {
  ~HidapiLifetime() { hid_exit(); }
} hidapi_lifetime;

std::unique_ptr<DeviceImpl> make_spacemouse(const Options& o) { return std::make_unique<SpaceMouseDevice>(o); }

}  // namespace

PALPA_EXPORT_DEVICE_PLUGIN("spacemouse", make_spacemouse, kOptions)
