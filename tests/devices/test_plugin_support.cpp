// The option parser plugins share: separators, blanks, typed getters and the
// exact message for every mistake.

#include "devices/plugin_support.h"

#include <gtest/gtest.h>

namespace palpa::devices::plugin {
namespace {

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const PluginError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Options, ParsesPairsSeparatedBySemicolonsOrNewlines) {
  const Options o(" file = /tmp/a b.csv ;loop=true\n rate=2e3;;\n", "x");
  EXPECT_EQ(o.get_string("file"), "/tmp/a b.csv");
  EXPECT_TRUE(o.get_bool("loop", false));
  EXPECT_DOUBLE_EQ(o.get_double("rate", 0, 0, 1e4), 2000.0);
  EXPECT_EQ(o.get_int("missing", 7, 0, 10), 7);
  EXPECT_FALSE(o.has("missing"));
  EXPECT_NO_THROW(o.check_known({"file", "loop", "rate"}));
  EXPECT_EQ(Options(nullptr, "x").get_string("a", "default"), "default");
}

TEST(Options, EveryMistakeHasItsMessage) {
  EXPECT_EQ(message_of([] { Options("abc", "x"); }), "x: option 'abc' is not of the form key=value");
  EXPECT_EQ(message_of([] { Options("=3", "x"); }), "x: option '=3' has no key");
  EXPECT_EQ(message_of([] { Options("a=1;a=2", "x"); }), "x: option 'a' is given twice");
  const Options o("rate=fast;n=3.5;big=1e400;b=maybe;lo=5", "x");
  EXPECT_EQ(message_of([&] { o.get_double("rate", 0, 0, 1); }), "x: option rate='fast' is not a number");
  EXPECT_EQ(message_of([&] { o.get_double("big", 0, 0, 1); }), "x: option big='1e400' is not a number");
  EXPECT_EQ(message_of([&] { o.get_double("lo", 0, 10, 20); }), "x: option lo=5 is outside [10, 20]");
  EXPECT_EQ(message_of([&] { o.get_int("n", 0, 0, 10); }), "x: option n='3.5' is not an integer");
  EXPECT_EQ(message_of([&] { o.get_int("lo", 0, 6, 9); }), "x: option lo=5 is outside [6, 9]");
  EXPECT_EQ(message_of([&] { o.get_bool("b", false); }), "x: option b='maybe' is not a boolean (use true or false)");
  EXPECT_EQ(message_of([&] { o.check_known({"rate", "n"}); }),
            "x: unknown option 'b' (known options: rate, n)");
}

// The table-driven getters: defaults and ranges from the declaration.
constexpr PalpaDeviceOption kTable[] = {
    option_double("rate", "Hz", 1.0, 100.0, "60", "r"),
    option_int("n", "", 0, 9, "3", "n"),
    option_bool("loop", "true", "l"),
    option_string("host", "127.0.0.1", "h"),
    option_choice("mode", "client|server|relay", "client", "m"),
};

TEST(Options, TheTableGivesKeysDefaultsAndRanges) {
  const Options defaults("", "x", kTable);
  EXPECT_DOUBLE_EQ(defaults.number("rate"), 60.0);
  EXPECT_EQ(defaults.integer("n"), 3);
  EXPECT_TRUE(defaults.flag("loop"));
  EXPECT_EQ(defaults.text("host"), "127.0.0.1");
  EXPECT_EQ(defaults.choice("mode"), "client");
  const Options given("rate=100;n=0;loop=no;mode=relay", "x", kTable);
  EXPECT_DOUBLE_EQ(given.number("rate"), 100.0);
  EXPECT_EQ(given.integer("n"), 0);
  EXPECT_FALSE(given.flag("loop"));
  EXPECT_EQ(given.choice("mode"), "relay");
  EXPECT_EQ(message_of([] { Options("rate=101", "x", kTable).number("rate"); }), "x: option rate=101 is outside [1, 100]");
  EXPECT_EQ(message_of([] { Options("n=10", "x", kTable).integer("n"); }), "x: option n=10 is outside [0, 9]");
  EXPECT_EQ(message_of([] { Options("mode=peer", "x", kTable).choice("mode"); }),
            "x: option mode='peer' must be client, server or relay");
  EXPECT_EQ(message_of([] { Options("bogus=1", "x", kTable); }),
            "x: unknown option 'bogus' (known options: rate, n, loop, host, mode)");
  EXPECT_THROW(defaults.number("n"), std::logic_error);     // declared with another type
  EXPECT_THROW(defaults.number("other"), std::logic_error);  // not declared
}

TEST(Support, CopyMessageAlwaysTerminates) {
  char buf[5];
  copy_message("abcdefgh", buf, sizeof buf);
  EXPECT_STREQ(buf, "abcd");
  copy_message("ab", buf, sizeof buf);
  EXPECT_STREQ(buf, "ab");
}

}  // namespace
}  // namespace palpa::devices::plugin
