// The preparation pipeline: each step timed and announced, the CGAL work
// behind internal::Work, the measurements and targets. No CGAL header here.

#include "prep/internal_cgal.h"

#include "mesh/io.h"
#include "mesh/organ.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <utility>

namespace palpa::prep {

namespace {

std::string fmt(const char* f, double v) {
  char b[96];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// Largest triangle count a target edge may produce before we refuse it.
constexpr double kMaxTriangles = 5e6;

}  // namespace

// ---------------------------------------------------------------------------
double target_edge_for(double probe_radius_m, double diagonal_m, double lesion_radius_m) {
  double edge = probe_radius_m / 4;
  if (diagonal_m > 0) edge = std::min(edge, diagonal_m / 40);
  if (lesion_radius_m > 0) edge = std::min(edge, lesion_radius_m / 2);
  return edge;
}

// ---------------------------------------------------------------------------
// Edge lengths, angles and topology of a mesh in metres.
MeshSummary summarize(const mesh::SurfaceMesh& m) {
  MeshSummary s;
  const mesh::MeshFacts f = mesh::analyse(m);
  s.vertices = f.vertices;
  s.triangles = f.triangles;
  s.components = f.components;
  s.boundary_edges = f.boundary_edges;
  s.nonmanifold_edges = f.nonmanifold_edges;
  s.closed = f.closed();
  s.manifold = f.manifold();
  s.outward = s.closed && f.consistently_oriented && f.signed_volume > 0;
  s.euler = f.euler_characteristic;
  s.genus = s.closed ? (2 * static_cast<long>(f.components) - f.euler_characteristic) / 2 : -1;
  s.volume_m3 = f.signed_volume;
  s.area_m2 = f.area;
  s.extent_m = (f.bbox_max - f.bbox_min).norm();

  // Every undirected edge once: its length; every corner: its angle.
  std::vector<std::pair<Index, Index>> edges;
  edges.reserve(3 * m.triangles.size());
  double min_angle = 180;
  for (const auto& t : m.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Index a = t[k], b = t[(k + 1) % 3];
      edges.emplace_back(std::min(a, b), std::max(a, b));
      const Vec3 u = m.positions[t[(k + 1) % 3]] - m.positions[t[k]];
      const Vec3 v = m.positions[t[(k + 2) % 3]] - m.positions[t[k]];
      const double nu = u.norm(), nv = v.norm();
      if (nu > 0 && nv > 0) {
        const double c = std::clamp(u.dot(v) / (nu * nv), -1.0, 1.0);
        min_angle = std::min(min_angle, std::acos(c) * 180.0 / M_PI);
      } else {
        min_angle = 0;
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  double sum = 0, sum2 = 0, lo = edges.empty() ? 0 : 1e300, hi = 0;
  for (const auto& [a, b] : edges) {
    const double l = (m.positions[a] - m.positions[b]).norm();
    sum += l;
    sum2 += l * l;
    lo = std::min(lo, l);
    hi = std::max(hi, l);
  }
  const double n = static_cast<double>(edges.size());
  if (n > 0) {
    s.edge_mean_m = sum / n;
    const double var = std::max(0.0, sum2 / n - s.edge_mean_m * s.edge_mean_m);
    s.edge_cv = s.edge_mean_m > 0 ? std::sqrt(var) / s.edge_mean_m : 0;
  }
  s.edge_min_m = lo;
  s.edge_max_m = hi;
  s.min_angle_deg = m.triangles.empty() ? 0 : min_angle;
  return s;
}

// ---------------------------------------------------------------------------
std::vector<std::string> unmet_targets(const PrepReport& r) {
  std::vector<std::string> unmet;
  if (!r.after.closed) unmet.push_back("not closed (" + std::to_string(r.after.boundary_edges) + " boundary edges)");
  if (!r.after.manifold) unmet.push_back("not manifold (" + std::to_string(r.after.nonmanifold_edges) + " edges)");
  if (!r.after.outward) unmet.push_back("not oriented outward");
  if (r.after.edge_cv > 0.2) unmet.push_back("edge-length CV " + fmt("%.3f", r.after.edge_cv) + " > 0.2");
  const double h_limit = std::max(0.5e-3, r.edge_target_m / 4);
  if (r.hausdorff_m > h_limit)
    unmet.push_back("Hausdorff " + fmt("%.3g", r.hausdorff_m * 1e3) + " mm > " + fmt("%.3g", h_limit * 1e3) + " mm");
  if (std::abs(r.volume_change) > 0.01)
    unmet.push_back("volume change " + fmt("%+.2f", r.volume_change * 100) + "% beyond 1%");
  return unmet;
}

// ---------------------------------------------------------------------------
// The pipeline. Each step: announced, timed, cancellable between steps.
mesh::SurfaceMesh prepare(const mesh::SurfaceMesh& input, const PrepOptions& options, PrepReport* report_out,
                          const std::string& source) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  PrepReport r;
  if (report_out) {
    // Keep what prepare_file() filled in (unit, loader counts).
    r.unit_m = report_out->unit_m;
    r.unit_guessed = report_out->unit_guessed;
    r.loader_degenerate = report_out->loader_degenerate;
    r.loader_duplicate = report_out->loader_duplicate;
  }
  r.input = source;
  if (input.triangles.empty()) throw PrepError(source + ": cannot make a closed surface: it has no triangles");

  // Options.
  if (!(options.edge_m >= 0) || !std::isfinite(options.edge_m))
    throw PrepError(source + ": the edge length must be a positive length in metres");
  if (options.edge_m == 0 && (!(options.probe_radius_m > 0) || !std::isfinite(options.probe_radius_m)))
    throw PrepError(source + ": the probe radius must be a positive length in metres");
  if (!(options.lesion_radius_m >= 0) || !std::isfinite(options.lesion_radius_m))
    throw PrepError(source + ": the lesion radius must be zero (none) or a positive length in metres");

  r.before = summarize(input);
  const double diag = r.before.extent_m;
  if (options.edge_m > 0) {
    r.edge_target_m = options.edge_m;
    r.edge_rule = "given: " + fmt("%.3g", options.edge_m * 1e3) + " mm";
  } else {
    r.edge_target_m = target_edge_for(options.probe_radius_m, diag, options.lesion_radius_m);
    const std::string quarter = "a quarter of the probe radius " + fmt("%.3g", options.probe_radius_m * 1e3) + " mm";
    if (options.lesion_radius_m > 0 && r.edge_target_m == options.lesion_radius_m / 2 &&
        r.edge_target_m < options.probe_radius_m / 4)
      r.edge_rule = "half the smallest lesion's radius " + fmt("%.3g", options.lesion_radius_m * 1e3) +
                    " mm, shorter than " + quarter;
    else if (r.edge_target_m < options.probe_radius_m / 4)
      r.edge_rule = "1/40 of the bounding-box diagonal (" + fmt("%.3g", diag * 1e3) + " mm), shorter than " + quarter;
    else
      r.edge_rule = quarter;
  }
  double L = r.edge_target_m;
  r.edge_requested_m = L;
  const double expected_triangles = r.before.area_m2 / (std::sqrt(3.0) / 4 * L * L);
  if (expected_triangles > kMaxTriangles)
    throw PrepError(source + ": an edge of " + fmt("%.3g", L * 1e3) + " mm would give about " +
                    fmt("%.3g", expected_triangles) + " triangles (more than " + fmt("%.0f", kMaxTriangles) +
                    "); choose a longer edge");

  // Steps.
  const char* names[] = {"repair soup", "drop specks", "fill holes", "self-intersections", "orient outward",
                         "remesh",      "relax",       "refine features", "fit edge", "reorder", "measure"};
  const int count = static_cast<int>(std::size(names));
  int index = 0;
  auto step = [&](auto&& fn) {
    if (options.cancel && options.cancel->load()) throw PrepCancelled(source + ": preparation cancelled");
    const char* name = names[index];
    if (options.progress) options.progress(name, index, count, 0.0);
    const auto t0 = Clock::now();
    fn();
    const double dt = std::chrono::duration<double>(Clock::now() - t0).count();
    r.times.push_back({name, dt});
    if (options.progress) options.progress(name, index, count, 1.0);
    ++index;
  };

  internal::Soup soup{input.positions, input.triangles};
  internal::Work work(soup, source);
  internal::Soup kept, before_fix, reference, out;

  step([&] {
    const internal::SoupRepair s = work.repair_soup();
    r.merged_points = s.merged_points;
    r.removed_polygons = s.removed_polygons;
    r.nonmanifold_duplicated = s.nonmanifold_duplicated;
  });
  step([&] {
    r.dropped = work.drop_specks(options.speck_area_fraction);
    kept = work.soup();
  });
  step([&] {
    r.holes = work.fill_holes(options.max_hole_area_fraction);
    before_fix = work.soup();
  });
  step([&] {
    const internal::IntersectionFix fix = work.fix_self_intersections(L, L / 20, options.allow_autorefine, options.allow_local_repair);
    r.self_intersections = fix.pairs;
    r.self_intersection_fix = fix.method;
    for (const auto& n : fix.notes) r.warnings.push_back("self-intersections: " + n);
  });
  step([&] {
    r.flipped_components = work.orient_outward();
    r.reoriented = r.flipped_components > 0;
    r.volume_repaired_m3 = work.volume();
    reference = work.soup();
    if (options.repaired) {
      options.repaired->positions = reference.points;
      options.repaired->triangles = reference.triangles;
      mesh::finalize(*options.repaired);
    }
    const double box = std::pow(diag / std::sqrt(3.0), 3);
    if (!(r.volume_repaired_m3 > 1e-9 * box))
      throw PrepError(source + ": cannot make a closed surface: the repaired surface encloses no volume (" +
                      fmt("%.3g", r.volume_repaired_m3 * 1e6) + " cm^3)");
  });
  if (r.self_intersection_fix == "alpha_wrap") {
    // The last resort changed the shape: say by how much (first warning).
    const double moved = internal::hausdorff_one_sided(reference, before_fix, L / 100);
    r.warnings.insert(r.warnings.begin(), "self-intersections (" + std::to_string(r.self_intersections) +
                         " triangle pairs) could not be repaired in place: the surface was alpha-wrapped (alpha " +
                         fmt("%.3g", L * 1e3) + " mm, offset " + fmt("%.3g", L / 20 * 1e3) +
                         " mm), so the shape changed: the wrap lies up to " + fmt("%.3g", moved * 1e3) +
                         " mm from the input surface");
  }
  step([&] {
    r.crease_edges = work.remesh(L, options.remesh_iterations, options.relaxation_steps, options.feature_angle_deg);
  });
  step([&] { work.relax(options.relaxation_steps); });
  step([&] {
    // Where a feature is thinner than the edge, refine locally until the
    // surface is within 60% of the Hausdorff target.
    r.refine_tolerance_m = 0.6 * std::max(0.5e-3, L / 4);
    r.refined_triangles = work.refine(r.refine_tolerance_m, L, options.refine_rounds, r.refine_rounds);
  });
  step([&] {
    // While the Hausdorff or volume target is missed (a feature narrower than
    // the edge), remesh the repaired surface again with a shorter uniform edge.
    for (int round = 0; round < options.fit_rounds; ++round) {
      const double limit = std::max(0.5e-3, L / 4);
      const double h = internal::hausdorff_symmetric(work.soup(), reference, std::max(1e-7, L / 10));
      const double dv = std::abs(work.volume() - r.volume_repaired_m3) / r.volume_repaired_m3;
      if (h <= limit && dv <= 0.01) break;
      const double next = L * options.fit_factor;
      const double triangles = r.before.area_m2 / (std::sqrt(3.0) / 4 * next * next);
      if (triangles > options.fit_max_triangles) {
        r.warnings.push_back("the edge was not shortened below " + fmt("%.3g", L * 1e3) + " mm: " +
                             fmt("%.3g", next * 1e3) + " mm would give about " + fmt("%.3g", triangles) +
                             " triangles (PrepOptions::fit_max_triangles " +
                             fmt("%.0f", static_cast<double>(options.fit_max_triangles)) + ")");
        break;
      }
      L = next;
      ++r.fit_rounds;
      work.restore_reference();
      work.remesh(L, options.remesh_iterations, options.relaxation_steps, options.feature_angle_deg);
      work.relax(options.relaxation_steps);
      r.refine_tolerance_m = 0.6 * std::max(0.5e-3, L / 4);
      r.refined_triangles = work.refine(r.refine_tolerance_m, L, options.refine_rounds, r.refine_rounds);
    }
    if (r.fit_rounds > 0)
      r.edge_rule += "; shortened to " + fmt("%.3g", L * 1e3) + " mm in " + std::to_string(r.fit_rounds) +
                     " round(s) to meet the Hausdorff and volume targets";
    r.edge_target_m = L;
  });
  mesh::SurfaceMesh result;
  step([&] {
    out = work.sorted_soup();
    result.positions = out.points;
    result.triangles = out.triangles;
    mesh::finalize(result);
  });
  step([&] {
    r.after = summarize(result);
    r.self_intersecting_after = work.self_intersects();
    r.hausdorff_bound_m = std::max(1e-7, L / 40);
    r.hausdorff_m = internal::hausdorff_symmetric(out, reference, r.hausdorff_bound_m);
    r.hausdorff_input_m = internal::hausdorff_one_sided(kept, out, r.hausdorff_bound_m);
    r.volume_change = (r.after.volume_m3 - r.volume_repaired_m3) / r.volume_repaired_m3;
    // Against the input itself when it was a closed surface (after welding) kept as it was.
    const double v_in = std::abs(r.before.volume_m3);
    if (r.holes.empty() && r.self_intersection_fix.empty() && v_in > 0 && r.before.boundary_edges == 0)
      r.volume_change_input = (r.after.volume_m3 - v_in) / v_in;
  });
  if (r.self_intersection_fix == "alpha_wrap" && r.before.volume_m3 != 0)
    r.warnings.front() += "; the volume changed by " +
                          fmt("%+.2f", (r.after.volume_m3 / std::abs(r.before.volume_m3) - 1) * 100) +
                          "% from the input's";

  // Facts the user should hear about.
  for (const auto& d : r.dropped)
    r.warnings.push_back("dropped a speck of " + std::to_string(d.triangles) + " triangles (" +
                         fmt("%.3g", d.extent_m * 1e3) + " mm across, " + fmt("%.3g", d.area_m2 * 1e6) + " mm^2)");
  if (r.self_intersecting_after)
    r.warnings.push_back("the remeshed surface intersects itself (a part thinner than the edge); choose a shorter edge");
  for (const auto& u : unmet_targets(r)) r.warnings.push_back("target not met: " + u);
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (report_out) *report_out = std::move(r);
  return result;
}

// ---------------------------------------------------------------------------
// The file as it is: no welding, no reorientation, every component; the unit
// given or guessed from the size.
mesh::SurfaceMesh prepare_file(const std::filesystem::path& path, const PrepOptions& options, PrepReport* report) {
  mesh::LoadOptions lo;
  lo.unit_m = options.unit_m > 0 ? options.unit_m : 1.0;
  lo.weld = false;
  lo.orient_outward = false;
  lo.keep_largest_component = false;
  mesh::CleanReport clean;
  mesh::SurfaceMesh m = mesh::load_mesh(path, lo, &clean);
  PrepReport r;
  r.unit_m = lo.unit_m;
  if (!(options.unit_m > 0)) {
    // Guess among m, cm, mm from the largest extent.
    Vec3 lo_p = m.positions[0], hi_p = m.positions[0];
    for (const Vec3& p : m.positions) {
      lo_p = lo_p.cwiseMin(p);
      hi_p = hi_p.cwiseMax(p);
    }
    r.unit_m = mesh::auto_unit_metres((hi_p - lo_p).maxCoeff());
    r.unit_guessed = true;
    for (Vec3& p : m.positions) p *= r.unit_m;
    mesh::finalize(m);
  }
  r.loader_degenerate = clean.degenerate_triangles;
  r.loader_duplicate = clean.duplicate_triangles;
  PrepReport* out = report ? report : &r;
  if (report) *report = r;
  mesh::SurfaceMesh prepared = prepare(m, options, out, path.string());
  if (r.unit_guessed)
    out->warnings.insert(out->warnings.begin(), "unit guessed from the size: " + fmt("%g", r.unit_m) +
                                                    " m per file unit (give --unit to say)");
  return prepared;
}

}  // namespace palpa::prep
