#pragma once
// A small RAII wrapper around a umockdev testbed for the device tests.
// umockdev's preload library must be loaded when the process starts, so
// these tests run under umockdev-wrapper (CTest does that; to run one by
// hand: umockdev-wrapper ./test_plugins_falcon_umockdev).

#include <umockdev.h>

#include <filesystem>
#include <string>

namespace palpa::test {

/// True when libumockdev-preload is loaded into this process.
bool umockdev_preloaded();

/// The message a test shows when it is not run under umockdev-wrapper.
inline const char* kNeedsUmockdevWrapper =
    "this test needs umockdev's preload library: run it under umockdev-wrapper (ctest does)";

/// Where the repository's device fixtures live.
std::filesystem::path fixture_dir();

class Testbed {
 public:
  Testbed();
  ~Testbed();
  Testbed(const Testbed&) = delete;
  Testbed& operator=(const Testbed&) = delete;

  UMockdevTestbed* get() const { return tb_; }
  /// Adds the devices of a umockdev-record description file; throws on error.
  void add_from_file(const std::filesystem::path& file);
  /// Replays a script of timed reads on a device node (umockdev script format).
  void load_script(const std::string& devnode, const std::filesystem::path& script);
  /// Routes ioctl/read/write of `devnode` to `handler`.
  void attach_ioctl(const std::string& devnode, UMockdevIoctlBase* handler);
  /// Removes a device (sysfs path) and sends its "remove" uevent.
  void remove_device(const std::string& syspath);
  /// Breaks the connection behind a scripted device node so the client
  /// sees a hang-up, as when a device is unplugged.
  void hang_up(const std::string& devnode);

 private:
  UMockdevTestbed* tb_ = nullptr;
};

}  // namespace palpa::test
