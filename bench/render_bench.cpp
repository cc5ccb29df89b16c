// palpa-render-bench: what a frame costs and uploads when contacts move over
// a mesh, with no display. For 100k and 1M triangles and 1 and 3 moving
// contacts, in one run, three cases on the same mesh, camera and window:
//   partial  our path: dirty stream ranges by glBufferSubData into a texture buffer
//   vtk      VTK's own path: the stream array updated and Modified()
//   static   the same mesh rendered with nothing changed
//   culled   partial, with back faces culled (as the workbench and the
//            replay draw a closed, outward organ)
// All are measured frame by frame in rotating order (same core
// surface, same contacts), so load from other processes hits them alike.
// Bytes are counted at GLEW's glBufferData/glBufferSubData (all of VTK's
// uploads and ours, by target); calls/fr is our path's glBufferSubData
// calls (one per dirty range; full uploads not counted). "gpu ms" is the
// GPU's time from the start to the end of the frame's commands (a
// GL_TIME_ELAPSED query round render()); it also counts moments the GPU
// waits for the CPU to send more, so it bounds the GPU's work from above
// and frame ms less gpu ms bounds the CPU's share from below. A software
// renderer (llvmpipe) draws at the glFinish after the query and shows
// about 0 there. Multisampling is off in all cases.
// Targets (issue 3): uploads <= 16 bytes x changed vertices, no index-buffer
// upload, frame time within 10% of the static render.

#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "haptics/session.h"
#include "mesh/generate.h"
#include "render/heap.h"
#include "render/offscreen.h"
#include "render/scene.h"
#include "render/surface_view.h"
#include "upload_counter.h"  // tests/render: a test aid

#include <GL/glew.h>
#include <vtkRenderWindow.h>
#include <vtkActor.h>
#include <vtkRenderer.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

