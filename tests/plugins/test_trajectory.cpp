// Trajectory files: the documented format, linear interpolation, and one
// message per kind of mistake (file and line named).

#include "trajectory.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <fstream>
#include <utility>

#include <sys/stat.h>

namespace palpa::plugins {
namespace {

std::string message_of(const std::string& text) {
  try {
    Trajectory::parse(text, "traj.csv");
  } catch (const TrajectoryError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Trajectory, ParsesTheDocumentedExample) {
  const Trajectory t = Trajectory::parse(
      "# press down 2 cm and come back\n"
      "t,x,y,z,buttons\n"
      "0.0, 0.0, 0.0, 0.10, 0\n"
      "1.0, 0.0, 0.0, 0.08, 1\n"
      "\n"
      "2.0, 0.0, 0.0, 0.10, 0\n",
      "example");
  ASSERT_EQ(t.samples().size(), 3u);
  EXPECT_EQ(t.duration(), 2.0);
  EXPECT_EQ(t.samples()[1].buttons, 1u);
  EXPECT_EQ(t.samples()[1].position[2], 0.08);
}

TEST(Trajectory, InterpolatesLinearlyAndHoldsButtons) {
  const Trajectory t = Trajectory::parse("t,x,y,z,buttons\n0,0,0,0,0\n1,1,2,3,4\n3,3,2,-1,8\n", "s");
  std::array<double, 3> p;
  std::uint32_t b = 0;
  std::size_t cursor = 0;
  t.at(0.25, p, b, cursor);
  EXPECT_DOUBLE_EQ(p[0], 0.25);
  EXPECT_DOUBLE_EQ(p[1], 0.5);
  EXPECT_DOUBLE_EQ(p[2], 0.75);
  EXPECT_EQ(b, 0u);
  t.at(2.0, p, b, cursor);  // halfway between samples 1 and 2
  EXPECT_DOUBLE_EQ(p[0], 2.0);
  EXPECT_DOUBLE_EQ(p[1], 2.0);
  EXPECT_DOUBLE_EQ(p[2], 1.0);
  EXPECT_EQ(b, 4u);
  t.at(0.5, p, b, cursor);  // backwards with a stale cursor
  EXPECT_DOUBLE_EQ(p[0], 0.5);
  t.at(-1.0, p, b, cursor);
  EXPECT_EQ(p, (std::array<double, 3>{0, 0, 0}));
  t.at(99.0, p, b, cursor);
  EXPECT_EQ(p, (std::array<double, 3>{3, 2, -1}));
  EXPECT_EQ(b, 8u);
  cursor = 12345;  // any cursor value is accepted
  t.at(1.5, p, b, cursor);
  EXPECT_DOUBLE_EQ(p[0], 1.5);
}

TEST(Trajectory, EveryMistakeNamesFileAndLine) {
  struct Case {
    const char* text;
    const char* message;
  } cases[] = {
      {"", "traj.csv: no header line (expected t,x,y,z,buttons)"},
      {"# only a comment\n", "traj.csv: no header line (expected t,x,y,z,buttons)"},
      {"t,x,y,z,buttons\n", "traj.csv: no samples after the header"},
      {"time,x,y,z,b\n0,0,0,0,0\n", "traj.csv:1: expected the header t,x,y,z,buttons, got 'time,x,y,z,b'"},
      {"t,x,y,z,buttons\n0,0,0\n", "traj.csv:2: expected 5 comma-separated values (t,x,y,z,buttons), got 3"},
      {"t,x,y,z,buttons\n0,0,0,0,0,0\n", "traj.csv:2: expected 5 comma-separated values (t,x,y,z,buttons), got 6"},
      {"t,x,y,z,buttons\n0,abc,0,0,0\n", "traj.csv:2: x 'abc' is not a finite number"},
      {"t,x,y,z,buttons\n0,0,nan,0,0\n", "traj.csv:2: y 'nan' is not a finite number"},
      {"t,x,y,z,buttons\n0,0,0,1e999,0\n", "traj.csv:2: z '1e999' is not a finite number"},
      {"t,x,y,z,buttons\n,0,0,0,0\n", "traj.csv:2: time '' is not a finite number"},
      {"t,x,y,z,buttons\n-1,0,0,0,0\n", "traj.csv:2: time -1 is negative"},
      {"t,x,y,z,buttons\n0,0,0,0,0\n# c\n0.5,0,0,0,0\n0.5,0,0,0,0\n",
       "traj.csv:5: time 0.5 is not after the previous time 0.5"},
      {"t,x,y,z,buttons\n1,0,0,0,0\n0.5,0,0,0,0\n", "traj.csv:3: time 0.5 is not after the previous time 1"},
      {"t,x,y,z,buttons\n0,0,0,0,1.5\n", "traj.csv:2: buttons '1.5' is not an integer in 0 .. 4294967295"},
      {"t,x,y,z,buttons\n0,0,0,0,-1\n", "traj.csv:2: buttons '-1' is not an integer in 0 .. 4294967295"},
      {"t,x,y,z,buttons\n0,0,0,0,4294967296\n",
       "traj.csv:2: buttons '4294967296' is not an integer in 0 .. 4294967295"},
      // Hardening (issue 12): the workspace, NUL bytes, absurd times.
      {"t,x,y,z,buttons\n0,1.7e308,0,0,0\n1,-1.7e308,0,0,0\n",
       "traj.csv:2: x 1.7e+308 m is outside the workspace (|x| <= 10 m)"},
      {"t,x,y,z,buttons\n0,0,0,-11,0\n", "traj.csv:2: z -11 m is outside the workspace (|z| <= 10 m)"},
      {"t,x,y,z,buttons\n2e9,0,0,0,0\n", "traj.csv:2: time 2e+09 s is beyond the limit of 1e+09 s"},
  };
  for (const auto& c : cases) EXPECT_EQ(message_of(c.text), c.message) << c.text;
}

// A NUL byte inside a field is refused (strtod stopped at it and took the field as ended).
TEST(Trajectory, NulBytesAreRefusedWithTheirLineAndColumn) {
  const std::string text = std::string("t,x,y,z,buttons\n0,0,0,0,0\n1,0.5") + '\0' + "7,0,0,0\n";
  EXPECT_EQ(message_of(text), "traj.csv:3: contains a NUL byte (column 6)");
}

// A denormal is a finite number; the workspace can be stated.
TEST(Trajectory, DenormalsAreFiniteAndTheWorkspaceIsTheCallers) {
  const Trajectory t = Trajectory::parse("t,x,y,z,buttons\n0,4.9e-324,0,1e-310,0\n", "traj.csv");
  EXPECT_EQ(t.samples()[0].position[0], 4.9e-324);
  EXPECT_EQ(t.samples()[0].position[2], 1e-310);
  try {
    Trajectory::parse("t,x,y,z,buttons\n0,0,0.5,0,0\n", "traj.csv", 0.25);
    FAIL();
  } catch (const TrajectoryError& e) {
    EXPECT_STREQ(e.what(), "traj.csv:2: y 0.5 m is outside the workspace (|y| <= 0.25 m)");
  }
}

// /dev/zero would fill memory and a FIFO would hang: only regular files are read.
TEST(Trajectory, LoadRefusesWhatIsNotARegularFile) {
  const auto dir = test::temp_dir("trajectory_special");
  const auto fifo = dir / "pipe.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::pair<std::string, std::string> cases[] = {
      {"/dev/zero", "trajectory file '/dev/zero' is not a regular file (a character device)"},
      {fifo.string(), "trajectory file '" + fifo.string() + "' is not a regular file (a FIFO)"},
      {dir.string(), "trajectory file '" + dir.string() + "' is not a regular file (a directory)"},
  };
  for (const auto& [path, message] : cases) {
    try {
      Trajectory::load(path);
      ADD_FAILURE() << path;
    } catch (const TrajectoryError& e) {
      EXPECT_EQ(std::string(e.what()), message);
    }
  }
}

TEST(Trajectory, LoadNamesAMissingFile) {
  try {
    Trajectory::load("/nonexistent/t.csv");
    FAIL();
  } catch (const TrajectoryError& e) {
    EXPECT_STREQ(e.what(), "cannot open trajectory file '/nonexistent/t.csv'");
  }
}

}  // namespace
}  // namespace palpa::plugins
