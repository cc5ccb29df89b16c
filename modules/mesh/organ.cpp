// Organ loading with unit handling.

#include "mesh/organ.h"

#include "mesh/generate.h"

#include <algorithm>
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
  if (o.unit_m != 1.0)
    for (Vec3& p : m.positions) p *= o.unit_m;
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
  o.mesh = std::make_shared<const SurfaceMesh>(make_organ(40000));
  o.facts = analyse(*o.mesh);
  return o;
}

}  // namespace palpa::mesh
