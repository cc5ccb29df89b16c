#include "trajectory.h"

#include "core/input_file.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace palpa::plugins {

namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    out.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

std::string format(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

Trajectory Trajectory::parse(const std::string& text, const std::string& source, double workspace) {
  Trajectory tr;
  std::istringstream in(text);
  std::string raw;
  int line_no = 0;
  bool header = false;
  auto fail = [&](const std::string& what) -> TrajectoryError {
    return TrajectoryError(source + ":" + std::to_string(line_no) + ": " + what);
  };
  // A finite number, or a message naming the field and the text. (A denormal
  // sets ERANGE but is finite; only overflow gives inf.)
  auto number = [&](const std::string& field, const std::string& s) {
    const char* str = s.c_str();
    char* end = nullptr;
    const double v = std::strtod(str, &end);
    if (s.empty() || end == str || *end != '\0' || !std::isfinite(v))
      throw fail(field + " '" + s + "' is not a finite number");
    return v;
  };
  // A coordinate inside the workspace (so that no difference or interpolation overflows).
  auto coordinate = [&](const std::string& field, const std::string& s) {
    const double v = number(field, s);
    if (!(std::abs(v) <= workspace))
      throw fail(field + " " + format(v) + " m is outside the workspace (|" + field + "| <= " + format(workspace) +
                 " m)");
    return v;
  };

  // No NUL byte anywhere (strtod would stop at one and take the field as ended).
  if (const auto nul = text.find('\0'); nul != std::string::npos) {
    line_no = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(nul), '\n'));
    const auto line_start = text.rfind('\n', nul);
    const std::size_t column = nul - (line_start == std::string::npos ? 0 : line_start + 1) + 1;
    throw fail("contains a NUL byte (column " + std::to_string(column) + ")");
  }

  while (std::getline(in, raw)) {
    ++line_no;
    const std::string line = trim(raw);
    if (line.empty() || line[0] == '#') continue;
    const auto fields = split(line);
    // The header comes first.
    if (!header) {
      if (fields != std::vector<std::string>{"t", "x", "y", "z", "buttons"})
        throw fail("expected the header t,x,y,z,buttons, got '" + line + "'");
      header = true;
      continue;
    }
    if (fields.size() != 5)
      throw fail("expected 5 comma-separated values (t,x,y,z,buttons), got " + std::to_string(fields.size()));
    TrajectorySample s;
    s.t = number("time", fields[0]);
    s.position = {coordinate("x", fields[1]), coordinate("y", fields[2]), coordinate("z", fields[3])};
    // Buttons: a non-negative integer that fits 32 bits.
    {
      const std::string& b = fields[4];
      char* end = nullptr;
      errno = 0;
      const unsigned long long v = std::strtoull(b.c_str(), &end, 10);
      if (b.empty() || b[0] == '-' || b[0] == '+' || *end != '\0' || errno == ERANGE || v > 0xffffffffull)
        throw fail("buttons '" + b + "' is not an integer in 0 .. 4294967295");
      s.buttons = static_cast<std::uint32_t>(v);
    }
    if (s.t < 0) throw fail("time " + format(s.t) + " is negative");
    if (s.t > kMaxTime) throw fail("time " + format(s.t) + " s is beyond the limit of " + format(kMaxTime) + " s");
    if (!tr.samples_.empty() && !(s.t > tr.samples_.back().t))
      throw fail("time " + format(s.t) + " is not after the previous time " + format(tr.samples_.back().t));
    tr.samples_.push_back(s);
  }
  if (!header) throw TrajectoryError(source + ": no header line (expected t,x,y,z,buttons)");
  if (tr.samples_.empty()) throw TrajectoryError(source + ": no samples after the header");
  return tr;
}

Trajectory Trajectory::load(const std::filesystem::path& path, double workspace) {
  // Only a regular file within the limit (/dev/zero would fill memory, a FIFO hang).
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw TrajectoryError("cannot open trajectory file '" + path.string() + "'");
  std::string bytes;
  const std::string problem = read_regular_file(path, kMaxFileBytes, "the trajectory file limit", bytes);
  if (!problem.empty()) throw TrajectoryError("trajectory file '" + path.string() + "' " + problem);
  return parse(bytes, path.string(), workspace);
}

// Finds the segment [i, i+1] holding t (moving the cursor), interpolates.
void Trajectory::at(double t, std::array<double, 3>& position, std::uint32_t& buttons,
                    std::size_t& cursor) const noexcept {
  const std::size_t n = samples_.size();
  if (!(t > samples_.front().t) || n == 1) {
    position = samples_.front().position;
    buttons = samples_.front().buttons;
    cursor = 0;
    return;
  }
  if (t >= samples_.back().t) {
    position = samples_.back().position;
    buttons = samples_.back().buttons;
    cursor = n - 1;
    return;
  }
  std::size_t i = cursor < n - 1 ? cursor : 0;
  if (samples_[i].t > t) i = 0;
  while (samples_[i + 1].t <= t) ++i;
  cursor = i;
  const TrajectorySample& a = samples_[i];
  const TrajectorySample& b = samples_[i + 1];
  const double u = (t - a.t) / (b.t - a.t);
  for (int k = 0; k < 3; ++k) position[k] = a.position[k] + u * (b.position[k] - a.position[k]);
  buttons = a.buttons;
}

}  // namespace palpa::plugins