namespace {

using palpa::Index;
using palpa::IndexRange;
using palpa::Vec3;
using namespace palpa::render;
using palpa::render::test::GlUploadCounter;
using Clock = std::chrono::steady_clock;

constexpr double kRadius = 0.1;       // sphere radius, m
constexpr double kDepth = 0.006;      // contact depth, m
constexpr double kSupport = 0.025;    // shape-function radius, m
constexpr double kSpeed = 0.05;       // contact sliding speed, m/s
constexpr double kFrameDt = 1.0 / 60; // simulated time per frame, s
constexpr double kTickDt = 1e-3;      // deformation step, s

struct Options {
  bool quick = false;
  int frames = 40;
  int warmup = 5;
  int width = 1024, height = 768;
  GlBackend backend = GlBackend::Auto;
  std::vector<std::size_t> triangles;  // empty: the default sizes
  std::string json;
};

struct CaseResult {
  std::string mesh_name;
  std::size_t triangles = 0, vertices = 0;
  int contacts = 0;
  std::string method;
  double frame_ms_median = 0, frame_ms_mean = 0;
  double upload_ms_median = 0;         // update() + the first part of the frame (CPU)
  double bytes_per_frame = 0;          // all buffer uploads
  double index_bytes_per_frame = 0;
  double upload_calls_per_frame = 0;   // glBufferSubData calls of our path (one per dirty range)
  double gpu_ms_median = -1;           // GL_TIME_ELAPSED of the frame's commands (-1: no timer query)
  double changed_vertices_per_frame = 0;
  double step_ms_per_frame = 0;        // the core's deformation for the frame (not in frame time)
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}
double mean(const std::vector<double>& v) {
  return v.empty() ? 0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

// Contact k of `count` at time t: sliding along a circle of latitude on the
// upper half of the sphere, facing the camera.
palpa::deform::Contact contact_at(const palpa::mesh::SurfaceMesh& mesh, const palpa::collision::VertexTree& tree,
                                  int k, int count, double t) {
  const double lat = 0.6 + 0.25 * k / std::max(1, count);         // rad above the equator
  const double lon = 2.0 * k + kSpeed * t / (kRadius * std::cos(lat));
  const Vec3 p = kRadius * Vec3(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat));
  const auto nearest = tree.nearest(p);
  palpa::deform::Contact c;
  c.vertex = nearest.vertex;
  c.point = mesh.positions[c.vertex];
  c.normal = mesh.normals[c.vertex];
  c.depth = kDepth;
  c.shape = {palpa::deform::ShapeKind::Wendland, kSupport};
  return c;
}

// One configuration (mesh x contacts): the three methods measured frame by
// frame in rotating order, so machine load drifts hit them alike. One core
// surface drives both moving views; the static view never changes.
std::vector<CaseResult> run_config(OffscreenScene& scene, const std::shared_ptr<const palpa::mesh::SurfaceMesh>& mesh,
                                   const palpa::collision::VertexTree& tree, int contacts, const Options& o) {
  constexpr int kMethods = 4;
  const char* methods[kMethods] = {"static", "partial", "vtk", "culled"};
  SurfaceView static_view(mesh, UploadPath::PartialTextureBuffer);
  SurfaceView partial_view(mesh, UploadPath::PartialTextureBuffer);
  SurfaceView vtk_view(mesh, UploadPath::VtkModified);
  SurfaceView culled_view(mesh, UploadPath::PartialTextureBuffer);
  culled_view.set_backface_culling(true);
  SurfaceView* views[kMethods] = {&static_view, &partial_view, &vtk_view, &culled_view};
  palpa::deform::Material mat;
  mat.stiffness = 200;
  mat.damping = 2;
  // The session: one probe per contact (no force output), pressed kDepth
  // into the surface along the contact's normal; a deformation step per tick.
  auto model = std::make_shared<palpa::haptics::SessionModel>();
  model->mesh = mesh;
  model->tree = std::shared_ptr<const palpa::collision::VertexTree>(&tree, [](const palpa::collision::VertexTree*) {});
  model->config.rate_hz = 1.0 / kTickDt;
  model->config.deform_rate_hz = 1.0 / kTickDt;
  model->config.shape = {palpa::deform::ShapeKind::Wendland, kSupport};
  model->config.force.max_force = 1e3;
  std::vector<palpa::haptics::ProbeSetup> setups(static_cast<std::size_t>(contacts));
  for (auto& su : setups) {
    su.name = "render bench probe";
    su.spec.position_dof = 3;
    su.safety.max_jump = 1e3;
  }
  palpa::haptics::Session session(model, palpa::deform::MaterialArrays::uniform(mesh->vertex_count(), mat), setups);
  palpa::deform::DeformableSurface& surface = session.surface();
  const auto first = IndexRange{0, static_cast<palpa::Index>(mesh->vertex_count())};
  std::vector<palpa::haptics::ProbeTickInput> inputs(setups.size());
  std::vector<palpa::haptics::ProbeTickResult> results(setups.size());
  std::uint64_t tick = 0;
  scene.renderer()->RemoveAllViewProps();
  for (SurfaceView* v : views) {
    v->update(surface.stream(), std::span<const IndexRange>(&first, 1));
    scene.add(v->actor());
  }
  scene.look_at(static_view.bounds(), Vec3(0.2, -0.6, 1.0), Vec3::UnitZ());
  // First frame of each: everything uploaded.
  for (int m = 0; m < kMethods; ++m) {
    for (int k = 0; k < kMethods; ++k) views[k]->actor()->SetVisibility(k == m);
    scene.render_image();
  }

  struct Samples {
    std::vector<double> frame_ms, upload_ms, bytes, index_bytes, calls, gpu_ms;
  } samples[kMethods];
  std::vector<double> changed, step_ms;
  GlUploadCounter counter;
  // The GPU's time for each frame's commands (uploads included), where the
  // driver has timer queries (GL 3.3, ARB_timer_query); see the top of the
  // file for what it bounds.
  GLuint query = 0;
  if (GLEW_VERSION_3_3 || GLEW_ARB_timer_query) glGenQueries(1, &query);
  double t = 0;
  for (int f = 0; f < o.warmup + o.frames; ++f) {
    // The core: move the contacts and deform for one frame's time.
    const auto s0 = Clock::now();
    for (int s = 0; s < static_cast<int>(std::lround(kFrameDt / kTickDt)); ++s) {
      const double ts = t + s * kTickDt;
      for (int k = 0; k < contacts; ++k) {
        const palpa::deform::Contact c = contact_at(*mesh, tree, k, contacts, ts);
        const Vec3 tip = c.point - c.depth * c.normal;
        inputs[static_cast<std::size_t>(k)].sample = palpa::haptics::position_sample(tip, tick + 1, ts);
      }
      session.step(ts, inputs, results);
      ++tick;
    }
    t += kFrameDt;
    const auto ranges = surface.take_dirty_ranges();
    const double step = std::chrono::duration<double, std::milli>(Clock::now() - s0).count();
    std::uint64_t n_changed = 0;
    for (const IndexRange& rg : ranges) n_changed += rg.end - rg.begin;
    if (f >= o.warmup) {
      changed.push_back(static_cast<double>(n_changed));
      step_ms.push_back(step);
    }

    // The frames: each view alone, in rotating order; hand over the stream
    // (not to "static"), render, finish.
    for (int q = 0; q < kMethods; ++q) {
      const int m = (f + q) % kMethods;
      for (int k = 0; k < kMethods; ++k) views[k]->actor()->SetVisibility(k == m);
      counter.reset();
      const std::uint64_t calls0 = views[m]->stats().ranges;
      const auto f0 = Clock::now();
      if (m != 0) views[m]->update(surface.stream(), ranges);
      const auto f1 = Clock::now();
      if (query) glBeginQuery(GL_TIME_ELAPSED, query);
      scene.window().render();
      if (query) glEndQuery(GL_TIME_ELAPSED);
      glFinish();
      const auto f2 = Clock::now();
      GLuint64 gpu_ns = 0;
      if (query) glGetQueryObjectui64v(query, GL_QUERY_RESULT, &gpu_ns);
      if (f < o.warmup) continue;
      const auto c = counter.counts();
      samples[m].frame_ms.push_back(std::chrono::duration<double, std::milli>(f2 - f0).count());
      samples[m].upload_ms.push_back(std::chrono::duration<double, std::milli>(f1 - f0).count());
      samples[m].bytes.push_back(static_cast<double>(c.total_bytes()));
      samples[m].index_bytes.push_back(static_cast<double>(c.index_bytes));
      samples[m].calls.push_back(static_cast<double>(views[m]->stats().ranges - calls0));
      if (query) samples[m].gpu_ms.push_back(static_cast<double>(gpu_ns) * 1e-6);
    }
  }
  if (query) glDeleteQueries(1, &query);
  scene.renderer()->RemoveAllViewProps();

  std::vector<CaseResult> rs;
  for (int m = 0; m < kMethods; ++m) {
    CaseResult r;
    r.triangles = mesh->triangle_count();
    r.vertices = mesh->vertex_count();
    r.contacts = contacts;
    r.method = methods[m];
    r.frame_ms_median = median(samples[m].frame_ms);
    r.frame_ms_mean = mean(samples[m].frame_ms);
    r.upload_ms_median = median(samples[m].upload_ms);
    r.bytes_per_frame = mean(samples[m].bytes);
    r.index_bytes_per_frame = mean(samples[m].index_bytes);
    r.upload_calls_per_frame = mean(samples[m].calls);
    if (query) r.gpu_ms_median = median(samples[m].gpu_ms);
    r.changed_vertices_per_frame = mean(changed);
    r.step_ms_per_frame = mean(step_ms);
    rs.push_back(r);
  }
  return rs;
}

void usage() {
  std::puts(
      "usage: palpa-render-bench [--quick] [--frames N] [--size WxH] [--gl auto|osmesa|egl] [--json FILE]\n"
      "                          [--triangles N,N,...]\n"
      "  --quick        100k triangles only, 15 frames per case\n"
      "  --triangles L  sphere sizes in triangles, e.g. 1000000,2000000 (default 100000,1000000)\n"
      "  --frames N     measured frames per case (default 40, after 5 warm-up frames)\n"
      "  --size WxH     window size in pixels (default 1024x768)\n"
      "  --gl BACKEND   offscreen OpenGL (default auto: EGL on a GPU, else OSMesa)\n"
      "  --json FILE    also write the records as a JSON array");
}

}  // namespace

