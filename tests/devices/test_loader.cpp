// Plugin loading: every real plugin loads by name from the build tree, and
// unknown name, invalid name, missing file, unloadable file, missing entry
// point and version mismatch each give their own message.

#include "devices/loader.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include <unistd.h>

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
      "device plugin '" + p.string() + "' implements interface palpa.device/0, but this program needs palpa.device/2";
  EXPECT_EQ(message_of([&] { PluginLoader::load_file(p); }), expected);
  // The same through a search directory and a name.
  EXPECT_EQ(message_of([&] { PluginLoader({bad_}).load("old_version"); }), expected);
}

// A whole plugin of the previous interface (no palpa_device_options) is
// refused by its version, naming both, not by the entry point it lacks.
TEST_F(Loader, APluginOfInterfaceOneIsRefusedNamingBothVersions) {
  const fs::path p = bad_ / "libpalpa_device_v1_plugin.so";
  const std::string expected =
      "device plugin '" + p.string() + "' implements interface palpa.device/1, but this program needs palpa.device/2";
  EXPECT_EQ(message_of([&] { PluginLoader::load_file(p); }), expected);
  EXPECT_EQ(message_of([&] { PluginLoader({bad_}).load("v1_plugin"); }), expected);
  const auto names = PluginLoader({bad_}).available();
  EXPECT_EQ(std::find(names.begin(), names.end(), "v1_plugin"), names.end());
}

// $PALPA_PLUGIN_PATH comes last: it adds plugins but cannot shadow the program's own;
// relative entries are ignored and said so.
TEST_F(Loader, EnvironmentPathAddsPluginsButCannotShadowThem) {
  const fs::path dir = test::temp_dir("loader_env");
  fs::create_symlink(bad_ / "libpalpa_device_old_version.so", dir / "libpalpa_device_scripted.so");
  fs::create_symlink(bad_ / "libpalpa_device_old_version.so", dir / "libpalpa_device_envonly.so");
  setenv("PALPA_PLUGIN_PATH", ("plugins:" + dir.string() + ":/nonexistent").c_str(), 1);
  PluginLoader loader;
  ASSERT_GE(loader.search_path().size(), 2u);
  EXPECT_EQ(loader.search_path()[loader.search_path().size() - 2], dir);
  EXPECT_EQ(loader.search_path().back(), fs::path("/nonexistent"));
  ASSERT_EQ(loader.ignored(), std::vector<std::string>{"relative folder 'plugins' in $PALPA_PLUGIN_PATH ignored"});
  EXPECT_EQ(loader.load("scripted").path(), fs::path(PALPA_PLUGIN_DIR) / "libpalpa_device_scripted.so");
  EXPECT_EQ(message_of([&] { loader.load("envonly"); }),
            "device plugin '" + (dir / "libpalpa_device_envonly.so").string() +
                "' implements interface palpa.device/0, but this program needs palpa.device/2");
  std::string dirs;
  for (const auto& d : loader.search_path()) dirs += (dirs.empty() ? "" : ", ") + d.string();
  EXPECT_EQ(message_of([&] { loader.load("nosuch"); }),
            "unknown device plugin 'nosuch': no libpalpa_device_nosuch.so in " + dirs +
                "; relative folder 'plugins' in $PALPA_PLUGIN_PATH ignored");
}

