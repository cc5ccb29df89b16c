#pragma once
// Bit-for-bit comparisons of tick results and surface states for the
// session, loop and replay tests (no tolerance: exact replays must give the
// same bits).

#include "haptics/loop_core.h"

#include <cstring>
#include <span>
#include <sstream>
#include <string>
#include <vector>

namespace palpa::test {

inline bool same_bits(const haptics::Triple& a, const haptics::Triple& b) {
  return std::memcmp(a.data(), b.data(), sizeof(haptics::Triple)) == 0;
}
inline bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// Empty when a and b agree in every field a tick computes (forces, flags,
/// position, velocity, contact); otherwise the first field that differs.
inline std::string result_difference(const haptics::ProbeTickResult& a, const haptics::ProbeTickResult& b) {
  if (!same_bits(a.force_device, b.force_device)) return "force_device";
  if (!same_bits(a.force_world, b.force_world)) return "force_world";
  if (a.flags != b.flags) return "flags";
  if (!same_bits(a.world, b.world)) return "world";
  if (!same_bits(a.velocity, b.velocity)) return "velocity";
  if (!same_bits(a.contact_point, b.contact_point)) return "contact_point";
  if (!same_bits(a.contact_normal, b.contact_normal)) return "contact_normal";
  if (!same_bits(a.depth, b.depth)) return "depth";
  if (!same_bits(a.normal_reaction, b.normal_reaction)) return "normal_reaction";
  if (a.in_contact != b.in_contact) return "in_contact";
  if (a.enabled != b.enabled) return "enabled";
  if (a.clutched != b.clutched) return "clutched";
  if (a.fault != b.fault) return "fault";
  return {};
}

/// Number of vertices whose state (h, h', q) differs in any bit.
inline std::size_t vertex_differences(std::span<const deform::VertexState> a, std::span<const deform::VertexState> b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(a[i])) != 0;
  return n;
}

/// Vertices pushed in (h < 0).
inline std::size_t dented(std::span<const deform::VertexState> v) {
  std::size_t n = 0;
  for (const auto& s : v) n += s.h < 0;
  return n;
}

}  // namespace palpa::test