int main(int argc, char** argv) {
  // llvmpipe's per-frame buffers: keep the freed heap (render/heap.h).
  palpa::render::keep_freed_heap();
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "palpa-render-bench: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      usage();
      return 0;
    } else if (a == "--quick") {
      o.quick = true;
      o.frames = 15;
    } else if (a == "--frames") {
      o.frames = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--size") {
      const std::string v = value();
      if (std::sscanf(v.c_str(), "%dx%d", &o.width, &o.height) != 2 || o.width < 16 || o.height < 16) {
        std::fprintf(stderr, "palpa-render-bench: --size: expected WxH, got '%s'\n", v.c_str());
        return 2;
      }
    } else if (a == "--gl") {
      try {
        o.backend = parse_gl_backend(value());
      } catch (const std::exception& e) {
        std::fprintf(stderr, "palpa-render-bench: %s\n", e.what());
        return 2;
      }
    } else if (a == "--json") {
      o.json = value();
    } else if (a == "--triangles") {
      const std::string v = value();
      for (std::size_t p = 0; p <= v.size();) {
        const std::size_t q = std::min(v.find(',', p), v.size());
        const std::string item = v.substr(p, q - p);
        char* end = nullptr;
        const long long n = std::strtoll(item.c_str(), &end, 10);
        if (item.empty() || *end != '\0' || n < 100 || n > 20'000'000) {
          std::fprintf(stderr, "palpa-render-bench: --triangles: expected counts from 100 to 20000000, got '%s'\n",
                       v.c_str());
          return 2;
        }
        o.triangles.push_back(static_cast<std::size_t>(n));
        p = q + 1;
      }
    } else {
      std::fprintf(stderr, "palpa-render-bench: unknown option '%s' (see --help)\n", a.c_str());
      return 2;
    }
  }

  try {
    OffscreenScene scene(o.width, o.height, o.backend);
    std::printf("palpa-render-bench: %s (%s, %s), %dx%d, multisampling %d, %d frames per case\n",
                std::string(gl_backend_name(scene.window().backend())).c_str(), scene.window().gl_renderer().c_str(),
                scene.window().gl_version().c_str(), o.width, o.height, scene.window().window()->GetMultiSamples(),
                o.frames);
    std::vector<std::size_t> sizes = {50'000, 500'000};  // vertices: ~100k and ~1M triangles
    if (o.quick) sizes = {50'000};
    if (!o.triangles.empty()) {
      sizes.clear();
      for (std::size_t t : o.triangles) sizes.push_back(t / 2 + 2);  // a closed sphere: F = 2V - 4
    }
    std::vector<CaseResult> all;
    std::printf("\n%-10s %8s %-8s %10s %8s %10s %12s %12s %10s %9s %10s\n", "triangles", "contacts", "method",
                "frame ms", "gpu ms", "upload ms", "bytes/frame", "index B/fr", "changed V", "calls/fr", "step ms");
    for (std::size_t target : sizes) {
      auto mesh = std::make_shared<const palpa::mesh::SurfaceMesh>(palpa::mesh::make_sphere(target, kRadius));
      const palpa::collision::VertexTree tree(*mesh);
      for (int contacts : {1, 3}) {
        std::vector<CaseResult> rs = run_config(scene, mesh, tree, contacts, o);
        for (CaseResult& r : rs) {
          r.mesh_name = "sphere" + std::to_string(mesh->triangle_count());
          std::printf("%-10zu %8d %-8s %10.2f %8.2f %10.3f %12.0f %12.0f %10.0f %9.0f %10.2f\n", r.triangles,
                      r.contacts, r.method.c_str(), r.frame_ms_median, r.gpu_ms_median, r.upload_ms_median,
                      r.bytes_per_frame, r.index_bytes_per_frame, r.changed_vertices_per_frame,
                      r.upload_calls_per_frame, r.step_ms_per_frame);
          std::fflush(stdout);
        }
        // Ratios against the targets.
        const CaseResult& st = rs[0];
        const CaseResult& pa = rs[1];
        const CaseResult& vt = rs[2];
        const CaseResult& cu = rs[3];
        const double bytes_ratio = pa.bytes_per_frame / std::max(1.0, 16.0 * pa.changed_vertices_per_frame);
        std::printf("  -> partial/static frame %.3f (target <= 1.10), vtk/static %.3f, vtk/partial %.2f; "
                    "partial bytes / (16 x changed) %.3f (target <= 1), partial index bytes %.0f (target 0), "
                    "vtk bytes/partial bytes %.0f\n",
                    pa.frame_ms_median / st.frame_ms_median, vt.frame_ms_median / st.frame_ms_median,
                    vt.frame_ms_median / pa.frame_ms_median, bytes_ratio, pa.index_bytes_per_frame,
                    vt.bytes_per_frame / std::max(1.0, pa.bytes_per_frame));
        std::printf("  -> back faces culled: %.3f of partial's frame\n", cu.frame_ms_median / pa.frame_ms_median);
        all.insert(all.end(), rs.begin(), rs.end());
      }
    }
    if (!o.json.empty()) {
      std::ofstream out(o.json);
      out << "[\n";
      for (std::size_t i = 0; i < all.size(); ++i) {
        const auto& r = all[i];
        out << "  {\"suite\": \"render\", \"backend\": \"" << gl_backend_name(scene.window().backend())
            << "\", \"mesh\": \"" << r.mesh_name << "\", \"triangles\": " << r.triangles
            << ", \"vertices\": " << r.vertices << ", \"contacts\": " << r.contacts << ", \"method\": \"" << r.method
            << "\", \"frame_ms_median\": " << r.frame_ms_median << ", \"frame_ms_mean\": " << r.frame_ms_mean
            << ", \"upload_ms_median\": " << r.upload_ms_median << ", \"bytes_per_frame\": " << r.bytes_per_frame
            << ", \"index_bytes_per_frame\": " << r.index_bytes_per_frame
            << ", \"upload_calls_per_frame\": " << r.upload_calls_per_frame
            << ", \"gpu_ms_median\": " << r.gpu_ms_median
            << ", \"changed_vertices_per_frame\": " << r.changed_vertices_per_frame
            << ", \"step_ms_per_frame\": " << r.step_ms_per_frame << "}" << (i + 1 < all.size() ? "," : "") << "\n";
      }
      out << "]\n";
      if (!out) {
        std::fprintf(stderr, "palpa-render-bench: %s: cannot write JSON\n", o.json.c_str());
        return 1;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-render-bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
