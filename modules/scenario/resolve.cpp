// From a scenario to a session model (resolve.h).

#include "scenario/resolve.h"

#include "collision/vertex_tree.h"
#include "mesh/spatial_order.h"
#if PALPA_HAVE_PREP
#include "prep/prep.h"
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace palpa::scenario {

namespace {

// splitmix64: the same sequence from the same seed on every machine and
// library (std:: distributions are not specified bit for bit).
struct Random {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)
  double between(double lo, double hi) { return lo + (hi - lo) * uniform(); }
};

std::string file_of(const Scenario& s) { return s.file.empty() ? std::string("scenario") : s.file.string(); }

std::size_t tissue_index(const Scenario& s, const std::string& name, const std::string& pointer) {
  for (std::size_t k = 0; k < s.tissues.size(); ++k)
    if (s.tissues[k].name == name) return k;
  throw ScenarioError(file_of(s), pointer, "no tissue named '" + name + "'");
}

const tissue::Region* region_named(const Scenario& s, const std::string& name) {
  for (const auto& r : s.regions)
    if (r.name == name) return &r;
  return nullptr;
}

}  // namespace

std::vector<tissue::Lesion> place_lesions(const Scenario& s, const mesh::SurfaceMesh& organ) {
  std::vector<tissue::Lesion> out;
  collision::VertexTree tree(std::span<const Vec3>(organ.positions));
  for (std::size_t k = 0; k < s.lesions.size(); ++k) {
    const LesionSpec& spec = s.lesions[k];
    tissue::Lesion l = spec.lesion;
    if (l.name.empty()) l.name = "lesion " + std::to_string(k + 1);
    if (spec.from_surface) {
      const Index v = tree.nearest(spec.surface_point).vertex;
      l.centre = organ.positions[v] - spec.depth * organ.normals[v].normalized();
    }
    out.push_back(l);
  }

  const RandomLesions& rl = s.random_lesions;
  if (rl.count == 0) return out;
  std::vector<Index> candidates;
  if (rl.region.empty()) {
    for (Index i = 0; i < organ.vertex_count(); ++i) candidates.push_back(i);
  } else {
    const tissue::Region* r = region_named(s, rl.region);
    if (!r) throw ScenarioError(file_of(s), "/random_lesions/region", "no region named '" + rl.region + "'");
    const std::vector<float> w = tissue::region_weights(organ, *r);
    for (Index i = 0; i < organ.vertex_count(); ++i)
      if (w[i] >= 0.5f) candidates.push_back(i);
  }
  if (candidates.empty())
    throw ScenarioError(file_of(s), "/random_lesions/region", "the region '" + rl.region + "' holds no vertex of the organ");
  Random rng{rl.seed};
  const std::size_t first_random = out.size();
  for (std::uint32_t k = 0; k < rl.count; ++k) {
    tissue::Lesion l;
    l.name = "random " + std::to_string(k + 1);
    l.visibility = rl.visibility;
    // Up to 100 draws for one that does not touch an earlier lesion.
    for (int attempt = 0; attempt < 100; ++attempt) {
      const double radius = rng.between(rl.radius_min, rl.radius_max);
      const double depth = std::max(rng.between(rl.depth_min, rl.depth_max), radius + 0.001);
      l.modulus_ratio = rng.between(rl.ratio_min, rl.ratio_max);
      const Index v = candidates[std::min<std::size_t>(candidates.size() - 1,
                                                       static_cast<std::size_t>(rng.uniform() * candidates.size()))];
      l.semi_axes = Vec3::Constant(radius);
      l.centre = organ.positions[v] - depth * organ.normals[v].normalized();
      bool clear = true;
      for (std::size_t j = first_random; j < out.size(); ++j)
        clear = clear && (out[j].centre - l.centre).norm() > radius + out[j].semi_axes.maxCoeff() + 0.002;
      if (clear) break;
    }
    out.push_back(l);
  }
  return out;
}

