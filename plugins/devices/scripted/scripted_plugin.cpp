// The `scripted` device: replays a trajectory file (see trajectory.h for the
// format) against CLOCK_MONOTONIC from the moment it is started, for demos,
// tests and benchmarks. It accepts force commands like a haptic device and
// reports the latest one (zero once it has expired) in its message.
//
// Options:
//   file=PATH        trajectory CSV (required)
//   loop=false       start over after the last sample
//   time_scale=1     playback speed (2 = twice as fast)
//   rate=1000        nominal sample rate reported in the spec, Hz
//   max_force=10     N; the spec's maximum force (0: no force output)
//   workspace=10     m, 0.001 .. 1000: half-size of the cube around the origin
//                    every trajectory position must lie in (refused otherwise)

#include "core/triple_buffer.h"
#include "devices/plugin_support.h"
#include "trajectory.h"

#include <atomic>
#include <cmath>
#include <mutex>

namespace {

using namespace palpa::devices::plugin;
using palpa::plugins::Trajectory;

// The options: the form's fields and the parser's defaults and ranges.
constexpr PalpaDeviceOption kOptions[] = {
    option_file("file", PALPA_OPTION_REQUIRED,
                "The trajectory CSV to replay (t,x,y,z[,buttons]; positions in metres, world frame)."),
    option_bool("loop", "false", "Start over at the first sample after the last one."),
    option_double("time_scale", "", 1e-6, 1e6, "1", "Playback speed: 2 plays twice as fast, 0.5 half as fast."),
    option_double("rate", "Hz", 1.0, 100000.0, "1000", "The nominal sample rate the device reports."),
    option_double("max_force", "N", 0.0, 1e4, "10", "The largest force the device may be asked for (0: no force output)."),
    option_double("workspace", "m", 1e-3, 1e3, "10",
                  "Half-size of the cube around the origin every trajectory position must lie in; "
                  "a file with a position outside it is refused."),
};

class ScriptedDevice final : public DeviceImpl {
 public:
  explicit ScriptedDevice(const Options& o) {
    if (!o.has("file")) throw PluginError("scripted: option file is missing (file=/path/to/trajectory.csv)");
    const double workspace = o.number("workspace");
    try {
      trajectory_ = Trajectory::load(o.text("file"), workspace);
    } catch (const std::exception& e) {
      throw PluginError(std::string("scripted: ") + e.what());
    }
    loop_ = o.flag("loop");
    time_scale_ = o.number("time_scale");
    rate_ = o.number("rate");
    max_force_ = o.number("max_force");
    PalpaForceCommand zero{};
    commands_.write(zero);
  }

  PalpaDeviceSpec spec() const override {
    PalpaDeviceSpec s{};
    set_spec_name(s, "Scripted trajectory");
    s.position_dof = 3;
    s.force_dof = max_force_ > 0 ? 3 : 0;
    // The box the trajectory spans.
    for (int k = 0; k < 3; ++k) {
      s.workspace_min[k] = s.workspace_max[k] = trajectory_.samples().front().position[k];
      for (const auto& p : trajectory_.samples()) {
        s.workspace_min[k] = std::min(s.workspace_min[k], p.position[k]);
        s.workspace_max[k] = std::max(s.workspace_max[k], p.position[k]);
      }
    }
    s.max_force = max_force_;
    s.max_stiffness = 1e5;
    s.max_damping = 1e3;
    s.nominal_rate = rate_;
    s.button_count = 32;
    return s;
  }

  void start() override {
    start_time_.store(monotonic_now());
    started_.store(true, std::memory_order_release);
  }
  void stop() override { started_.store(false, std::memory_order_release); }

  // Real-time: the position at the current playback time.
  void read(PalpaDeviceSample& s) noexcept override {
    s = empty_sample();
    if (!started_.load(std::memory_order_acquire)) return;
    const double now = monotonic_now();
    double t = (now - start_time_.load(std::memory_order_relaxed)) * time_scale_;
    if (loop_ && trajectory_.duration() > 0) t = std::fmod(t, trajectory_.duration());
    std::array<double, 3> p;
    trajectory_.at(t, p, s.buttons, cursor_);
    for (int k = 0; k < 3; ++k) s.position[k] = p[k];
    s.sequence = ++sequence_;
    s.time = now;
    // Valid only when every intermediate stayed finite (the workspace bound makes this hold).
    s.status = std::isfinite(t) && std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])
                   ? PALPA_STATUS_VALID
                   : 0;
  }

  int write(const PalpaForceCommand& c) noexcept override {
    if (max_force_ <= 0) return PALPA_DEVICE_UNSUPPORTED;
    commands_.write(c);
    return PALPA_DEVICE_OK;
  }

  // The latest command, as the device would output it (zero once expired).
  std::string message() const override {
    if (!started_.load()) return "scripted: stopped";
    std::lock_guard<std::mutex> lock(message_mutex_);
    const PalpaForceCommand c = commands_.latest();
    const bool live = monotonic_now() <= c.time + c.expires_after;
    char buf[160];
    std::snprintf(buf, sizeof buf, "scripted: running; force %.6g %.6g %.6g N", live ? c.force[0] : 0.0,
                  live ? c.force[1] : 0.0, live ? c.force[2] : 0.0);
    return buf;
  }

 private:
  Trajectory trajectory_;
  bool loop_ = false;
  double time_scale_ = 1, rate_ = 1000, max_force_ = 10;
  std::atomic<double> start_time_{0};
  std::atomic<bool> started_{false};
  std::size_t cursor_ = 0;        // reader thread only
  std::uint64_t sequence_ = 0;    // reader thread only
  mutable std::mutex message_mutex_;
  mutable palpa::TripleBuffer<PalpaForceCommand> commands_;
};

std::unique_ptr<DeviceImpl> make_scripted(const Options& o) { return std::make_unique<ScriptedDevice>(o); }

}  // namespace

PALPA_EXPORT_DEVICE_PLUGIN("scripted", make_scripted, kOptions)
