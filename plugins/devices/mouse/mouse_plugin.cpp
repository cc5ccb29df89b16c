// The `mouse` device: the workbench's virtual probe as a device like any
// other. The host (the GUI, which turns mouse motion into a probe position)
// feeds positions itself through the optional entry point
//
//   int palpa_device_feed(PalpaDevice*, const PalpaDeviceSample*)
//
// (devices::Device::feed() on the host side). It is real-time safe and
// lock-free: the sample goes into a triple buffer that the haptic loop's
// palpa_device_read() takes from. One thread may feed. The plugin stamps
// each fed sample with the next sequence number, with the current
// CLOCK_MONOTONIC time when sample.time <= 0, and with PALPA_STATUS_VALID when
// sample.status is 0. Until the first feed, read() returns a sample without
// PALPA_STATUS_VALID (the loop treats the probe as not ready).
//
// No force output. Options:
//   workspace=0.5   half-size of the reachable cube around the origin, m
//   rate=60         nominal rate at which the host feeds, Hz
//   buttons=3       number of buttons the host reports

#include "core/triple_buffer.h"
#include "devices/plugin_support.h"

#include <atomic>

namespace {

using namespace palpa::devices::plugin;

// The options: the form's fields and the parser's defaults and ranges.
constexpr PalpaDeviceOption kOptions[] = {
    option_double("workspace", "m", 1e-3, 100.0, "0.5", "Half-size of the reachable cube around the origin."),
    option_double("rate", "Hz", 1.0, 10000.0, "60", "The nominal rate at which the host feeds positions."),
    option_int("buttons", "", 0, 32, "3", "The number of buttons the host reports."),
};

class MouseDevice final : public DeviceImpl {
 public:
  explicit MouseDevice(const Options& o) {
    half_ = o.number("workspace");
    rate_ = o.number("rate");
    buttons_ = static_cast<std::uint32_t>(o.integer("buttons"));
    samples_.write(empty_sample());
  }

  PalpaDeviceSpec spec() const override {
    PalpaDeviceSpec s{};
    set_spec_name(s, "Palpa virtual probe (mouse)");
    s.position_dof = 3;
    s.force_dof = 0;
    for (int i = 0; i < 3; ++i) {
      s.workspace_min[i] = -half_;
      s.workspace_max[i] = half_;
    }
    s.nominal_rate = rate_;
    s.button_count = buttons_;
    return s;
  }

  void start() override { started_.store(true); }
  void stop() override { started_.store(false); }

  void read(PalpaDeviceSample& sample) noexcept override { sample = samples_.latest(); }

  // Host side: stamp and publish (wait-free).
  int feed(const PalpaDeviceSample& in) noexcept override {
    PalpaDeviceSample& s = samples_.write_buffer();
    s = in;
    s.sequence = ++sequence_;
    if (!(s.time > 0)) s.time = monotonic_now();
    if (s.status == 0) s.status = PALPA_STATUS_VALID;
    samples_.publish();
    fed_.store(true, std::memory_order_relaxed);
    return PALPA_DEVICE_OK;
  }

  std::string message() const override {
    if (!started_.load()) return "mouse: stopped";
    return fed_.load(std::memory_order_relaxed) ? "mouse: running" : "mouse: waiting for the first position";
  }

 private:
  double half_ = 0.5, rate_ = 60;
  std::uint32_t buttons_ = 3;
  std::uint64_t sequence_ = 0;  // feeding thread only
  std::atomic<bool> started_{false}, fed_{false};
  palpa::TripleBuffer<PalpaDeviceSample> samples_;
};

std::unique_ptr<DeviceImpl> make_mouse(const Options& o) { return std::make_unique<MouseDevice>(o); }

}  // namespace

PALPA_EXPORT_DEVICE_PLUGIN("mouse", make_mouse, kOptions)
PALPA_EXPORT_DEVICE_FEED()
