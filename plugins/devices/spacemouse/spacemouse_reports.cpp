#include "spacemouse_reports.h"

#include <algorithm>
#include <cmath>

namespace palpa::plugins::spacemouse {

bool is_spacemouse(std::uint16_t vendor, std::uint16_t product) {
  if (vendor == 0x256f) return true;
  if (vendor != 0x046d) return false;
  // 3Dconnexion products sold under the Logitech vendor ID.
  static constexpr std::uint16_t kKnown[] = {
      0xc603,  // SpaceMouse Plus XT
      0xc605,  // CADman
      0xc606,  // SpaceMouse Classic
      0xc621,  // SpaceBall 5000
      0xc623,  // SpaceTraveler
      0xc625,  // SpacePilot
      0xc626,  // SpaceNavigator
      0xc627,  // SpaceExplorer
      0xc628,  // SpaceNavigator for Notebooks
      0xc629,  // SpacePilot Pro
      0xc62b,  // SpaceMouse Pro
  };
  return std::find(std::begin(kKnown), std::end(kKnown), product) != std::end(kKnown);
}

namespace {

std::int16_t le16(const std::uint8_t* p) {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(p[0] | (p[1] << 8)));
}

void read3(const std::uint8_t* p, std::array<std::int16_t, 3>& out) {
  for (int i = 0; i < 3; ++i) out[i] = le16(p + 2 * i);
}

}  // namespace

Report apply_report(std::span<const std::uint8_t> b, AxisState& s) {
  if (b.empty()) return Report::Malformed;
  switch (b[0]) {
    case 1:
      if (b.size() == 7) {
        read3(&b[1], s.translation);
        return Report::Translation;
      }
      if (b.size() == 13) {
        read3(&b[1], s.translation);
        read3(&b[7], s.rotation);
        return Report::TranslationRotation;
      }
      return Report::Malformed;
    case 2:
      if (b.size() != 7) return Report::Malformed;
      read3(&b[1], s.rotation);
      return Report::Rotation;
    case 3: {
      if (b.size() < 2 || b.size() > 5) return Report::Malformed;
      std::uint32_t mask = 0;
      for (std::size_t i = 1; i < b.size(); ++i) mask |= static_cast<std::uint32_t>(b[i]) << (8 * (i - 1));
      s.buttons = mask;
      return Report::Buttons;
    }
    default:
      return Report::Ignored;
  }
}

std::array<double, 3> RateControl::velocity(const AxisState& s) const {
  // Shape one HID axis value into a signed speed.
  auto shape = [&](double raw) {
    const double u = std::clamp(raw / full_scale, -1.0, 1.0);
    const double a = std::abs(u);
    if (a <= deadzone) return 0.0;
    const double v = (a - deadzone) / (1.0 - deadzone) * max_speed;
    return u < 0 ? -v : v;
  };
  // Device frame from HID axes: x = TX, y = -TZ, z = TY.
  return {shape(s.translation[0]), shape(-static_cast<double>(s.translation[2])), shape(s.translation[1])};
}

}  // namespace palpa::plugins::spacemouse
