// Trajectory files: the documented format, linear interpolation, and one
// message per kind of mistake (file and line named).

#include "trajectory.h"
#include "common/test_support.h"

#include <gtest/gtest.h>

#include <fstream>

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
  };
  for (const auto& c : cases) EXPECT_EQ(message_of(c.text), c.message) << c.text;
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
