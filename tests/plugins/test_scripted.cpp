// The `scripted` plugin replays a trajectory against the clock, loops on
// request, declares the box it spans, and reports the force command it got
// (zero once expired).

#include "devices/loader.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

namespace palpa {
namespace {

using namespace std::chrono_literals;

std::string write_trajectory(const std::string& name, const std::string& text) {
  const auto dir = test::temp_dir("scripted_" + name);
  const auto path = dir / (name + ".csv");
  std::ofstream(path) << text;
  return path.string();
}

double now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

TEST(ScriptedPlugin, FollowsTheTrajectoryInTime) {
  // x goes from 0 to 1 m in 1 s, then back to 0 in 1 s.
  const std::string file = write_trajectory("ramp", "t,x,y,z,buttons\n0,0,0,0.1,0\n1,1,0,0.1,3\n2,0,0,0.1,0\n");
  devices::Device d = devices::PluginLoader({PALPA_PLUGIN_DIR}).load("scripted").create("file=" + file);
  EXPECT_EQ(d.spec().workspace_min[0], 0.0);
  EXPECT_EQ(d.spec().workspace_max[0], 1.0);
  EXPECT_EQ(d.spec().workspace_max[2], 0.1);
  EXPECT_EQ(d.spec().force_dof, 3u);
  PalpaDeviceSample s;
  d.read(s);
  EXPECT_EQ(s.status & PALPA_STATUS_VALID, 0u);  // not started
  const double t0 = now();
  d.start();
  std::uint64_t last = 0;
  for (int i = 0; i < 20; ++i) {
    std::this_thread::sleep_for(30ms);
    ASSERT_TRUE(d.read(s));
    const double t = s.time - t0;  // the sample's own time
    const double expected = t < 1 ? t : 2 - t;
    EXPECT_NEAR(s.position[0], expected, 2e-3) << t;  // start-time uncertainty only
    EXPECT_EQ(s.position[2], 0.1);
    EXPECT_EQ(s.status, PALPA_STATUS_VALID);
    EXPECT_GT(s.sequence, last);
    last = s.sequence;
  }
}

TEST(ScriptedPlugin, LoopsAndScalesTime) {
  const std::string file = write_trajectory("loop", "t,x,y,z,buttons\n0,0,0,0,0\n0.1,1,0,0,0\n");
  devices::Device d =
      devices::PluginLoader({PALPA_PLUGIN_DIR}).load("scripted").create("file=" + file + ";loop=true;time_scale=0.5");
  const double t0 = now();
  d.start();
  std::this_thread::sleep_for(250ms);
  PalpaDeviceSample s;
  d.read(s);
  // Playback time (s.time - t0) * 0.5, wrapped at 0.1 s.
  const double played = std::fmod((s.time - t0) * 0.5, 0.1);
  EXPECT_NEAR(s.position[0], played / 0.1, 0.03);
}

TEST(ScriptedPlugin, ReportsTheForceCommandUntilItExpires) {
  const std::string file = write_trajectory("force", "t,x,y,z,buttons\n0,0,0,0,0\n");
  devices::Device d = devices::PluginLoader({PALPA_PLUGIN_DIR}).load("scripted").create("file=" + file);
  d.start();
  PalpaForceCommand c{};
  c.force[0] = 1.5;
  c.force[2] = -2;
  c.time = now();
  c.expires_after = 0.2;
  ASSERT_TRUE(d.write(c));
  EXPECT_EQ(d.message(), "scripted: running; force 1.5 0 -2 N");
  std::this_thread::sleep_for(250ms);
  EXPECT_EQ(d.message(), "scripted: running; force 0 0 0 N");  // the watchdog expiry
}

TEST(ScriptedPlugin, WithoutForceOutput) {
  const std::string file = write_trajectory("noforce", "t,x,y,z,buttons\n0,0,0,0,0\n");
  devices::Device d =
      devices::PluginLoader({PALPA_PLUGIN_DIR}).load("scripted").create("file=" + file + ";max_force=0");
  EXPECT_EQ(d.spec().force_dof, 0u);
  PalpaForceCommand c{};
  EXPECT_FALSE(d.write(c));
}

TEST(ScriptedPlugin, BadTrajectoryIsReportedWithFileAndLine) {
  const std::string file = write_trajectory("bad", "t,x,y,z,buttons\n0,0,0,0,0\n0,1,1,1,0\n");
  try {
    devices::PluginLoader({PALPA_PLUGIN_DIR}).load("scripted").create("file=" + file);
    FAIL();
  } catch (const devices::DeviceError& e) {
    EXPECT_EQ(std::string(e.what()), "scripted: " + file + ":3: time 0 is not after the previous time 0");
  }
}

// The plugin refuses /dev/zero (it used to read it without bound) and positions outside its workspace.
TEST(ScriptedPlugin, RefusesDevZeroAndPositionsOutsideTheWorkspace) {
  try {
    devices::PluginLoader({PALPA_PLUGIN_DIR}).load("scripted").create("file=/dev/zero");
    FAIL();
  } catch (const devices::DeviceError& e) {
    EXPECT_EQ(std::string(e.what()), "scripted: trajectory file '/dev/zero' is not a regular file (a character device)");
  }
  const std::string file = write_trajectory("far", "t,x,y,z,buttons\n0,0,0,0,0\n1,0,0.3,0,0\n");
  try {
    devices::PluginLoader({PALPA_PLUGIN_DIR}).load("scripted").create("file=" + file + ";workspace=0.2");
    FAIL();
  } catch (const devices::DeviceError& e) {
    EXPECT_EQ(std::string(e.what()), "scripted: " + file + ":3: y 0.3 m is outside the workspace (|y| <= 0.2 m)");
  }
}

}  // namespace
}  // namespace palpa