// A plugin in a folder others can write to is refused before dlopen runs any
// of its code (its constructor would run at load time, before the version check).
TEST_F(Loader, UntrustedPluginsAreRefusedBeforeAnyOfTheirCodeRuns) {
  const fs::path dir = test::temp_dir("loader_trust");
  const fs::path marker = dir / "constructor-ran";
  setenv("PALPA_TEST_PLANTED_MARKER", marker.c_str(), 1);
  const fs::path open_dir = dir / "open";
  fs::create_directory(open_dir);
  fs::copy_file(bad_ / "libpalpa_device_planted.so", open_dir / "libpalpa_device_planted.so");
  fs::permissions(open_dir, fs::perms::all);  // 0777, as a shared drop folder
  const fs::path planted = open_dir / "libpalpa_device_planted.so";
  EXPECT_EQ(message_of([&] { PluginLoader::load_file(planted); }),
            "refused device plugin '" + planted.string() + "': its folder '" + open_dir.string() +
                "' is writable by its group and by others (mode 0777); a plugin and its folders must be writable "
                "only by their owner (chmod go-w '" + open_dir.string() + "')");
  EXPECT_FALSE(fs::exists(marker)) << "the planted constructor ran";

  // The file itself writable by others.
  fs::permissions(open_dir, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                fs::perms::others_read | fs::perms::others_exec);
  fs::permissions(planted, fs::perms::owner_all | fs::perms::others_write | fs::perms::others_read);
  EXPECT_EQ(message_of([&] { PluginLoader({open_dir}).load("planted"); }),
            "refused device plugin '" + planted.string() + "': the file '" + planted.string() +
                "' is writable by others (mode 0706); a plugin and its folders must be writable only by their "
                "owner (chmod go-w '" + planted.string() + "')");
  EXPECT_FALSE(fs::exists(marker));

  // A link from a trusted folder into an open one is judged by where it leads.
  const fs::path safe_dir = dir / "safe";
  fs::create_directory(safe_dir);
  fs::permissions(planted, fs::perms::owner_all);
  fs::permissions(open_dir, fs::perms::all);
  fs::create_symlink(planted, safe_dir / "libpalpa_device_planted.so");
  EXPECT_EQ(message_of([&] { PluginLoader({safe_dir}).load("planted"); }),
            "refused device plugin '" + (safe_dir / "libpalpa_device_planted.so").string() + "': its folder '" +
                open_dir.string() + "' is writable by its group and by others (mode 0777); a plugin and its folders "
                "must be writable only by their owner (chmod go-w '" + open_dir.string() + "') (the link leads there)");
  EXPECT_FALSE(fs::exists(marker));

  // The check is what stops it: once the folder is private, the constructor does run.
  fs::permissions(open_dir, fs::perms::owner_all);
  EXPECT_NE(message_of([&] { PluginLoader::load_file(planted); }), "no error");  // interface palpa.device/0
  EXPECT_TRUE(fs::exists(marker));
  unsetenv("PALPA_TEST_PLANTED_MARKER");
}

TEST_F(Loader, PluginsOwnedByAnotherUserAreRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give a file to another user";
  const fs::path dir = test::temp_dir("loader_owner");
  const fs::path file = dir / "libpalpa_device_theirs.so";
  fs::copy_file(bad_ / "libpalpa_device_old_version.so", file);
  ASSERT_EQ(::chown(file.c_str(), 65534, 65534), 0);
  EXPECT_EQ(message_of([&] { PluginLoader::load_file(file); }),
            "refused device plugin '" + file.string() + "': the file '" + file.string() +
                "' is owned by user 65534, not by you (user 0) or root");
}

TEST_F(Loader, RelativePluginFilesAreRefused) {
  EXPECT_EQ(message_of([&] { PluginLoader::load_file("libpalpa_device_scripted.so"); }),
            "device plugin file 'libpalpa_device_scripted.so' does not exist");
  const fs::path here = fs::current_path();
  fs::current_path(PALPA_PLUGIN_DIR);
  EXPECT_EQ(message_of([&] { PluginLoader::load_file("libpalpa_device_scripted.so"); }),
            "device plugin file 'libpalpa_device_scripted.so' is not an absolute path");
  fs::current_path(here);
}

// available() lists only what load() would load.
TEST_F(Loader, AvailableListsOnlyLoadableNames) {
  const auto names = PluginLoader({bad_}).available();
  for (const char* bad : {"old_version", "v1_plugin", "missing_read", "no_interface", "planted"})
    EXPECT_EQ(std::find(names.begin(), names.end(), bad), names.end()) << bad;
  for (const char* good : {"falcon", "igtl", "mouse", "scripted", "spacemouse"})
    EXPECT_NE(std::find(names.begin(), names.end(), good), names.end()) << good;
}

TEST_F(Loader, PluginOptionErrorsComeBackVerbatim) {
  const Plugin p = PluginLoader().load("scripted");
  EXPECT_EQ(message_of([&] { p.create(""); }), "scripted: option file is missing (file=/path/to/trajectory.csv)");
  EXPECT_EQ(message_of([&] { p.create("file=/nonexistent.csv"); }),
            "scripted: cannot open trajectory file '/nonexistent.csv'");
  EXPECT_EQ(message_of([&] { p.create("bogus=1"); }),
            "scripted: unknown option 'bogus' (known options: file, loop, time_scale, rate, max_force, workspace)");
  EXPECT_EQ(message_of([&] { PluginLoader().load("falcon").create("index=99"); }),
            "falcon: option index=99 is outside [0, 15]");
}

}  // namespace
}  // namespace palpa::devices