std::string PrepSummary::text() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "prepared%s: %zu -> %zu triangles (%zu -> %zu vertices), %s, edge %.3g mm (mean %.3g mm, CV %.3f), "
                "Hausdorff %.3g mm, volume %+.2f%%",
                from_cache ? " (from the cache)" : "", triangles_before, triangles_after, vertices_before,
                vertices_after, closed ? "closed" : "NOT closed", edge_target * 1e3, edge_mean * 1e3, edge_cv,
                hausdorff * 1e3, volume_change * 100);
  std::string out = buf;
  for (const std::string& u : unmet) out += "; target missed: " + u;
  return out;
}

mesh::Organ load_scenario_organ(const OrganRef& ref, const std::string& file, const PrepHooks& hooks,
                                PrepSummary* summary) {
  const bool bundled = ref.path == "default" || ref.path.empty();
  const std::filesystem::path path =
      bundled ? mesh::default_organ_path() : (ref.resolved.empty() ? std::filesystem::path(ref.path) : ref.resolved);
  if (!ref.prep) return bundled ? mesh::load_default_organ() : mesh::load_organ(path, mesh::parse_mesh_unit(ref.unit));

  const PrepSpec& spec = *ref.prep;
  if (const std::string error = prep_spec_error(spec); !error.empty()) throw ScenarioError(file, "/organ/prep", error);
#if !PALPA_HAVE_PREP
  (void)hooks;
  (void)summary;
  throw ScenarioError(file, "/organ/prep", "this build has no mesh preparation (palpa-prep needs CGAL)");
#else
  prep::PrepOptions o;
  o.unit_m = bundled ? 1.0 : mesh::unit_metres(mesh::parse_mesh_unit(ref.unit));
  o.edge_m = spec.edge;
  o.probe_radius_m = spec.edge > 0 ? prep::kDefaultProbeRadius : spec.probe_radius;
  o.lesion_radius_m = spec.edge > 0 ? 0.0 : spec.lesion_radius;
  o.speck_area_fraction = spec.speck_area_fraction;
  o.max_hole_area_fraction = spec.max_hole_area_fraction;
  o.allow_autorefine = spec.autorefine;
  o.allow_local_repair = spec.local_repair;
  o.remesh_iterations = spec.remesh_iterations;
  o.relaxation_steps = spec.relaxation_steps;
  o.feature_angle_deg = spec.feature_angle_deg;
  o.refine_rounds = spec.refine_rounds;
  o.fit_rounds = spec.fit_rounds;
  o.fit_factor = spec.fit_factor;
  o.fit_max_triangles = static_cast<std::size_t>(spec.fit_max_triangles);
  o.progress = hooks.progress;
  o.cancel = hooks.cancel;

  mesh::Organ organ;
  organ.name = bundled ? std::string("default organ") : path.filename().string();
  organ.unit_m = o.unit_m;
  prep::PrepReport report;
  mesh::SurfaceMesh m;
  try {
    if (bundled && !std::filesystem::exists(path)) {
      // The bundled file is missing: prepare the generated organ (not cached: there are no bytes to key it by).
      const mesh::Organ raw = mesh::load_default_organ();
      m = prep::prepare(*raw.mesh, o, &report, raw.name);
    } else {
      m = prep::prepare_cached(path, o, &report, hooks.cache_dir.empty() ? prep::default_cache_dir() : hooks.cache_dir);
    }
  } catch (const prep::PrepCancelled& e) {
    throw PrepCancelled(e.what());
  } catch (const prep::PrepError& e) {
    throw ScenarioError(file, "/organ/prep", e.what());
  }
  PrepSummary sum;
  sum.vertices_before = report.before.vertices;
  sum.triangles_before = report.before.triangles;
  sum.vertices_after = m.vertex_count();
  sum.triangles_after = m.triangle_count();
  sum.closed = report.after.closed && report.after.manifold && report.after.outward;
  sum.edge_target = report.edge_target_m;
  sum.edge_mean = report.after.edge_mean_m;
  sum.edge_cv = report.after.edge_cv;
  sum.hausdorff = report.hausdorff_m;
  sum.volume_change = report.volume_change;
  sum.seconds = report.seconds;
  sum.from_cache = report.from_cache;
  sum.unmet = prep::unmet_targets(report);
  sum.warnings = report.warnings;
  mesh::reorder_spatially(m);  // as load_organ numbers every organ
  organ.facts = mesh::analyse(m);
  organ.note = sum.text();
  organ.mesh = std::make_shared<const mesh::SurfaceMesh>(std::move(m));
  if (summary) *summary = std::move(sum);
  return organ;
#endif
}

