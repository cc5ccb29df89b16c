#pragma once
// Finds and loads device plugins (shared libraries exporting the entry points
// of plugin_api.h) and checks their interface version.
//
// Plugin NAME is the file libpalpa_device_NAME.so, looked up in this order:
//   1. directories given to the PluginLoader constructor,
//   2. the build tree's plugin folder (PALPA_DEFAULT_PLUGIN_DIR, i.e.
//      <build>/plugins), then <dir of the executable>/../lib/palpa/plugins,
//   3. every directory in $PALPA_PLUGIN_PATH (':'-separated): it adds
//      plugins, it cannot shadow the program's own.
// Only absolute folders are searched (relative ones are ignored, and the
// "unknown device plugin" message says so). Before dlopen runs any code of a
// plugin, the file, its folder and every folder above them (and, through a
// symbolic link, the file it leads to and its folders) must be owned by this
// user or root and writable by no one else (a sticky folder such as /tmp may
// be above it), as OpenSSH's StrictModes requires of its files; otherwise
// the plugin is refused and the message says which one and why
// (plugins/README.md, "Trust").

#include "devices/device.h"

#include <filesystem>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace palpa::devices {

/// One option a plugin declares (palpa_device_options(), a copy of its
/// PalpaDeviceOption row that outlives the library).
struct OptionDescription {
  std::string name;
  std::uint32_t type = 0;  ///< PALPA_OPTION_*
  bool required = false;
  std::string unit;        ///< "" when none
  double min = 0, max = 0; ///< DOUBLE and INT
  std::string default_value;  ///< as it would be given; "" when none
  std::vector<std::string> choices;  ///< CHOICE
  std::string help;
};

/// A loaded plugin library whose interface version matched.
class Plugin {
 public:
  const std::string& name() const { return name_; }
  /// The options its create() accepts, in the order a form shows them.
  std::vector<OptionDescription> options() const;
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
  std::vector<OptionDescription> options_;
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
  ///  - "device plugin file '<path>' is not an absolute path"
  ///  - "refused device plugin '<path>': its folder '<dir>' is writable by others
  ///    (mode 0777); a plugin and its folders must be writable only by their
  ///    owner (chmod go-w '<dir>')", or "... is owned by user 1000, not by you
  ///    (user 0) or root" (checked before dlopen)
  ///  - "cannot load device plugin '<path>': <reason from the dynamic loader>"
  ///  - "device plugin '<path>' lacks the entry point <symbol>"
  ///  - "device plugin '<path>' declares a bad option table: <why>"
  ///  - "device plugin '<path>' implements interface <theirs>, but this program needs <ours>"
  static Plugin load_file(const std::filesystem::path& path);

  /// Names of the plugins load() would load (sorted, unique): trusted,
  /// loadable and of this interface version. (Each is loaded to find out.)
  std::vector<std::string> available() const;

  /// Search-path entries that were dropped, with the reason.
  const std::vector<std::string>& ignored() const { return ignored_; }

  /// File name of plugin `name`: libpalpa_device_<name>.so.
  static std::string file_name(std::string_view name);

 private:
  std::vector<std::filesystem::path> dirs_;
  std::vector<std::string> ignored_;
};

}  // namespace palpa::devices
