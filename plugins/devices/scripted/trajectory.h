#pragma once
// Trajectory files for the `scripted` device: timed positions and buttons.
//
// Format (CSV, UTF-8/ASCII):
//   - lines starting with '#' and blank lines are ignored;
//   - the first other line is the header, exactly: t,x,y,z,buttons
//   - every following line: t, x, y, z, buttons
//       t        time in s, >= 0, strictly increasing
//       x, y, z  position in m (device frame), finite
//       buttons  integer bit mask 0 .. 4294967295 (bit i = button i)
// Between samples the position is interpolated linearly; buttons keep the
// value of the last sample at or before the time.
//
// Example:
//   # press down 2 cm and come back
//   t,x,y,z,buttons
//   0.0, 0.0, 0.0, 0.10, 0
//   1.0, 0.0, 0.0, 0.08, 1
//   2.0, 0.0, 0.0, 0.10, 0

#include <array>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace palpa::plugins {

/// A bad trajectory file: "<file>:<line>: <what is wrong>".
class TrajectoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TrajectorySample {
  double t = 0;                      ///< s
  std::array<double, 3> position{};  ///< m
  std::uint32_t buttons = 0;
};

class Trajectory {
 public:
  /// Parses CSV text; `source` names it in messages. Throws TrajectoryError.
  static Trajectory parse(const std::string& text, const std::string& source);
  /// Reads and parses a file. Throws TrajectoryError (also when unreadable).
  static Trajectory load(const std::filesystem::path& path);

  const std::vector<TrajectorySample>& samples() const { return samples_; }
  /// Time of the last sample, s.
  double duration() const { return samples_.back().t; }

  /// Position (m) and buttons at time t (s): clamped to the first/last sample
  /// outside the recorded span. `cursor` speeds up monotone queries (start
  /// with 0); any value is accepted. No allocation.
  void at(double t, std::array<double, 3>& position, std::uint32_t& buttons, std::size_t& cursor) const noexcept;

 private:
  std::vector<TrajectorySample> samples_;
};

}  // namespace palpa::plugins
