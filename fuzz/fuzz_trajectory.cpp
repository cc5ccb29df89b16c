// libFuzzer target: the scripted device's trajectory CSV parser, and
// interpolation over what it accepts. TrajectoryError is the expected answer
// to bad input; anything else is a finding.

#include "trajectory.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto t = palpa::plugins::Trajectory::parse(text, "fuzz.csv");
    // Every accepted trajectory interpolates to finite positions inside the workspace.
    std::size_t cursor = 0;
    std::array<double, 3> p;
    std::uint32_t buttons = 0;
    for (double s : {0.0, 0.5 * t.duration(), t.duration(), 2 * t.duration() + 1}) {
      t.at(s, p, buttons, cursor);
      for (double x : p)
        if (!std::isfinite(x) || std::abs(x) > palpa::plugins::kDefaultWorkspace) std::abort();
    }
  } catch (const palpa::plugins::TrajectoryError&) {
  }
  return 0;
}
