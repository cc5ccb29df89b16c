#pragma once
// Helpers for writing a device plugin in C++: a base class with one virtual
// per entry point, the option table and the parser that reads options by it
// (with clear messages), and the macro that exports the extern "C" entry
// points of plugin_api.h for a class. Header only, so a plugin links nothing
// of the host.
//
// One table per plugin declares its options (palpa_device_options() hands it
// to the host, which builds its forms from it) and is also what the parser
// checks: unknown keys, defaults and ranges all come from it, so what the
// form offers and what create() accepts cannot drift apart.

#include "devices/plugin_api.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace palpa::devices::plugin {

/// Seconds on CLOCK_MONOTONIC (the clock of every sample and command).
/// Real-time safe (vDSO, no system call on Linux).
inline double monotonic_now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Copies `text` into a C buffer, always NUL-terminated (truncated if needed).
inline void copy_message(std::string_view text, char* buf, std::size_t size) {
  if (buf == nullptr || size == 0) return;
  const std::size_t n = std::min(text.size(), size - 1);
  std::memcpy(buf, text.data(), n);
  buf[n] = '\0';
}

/// A sample with no reading yet: identity orientation, status 0.
inline PalpaDeviceSample empty_sample() {
  PalpaDeviceSample s{};
  s.orientation[0] = 1.0;
  return s;
}

/// Bad options or a failed start: the message names the plugin and the problem.
class PluginError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A plugin's declared options (a static array of PalpaDeviceOption).
using OptionTable = std::span<const PalpaDeviceOption>;

/// Table rows. Numbers: unit ("" for none), inclusive range, default as text.
constexpr PalpaDeviceOption option_double(const char* name, const char* unit, double min, double max,
                                          const char* default_value, const char* help) {
  return {name, PALPA_OPTION_DOUBLE, 0u, unit, min, max, default_value, "", help};
}
constexpr PalpaDeviceOption option_int(const char* name, const char* unit, long min, long max,
                                       const char* default_value, const char* help) {
  return {name, PALPA_OPTION_INT, 0u, unit, static_cast<double>(min), static_cast<double>(max), default_value, "",
          help};
}
constexpr PalpaDeviceOption option_bool(const char* name, const char* default_value, const char* help) {
  return {name, PALPA_OPTION_BOOL, 0u, "", 0.0, 0.0, default_value, "", help};
}
constexpr PalpaDeviceOption option_string(const char* name, const char* default_value, const char* help) {
  return {name, PALPA_OPTION_STRING, 0u, "", 0.0, 0.0, default_value, "", help};
}
/// A file path; `flags` PALPA_OPTION_REQUIRED when create() needs it.
constexpr PalpaDeviceOption option_file(const char* name, std::uint32_t flags, const char* help) {
  return {name, PALPA_OPTION_FILE, flags, "", 0.0, 0.0, "", "", help};
}
/// One of the '|'-separated `choices`.
constexpr PalpaDeviceOption option_choice(const char* name, const char* choices, const char* default_value,
                                          const char* help) {
  return {name, PALPA_OPTION_CHOICE, 0u, "", 0.0, 0.0, default_value, choices, help};
}

