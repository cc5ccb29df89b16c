// palpa-palpate's command line: every number has a range and a type and is
// refused outside it with the exact message (exit 2), never clamped, never
// left to crash (--rate 0.1), hang (--rate 1e9) or run out of memory; bad
// meshes are refused with the loader's message (exit 1). Runs the executable.

#include "common/test_support.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <string>

namespace {

// Runs palpa-palpate with `args`, returns stdout+stderr and the exit status.
std::string palpate(const std::string& args, int* status) {
  std::string out;
  FILE* pipe = popen(("'" PALPA_PALPATE_EXE "' " + args + " 2>&1").c_str(), "r");
  if (!pipe) return "(popen failed)";
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), buf.size(), pipe)) out += buf.data();
  const int rc = pclose(pipe);
  *status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  return out;
}

struct BadArgs {
  const char* args;
  const char* expected;  // the whole output
};

TEST(PalpateCli, EveryBadNumberIsRefusedWithItsRange) {
  const BadArgs cases[] = {
      {"--rate 0.1", "palpa-palpate: --rate: expected a number in 100 .. 10000 Hz, got '0.1'\n"},
      {"--rate 1e9", "palpa-palpate: --rate: expected a number in 100 .. 10000 Hz, got '1e9'\n"},
      {"--rate inf", "palpa-palpate: --rate: expected a number in 100 .. 10000 Hz, got 'inf'\n"},
      {"--seconds 1e300", "palpa-palpate: --seconds: expected a number in 0.001 .. 3600 s, got '1e300'\n"},
      {"--seconds -1", "palpa-palpate: --seconds: expected a number in 0.001 .. 3600 s, got '-1'\n"},
      {"--seconds 0.001 --rate 100",
       "palpa-palpate: --seconds 0.001 at --rate 100 makes 0 ticks; it must make 1 .. 10000000\n"},
      {"--seconds 3600 --rate 10000",
       "palpa-palpate: --seconds 3600 at --rate 10000 makes 36000000 ticks; it must make 1 .. 10000000\n"},
      {"--probes 0", "palpa-palpate: --probes: expected an integer in 1 .. 8, got '0'\n"},
      {"--probes 9", "palpa-palpate: --probes: expected an integer in 1 .. 8, got '9'\n"},
      {"--probes 2.5", "palpa-palpate: --probes: expected an integer in 1 .. 8, got '2.5'\n"},
      {"--organ-vertices 1e9", "palpa-palpate: --organ-vertices: expected an integer in 100 .. 5000000, got '1e9'\n"},
      {"--organ-vertices 99999999999999999999",
       "palpa-palpate: --organ-vertices: expected an integer in 100 .. 5000000, got '99999999999999999999'\n"},
      {"--unit 0", "palpa-palpate: --unit: expected a number in 1e-06 .. 1 m, got '0'\n"},
      {"--depth 1", "palpa-palpate: --depth: expected a number in 0.0001 .. 0.05 m, got '1'\n"},
      {"--stiffness 1e300", "palpa-palpate: --stiffness: expected a number in 0.001 .. 1e+06 N/m, got '1e300'\n"},
      {"--friction -0.1", "palpa-palpate: --friction: expected a number in 0 .. 2, got '-0.1'\n"},
      {"--rate", "palpa-palpate: --rate needs a value\n"},
  };
  for (const BadArgs& c : cases) {
    SCOPED_TRACE(c.args);
    int status = 0;
    EXPECT_EQ(palpate(c.args, &status), c.expected);
    EXPECT_EQ(status, 2);
  }
}

// The limits themselves are accepted: a short run at the highest rate works.
TEST(PalpateCli, TheEdgesOfTheRangesRun) {
  int status = 0;
  const std::string out = palpate("--organ-vertices 2000 --probes 1 --seconds 0.01 --rate 10000", &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("palpating with 1 probe(s) at 10000 Hz for 0.01 s"), std::string::npos) << out;
}

// Finite but absurd coordinates are refused by the loader, not palpated.
TEST(PalpateCli, AbsurdMeshesAreRefusedWithTheLoadersMessage) {
  const auto dir = palpa::test::temp_dir("palpate_cli");
  const auto huge = dir / "huge.trian";
  std::ofstream(huge) << "3\n0 0 0\n1e300 0 0\n0 1 0\n1\n0 1 2\n";
  int status = 0;
  EXPECT_EQ(palpate("--mesh '" + huge.string() + "'", &status),
            "palpa-palpate: " + huge.string() +
                ": vertex 1 has the coordinate 1e+300, beyond the limit of 1e+06 file units "
                "(LoadOptions::max_coordinate)\n");
  EXPECT_EQ(status, 1);
}

}  // namespace
