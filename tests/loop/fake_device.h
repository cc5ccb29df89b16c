#pragma once
// An in-process device for loop tests: the test sets its position and status
// (lock-free, from the test thread) and sees every force command the loop
// sent. It goes through the same PluginApi path as a loaded plugin.

#include "devices/device.h"
#include "haptics/loop.h"

#include <atomic>
#include <cmath>
#include <ctime>
#include <functional>
#include <mutex>
#include <string>

namespace palpa::test {

struct FakeDeviceState {
  std::atomic<double> x{0}, y{0}, z{0};
  std::atomic<std::uint32_t> status{PALPA_STATUS_VALID};
  std::atomic<std::uint32_t> buttons{0};
  std::atomic<bool> read_fails{false};
  std::atomic<std::uint64_t> reads{0}, writes{0};
  std::atomic<double> fx{0}, fy{0}, fz{0};     // last command, N
  std::atomic<double> max_norm{0};             // largest commanded |F| seen, N
  std::atomic<double> expires_after{0};
  std::atomic<bool> non_finite_seen{false};
  PalpaDeviceSpec spec{};
  /// Sample times (s): CLOCK_MONOTONIC by default; when set (before the loop
  /// reads the device), this clock instead, e.g. a ManualClock, so that the
  /// velocity estimate, and with it every force, depends only on the ticks.
  std::function<double()> clock;
};

namespace fake_device_detail {

inline FakeDeviceState* state(PalpaDevice* d) { return reinterpret_cast<FakeDeviceState*>(d); }

inline double now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

inline const char* interface_fn() { return PALPA_DEVICE_INTERFACE; }
// `options` carries the address of the test's FakeDeviceState.
inline PalpaDevice* create_fn(const char* options, char*, size_t) {
  return reinterpret_cast<PalpaDevice*>(std::stoull(options, nullptr, 16));
}
inline void destroy_fn(PalpaDevice*) {}
inline int spec_fn(PalpaDevice* d, PalpaDeviceSpec* s) {
  *s = state(d)->spec;
  return PALPA_DEVICE_OK;
}
inline int start_fn(PalpaDevice*, char*, size_t) { return PALPA_DEVICE_OK; }
inline void stop_fn(PalpaDevice*) {}
inline int read_fn(PalpaDevice* d, PalpaDeviceSample* s) {
  FakeDeviceState* st = state(d);
  if (st->read_fails.load()) return PALPA_DEVICE_FAILED;
  *s = PalpaDeviceSample{};
  s->orientation[0] = 1;
  s->position[0] = st->x.load();
  s->position[1] = st->y.load();
  s->position[2] = st->z.load();
  s->status = st->status.load();
  s->buttons = st->buttons.load();
  s->sequence = st->reads.fetch_add(1) + 1;
  s->time = st->clock ? st->clock() : now();
  return PALPA_DEVICE_OK;
}
inline int write_fn(PalpaDevice* d, const PalpaForceCommand* c) {
  FakeDeviceState* st = state(d);
  const double n = std::sqrt(c->force[0] * c->force[0] + c->force[1] * c->force[1] + c->force[2] * c->force[2]);
  if (!std::isfinite(n)) st->non_finite_seen.store(true);
  if (n > st->max_norm.load()) st->max_norm.store(n);
  st->fx.store(c->force[0]);
  st->fy.store(c->force[1]);
  st->fz.store(c->force[2]);
  st->expires_after.store(c->expires_after);
  st->writes.fetch_add(1);
  return PALPA_DEVICE_OK;
}
inline int message_fn(PalpaDevice*, char* buf, size_t size) {
  std::snprintf(buf, size, "fake: running");
  return PALPA_DEVICE_OK;
}

}  // namespace fake_device_detail

/// A started Device backed by `state` (which must outlive it). The spec
/// defaults to a 3-DoF force device with max_force 5 N.
inline devices::Device make_fake_device(FakeDeviceState& state, const std::string& label = "fake") {
  if (state.spec.max_force == 0 && state.spec.force_dof == 0) {
    state.spec.position_dof = 3;
    state.spec.force_dof = 3;
    state.spec.max_force = 5.0;
    state.spec.max_stiffness = 1e5;
    state.spec.nominal_rate = 1000;
  }
  namespace d = fake_device_detail;
  devices::PluginApi api;
  api.interface = d::interface_fn;
  api.create = d::create_fn;
  api.destroy = d::destroy_fn;
  api.spec = d::spec_fn;
  api.start = d::start_fn;
  api.stop = d::stop_fn;
  api.read = d::read_fn;
  api.write = d::write_fn;
  api.message = d::message_fn;
  char address[32];
  std::snprintf(address, sizeof address, "%llx", static_cast<unsigned long long>(reinterpret_cast<std::uintptr_t>(&state)));
  devices::Device dev(nullptr, api, address, label);
  dev.start();
  return dev;
}

/// A loop binding for `device` with the safety ramp-in `ramp_time_s` (s) and
/// force-rate limit `max_force_rate` (N/s), the rest default.
inline haptics::ProbeBinding fake_binding(devices::Device& device, double ramp_time_s, double max_force_rate) {
  haptics::ProbeBinding b;
  b.device = &device;
  b.safety.ramp_time = ramp_time_s;
  b.safety.max_force_rate = max_force_rate;
  return b;
}

}  // namespace palpa::test
