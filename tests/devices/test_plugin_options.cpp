// Every plugin's declared option table (palpa_device_options) against what
// its create() does: each declared default is accepted when given
// explicitly, each value outside a declared range (or not one of the declared
// choices, or not a boolean) is refused with the plugin's own message naming
// the declared range, and an undeclared key is refused listing exactly the
// declared names. The table and the parser are one, so these hold for every
// row; a row whose range drifted from the parser would fail here.

#include "devices/loader.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
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

std::string g(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}
std::string exact(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const char* kPlugins[] = {"mouse", "scripted", "spacemouse", "falcon", "igtl"};

// Options every create() of `plugin` needs besides the one under test.
std::string base_options(const std::string& plugin, const std::string& key, const fs::path& trajectory) {
  if (plugin == "scripted" && key != "file") return "file=" + trajectory.string();
  return "";
}

std::string join(const std::string& a, const std::string& b) { return a.empty() ? b : b.empty() ? a : a + ";" + b; }

class PluginOptions : public ::testing::Test {
 protected:
  void SetUp() override {
    trajectory_ = test::temp_dir("plugin_options") / "t.csv";
    std::ofstream(trajectory_) << "t,x,y,z,buttons\n0,0,0,0,0\n1,0,0,0.001,0\n";
  }
  fs::path trajectory_;
};

TEST_F(PluginOptions, EveryPluginDeclaresItsOptionsWithHelp) {
  for (const char* name : kPlugins) {
    const Plugin p = PluginLoader().load(name);
    const auto options = p.options();
    ASSERT_FALSE(options.empty()) << name;
    for (const OptionDescription& o : options) {
      EXPECT_FALSE(o.help.empty()) << name << " " << o.name;
      if (o.type == PALPA_OPTION_DOUBLE || o.type == PALPA_OPTION_INT) {
        EXPECT_LT(o.min, o.max) << name << " " << o.name;
        EXPECT_FALSE(o.default_value.empty()) << name << " " << o.name;
      }
      if (o.type == PALPA_OPTION_CHOICE) {
        EXPECT_GE(o.choices.size(), 2u) << name << " " << o.name;
      }
    }
  }
  // The scripted plugin's file is required, with units where they apply.
  const auto scripted = PluginLoader().load("scripted").options();
  ASSERT_EQ(scripted.front().name, "file");
  EXPECT_EQ(scripted.front().type, static_cast<std::uint32_t>(PALPA_OPTION_FILE));
  EXPECT_TRUE(scripted.front().required);
}

TEST_F(PluginOptions, EveryDeclaredDefaultIsAccepted) {
  for (const char* name : kPlugins) {
    const Plugin p = PluginLoader().load(name);
    for (const OptionDescription& o : p.options()) {
      if (o.default_value.empty()) continue;  // nothing to give (a file, an empty filter)
      const std::string opts = join(base_options(name, o.name, trajectory_), o.name + "=" + o.default_value);
      EXPECT_EQ(message_of([&] { p.create(opts); }), "no error") << name << ": " << opts;
    }
  }
}

TEST_F(PluginOptions, ValuesOutsideTheDeclaredRangeAreRefusedWithThePluginsMessage) {
  int checked = 0;
  for (const char* name : kPlugins) {
    const Plugin p = PluginLoader().load(name);
    for (const OptionDescription& o : p.options()) {
      const std::string base = base_options(name, o.name, trajectory_);
      auto refused = [&](const std::string& value, const std::string& expected) {
        const std::string opts = join(base, o.name + "=" + value);
        EXPECT_EQ(message_of([&] { p.create(opts); }), expected) << name << ": " << opts;
        ++checked;
      };
      switch (o.type) {
        case PALPA_OPTION_DOUBLE: {
          const std::string range = " is outside [" + g(o.min) + ", " + g(o.max) + "]";
          const double below = o.min == 0 ? -1e-3 : o.min - 0.5 * std::abs(o.min);
          const double above = o.max + 0.5 * std::abs(o.max);
          refused(exact(below), std::string(name) + ": option " + o.name + "=" + exact(below) + range);
          refused(exact(above), std::string(name) + ": option " + o.name + "=" + exact(above) + range);
          refused("abc", std::string(name) + ": option " + o.name + "='abc' is not a number");
          break;
        }
        case PALPA_OPTION_INT: {
          const std::string range = " is outside [" + std::to_string(static_cast<long>(o.min)) + ", " +
                                    std::to_string(static_cast<long>(o.max)) + "]";
          const std::string below = std::to_string(static_cast<long>(o.min) - 1);
          const std::string above = std::to_string(static_cast<long>(o.max) + 1);
          refused(below, std::string(name) + ": option " + o.name + "=" + below + range);
          refused(above, std::string(name) + ": option " + o.name + "=" + above + range);
          break;
        }
        case PALPA_OPTION_BOOL:
          refused("maybe", std::string(name) + ": option " + o.name + "='maybe' is not a boolean (use true or false)");
          break;
        case PALPA_OPTION_CHOICE: {
          std::string list;
          for (std::size_t i = 0; i < o.choices.size(); ++i)
            list += (i == 0 ? "" : i + 1 == o.choices.size() ? " or " : ", ") + o.choices[i];
          refused("bogus", std::string(name) + ": option " + o.name + "='bogus' must be " + list);
          break;
        }
        default: break;
      }
    }
  }
  EXPECT_GT(checked, 40);
}

TEST_F(PluginOptions, AnUndeclaredKeyIsRefusedListingTheDeclaredOnes) {
  for (const char* name : kPlugins) {
    const Plugin p = PluginLoader().load(name);
    std::string list;
    for (const auto& o : p.options()) list += (list.empty() ? "" : ", ") + o.name;
    EXPECT_EQ(message_of([&] { p.create("bogus=1"); }),
              std::string(name) + ": unknown option 'bogus' (known options: " + list + ")");
  }
}

}  // namespace
}  // namespace palpa::devices
