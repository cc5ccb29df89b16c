#include "devices/loader.h"

#include <dlfcn.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <cstdio>
#include <set>
#include <system_error>

#ifndef PALPA_DEFAULT_PLUGIN_DIR
#define PALPA_DEFAULT_PLUGIN_DIR ""
#endif

namespace palpa::devices {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kPrefix = "libpalpa_device_";
constexpr std::string_view kSuffix = ".so";

// Splits $PALPA_PLUGIN_PATH at ':' (empty entries ignored; relative ones are
// dropped later by the constructor, which says so).
std::vector<fs::path> env_dirs() {
  std::vector<fs::path> out;
  const char* env = std::getenv("PALPA_PLUGIN_PATH");
  if (env == nullptr) return out;
  std::string s = env;
  std::size_t start = 0;
  while (start <= s.size()) {
    std::size_t end = s.find(':', start);
    if (end == std::string::npos) end = s.size();
    if (end > start) out.emplace_back(s.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

// <dir of the running executable>/../lib/palpa/plugins (installed layout).
fs::path installed_dir() {
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  return exe.parent_path().parent_path() / "lib" / "palpa" / "plugins";
}

bool valid_name(std::string_view name) {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

std::string octal_mode(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

// The trust rule for one file or folder (as OpenSSH's StrictModes): owned by
// this user or root, and writable by no one else. An ancestor folder may be
// world-writable when it is sticky (/tmp): others cannot replace what is in it.
std::string untrusted(const fs::path& p, const std::string& subject, bool ancestor) {
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0) return subject + " cannot be examined (" + std::strerror(errno) + ")";
  const uid_t me = ::geteuid();
  if (st.st_uid != me && st.st_uid != 0)
    return subject + " is owned by user " + std::to_string(st.st_uid) + ", not by you (user " + std::to_string(me) +
           ") or root";
  const bool group = st.st_mode & S_IWGRP, others = st.st_mode & S_IWOTH;
  if ((group || others) && !(ancestor && S_ISDIR(st.st_mode) && (st.st_mode & S_ISVTX))) {
    const std::string who = group && others ? "its group and by others" : group ? "its group" : "others";
    return subject + " is writable by " + who + " (mode " + octal_mode(st.st_mode) +
           "); a plugin and its folders must be writable only by their owner (chmod go-w '" + p.string() + "')";
  }
  return "";
}

// Every check a plugin file must pass before dlopen runs any of its code: the
// file and its folder, every folder above them, and the same for the file a
// symbolic link leads to. "" when it may be loaded.
std::string trust_problem(const fs::path& path) {
  auto chain = [](const fs::path& file) -> std::string {
    if (std::string why = untrusted(file, "the file '" + file.string() + "'", false); !why.empty()) return why;
    fs::path dir = file.parent_path();
    bool first = true;
    while (!dir.empty()) {
      if (std::string why = untrusted(dir, "its folder '" + dir.string() + "'", !first); !why.empty()) return why;
      first = false;
      if (dir == dir.root_path()) break;
      dir = dir.parent_path();
    }
    return "";
  };
  if (std::string why = chain(path); !why.empty()) return why;
  std::error_code ec;
  const fs::path real = fs::canonical(path, ec);
  if (ec) return "the file cannot be resolved (" + ec.message() + ")";
  if (real != path)
    if (std::string why = chain(real); !why.empty()) return why + " (the link leads there)";
  return "";
}

// Resolves one entry point; missing required ones are an error naming the symbol.
template <class Fn>
Fn symbol(void* lib, const char* name, const fs::path& path, bool required) {
  dlerror();
  void* p = dlsym(lib, name);
  if (p == nullptr && required)
    throw DeviceError("device plugin '" + path.string() + "' lacks the entry point " + name);
  return reinterpret_cast<Fn>(p);
}

}  // namespace

PluginLoader::PluginLoader() : PluginLoader(std::vector<fs::path>{}) {}

// Search order: extra dirs, build tree, installed layout, then $PALPA_PLUGIN_PATH
// (which adds plugins but cannot shadow the program's own). Absolute folders only.
PluginLoader::PluginLoader(std::vector<fs::path> extra_dirs) {
  auto add = [&](fs::path d, const char* from) {
    if (d.is_absolute())
      dirs_.push_back(d.lexically_normal());
    else
      ignored_.push_back("relative folder '" + d.string() + "' " + from + " ignored");
  };
  for (auto& d : extra_dirs) add(std::move(d), "given to the loader");
  if (std::strlen(PALPA_DEFAULT_PLUGIN_DIR) > 0) add(PALPA_DEFAULT_PLUGIN_DIR, "of the build");
  if (fs::path inst = installed_dir(); !inst.empty()) add(inst, "of the installation");
  for (auto& d : env_dirs()) add(std::move(d), "in $PALPA_PLUGIN_PATH");
}

std::string PluginLoader::file_name(std::string_view name) {
  return std::string(kPrefix) + std::string(name) + std::string(kSuffix);
}

Plugin PluginLoader::load(std::string_view name) const {
  if (!valid_name(name))
    throw DeviceError("invalid device plugin name '" + std::string(name) + "': use letters, digits, '_' and '-'");
  // First directory holding the file wins.
  const std::string file = file_name(name);
  for (const auto& dir : dirs_) {
    std::error_code ec;
    const fs::path candidate = dir / file;
    if (fs::is_regular_file(candidate, ec)) {
      Plugin p = load_file(candidate);
      p.name_ = std::string(name);
      return p;
    }
  }
  std::string list;
  for (const auto& dir : dirs_) list += (list.empty() ? "" : ", ") + dir.string();
  if (list.empty()) list = "(empty search path)";
  for (const auto& note : ignored_) list += "; " + note;
  throw DeviceError("unknown device plugin '" + std::string(name) + "': no " + file + " in " + list);
}

Plugin PluginLoader::load_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw DeviceError("device plugin file '" + path.string() + "' does not exist");
  if (!path.is_absolute())
    throw DeviceError("device plugin file '" + path.string() + "' is not an absolute path");

  // Trust before any code of it runs (dlopen runs its constructors).
  if (const std::string why = trust_problem(path.lexically_normal()); !why.empty())
    throw DeviceError("refused device plugin '" + path.string() + "': " + why);

  // Load with all symbols resolved now, kept private to this plugin.
  dlerror();
  void* lib = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (lib == nullptr) {
    const char* why = dlerror();
    throw DeviceError("cannot load device plugin '" + path.string() + "': " + (why ? why : "unknown reason"));
  }
  std::shared_ptr<void> handle(lib, [](void* h) { dlclose(h); });

  // The version check comes first: other entry points of another version
  // may have other signatures.
  PluginApi api;
  api.interface = symbol<palpa_device_interface_fn>(lib, "palpa_device_interface", path, true);
  const char* theirs = api.interface();
  const std::string their_version = theirs ? theirs : "(null)";
  if (their_version != PALPA_DEVICE_INTERFACE)
    throw DeviceError("device plugin '" + path.string() + "' implements interface " + their_version +
                      ", but this program needs " + PALPA_DEVICE_INTERFACE);

  api.options = symbol<palpa_device_options_fn>(lib, "palpa_device_options", path, true);
  api.create = symbol<palpa_device_create_fn>(lib, "palpa_device_create", path, true);
  api.destroy = symbol<palpa_device_destroy_fn>(lib, "palpa_device_destroy", path, true);
  api.spec = symbol<palpa_device_spec_fn>(lib, "palpa_device_spec", path, true);
  api.start = symbol<palpa_device_start_fn>(lib, "palpa_device_start", path, true);
  api.stop = symbol<palpa_device_stop_fn>(lib, "palpa_device_stop", path, true);
  api.read = symbol<palpa_device_read_fn>(lib, "palpa_device_read", path, true);
  api.write = symbol<palpa_device_write_fn>(lib, "palpa_device_write", path, true);
  api.message = symbol<palpa_device_message_fn>(lib, "palpa_device_message", path, true);
  api.feed = symbol<palpa_device_feed_fn>(lib, "palpa_device_feed", path, false);

  Plugin p;
  p.api_ = api;
  // The option table is read once here, so a broken one is refused at load time.
  {
    std::size_t count = 0;
    const PalpaDeviceOption* rows = api.options(&count);
    if (count > 0 && rows == nullptr)
      throw DeviceError("device plugin '" + path.string() + "' declares a bad option table: no rows for " +
                        std::to_string(count) + " options");
    for (std::size_t i = 0; i < count; ++i) {
      const PalpaDeviceOption& r = rows[i];
      auto str = [](const char* c) { return std::string(c ? c : ""); };
      if (r.name == nullptr || *r.name == '\0' || r.type < PALPA_OPTION_DOUBLE || r.type > PALPA_OPTION_CHOICE)
        throw DeviceError("device plugin '" + path.string() + "' declares a bad option table: row " +
                          std::to_string(i) + " has no name or an unknown type");
      OptionDescription d;
      d.name = r.name;
      d.type = r.type;
      d.required = (r.flags & PALPA_OPTION_REQUIRED) != 0;
      d.unit = str(r.unit);
      d.min = r.min;
      d.max = r.max;
      d.default_value = str(r.default_value);
      d.help = str(r.help);
      const std::string choices = str(r.choices);
      for (std::size_t start = 0; !choices.empty() && start <= choices.size();) {
        std::size_t end = choices.find('|', start);
        if (end == std::string::npos) end = choices.size();
        d.choices.push_back(choices.substr(start, end - start));
        start = end + 1;
      }
      p.options_.push_back(std::move(d));
    }
  }
  p.name_ = path.stem().string();
  if (p.name_.rfind(kPrefix, 0) == 0) p.name_ = p.name_.substr(kPrefix.size());
  p.path_ = path;
  p.library_ = std::move(handle);
  return p;
}

std::vector<std::string> PluginLoader::available() const {
  // Every name present in the search path, then only those load() would load.
  std::set<std::string> names;
  for (const auto& dir : dirs_) {
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string f = it->path().filename().string();
      if (f.size() > kPrefix.size() + kSuffix.size() && f.rfind(kPrefix, 0) == 0 &&
          f.compare(f.size() - kSuffix.size(), kSuffix.size(), kSuffix) == 0)
        names.insert(f.substr(kPrefix.size(), f.size() - kPrefix.size() - kSuffix.size()));
    }
  }
  std::vector<std::string> out;
  for (const auto& name : names) {
    try {
      load(name);
      out.push_back(name);
    } catch (const DeviceError&) {
      // not loadable: an invalid name, untrusted, not a library, another interface version
    }
  }
  return out;
}

std::vector<OptionDescription> Plugin::options() const { return options_; }

Device Plugin::create(const std::string& options) const {
  return Device(library_, api_, options, name_);
}

}  // namespace palpa::devices
