#pragma once
// 3Dconnexion SpaceMouse HID input reports and rate control.
//
// Devices: vendor 046d (Logitech-era 3Dconnexion: SpaceNavigator, SpaceExplorer,
// SpacePilot, SpaceMouse Pro ...) and vendor 256f (3Dconnexion: SpaceMouse
// Wireless, Compact, Enterprise, universal receiver ...).
//
// Input reports (first byte = report ID), values little-endian int16, about
// +-350 at full deflection:
//   ID 1, 7 bytes:   translation TX, TY, TZ
//   ID 1, 13 bytes:  translation TX, TY, TZ then rotation RX, RY, RZ (newer devices)
//   ID 2, 7 bytes:   rotation RX, RY, RZ
//   ID 3, 2..5 bytes: button bit mask (little-endian, bit i = button i)
// Other report IDs are ignored (battery, LEDs ...).
//
// HID axes: TX right, TY toward the user, TZ down. The plugin's device frame
// is x right, y up, z toward the user: (x, y, z) = (TX, -TZ, TY).

#include <array>
#include <cstdint>
#include <span>

namespace palpa::plugins::spacemouse {

/// True for the product IDs of known 3Dconnexion devices of vendor 046d, and
/// for every product of vendor 256f.
bool is_spacemouse(std::uint16_t vendor, std::uint16_t product);

/// The latest axis and button state, HID units and orientation.
struct AxisState {
  std::array<std::int16_t, 3> translation{};  ///< TX, TY, TZ
  std::array<std::int16_t, 3> rotation{};     ///< RX, RY, RZ
  std::uint32_t buttons = 0;
};

enum class Report {
  Translation,          ///< ID 1, 7 bytes
  TranslationRotation,  ///< ID 1, 13 bytes
  Rotation,             ///< ID 2, 7 bytes
  Buttons,              ///< ID 3
  Ignored,              ///< another report ID
  Malformed,            ///< empty, or a known ID with a wrong length
};

/// Applies one input report to `state` (unchanged for Ignored / Malformed).
Report apply_report(std::span<const std::uint8_t> bytes, AxisState& state);

/// Rate control: maps the translation to a velocity in the device frame.
struct RateControl {
  double full_scale = 350;  ///< HID value at full deflection
  double max_speed = 0.1;   ///< m/s at full deflection
  double deadzone = 0.05;   ///< fraction of full scale ignored around rest

  /// Velocity (m/s), device frame (x right, y up, z toward the user).
  /// Per axis: 0 inside the deadzone, then linear up to max_speed at full
  /// scale (rescaled so there is no step at the deadzone edge), saturated.
  std::array<double, 3> velocity(const AxisState& s) const;
};

}  // namespace palpa::plugins::spacemouse
