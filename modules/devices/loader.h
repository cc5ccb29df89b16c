#pragma once
// Finds and loads device plugins (shared libraries exporting the entry points
// of plugin_api.h) and checks their interface version.
//
// Plugin NAME is the file libpalpa_device_NAME.so, looked up in this order:
//   1. every directory in $PALPA_PLUGIN_PATH (':'-separated),
//   2. directories given to the PluginLoader constructor,
//   3. the build tree's plugin folder (PALPA_DEFAULT_PLUGIN_DIR, i.e.
//      <build>/plugins), then <dir of the executable>/../lib/palpa/plugins.

#include "devices/device.h"

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace palpa::devices {

/// A loaded plugin library whose interface version matched.
class Plugin {
 public:
  const std::string& name() const { return name_; }
  const std::filesystem::path& path() const { return path_; }
  const PluginApi& api() const { return api_; }

  /// A new device instance. Throws DeviceError with the plugin's message
  /// (e.g. "scripted: option file is missing") when the options are bad.
  Device create(const std::string& options = "") const;

 private:
  friend class PluginLoader;
  std::string name_;
  std::filesystem::path path_;
  std::shared_ptr<void> library_;
  PluginApi api_{};
};

class PluginLoader {
 public:
  /// Default search path (see above).
  PluginLoader();
  /// Default search path with `extra_dirs` inserted after $PALPA_PLUGIN_PATH.
  explicit PluginLoader(std::vector<std::filesystem::path> extra_dirs);

  /// The directories searched, in order.
  const std::vector<std::filesystem::path>& search_path() const { return dirs_; }

  /// Loads plugin `name`. Throws DeviceError:
  ///  - "invalid device plugin name 'x/y': use letters, digits, '_' and '-'"
  ///  - "unknown device plugin 'foo': no libpalpa_device_foo.so in <dir>, <dir>"
  ///  - and every error of load_file().
  Plugin load(std::string_view name) const;

  /// Loads a plugin file. Throws DeviceError:
  ///  - "device plugin file '<path>' does not exist"
  ///  - "cannot load device plugin '<path>': <reason from the dynamic loader>"
  ///  - "device plugin '<path>' lacks the entry point <symbol>"
  ///  - "device plugin '<path>' implements interface <theirs>, but this program needs <ours>"
  static Plugin load_file(const std::filesystem::path& path);

  /// Names of the plugins present in the search path (sorted, unique).
  std::vector<std::string> available() const;

  /// File name of plugin `name`: libpalpa_device_<name>.so.
  static std::string file_name(std::string_view name);

 private:
  std::vector<std::filesystem::path> dirs_;
};

}  // namespace palpa::devices
