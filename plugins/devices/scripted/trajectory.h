#pragma once
// Trajectory files for the `scripted` device: timed positions and buttons.
//
// Format (CSV, UTF-8/ASCII):
//   - lines starting with '#' and blank lines are ignored;
//   - the first other line is the header, exactly: t,x,y,z,buttons
//   - every following line: t, x, y, z, buttons
//       t        time in s, 0 .. 1e9, strictly increasing
//       x, y, z  position in m (device frame), inside the workspace:
//                |x|, |y|, |z| <= the workspace half-size (kDefaultWorkspace,
//                10 m, unless the caller states another)
//       buttons  integer bit mask 0 .. 4294967295 (bit i = button i)
// A NUL byte anywhere is refused; files are read only when they are regular
// files of at most kMaxFileBytes (never a FIFO or a device such as /dev/zero).
// Denormal numbers are finite numbers.
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

/// Half-size of the default workspace cube around the origin, m.
inline constexpr double kDefaultWorkspace = 10.0;
/// Largest time accepted, s.
inline constexpr double kMaxTime = 1e9;
/// Largest trajectory file read, bytes (64 MiB).
inline constexpr std::uintmax_t kMaxFileBytes = std::uintmax_t(64) << 20;

class Trajectory {
 public:
  /// Parses CSV text; `source` names it in messages; positions must lie in
  /// the cube |x|, |y|, |z| <= workspace (m). Throws TrajectoryError.
  static Trajectory parse(const std::string& text, const std::string& source,
                          double workspace = kDefaultWorkspace);
  /// Reads and parses a file. Throws TrajectoryError (also when unreadable,
  /// not a regular file or larger than kMaxFileBytes).
  static Trajectory load(const std::filesystem::path& path, double workspace = kDefaultWorkspace);

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