Resolved resolve(const Scenario& s) { return resolve_on(s, load_scenario_organ(s.organ, file_of(s))); }

Resolved resolve_on(const Scenario& s, mesh::Organ organ) {
  const std::string file = file_of(s);
  if (!organ.mesh || organ.mesh->vertex_count() == 0) throw ScenarioError(file, "/organ", "no organ mesh to resolve on");
  Resolved r;
  r.scenario = s;
  r.organ = std::move(organ);
  const mesh::SurfaceMesh& m = *r.organ.mesh;

  // Tissues onto the Hertz model for this probe.
  if (s.tissues.empty()) throw ScenarioError(file, "/tissues", "no tissue");
  if (s.tissues.size() > 65535) throw ScenarioError(file, "/tissues", "at most 65535 tissues");
  for (std::size_t k = 0; k < s.tissues.size(); ++k) {
    try {
      r.tissues.push_back(tissue::hertz_material(s.tissues[k], s.probe.tip_radius));
    } catch (const std::invalid_argument& e) {
      throw ScenarioError(file, "/tissues/" + std::to_string(k), e.what());
    }
  }
  r.base = tissue_index(s, s.base_tissue, "/base_tissue");

  // The tissue map over the vertices.
  tissue::TissueMap map;
  try {
    map = tissue::evaluate_tissue_map(m, s.tissues, r.base, s.regions);
  } catch (const std::exception& e) {
    throw ScenarioError(file, "/regions", e.what());
  }
  auto materials = std::make_shared<deform::MaterialMap>();
  materials->tissues = r.tissues;
  materials->tissue_of = std::move(map.tissue_of);
  materials->scale = std::move(map.scale);
  r.materials = std::move(materials);

  // Lesions, pulses, breathing and dynamic regions.
  r.lesions = place_lesions(s, m);
  std::vector<std::vector<float>> dynamic_weights;
  for (std::size_t k = 0; k < s.dynamic_regions.size(); ++k) {
    const tissue::Region* region = region_named(s, s.dynamic_regions[k].region);
    if (!region)
      throw ScenarioError(file, "/dynamic_regions/" + std::to_string(k) + "/region",
                          "no region named '" + s.dynamic_regions[k].region + "'");
    dynamic_weights.push_back(tissue::region_weights(m, *region));
  }
  try {
    r.field = std::make_shared<tissue::TissueField>(tissue::make_field(m, s.probe.tip_radius, r.lesions, s.pulses,
                                                                       s.breathing, s.dynamic_regions,
                                                                       std::move(dynamic_weights)));
  } catch (const std::invalid_argument& e) {
    throw ScenarioError(file, "/", e.what());
  }
  return r;
}

haptics::CoreConfig core_config(const Resolved& r, double rate_hz, double deform_rate_hz) {
  haptics::CoreConfig c;
  c.rate_hz = rate_hz;
  c.deform_rate_hz = deform_rate_hz;
  c.shape = r.scenario.probe.shape;
  // The model never asks for more than the task's limit allows a device to show (x2 headroom).
  c.force.max_force = std::max(10.0, 2.0 * r.scenario.task.force_limit);
  return c;
}

std::shared_ptr<const haptics::TissueModel> tissue_model(const Resolved& r) {
  auto t = std::make_shared<haptics::TissueModel>();
  t->map = r.materials;
  t->field = r.field;
  return t;
}

std::shared_ptr<const haptics::SessionModel> session_model(const Resolved& r, const haptics::CoreConfig& config,
                                                           deform::SurfaceOptions options) {
  return haptics::SessionModel::make(r.organ.mesh, options, config, r.field, r.materials);
}

}  // namespace palpa::scenario