/// The words of a CHOICE option's `choices` ("a|b" -> {"a", "b"}).
inline std::vector<std::string> split_choices(const char* choices) {
  std::vector<std::string> out;
  std::string s = choices ? choices : "";
  std::size_t start = 0;
  while (start <= s.size() && !s.empty()) {
    std::size_t end = s.find('|', start);
    if (end == std::string::npos) end = s.size();
    out.push_back(s.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

/// The "key=value" options given to palpa_device_create(), separated by ';'
/// or newlines; blanks around keys and values are ignored.
class Options {
 public:
  /// Parses `text` and refuses keys not in `table` (see check_known); the
  /// table-driven getters (number, integer, flag, text) then take defaults
  /// and ranges from it.
  Options(const char* text, std::string plugin, OptionTable table) : Options(text, std::move(plugin)) {
    table_ = table;
    std::vector<std::string> known;
    for (const auto& d : table) known.emplace_back(d.name);
    check_known(known);
  }

  /// Parses `text` (may be null). `plugin` prefixes every message.
  /// Throws PluginError for an entry without '=' or a repeated key.
  Options(const char* text, std::string plugin) : plugin_(std::move(plugin)) {
    std::string s = text ? text : "";
    std::size_t start = 0;
    while (start <= s.size()) {
      std::size_t end = s.find_first_of(";\n", start);
      if (end == std::string::npos) end = s.size();
      std::string entry = trim(s.substr(start, end - start));
      start = end + 1;
      if (entry.empty()) continue;
      const auto eq = entry.find('=');
      if (eq == std::string::npos)
        throw PluginError(plugin_ + ": option '" + entry + "' is not of the form key=value");
      std::string key = trim(entry.substr(0, eq));
      std::string value = trim(entry.substr(eq + 1));
      if (key.empty()) throw PluginError(plugin_ + ": option '" + entry + "' has no key");
      if (values_.count(key)) throw PluginError(plugin_ + ": option '" + key + "' is given twice");
      values_[key] = value;
    }
  }

  /// Throws PluginError naming the first key not in `known`.
  void check_known(const std::vector<std::string>& known) const {
    for (const auto& [key, value] : values_) {
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw PluginError(plugin_ + ": unknown option '" + key + "' (known options: " + list + ")");
    }
  }

  bool has(const std::string& key) const { return values_.count(key) != 0; }

  std::string get_string(const std::string& key, const std::string& fallback = "") const {
    auto it = values_.find(key);
    return it == values_.end() ? fallback : it->second;
  }

  /// A finite number within [lo, hi]; throws PluginError otherwise.
  double get_double(const std::string& key, double fallback, double lo, double hi) const {
    auto it = values_.find(key);
    if (it == values_.end()) return fallback;
    const char* str = it->second.c_str();
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(str, &end);
    if (end == str || *end != '\0' || errno == ERANGE || !std::isfinite(v))
      throw PluginError(plugin_ + ": option " + key + "='" + it->second + "' is not a number");
    if (v < lo || v > hi)
      throw PluginError(plugin_ + ": option " + key + "=" + it->second + " is outside [" + format(lo) + ", " +
                        format(hi) + "]");
    return v;
  }

  /// An integer within [lo, hi]; throws PluginError otherwise.
  long get_int(const std::string& key, long fallback, long lo, long hi) const {
    auto it = values_.find(key);
    if (it == values_.end()) return fallback;
    const char* str = it->second.c_str();
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(str, &end, 0);
    if (end == str || *end != '\0' || errno == ERANGE)
      throw PluginError(plugin_ + ": option " + key + "='" + it->second + "' is not an integer");
    if (v < lo || v > hi)
      throw PluginError(plugin_ + ": option " + key + "=" + it->second + " is outside [" + std::to_string(lo) +
                        ", " + std::to_string(hi) + "]");
    return v;
  }

  /// true/false, yes/no, on/off, 1/0.
  bool get_bool(const std::string& key, bool fallback) const {
    auto it = values_.find(key);
    if (it == values_.end()) return fallback;
    const std::string& v = it->second;
    if (v == "1" || v == "true" || v == "yes" || v == "on") return true;
    if (v == "0" || v == "false" || v == "no" || v == "off") return false;
    throw PluginError(plugin_ + ": option " + key + "='" + v + "' is not a boolean (use true or false)");
  }

  /// The declaration of `key` in the table (a plugin asking for an option it
  /// did not declare is a programming error: std::logic_error).
  const PalpaDeviceOption& declared(std::string_view key, std::uint32_t type) const {
    for (const auto& d : table_)
      if (key == d.name) {
        if (d.type != type) throw std::logic_error(plugin_ + ": option " + std::string(key) + " is declared with another type");
        return d;
      }
    throw std::logic_error(plugin_ + ": option " + std::string(key) + " is not declared");
  }

  /// A DOUBLE option: its value, else its declared default; the declared range.
  double number(std::string_view key) const {
    const auto& d = declared(key, PALPA_OPTION_DOUBLE);
    return get_double(d.name, std::strtod(d.default_value, nullptr), d.min, d.max);
  }
  /// An INT option: its value, else its declared default; the declared range.
  long integer(std::string_view key) const {
    const auto& d = declared(key, PALPA_OPTION_INT);
    return get_int(d.name, std::strtol(d.default_value, nullptr, 0), static_cast<long>(d.min),
                   static_cast<long>(d.max));
  }
  /// A BOOL option: its value, else its declared default.
  bool flag(std::string_view key) const {
    const auto& d = declared(key, PALPA_OPTION_BOOL);
    const std::string def = d.default_value;
    return get_bool(d.name, def == "1" || def == "true" || def == "yes" || def == "on");
  }
  /// A STRING or FILE option: its value, else its declared default.
  std::string text(std::string_view key) const {
    for (const auto& d : table_)
      if (key == d.name && (d.type == PALPA_OPTION_STRING || d.type == PALPA_OPTION_FILE))
        return get_string(d.name, d.default_value);
    throw std::logic_error(plugin_ + ": option " + std::string(key) + " is not a declared text option");
  }
  /// A CHOICE option: its value (one of the declared words), else its
  /// default; "<plugin>: option mode='x' must be client or server" otherwise.
  std::string choice(std::string_view key) const {
    const auto& d = declared(key, PALPA_OPTION_CHOICE);
    const std::string v = get_string(d.name, d.default_value);
    const auto words = split_choices(d.choices);
    if (std::find(words.begin(), words.end(), v) != words.end()) return v;
    std::string list;
    for (std::size_t i = 0; i < words.size(); ++i)
      list += (i == 0 ? "" : i + 1 == words.size() ? " or " : ", ") + words[i];
    throw PluginError(plugin_ + ": option " + d.name + "='" + v + "' must be " + list);
  }

  const std::string& plugin() const { return plugin_; }

 private:
  static std::string trim(const std::string& s) {
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string::npos) return "";
    const auto e = s.find_last_not_of(" \t\r");
    return s.substr(b, e - b + 1);
  }
  static std::string format(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
  }

  std::string plugin_;
  std::map<std::string, std::string> values_;
  OptionTable table_;
};

/// One plugin instance. Subclasses implement the entry points; the real-time
/// ones (read, write, feed) must not allocate, lock, block or throw.
class DeviceImpl {
 public:
  virtual ~DeviceImpl() = default;
  virtual PalpaDeviceSpec spec() const = 0;
  /// Throws PluginError (message shown to the user) when the device cannot start.
  virtual void start() = 0;
  virtual void stop() = 0;
  virtual void read(PalpaDeviceSample& sample) noexcept = 0;
  /// Default: no force output.
  virtual int write(const PalpaForceCommand&) noexcept { return PALPA_DEVICE_UNSUPPORTED; }
  virtual std::string message() const = 0;
  /// Default: not host-fed.
  virtual int feed(const PalpaDeviceSample&) noexcept { return PALPA_DEVICE_UNSUPPORTED; }
};

/// Fills a spec's name safely.
inline void set_spec_name(PalpaDeviceSpec& spec, std::string_view name) {
  copy_message(name, spec.name, sizeof spec.name);
}

}  // namespace palpa::devices::plugin

/// The opaque instance handed to the host.
struct PalpaDevice {
  std::unique_ptr<palpa::devices::plugin::DeviceImpl> impl;
};

/// Exports the required entry points for a plugin whose instances are made by
/// `FACTORY(const palpa::devices::plugin::Options&)` returning
/// std::unique_ptr<DeviceImpl>; NAME prefixes messages; TABLE is the static
/// array of PalpaDeviceOption it declares (palpa_device_options() returns
/// it, and the Options handed to FACTORY refuse keys not in it and read
/// defaults and ranges from it). Exceptions never cross the C boundary.
#define PALPA_EXPORT_DEVICE_PLUGIN(NAME, FACTORY, TABLE)                                              \
  extern "C" __attribute__((visibility("default"))) const char* palpa_device_interface(void) {       \
    return PALPA_DEVICE_INTERFACE;                                                                    \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) const PalpaDeviceOption* palpa_device_options(   \
      size_t* count) {                                                                                \
    if (count != nullptr) *count = sizeof(TABLE) / sizeof(TABLE[0]);                                 \
    return TABLE;                                                                                     \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) PalpaDevice* palpa_device_create(                \
      const char* options, char* error, size_t error_size) {                                          \
    try {                                                                                             \
      palpa::devices::plugin::Options opts(options, NAME, palpa::devices::plugin::OptionTable(TABLE));  \
      auto dev = std::make_unique<PalpaDevice>();                                                     \
      dev->impl = FACTORY(opts);                                                                      \
      return dev.release();                                                                           \
    } catch (const std::exception& e) {                                                               \
      palpa::devices::plugin::copy_message(e.what(), error, error_size);                              \
    } catch (...) {                                                                                   \
      palpa::devices::plugin::copy_message(NAME ": unknown error while creating the device", error,   \
                                           error_size);                                               \
    }                                                                                                 \
    return nullptr;                                                                                   \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) void palpa_device_destroy(PalpaDevice* d) {       \
    if (d == nullptr) return;                                                                         \
    try {                                                                                             \
      d->impl->stop();                                                                                \
    } catch (...) {                                                                                   \
    }                                                                                                 \
    delete d;                                                                                         \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) int palpa_device_spec(PalpaDevice* d,             \
                                                                          PalpaDeviceSpec* s) {       \
    if (d == nullptr || s == nullptr) return PALPA_DEVICE_FAILED;                                     \
    *s = d->impl->spec();                                                                             \
    return PALPA_DEVICE_OK;                                                                           \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) int palpa_device_start(PalpaDevice* d, char* error, \
                                                                           size_t error_size) {       \
    try {                                                                                             \
      d->impl->start();                                                                               \
      return PALPA_DEVICE_OK;                                                                         \
    } catch (const std::exception& e) {                                                               \
      palpa::devices::plugin::copy_message(e.what(), error, error_size);                              \
    } catch (...) {                                                                                   \
      palpa::devices::plugin::copy_message(NAME ": unknown error while starting", error, error_size); \
    }                                                                                                 \
    return PALPA_DEVICE_FAILED;                                                                       \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) void palpa_device_stop(PalpaDevice* d) {          \
    try {                                                                                             \
      d->impl->stop();                                                                                \
    } catch (...) {                                                                                   \
    }                                                                                                 \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) int palpa_device_read(PalpaDevice* d,             \
                                                                          PalpaDeviceSample* s) {     \
    d->impl->read(*s);                                                                                \
    return PALPA_DEVICE_OK;                                                                           \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) int palpa_device_write(PalpaDevice* d,            \
                                                                           const PalpaForceCommand* c) { \
    return d->impl->write(*c);                                                                        \
  }                                                                                                   \
  extern "C" __attribute__((visibility("default"))) int palpa_device_message(PalpaDevice* d, char* buf, \
                                                                             size_t size) {           \
    try {                                                                                             \
      palpa::devices::plugin::copy_message(d->impl->message(), buf, size);                            \
    } catch (...) {                                                                                   \
      palpa::devices::plugin::copy_message(NAME ": status unavailable", buf, size);                   \
    }                                                                                                 \
    return PALPA_DEVICE_OK;                                                                           \
  }

/// Additionally exports palpa_device_feed (host-fed devices only).
#define PALPA_EXPORT_DEVICE_FEED()                                                                  \
  extern "C" __attribute__((visibility("default"))) int palpa_device_feed(PalpaDevice* d,            \
                                                                          const PalpaDeviceSample* s) { \
    return d->impl->feed(*s);                                                                       \
  }
