#include "haptics/device_mapping.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace palpa::haptics {

namespace {

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos) return "";
  const auto e = s.find_last_not_of(" \t");
  return std::string(s.substr(b, e - b + 1));
}

}  // namespace

// Three comma-separated entries, each an optional sign and x, y or z.
AxisMap AxisMap::parse(std::string_view text) {
  const std::string whole(text);
  AxisMap m;
  std::array<bool, 3> used{false, false, false};
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', start);
    if ((i < 2 && comma == std::string_view::npos) || (i == 2 && comma != std::string_view::npos))
      throw std::invalid_argument("axis order '" + whole + "': expected three entries like x,-z,y");
    std::string entry = trim(text.substr(start, i < 2 ? comma - start : std::string_view::npos));
    start = comma + 1;
    double sign = 1.0;
    if (!entry.empty() && (entry[0] == '-' || entry[0] == '+')) {
      sign = entry[0] == '-' ? -1.0 : 1.0;
      entry = trim(entry.substr(1));
    }
    if (entry.size() != 1 || entry[0] < 'x' || entry[0] > 'z')
      throw std::invalid_argument("axis order '" + whole + "': '" + entry + "' is not x, y or z");
    const int a = entry[0] - 'x';
    if (used[a]) throw std::invalid_argument("axis order '" + whole + "': axis " + entry + " is used twice");
    used[a] = true;
    m.axis[i] = a;
    m.sign[i] = sign;
  }
  return m;
}

std::string AxisMap::to_string() const {
  std::string s;
  for (int i = 0; i < 3; ++i) {
    if (i) s += ',';
    if (sign[i] < 0) s += '-';
    s += static_cast<char>('x' + axis[i]);
  }
  return s;
}

// Every field finite and in range; the axis map a signed permutation.
void DeviceMapping::validate(const std::string& who) const {
  const std::string p = "mapping of " + who + ": ";
  if (!(std::isfinite(scale) && scale > 0))
    throw std::invalid_argument(p + "scale must be a positive finite number, got " + number(scale));
  for (double o : offset)
    if (!std::isfinite(o)) throw std::invalid_argument(p + "offset must be finite, got " + number(o));
  if (!(std::isfinite(force_scale) && force_scale >= 0))
    throw std::invalid_argument(p + "force_scale must be a finite number >= 0, got " + number(force_scale));
  std::array<bool, 3> used{false, false, false};
  for (int i = 0; i < 3; ++i) {
    if (axes.axis[i] < 0 || axes.axis[i] > 2 || used[axes.axis[i]])
      throw std::invalid_argument(p + "axis order must use each device axis exactly once");
    used[axes.axis[i]] = true;
    if (axes.sign[i] != 1.0 && axes.sign[i] != -1.0)
      throw std::invalid_argument(p + "axis signs must be +1 or -1");
  }
  if (clutch_button < -1 || clutch_button > 31)
    throw std::invalid_argument(p + "clutch_button must be -1 (none) or 0 .. 31, got " +
                                std::to_string(clutch_button));
}

// Engage: remember where the probe is. Release: re-anchor the offset there.
Vec3 ClutchedMapping::update(const Vec3& device, bool clutch) noexcept {
  const Vec3 free = mapping_.to_world(device);
  if (!free.allFinite()) return engaged_ ? held_ : free;
  if (clutch) {
    if (!engaged_) {
      engaged_ = true;
      held_ = free;
    }
    return held_;
  }
  if (engaged_) {
    engaged_ = false;
    const Vec3 moved = held_ - mapping_.scale * mapping_.axes.to_world(device);
    mapping_.offset = {moved[0], moved[1], moved[2]};
    return held_;
  }
  return free;
}

}  // namespace palpa::haptics
