// The preparation report as JSON (for --report and the cache) and as text
// for the terminal.

#include "prep/prep.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>

namespace palpa::prep {

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(DroppedComponent, triangles, area_m2, extent_m)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(FilledHole, boundary_edges, perimeter_m, area_m2, added_triangles,
                                                faired)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(MeshSummary, vertices, triangles, components, boundary_edges,
                                                nonmanifold_edges, closed, manifold, outward, euler, genus, volume_m3,
                                                area_m2, edge_mean_m, edge_cv, edge_min_m, edge_max_m, min_angle_deg,
                                                extent_m)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(StepTime, step, seconds)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(PrepReport, input, unit_m, unit_guessed, edge_target_m,
                                                edge_requested_m, fit_rounds, edge_rule,
                                                before, after, loader_degenerate, loader_duplicate, merged_points,
                                                removed_polygons, nonmanifold_duplicated, dropped, holes,
                                                flipped_components, reoriented, self_intersections,
                                                self_intersection_fix, volume_repaired_m3, crease_edges, refine_tolerance_m,
                                                refined_triangles, refine_rounds, hausdorff_m,
                                                hausdorff_input_m, hausdorff_bound_m, volume_change,
                                                volume_change_input, self_intersecting_after, warnings, times, seconds, from_cache, cache_key)

namespace {
constexpr const char* kFormat = "palpa.prep-report";
constexpr int kVersion = 1;
}  // namespace

std::string report_json(const PrepReport& report) {
  nlohmann::json j = report;
  j["format"] = kFormat;
  j["version"] = kVersion;
  j["targets_unmet"] = unmet_targets(report);
  return j.dump(2) + "\n";
}

PrepReport report_from_json(const std::string& text) {
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    if (j.value("format", "") != kFormat || j.value("version", 0) != kVersion)
      throw PrepError(std::string("not a ") + kFormat + " version " + std::to_string(kVersion) + " report");
    return j.get<PrepReport>();
  } catch (const nlohmann::json::exception& e) {
    throw PrepError(std::string("bad preparation report: ") + e.what());
  }
}

// ---------------------------------------------------------------------------
std::string report_text(const PrepReport& r) {
  std::string s;
  char b[512];
  auto line = [&](const char* f, auto... a) {
    std::snprintf(b, sizeof b, f, a...);
    s += b;
    s += '\n';
  };
  auto yes = [](bool v) { return v ? "yes" : "no"; };
  line("%s%s", r.input.c_str(), r.from_cache ? " (from the cache)" : "");
  line("  unit          %g m per file unit%s", r.unit_m, r.unit_guessed ? " (guessed)" : "");
  line("  edge target   %.3g mm (%s)", r.edge_target_m * 1e3, r.edge_rule.c_str());
  line("                %12s %12s", "before", "after");
  line("  vertices      %12zu %12zu", r.before.vertices, r.after.vertices);
  line("  triangles     %12zu %12zu", r.before.triangles, r.after.triangles);
  line("  components    %12zu %12zu", r.before.components, r.after.components);
  line("  boundary edges%12zu %12zu", r.before.boundary_edges, r.after.boundary_edges);
  line("  closed        %12s %12s", yes(r.before.closed), yes(r.after.closed));
  line("  manifold      %12s %12s", yes(r.before.manifold), yes(r.after.manifold));
  line("  outward       %12s %12s", yes(r.before.outward), yes(r.after.outward));
  line("  genus         %12ld %12ld", r.before.genus, r.after.genus);
  line("  edge mean mm  %12.4g %12.4g", r.before.edge_mean_m * 1e3, r.after.edge_mean_m * 1e3);
  line("  edge CV       %12.3f %12.3f", r.before.edge_cv, r.after.edge_cv);
  line("  min angle deg %12.2f %12.2f", r.before.min_angle_deg, r.after.min_angle_deg);
  line("  volume cm^3   %12.5g %12.5g", r.before.volume_m3 * 1e6, r.after.volume_m3 * 1e6);
  line("  repair: %zu points merged, %zu polygons removed (+%zu degenerate, %zu duplicate by the loader), "
       "%zu points split at non-manifold vertices",
       r.merged_points, r.removed_polygons, r.loader_degenerate, r.loader_duplicate, r.nonmanifold_duplicated);
  line("  specks dropped: %zu", r.dropped.size());
  for (const auto& d : r.dropped)
    line("    %zu triangles, %.3g mm across, %.3g mm^2", d.triangles, d.extent_m * 1e3, d.area_m2 * 1e6);
  line("  holes filled: %zu", r.holes.size());
  for (const auto& h : r.holes)
    line("    %zu boundary edges, perimeter %.3g mm, patch %.3g mm^2 in %zu triangles%s", h.boundary_edges,
         h.perimeter_m * 1e3, h.area_m2 * 1e6, h.added_triangles, h.faired ? "" : " (not faired)");
  line("  self-intersecting after: %s", yes(r.self_intersecting_after));
  line("  orientation: %s", r.reoriented ? (std::to_string(r.flipped_components) + " component(s) flipped outward").c_str()
                                         : "already outward");
  line("  self-intersections: %zu pairs%s%s", r.self_intersections, r.self_intersection_fix.empty() ? "" : ", fixed by ",
       r.self_intersection_fix.c_str());
  line("  creases kept: %zu input edges sharper than the feature angle", r.crease_edges);
  line("  refined: %zu triangles in %d round(s) where a feature is thinner than the edge (tolerance %.3g mm)",
       r.refined_triangles, r.refine_rounds, r.refine_tolerance_m * 1e3);
  line("  Hausdorff     %.4g mm to the repaired surface, %.4g mm from the input (error bound %.2g mm)",
       r.hausdorff_m * 1e3, r.hausdorff_input_m * 1e3, r.hausdorff_bound_m * 1e3);
  line("  volume change %+.3f%% (vs the repaired surface)%s", r.volume_change * 100,
       r.volume_change_input != 0 ? (", " + std::to_string(r.volume_change_input * 100).substr(0, 6) + "% vs the input")
                                        .c_str()
                                  : "");
  std::string times;
  for (const auto& t : r.times) {
    std::snprintf(b, sizeof b, "%s%s %.2f s", times.empty() ? "" : ", ", t.step.c_str(), t.seconds);
    times += b;
  }
  line("  time %.2f s: %s", r.seconds, times.c_str());
  for (const auto& w : r.warnings) line("  warning: %s", w.c_str());
  const auto unmet = unmet_targets(r);
  line("  targets (closed, manifold, outward, CV <= 0.2, Hausdorff <= max(0.5 mm, edge/4), volume <= 1%%): %s",
       unmet.empty() ? "all met" : "NOT all met");
  return s;
}

}  // namespace palpa::prep
