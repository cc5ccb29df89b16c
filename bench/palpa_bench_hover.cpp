// palpa-bench's hovering section (palpa_bench_hover.h).

#include "palpa_bench_hover.h"

#include "loop_bench_scene.h"

#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "haptics/probe_tick.h"
#include "mesh/generate.h"
#include "mesh/spatial_order.h"
#include "palpa_bench_util.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <memory>
#include <span>
#include <vector>

namespace palpa::bench {
namespace {

// palpa-loop-bench's three probes and paths (loop_bench_scene.h).
using loop_scene::kProbes;
constexpr double kTick = 1e-3;       // s, 1 kHz
constexpr int kTicksPerStep = 10;    // a deformation step at 100 Hz
constexpr std::size_t kWarmupTicks = 3000;

struct RunResult {
  Latency tick;
  Latency tree_ticks;  // ticks where a probe asked the tree
  std::array<long, 5> paths{};  // probe-ticks by collision::ContactPath
};

RunResult run(const std::shared_ptr<const mesh::SurfaceMesh>& mesh, const collision::VertexTree& tree,
              const std::array<Vec3, kProbes>& point, const std::array<Vec3, kProbes>& normal, std::size_t ticks) {
  deform::DeformableSurface surface(mesh,
                                    deform::MaterialArrays::uniform(mesh->vertex_count(), loop_scene::material()));
  deform::ShapeFunction shape;
  shape.radius = 0.015;
  std::array<haptics::ProbeMemory, kProbes> memory{}, warm_memory{};
  std::array<haptics::ProbeInput, kProbes> in{}, last{};
  std::array<haptics::ProbeOutput, kProbes> out{}, warm_out{};
  std::vector<deform::Contact> contacts;
  contacts.reserve(kProbes);
  std::vector<double> all, tree_ticks;
  all.reserve(ticks);
  tree_ticks.reserve(ticks);
  RunResult r;
  for (std::size_t k = 0; k < kWarmupTicks + ticks; ++k) {
    const double t = static_cast<double>(k) * kTick;
    for (int p = 0; p < kProbes; ++p) {
      const Vec3 x = loop_scene::path_point(point[p], normal[p], t + loop_scene::kPhase * p);
      in[p] = {x, k == 0 ? Vec3::Zero() : Vec3((x - last[p].position) / kTick)};
    }
    // The loop's warm-up (LoopCore::warm_caches): the last tick again, into
    // scratch, asking the tree for the probes it did not search for.
    if (k > 0) {
      for (int p = 0; p < kProbes; ++p) haptics::set_warm_up_memory(memory[p], warm_memory[p]);
      haptics::haptic_tick(surface, tree, last, warm_memory, warm_out, haptics::ForceParams{}, shape);
    }
    const auto t0 = Clock::now();
    haptics::haptic_tick(surface, tree, in, memory, out, haptics::ForceParams{}, shape);
    const double ns = elapsed_ns(t0, Clock::now());
    last = in;
    if (k >= kWarmupTicks) {
      all.push_back(ns);
      bool searched = false;
      for (const auto& o : out) {
        ++r.paths[static_cast<std::size_t>(o.path) % r.paths.size()];
        searched |= o.path == collision::ContactPath::Tree;
      }
      if (searched) tree_ticks.push_back(ns);
    }
    if (k % kTicksPerStep == kTicksPerStep - 1) {
      contacts.clear();
      for (const auto& o : out)
        if (o.in_contact) contacts.push_back(o.contact);
      surface.set_contacts(contacts);
      surface.step(kTicksPerStep * kTick);
    }
  }
  r.tick = latency_of(all);
  r.tree_ticks = latency_of(tree_ticks);
  return r;
}

}  // namespace

void run_hover_bench(std::size_t vertices, std::size_t ticks, int rounds, nlohmann::json& records) {
  const auto t0 = Clock::now();
  auto m = std::make_shared<mesh::SurfaceMesh>(mesh::make_organ(vertices));
  mesh::reorder_spatially(*m);
  const std::shared_ptr<const mesh::SurfaceMesh> mesh = m;
  const collision::VertexTree knows(*mesh), positions_only(std::span<const Vec3>(mesh->positions));
  // The three probes on top of the organ, as in palpa-loop-bench.
  std::array<Vec3, kProbes> point, normal;
  for (int p = 0; p < kProbes; ++p) {
    const Index v = positions_only.nearest(Vec3(loop_scene::kProbeX[p], 0.0, 1.0)).vertex;
    point[p] = mesh->positions[v];
    normal[p] = mesh->normals[v];
  }
  std::printf("\n== Hovering probes (haptics::haptic_tick on the default organ, %zu vertices, built in %.1f s; "
              "palpa-loop-bench's 3 paths: 4 mm above to 4 mm below, circling 3 mm; the loop's warm-up before "
              "each tick; a deformation step every %d ticks, not timed), %zu ticks per run, us\n",
              mesh->vertex_count(), elapsed_ns(t0, Clock::now()) * 1e-9, kTicksPerStep, ticks);
  std::printf("%-32s %8s %8s %8s %8s   %-30s %s\n", "tree", "p50", "p99", "p99.9", "max",
              "ticks with a search p50 / p99", "probe-ticks: walk / tree / proxy / clear");
  std::vector<double> p50[2], p99[2];
  for (int round = 0; round < rounds; ++round) {
    for (int variant = 0; variant < 2; ++variant) {
      const bool clearance = variant == 1;
      const RunResult r = run(mesh, clearance ? knows : positions_only, point, normal, ticks);
      p50[variant].push_back(r.tick.p50_us);
      p99[variant].push_back(r.tick.p99_us);
      char searched[64];
      std::snprintf(searched, sizeof searched, "%zu: %.3f / %.3f", r.tree_ticks.samples, r.tree_ticks.p50_us,
                    r.tree_ticks.p99_us);
      std::printf("%-32s %8.3f %8.3f %8.3f %8.2f   %-30s %ld / %ld / %ld / %ld\n",
                  clearance ? "knows the surface (clearance)" : "positions alone (always search)", r.tick.p50_us,
                  r.tick.p99_us, r.tick.p999_us, r.tick.max_us, searched, r.paths[1], r.paths[2], r.paths[3],
                  r.paths[4]);
      records.push_back({{"section", "hover"},
                         {"tree", clearance ? "clearance" : "positions"},
                         {"round", round},
                         {"vertices", mesh->vertex_count()},
                         {"ticks", ticks},
                         {"tick_p50_us", r.tick.p50_us},
                         {"tick_p99_us", r.tick.p99_us},
                         {"tick_p999_us", r.tick.p999_us},
                         {"ticks_with_a_search", r.tree_ticks.samples},
                         {"walk", r.paths[1]},
                         {"tree_queries", r.paths[2]},
                         {"proxy", r.paths[3]},
                         {"clear", r.paths[4]}});
    }
  }
  // The worse run of each variant (of two, a median would be one of them).
  auto worst = [](const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); };
  const double b50 = worst(p50[0]), a50 = worst(p50[1]), b99 = worst(p99[0]), a99 = worst(p99[1]);
  std::printf("the worse of %d runs each: tick p50 %.3f -> %.3f us (%.2fx), p99 %.3f -> %.3f us (%.2fx)\n", rounds,
              b50, a50, a50 > 0 ? b50 / a50 : 0.0, b99, a99, a99 > 0 ? b99 / a99 : 0.0);
}

}  // namespace palpa::bench
