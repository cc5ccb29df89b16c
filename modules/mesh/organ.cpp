// Organ loading with unit handling.

#include "mesh/organ.h"
#include "mesh/spatial_order.h"

#include "mesh/generate.h"

#include <algorithm>
#include <cstdio>
#include <utility>
#include <vector>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#ifndef PALPA_DEFAULT_DATA_DIR
#define PALPA_DEFAULT_DATA_DIR "data"
#endif

namespace palpa::mesh {

MeshUnit parse_mesh_unit(std::string_view name) {
  if (name == "auto") return MeshUnit::Auto;
  if (name == "m") return MeshUnit::Metre;
  if (name == "cm") return MeshUnit::Centimetre;
  if (name == "mm") return MeshUnit::Millimetre;
  throw std::invalid_argument("unknown mesh unit '" + std::string(name) + "' (expected auto, m, cm or mm)");
}

double unit_metres(MeshUnit unit) {
  switch (unit) {
    case MeshUnit::Metre: return 1.0;
    case MeshUnit::Centimetre: return 1e-2;
    case MeshUnit::Millimetre: return 1e-3;
    case MeshUnit::Auto: return 0.0;
  }
  return 0.0;
}

double auto_unit_metres(double largest_extent) {
  // Compare log ratios to a typical organ size.
  constexpr double kOrganSize = 0.15;  // m
  double best = 1.0, best_err = std::numeric_limits<double>::infinity();
  for (double u : {1.0, 1e-2, 1e-3}) {
    const double err = std::abs(std::log(std::max(largest_extent * u, 1e-300) / kOrganSize));
    if (err < best_err) best = u, best_err = err;
  }
  return best;
}

std::filesystem::path data_dir() {
  if (const char* env = std::getenv("PALPA_DATA_DIR"); env && *env) return env;
  return PALPA_DEFAULT_DATA_DIR;
}

std::filesystem::path default_organ_path() { return data_dir() / "default_organ.ply"; }

namespace {

// A length for a message, in the unit that reads best ("138 m", "12.5 mm").
std::string length_text(double m) {
  char buf[48];
  if (m >= 1.0 || m == 0) std::snprintf(buf, sizeof buf, "%.3g m", m);
  else if (m >= 1e-2) std::snprintf(buf, sizeof buf, "%.3g cm", m * 1e2);
  else if (m >= 1e-4) std::snprintf(buf, sizeof buf, "%.3g mm", m * 1e3);
  else std::snprintf(buf, sizeof buf, "%.3g m", m);
  return buf;
}

const char* unit_name(double unit_m) { return unit_m == 1.0 ? "m" : unit_m == 1e-2 ? "cm" : "mm"; }

// Edges with one triangle (open boundaries, counted as loops of such edges)
// and with more than two (non-manifold), each named by where its first one is.
std::string topology_note(const SurfaceMesh& m) {
  std::vector<std::pair<Index, Index>> edges;
  edges.reserve(3 * m.triangles.size());
  for (const Triangle& t : m.triangles)
    for (int k = 0; k < 3; ++k) edges.emplace_back(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<Index, Index>> boundary, nonmanifold;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) boundary.push_back(edges[i]);
    if (j - i > 2) nonmanifold.push_back(edges[i]);
    i = j;
  }
  if (boundary.empty() && nonmanifold.empty()) return "";
  // Open boundaries: connected groups of boundary edges (union-find on their vertices).
  std::vector<Index> parent(m.positions.size());
  for (Index i = 0; i < parent.size(); ++i) parent[i] = i;
  auto root = [&](Index v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const auto& [a, b] : boundary) parent[root(a)] = root(b);
  std::vector<char> counted(parent.size(), 0);
  std::size_t loops = 0;
  for (const auto& [a, b] : boundary) {
    (void)b;
    const Index r = root(a);
    if (!counted[r]) counted[r] = 1, ++loops;
  }
  auto where = [&](const std::pair<Index, Index>& e) {
    const Vec3 p = 0.5 * (m.positions[e.first] + m.positions[e.second]) * 1e3;
    char buf[96];
    std::snprintf(buf, sizeof buf, "at (%.1f, %.1f, %.1f) mm", p.x(), p.y(), p.z());
    return std::string(buf);
  };
  std::string note = "not a closed surface:";
  if (!boundary.empty())
    note += " " + std::to_string(loops) + (loops == 1 ? " open boundary (" : " open boundaries (") +
            std::to_string(boundary.size()) + " boundary edges, the first " + where(boundary.front()) + ")";
  if (!boundary.empty() && !nonmanifold.empty()) note += " and";
  if (!nonmanifold.empty())
    note += " " + std::to_string(nonmanifold.size()) +
            (nonmanifold.size() == 1 ? " non-manifold edge (" : " non-manifold edges (the first ") +
            where(nonmanifold.front()) + ", shared by more than two triangles)";
  return note;
}

}  // namespace

Organ load_organ(const std::filesystem::path& path, MeshUnit unit) {
  // Load in file units, then scale to metres (normals and topology do not change).
  LoadOptions opt;
  opt.unit_m = 1.0;
  opt.keep_largest_component = true;
  SurfaceMesh m = load_mesh(path, opt);
  Organ o;
  o.name = path.filename().string();
  MeshFacts raw = analyse(m);
  const Vec3 ext = raw.bbox_max - raw.bbox_min;
  o.unit_guessed = unit == MeshUnit::Auto;
  o.unit_m = o.unit_guessed ? auto_unit_metres(ext.maxCoeff()) : unit_metres(unit);

  // An organ is 5 mm to 1 m across: refuse anything else, saying which unit would fit.
  const double size_m = ext.maxCoeff() * o.unit_m;
  if (!(size_m >= kMinOrganSize && size_m <= kMaxOrganSize)) {
    std::string msg = path.string() + ": the organ is " + length_text(size_m) + " across with the unit " +
                      unit_name(o.unit_m) + (o.unit_guessed ? " (the best guess)" : "") +
                      "; an organ is 5 mm to 1 m across";
    double fit = 0;
    for (double u : {1.0, 1e-2, 1e-3}) {
      const double s = ext.maxCoeff() * u;
      if (s >= kMinOrganSize && s <= kMaxOrganSize && (fit == 0 || std::abs(std::log(s / 0.15)) <
                                                                     std::abs(std::log(ext.maxCoeff() * fit / 0.15))))
        fit = u;
    }
    if (fit != 0)
      msg += std::string(": with the unit ") + unit_name(fit) + " it is " + length_text(ext.maxCoeff() * fit);
    else
      msg += ", and no unit (m, cm or mm) makes it so";
    throw MeshError(msg);
  }
  if (o.unit_m != 1.0)
    for (Vec3& p : m.positions) p *= o.unit_m;
  o.note = topology_note(m);  // names edges in the file's order
  reorder_spatially(m);
  o.facts = analyse(m);
  o.mesh = std::make_shared<const SurfaceMesh>(std::move(m));
  return o;
}

Organ load_default_organ() {
  const auto path = default_organ_path();
  if (std::filesystem::exists(path)) {
    Organ o = load_organ(path, MeshUnit::Metre);
    o.name = "default organ";
    return o;
  }
  // The bundled file is missing: generate the same organ.
  Organ o;
  o.name = "default organ";
  o.note = "default organ generated (" + path.string() + " not found)";
  SurfaceMesh m = make_organ(40000);
  reorder_spatially(m);
  o.mesh = std::make_shared<const SurfaceMesh>(std::move(m));
  o.facts = analyse(*o.mesh);
  return o;
}

}  // namespace palpa::mesh
