// The host-side Device: creation and start failures carry the plugin's
// message, ownership moves, destruction stops and destroys exactly once.

#include "devices/device.h"

#include <gtest/gtest.h>

#include <cstring>

namespace palpa::devices {
namespace {

// A scriptable in-process plugin.
struct Script {
  bool create_ok = true;
  const char* create_message = "";
  bool start_ok = true;
  const char* start_message = "";
  int creates = 0, destroys = 0, starts = 0, stops = 0;
};
Script* g = nullptr;

PalpaDevice* handle() { return reinterpret_cast<PalpaDevice*>(g); }
const char* iface() { return PALPA_DEVICE_INTERFACE; }
PalpaDevice* create(const char*, char* err, size_t size) {
  ++g->creates;
  if (g->create_ok) return handle();
  std::snprintf(err, size, "%s", g->create_message);
  return nullptr;
}
void destroy(PalpaDevice*) { ++g->destroys; }
int spec(PalpaDevice*, PalpaDeviceSpec* s) {
  *s = PalpaDeviceSpec{};
  std::snprintf(s->name, sizeof s->name, "scripted test device");
  s->force_dof = 3;
  s->max_force = 2.5;
  return PALPA_DEVICE_OK;
}
int start(PalpaDevice*, char* err, size_t size) {
  ++g->starts;
  if (g->start_ok) return PALPA_DEVICE_OK;
  std::snprintf(err, size, "%s", g->start_message);
  return PALPA_DEVICE_FAILED;
}
void stop(PalpaDevice*) { ++g->stops; }
int read(PalpaDevice*, PalpaDeviceSample* s) {
  *s = PalpaDeviceSample{};
  s->sequence = 42;
  return PALPA_DEVICE_OK;
}
int write(PalpaDevice*, const PalpaForceCommand*) { return PALPA_DEVICE_OK; }
int message(PalpaDevice*, char* buf, size_t size) {
  std::snprintf(buf, size, "all good");
  return PALPA_DEVICE_OK;
}

PluginApi api() {
  PluginApi a;
  a.interface = iface;
  a.create = create;
  a.destroy = destroy;
  a.spec = spec;
  a.start = start;
  a.stop = stop;
  a.read = read;
  a.write = write;
  a.message = message;
  return a;
}

class DeviceTest : public ::testing::Test {
 protected:
  void SetUp() override { g = &script_; }
  void TearDown() override { g = nullptr; }
  Script script_;
};

TEST_F(DeviceTest, CreationFailureCarriesThePluginsMessage) {
  script_.create_ok = false;
  script_.create_message = "thing: option x is wrong";
  try {
    Device d(nullptr, api(), "", "thing");
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_STREQ(e.what(), "thing: option x is wrong");
  }
  script_.create_message = "";
  try {
    Device d(nullptr, api(), "", "thing");
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_STREQ(e.what(), "thing: the plugin refused to create a device (no reason given)");
  }
}

TEST_F(DeviceTest, StartFailureCarriesThePluginsMessage) {
  script_.start_ok = false;
  script_.start_message = "thing: no device found";
  Device d(nullptr, api(), "", "thing");
  try {
    d.start();
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_STREQ(e.what(), "thing: no device found");
  }
  EXPECT_FALSE(d.started());
}

TEST_F(DeviceTest, SpecReadOnceAndCallsForwarded) {
  Device d(nullptr, api(), "", "thing");
  EXPECT_STREQ(d.spec().name, "scripted test device");
  EXPECT_EQ(d.spec().max_force, 2.5);
  PalpaDeviceSample s;
  EXPECT_TRUE(d.read(s));
  EXPECT_EQ(s.sequence, 42u);
  EXPECT_EQ(d.message(), "all good");
  EXPECT_FALSE(d.can_feed());
  EXPECT_FALSE(d.feed(s));
}

TEST_F(DeviceTest, MoveAndDestroyStopAndDestroyOnce) {
  {
    Device a(nullptr, api(), "", "thing");
    a.start();
    Device b(std::move(a));
    EXPECT_FALSE(static_cast<bool>(a));
    EXPECT_TRUE(b.started());
    Device c;
    c = std::move(b);
    EXPECT_TRUE(c.started());
  }
  EXPECT_EQ(script_.creates, 1);
  EXPECT_EQ(script_.starts, 1);
  EXPECT_EQ(script_.stops, 1);
  EXPECT_EQ(script_.destroys, 1);
}

TEST_F(DeviceTest, RestartStopsThenStarts) {
  Device d(nullptr, api(), "", "thing");
  d.start();
  d.restart();
  EXPECT_EQ(script_.stops, 1);
  EXPECT_EQ(script_.starts, 2);
  d.stop();
  d.stop();  // idempotent
  EXPECT_EQ(script_.stops, 2);
}

}  // namespace
}  // namespace palpa::devices
