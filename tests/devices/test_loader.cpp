// Plugin loading: every real plugin loads by name from the build tree, and
// unknown name, invalid name, missing file, unloadable file, missing entry
// point and version mismatch each give their own message.

#include "devices/loader.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

namespace palpa::devices {
namespace {

namespace fs = std::filesystem;

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const DeviceError& e) {
    return e.what();
  }
  return "no error";
}

class Loader : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const char* e = std::getenv("PALPA_PLUGIN_PATH")) saved_ = e;
    unsetenv("PALPA_PLUGIN_PATH");
  }
  void TearDown() override {
    if (saved_) setenv("PALPA_PLUGIN_PATH", saved_->c_str(), 1);
    else unsetenv("PALPA_PLUGIN_PATH");
  }
  const fs::path bad_ = PALPA_BAD_PLUGIN_DIR;
  std::optional<std::string> saved_;
};

TEST_F(Loader, EveryPluginLoadsByNameFromTheBuildTree) {
  PluginLoader loader;
  for (const char* name : {"mouse", "scripted", "spacemouse", "falcon", "igtl"}) {
    const Plugin p = loader.load(name);
    EXPECT_EQ(p.name(), name);
    EXPECT_EQ(p.path(), fs::path(PALPA_PLUGIN_DIR) / ("libpalpa_device_" + std::string(name) + ".so"));
    EXPECT_STREQ(p.api().interface(), PALPA_DEVICE_INTERFACE);
    EXPECT_EQ(p.api().feed != nullptr, std::string(name) == "mouse") << name;
  }
  const auto names = loader.available();
  for (const char* name : {"falcon", "igtl", "mouse", "scripted", "spacemouse"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
}

TEST_F(Loader, UnknownNameListsTheSearchPath) {
  PluginLoader loader;
  std::string dirs;
  for (const auto& d : loader.search_path()) dirs += (dirs.empty() ? "" : ", ") + d.string();
  EXPECT_EQ(message_of([&] { loader.load("nosuch"); }),
            "unknown device plugin 'nosuch': no libpalpa_device_nosuch.so in " + dirs);
}

TEST_F(Loader, InvalidNameIsRefusedBeforeAnyLookup) {
  EXPECT_EQ(message_of([] { PluginLoader().load("../etc/passwd"); }),
            "invalid device plugin name '../etc/passwd': use letters, digits, '_' and '-'");
  EXPECT_EQ(message_of([] { PluginLoader().load(""); }),
            "invalid device plugin name '': use letters, digits, '_' and '-'");
}

TEST_F(Loader, MissingFile) {
  EXPECT_EQ(message_of([] { PluginLoader::load_file("/nonexistent/libpalpa_device_x.so"); }),
            "device plugin file '/nonexistent/libpalpa_device_x.so' does not exist");
}

TEST_F(Loader, FileThatIsNotALibrary) {
  const fs::path dir = test::temp_dir("loader_text");
  const fs::path file = dir / "libpalpa_device_text.so";
  std::ofstream(file) << std::string(4096, 'x');  // long enough to be judged by its header
  const std::string m = message_of([&] { PluginLoader::load_file(file); });
  const std::string prefix = "cannot load device plugin '" + file.string() + "': ";
  ASSERT_EQ(m.substr(0, prefix.size()), prefix) << m;
  EXPECT_NE(m.find("ELF"), std::string::npos) << m;  // the dynamic loader's reason
}

TEST_F(Loader, MissingEntryPoint) {
  const fs::path p = bad_ / "libpalpa_device_missing_read.so";
  EXPECT_EQ(message_of([&] { PluginLoader::load_file(p); }),
            "device plugin '" + p.string() + "' lacks the entry point palpa_device_read");
  const fs::path q = bad_ / "libpalpa_device_no_interface.so";
  EXPECT_EQ(message_of([&] { PluginLoader::load_file(q); }),
            "device plugin '" + q.string() + "' lacks the entry point palpa_device_interface");
}

TEST_F(Loader, VersionMismatchNamesBothVersions) {
  const fs::path p = bad_ / "libpalpa_device_old_version.so";
  const std::string expected =
      "device plugin '" + p.string() + "' implements interface palpa.device/0, but this program needs palpa.device/1";
  EXPECT_EQ(message_of([&] { PluginLoader::load_file(p); }), expected);
  // The same through a search directory and a name.
  EXPECT_EQ(message_of([&] { PluginLoader({bad_}).load("old_version"); }), expected);
}

TEST_F(Loader, EnvironmentPathComesFirst) {
  const fs::path dir = test::temp_dir("loader_env");
  fs::create_symlink(bad_ / "libpalpa_device_old_version.so", dir / "libpalpa_device_scripted.so");
  setenv("PALPA_PLUGIN_PATH", (dir.string() + ":/nonexistent").c_str(), 1);
  PluginLoader loader;
  ASSERT_GE(loader.search_path().size(), 2u);
  EXPECT_EQ(loader.search_path()[0], dir);
  EXPECT_EQ(message_of([&] { loader.load("scripted"); }),
            "device plugin '" + (dir / "libpalpa_device_scripted.so").string() +
                "' implements interface palpa.device/0, but this program needs palpa.device/1");
}

TEST_F(Loader, PluginOptionErrorsComeBackVerbatim) {
  const Plugin p = PluginLoader().load("scripted");
  EXPECT_EQ(message_of([&] { p.create(""); }), "scripted: option file is missing (file=/path/to/trajectory.csv)");
  EXPECT_EQ(message_of([&] { p.create("file=/nonexistent.csv"); }),
            "scripted: cannot open trajectory file '/nonexistent.csv'");
  EXPECT_EQ(message_of([&] { p.create("bogus=1"); }),
            "scripted: unknown option 'bogus' (known options: file, loop, time_scale, rate, max_force)");
  EXPECT_EQ(message_of([&] { PluginLoader().load("falcon").create("index=99"); }),
            "falcon: option index=99 is outside [0, 15]");
}

}  // namespace
}  // namespace palpa::devices
