// palpa-replay SESSION: re-simulates a recorded session from its inputs and
// commands, checks the forces against the recorded ones, and (with --video
// or --frames) renders it offscreen with overlays into an MP4 (OpenCV's
// VideoWriter, mp4v) or PNG frames. No display needed.

#include "app/replay/overlay.h"
#include "app/replay/session_job.h"
#include "assess/coverage.h"
#include "mesh/surface_mesh.h"
#include "render/heap.h"
#include "render/lesion_view.h"
#include "render/offscreen.h"
#include "render/probe_view.h"
#include "render/scene.h"
#include "render/surface_view.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <pthread.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <filesystem>
#include <limits>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace palpa;
using Clock = std::chrono::steady_clock;
const Clock::time_point process_start = Clock::now();

struct Usage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

const char* kUsage =
    "usage: palpa-replay SESSION [--video OUT.mp4] [--frames DIR] [--size WxH] [--fps N]\n"
    "                    [--from S --to S] [--overlays force,levels,coverage,marks,timeline] [--reveal]\n"
    "  Re-simulates SESSION from its recorded inputs and commands and checks every force\n"
    "  against the recorded one (exit 3 when they differ); with --video or --frames renders it.\n"
    "  --video OUT.mp4     write an MP4 (mp4v, OpenCV's FFmpeg backend)\n"
    "  --frames DIR        write PNG frames DIR/frame_000001.png ...\n"
    "  --size WxH          frame size in pixels (default 1280x720)\n"
    "  --fps N             frames per second of session time (default 30)\n"
    "  --from S, --to S    the part of the session to render, s from its start (default: all)\n"
    "  --overlays LIST     any of force,levels,coverage,marks,timeline (default: all); 'none' for none\n"
    "  --reveal            draw the scenario's hidden and after-exam lesions too\n"
    "  --gl auto|osmesa|egl  offscreen OpenGL (default auto)\n"
    "  --pipeline on|off   re-simulate, render and encode on three threads at once, drawing in two\n"
    "                      scenes in turn (default on), or one stage after the other on one thread\n"
    "                      in one scene; the frames are the same\n"
    "  --cull on|off       skip the organ's back faces when it is closed and oriented outward (default\n"
    "                      on; the same picture, less rasterising)\n"
    "  --damage on|off     redraw only the pixels that changed since a scene's last frame (default\n"
    "                      on; the same frames, less rasterising; with --translucency blend only)\n"
    "  --translucency blend|oit  translucent props (probe shafts, lesions, marks) by plain alpha\n"
    "                      blending (default) or VTK's order-independent translucency (slower)\n"
    "  --timings           print where the time went, per stage and per frame\n";

struct Options {
  std::string session, video, frames;
  int width = 1280, height = 720;
  double fps = 30;
  double from = 0, to = std::numeric_limits<double>::infinity();
  std::set<std::string> overlays{"force", "levels", "coverage", "marks", "timeline"};
  bool reveal = false;
  render::GlBackend gl = render::GlBackend::Auto;
  bool pipeline = true;
  bool cull = true;
  bool damage = true;
  bool timings = false;
  bool plain_blending = true;
};

double number(const std::string& opt, const std::string& s) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size() || !std::isfinite(v)) throw Usage(opt + ": expected a number, got '" + s + "'");
  return v;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw Usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    } else if (a == "--video") {
      o.video = value();
    } else if (a == "--frames") {
      o.frames = value();
    } else if (a == "--size") {
      const std::string v = value();
      int w = 0, h = 0;
      char x = 0, extra = 0;
      if (std::sscanf(v.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || x != 'x' || w < 64 || h < 64 || w > 7680 ||
          h > 4320)
        throw Usage("--size: expected WxH with 64 <= W <= 7680 and 64 <= H <= 4320, got '" + v + "'");
      o.width = w;
      o.height = h;
    } else if (a == "--fps") {
      o.fps = number(a, value());
      if (!(o.fps >= 1 && o.fps <= 240)) throw Usage("--fps: expected a rate in [1, 240], got " + std::string(argv[i]));
    } else if (a == "--from") {
      o.from = number(a, value());
      if (o.from < 0) throw Usage("--from: expected a time >= 0 s, got " + std::string(argv[i]));
    } else if (a == "--to") {
      o.to = number(a, value());
    } else if (a == "--overlays") {
      o.overlays.clear();
      std::stringstream ss(value());
      std::string item;
      while (std::getline(ss, item, ',')) {
        if (item == "none") continue;
        if (item != "force" && item != "levels" && item != "coverage" && item != "marks" && item != "timeline")
          throw Usage("--overlays: unknown overlay '" + item + "' (expected force, levels, coverage, marks, timeline)");
        o.overlays.insert(item);
      }
    } else if (a == "--reveal") {
      o.reveal = true;
    } else if (a == "--gl") {
      o.gl = render::parse_gl_backend(value());
    } else if (a == "--pipeline" || a == "--cull" || a == "--damage") {
      const std::string v = value();
      if (v != "on" && v != "off") throw Usage(a + ": expected on or off, got '" + v + "'");
      (a == "--pipeline" ? o.pipeline : a == "--cull" ? o.cull : o.damage) = v == "on";
    } else if (a == "--translucency") {
      const std::string v = value();
      if (v != "blend" && v != "oit") throw Usage("--translucency: expected blend or oit, got '" + v + "'");
      o.plain_blending = v == "blend";
    } else if (a == "--timings") {
      o.timings = true;
    } else if (!a.empty() && a[0] == '-') {
      throw Usage("unknown option '" + a + "'");
    } else if (o.session.empty()) {
      o.session = a;
    } else {
      throw Usage("one session at a time, got '" + a + "' too");
    }
  }
  if (o.session.empty()) throw Usage("no session file given");
  if (!(o.to > o.from)) throw Usage("--to must be after --from");
  return o;
}

void progress(double fraction, std::size_t frames, double speed) {
  const int width = 30;
  const int fill = static_cast<int>(width * std::clamp(fraction, 0.0, 1.0));
  std::fprintf(stderr, "\r[%.*s%*s] %3.0f%%  %zu frames  %.2fx real time ", fill, "##############################",
               width - fill, "", 100 * fraction, frames, speed);
  std::fflush(stderr);
}

// Wall time spent in a stage (s), and waiting on its queues.
struct Span {
  double s = 0;
};
struct Stage : Span {
  Span wait;
};

// Adds the time of its scope to a Span.
class Timer {
 public:
  explicit Timer(Span& span) : span_(span), t0_(Clock::now()) {}
  ~Timer() { span_.s += std::chrono::duration<double>(Clock::now() - t0_).count(); }
  Timer(const Timer&) = delete;
  Timer& operator=(const Timer&) = delete;

 private:
  Span& span_;
  Clock::time_point t0_;
};

// A blocking queue between two stages; close() wakes everyone, and pop()
// then answers false once it is empty.
template <class T>
class Queue {
 public:
  void push(T v) {
    {
      std::lock_guard<std::mutex> lock(m_);
      q_.push_back(std::move(v));
    }
    cv_.notify_one();
  }
  bool pop(T& v) {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return !q_.empty() || closed_; });
    if (q_.empty()) return false;
    v = std::move(q_.front());
    q_.pop_front();
    return true;
  }
  void close() {
    {
      std::lock_guard<std::mutex> lock(m_);
      closed_ = true;
    }
    cv_.notify_all();
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<T> q_;
  bool closed_ = false;
};

// Thrown inside the re-simulation stage when another stage failed.
struct Cancelled {};

// What one frame needs from the re-simulation: the probe poses, the stream
// entries that changed since the previous frame (never the whole state) and
// the overlays' inputs. Recycled, so its vectors keep their memory.
struct ProbePose {
  Vec3 world, axis, force;
  bool in_contact = false;
};
struct Packet {
  std::size_t index = 0;  // frame number from 0
  double now = 0;         // s from the session's start
  Eigen::Matrix4d organ_to_world = Eigen::Matrix4d::Identity();
  std::vector<ProbePose> probes;
  std::vector<IndexRange> dirty;  // changed vertices, sorted, disjoint
  std::vector<float> values;      // their (nx, ny, nz, h), 4 per vertex, range after range
  std::vector<std::string> level_lines;
  std::vector<std::deque<std::pair<double, double>>> force;
  std::vector<std::pair<double, double>> over_limit;
  std::shared_ptr<const cv::Mat> coverage_map;  // redrawn only when the coverage changed
};

// A rendered frame on its way to the encoder: RGBA, bottom row first.
struct FrameBuffer {
  std::vector<std::uint8_t> rgba;
  Packet* packet = nullptr;
};

// What the rendering stage draws with: an offscreen window (its own OpenGL
// context) and every prop in it. Each scene takes every packet's stream
// changes, so it is current whenever it draws. Its framebuffer keeps the
// last frame it drew; `pending` gathers the pixels that changed since then
// (the stream's changes of every packet, its own props' moves), which is all
// it redraws with --damage on.
struct SceneSet {
  SceneSet(int width, int height, render::GlBackend gl, const std::shared_ptr<const mesh::SurfaceMesh>& mesh)
      : scene(width, height, gl), view(mesh) {}
  render::OffscreenScene scene;
  render::SurfaceView view;  // its stream starts at rest (zeros), as a new session's surface
  std::vector<std::unique_ptr<render::EllipsoidView>> lesion_views, mark_views;
  std::vector<bool> mark_shown;
  std::vector<std::unique_ptr<render::ProbeView>> probes;
  render::PixelRect pending;
  bool whole = true;  // redraw every pixel next time (the first frame, the organ moved, the clipping range grew)
};

int run(const Options& o) {
  app::LoadedSession s = app::load_session(o.session);
  const record::SessionHeader& h = s.file.header();
  const double rate = h.config.rate_hz;
  std::printf("session %s: %s, %llu ticks (%.2f s at %.0f Hz), %zu probes, %llu dropped records\n", o.session.c_str(),
              std::string(record::status_name(h.status)).c_str(), static_cast<unsigned long long>(h.ticks),
              static_cast<double>(h.ticks) / rate, rate, h.setups.size(), static_cast<unsigned long long>(h.dropped));
  if (!s.scenario_title.empty()) std::printf("scenario: %s (%zu lesions)\n", s.scenario_title.c_str(), s.lesions.size());
  std::printf("recorded by %s\n", h.build.c_str());
  if (!s.file.same_layout()) std::printf("note: recorded by a build of another layout; the replay may differ\n");
  if (h.ticks == 0) {
    std::printf("nothing to replay\n");
    return 0;
  }
  const std::uint64_t first = s.first_tick;  // 0 unless recorded from a running loop (the workbench)
  const double t0 = s.file.ticks(first, first + 1).ticks.front().time;
  const double duration = static_cast<double>(h.ticks - 1) / rate;
  const bool render_frames = !o.video.empty() || !o.frames.empty();
  app::ForceCheck check;

  if (!render_frames) {
    const auto start = Clock::now();
    app::replay_session(s, first, first + h.ticks, nullptr, check);
    const double wall = std::chrono::duration<double>(Clock::now() - start).count();
    std::printf("replay: %s (%.2f s, %.1fx real time)\n", app::describe(check).c_str(), wall, duration / wall);
    return check.identical ? 0 : 3;
  }

  // What the scenes show (made below, on this thread, which owns their GL
  // contexts): the organ, the probes, the lesions to show, the marks.
  const double to = std::min(o.to, duration);
  const std::uint64_t from_tick = first + static_cast<std::uint64_t>(std::floor(o.from * rate));
  const std::uint64_t to_tick =
      std::min<std::uint64_t>(first + h.ticks, first + static_cast<std::uint64_t>(std::floor(to * rate)) + 1);
  const bool with_coverage = o.overlays.count("coverage") > 0;
  const bool with_levels = o.overlays.count("levels") > 0;
  const auto& mesh = s.model->mesh;
  const tissue::TissueField* field = s.model->field.get();
  const std::vector<record::EventRecord> events = s.file.events();
  std::vector<double> mark_times, mark_view_times, mark_view_ends;
  std::vector<Vec3> mark_view_points;
  std::vector<double> mark_radii;
  for (const auto& e : events) {
    if (e.kind == record::EventKind::Unmark && o.overlays.count("marks") > 0) {
      // The trainee deleted a mark: the latest standing one at that point leaves the picture.
      for (std::size_t m = mark_view_points.size(); m-- > 0;)
        if (mark_view_points[m] == haptics::to_vec(e.point) && mark_view_ends[m] > e.time - t0) {
          mark_view_ends[m] = e.time - t0;
          break;
        }
    }
    if (e.kind == record::EventKind::Mark) {
      mark_times.push_back(e.time - t0);
      if (o.overlays.count("marks") == 0) continue;
      mark_radii.push_back(std::max(0.002, 0.5 * e.value));
      mark_view_times.push_back(e.time - t0);
      mark_view_ends.push_back(std::numeric_limits<double>::infinity());
      mark_view_points.push_back(haptics::to_vec(e.point));
    }
  }
  const mesh::MeshFacts facts = mesh::analyse(*mesh);
  const double size = (facts.bbox_max - facts.bbox_min).norm();
  const std::size_t probe_count = h.setups.size();
  const Vec3 view_dir = Vec3(0, -std::sin(0.61), std::cos(0.61)).normalized();
  // A closed, outward surface seen from outside looks the same without its
  // back faces (each lies behind a front face).
  const bool cull = o.cull && facts.closed_outward();
  // Three threads: two scenes drawn in turn, so that one frame's geometry
  // (on this thread) overlaps the previous frame's rasterisation (on the
  // software renderer's threads); one stage after the other: one scene.
  std::vector<std::unique_ptr<SceneSet>> scenes;
  // A clipping range that does not follow the probes: a frame's pixels then
  // depend only on what is drawn, so a scene can redraw only what changed.
  // The organ's box with room for the probes' shafts and arrows; a prop that
  // leaves it grows it (and every scene redraws in full).
  std::array<double, 6> held_box{};
  for (int a = 0; a < 3; ++a) {
    held_box[2 * a] = facts.bbox_min[a] - 0.25 * size;
    held_box[2 * a + 1] = facts.bbox_max[a] + 0.25 * size;
  }
  for (int k = 0; k < (o.pipeline ? 2 : 1); ++k) {
    auto set = std::make_unique<SceneSet>(o.width, o.height, o.gl, mesh);
    set->scene.set_plain_blending(o.plain_blending);
    set->scene.add(set->view.actor());
    set->view.set_backface_culling(cull);
    for (const auto& l : s.lesions) {
      if (!(l.visibility == tissue::Visibility::Shown || o.reveal)) continue;
      set->lesion_views.push_back(std::make_unique<render::EllipsoidView>(l.centre, l.semi_axes));
      set->lesion_views.back()->add_to(set->scene.renderer());
    }
    for (std::size_t m = 0; m < mark_view_points.size(); ++m) {
      auto mv = std::make_unique<render::EllipsoidView>(mark_view_points[m], Vec3::Constant(mark_radii[m]));
      mv->set_color(1.0, 0.85, 0.1, 0.9);
      set->mark_views.push_back(std::move(mv));
    }
    set->mark_shown.assign(set->mark_views.size(), false);
    for (std::size_t j = 0; j < probe_count; ++j) {
      auto pv = std::make_unique<render::ProbeView>(0.008 * size, 0.15 * size);
      pv->set_force_scale(0.25 * size / std::max(s.force_limit > 0 ? s.force_limit : 8.0, 1e-9));
      pv->add_to(set->scene.renderer());
      set->probes.push_back(std::move(pv));
    }
    set->scene.look_at(set->view.bounds(), view_dir, Vec3::UnitZ());
    set->scene.hold_clipping_range(held_box);
    scenes.push_back(std::move(set));
  }
  // Redrawing only what changed keeps every pass inside a scissor, which
  // VTK's order-independent translucency (full-frame passes) is not made for.
  const bool damage = o.damage && o.plain_blending;
  const render::PixelProjection projection = scenes[0]->scene.projection();
  const render::PixelRect whole_frame{0, 0, o.width, o.height};
  const int damage_margin = 2;  // pixels around the projected corners (float rounding on the GPU)
  Eigen::Matrix4d taken_transform = Eigen::Matrix4d::Identity();
  std::printf("rendering %dx%d at %.0f fps with %s (%s)%s\n", o.width, o.height, o.fps,
              std::string(render::gl_backend_name(scenes[0]->scene.window().backend())).c_str(),
              scenes[0]->scene.window().gl_renderer().c_str(),
              o.pipeline ? ", two scenes in turn" : ", one stage at a time");

  // Outputs.
  cv::VideoWriter writer;
  if (!o.video.empty()) {
    writer.open(o.video, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), o.fps, cv::Size(o.width, o.height), true);
    if (!writer.isOpened())
      throw std::runtime_error(o.video + ": cannot write an MP4 (mp4v) with this OpenCV; try --frames DIR");
  }
  if (!o.frames.empty()) std::filesystem::create_directories(o.frames);

  // State the overlays follow (the re-simulation stage's own).
  std::unique_ptr<assess::Coverage> coverage;
  std::unique_ptr<app::CoverageMap> coverage_map;
  const int map_side = std::min(o.width, o.height) / 3;
  // The levels need the thickness the coverage computes; the map needs every
  // tick. Made by the re-simulation stage when it starts (its rays through
  // the organ then overlap the rendering stage's first frame).
  auto make_coverage = [&] {
    if (with_coverage || with_levels) coverage = std::make_unique<assess::Coverage>(mesh, s.tip_radius, s.model->tree);
    if (with_coverage) coverage_map = std::make_unique<app::CoverageMap>(*mesh, view_dir, Vec3::UnitZ(), map_side);
  };
  std::shared_ptr<const cv::Mat> map_image;
  std::vector<std::uint32_t> episode(probe_count, 0);
  std::vector<bool> was_in(probe_count, false);
  std::uint32_t next_episode = 0;
  std::vector<std::deque<std::pair<double, double>>> force(probe_count);
  std::vector<std::pair<double, double>> over_limit;
  std::vector<Vec3> axis(probe_count, Vec3::UnitZ());
  std::vector<double> snapshot_times;
  for (const auto& snap : s.file.snapshots()) snapshot_times.push_back(static_cast<double>(snap.tick - first) / rate);
  const std::size_t n = mesh->vertex_count();
  std::vector<float> sent(4 * n, 0.0f);  // the stream as the last packet left it (the view's starts at rest)

  const std::size_t pool = o.pipeline ? 4 : 1;
  std::vector<Packet> packets(pool);
  std::vector<FrameBuffer> buffers(pool);
  Stage warm_stage, sim_stage, pack_stage, upload_stage, render_stage, finish_stage, read_stage, convert_stage, overlay_stage,
      encode_stage;
  Queue<Packet*> free_packets, to_render;
  Queue<FrameBuffer*> free_buffers, to_encode;
  for (auto& p : packets) free_packets.push(&p);
  for (auto& b : buffers) free_buffers.push(&b);

  std::size_t frames = 0;
  double next_frame = o.from;
  const auto start = Clock::now();
  const std::uint64_t replay_from = with_coverage ? first : from_tick;  // coverage needs every tick before the window
  const int strip_h = std::max(80, o.height / 6), bar_h = 22;
  cv::Mat frame(o.height, o.width, CV_8UC3);  // the encoding stage's frame, reused
  std::vector<float> mirror(4 * n, 0.0f);     // the rendering stage's copy of the stream

  // Stage 1 (re-simulation): a packet per frame with only what changed.
  auto fill = [&](Packet& p, const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r,
                  const deform::DeformableSurface& surface, double now) {
    p.index = frames++;
    p.now = now;
    p.organ_to_world = field ? field->organ_to_world(t.time) : Eigen::Matrix4d::Identity();
    p.probes.resize(r.size());
    p.level_lines.clear();
    for (std::size_t j = 0; j < r.size(); ++j) {
      p.probes[j] = {haptics::to_vec(r[j].world), axis[j], haptics::to_vec(r[j].force_world), r[j].in_contact != 0};
      if (with_levels) {
        const double th = coverage->thickness()[coverage->nearest(haptics::to_vec(r[j].contact_point))];
        const auto level = assess::level_of(r[j].depth, th, r[j].in_contact != 0);
        p.level_lines.push_back(cv::format("probe %zu: %s, depth %.1f mm, %.2f N", j + 1, assess::level_name(level),
                                           1e3 * (r[j].in_contact ? r[j].depth : 0.0),
                                           haptics::to_vec(r[j].force_world).norm()));
      }
    }
    // The stream entries that changed since the last packet, as ranges.
    p.dirty.clear();
    p.values.clear();
    const std::span<const float> st = surface.stream();
    for (std::size_t i = 0; i < n;) {
      if (std::memcmp(&st[4 * i], &sent[4 * i], 4 * sizeof(float)) == 0) {
        ++i;
        continue;
      }
      const std::size_t b = i;
      while (i < n && std::memcmp(&st[4 * i], &sent[4 * i], 4 * sizeof(float)) != 0) ++i;
      std::memcpy(&sent[4 * b], &st[4 * b], 4 * sizeof(float) * (i - b));
      p.values.insert(p.values.end(), st.begin() + 4 * b, st.begin() + 4 * i);
      p.dirty.push_back({static_cast<Index>(b), static_cast<Index>(i)});
    }
    // The overlays' inputs.
    p.force = force;
    p.over_limit = over_limit;
    if (coverage_map) {
      // A copy per change: packets in flight keep the map they were made with.
      if (coverage_map->update(*coverage) || !map_image)
        map_image = std::make_shared<const cv::Mat>(coverage_map->image().clone());
      p.coverage_map = map_image;
    }
  };

  // Stage 2 (rendering, this thread): take the packet's stream changes (every
  // scene), draw it in one scene (submitted: a software renderer rasterises
  // on its own threads after this returns), and later read that scene back.
  //
  // The pixels the stream's changes touch: a triangle's pixels lie within
  // its corners' projections, and a changed vertex (its h, its normal
  // correction) changes only the triangles around it; so the changed
  // vertices where they were and where they are, and their neighbours.
  const mesh::SurfaceMesh& organ = *mesh;
  auto drawn_at = [&](std::size_t v, const Eigen::Matrix4d& to_world) {
    const Vec3 q = organ.positions[v] + static_cast<double>(mirror[4 * v + 3]) * organ.normals[v];
    return Vec3(to_world.topLeftCorner<3, 3>() * q + to_world.topRightCorner<3, 1>());
  };
  auto take = [&](const Packet& p) {
    Timer tm(upload_stage);
    const bool moved = p.organ_to_world != taken_transform;
    taken_transform = p.organ_to_world;
    render::PixelProjection::Cover cover(projection);
    if (damage && !moved)
      for (const IndexRange& r : p.dirty)
        for (Index v = r.begin; v < r.end; ++v) cover.add(drawn_at(v, p.organ_to_world));
    std::size_t k = 0;
    for (const IndexRange& r : p.dirty) {
      const std::size_t len = 4 * std::size_t{r.end - r.begin};
      std::memcpy(&mirror[4 * std::size_t{r.begin}], &p.values[k], len * sizeof(float));
      k += len;
    }
    if (damage && !moved)
      for (const IndexRange& r : p.dirty)
        for (Index v = r.begin; v < r.end; ++v) {
          cover.add(drawn_at(v, p.organ_to_world));
          for (const Index u : organ.vertex_neighbors.row(v)) cover.add(drawn_at(u, p.organ_to_world));
        }
    const render::PixelRect changed = cover.rect(damage_margin);
    for (auto& set : scenes) {
      set->view.update(mirror, p.dirty);
      if (moved || cover.whole())
        set->whole = true;
      else
        set->pending.unite(changed);
    }
  };
  auto submit = [&](const Packet& p, SceneSet& set) {
    {
      Timer tm(upload_stage);
      // The props that change add where they were and where they are.
      render::PixelProjection::Cover cover(projection);
      set.view.set_transform(p.organ_to_world);
      for (auto& lv : set.lesion_views) lv->set_transform(p.organ_to_world);
      for (std::size_t m = 0; m < set.mark_views.size(); ++m) {
        const bool standing = mark_view_times[m] <= p.now && p.now < mark_view_ends[m];
        if (standing && !set.mark_shown[m]) {
          set.mark_views[m]->set_transform(p.organ_to_world);
          set.mark_views[m]->add_to(set.scene.renderer());
          set.mark_shown[m] = true;
          cover.add_box(set.mark_views[m]->bounds());
        } else if (!standing && set.mark_shown[m]) {
          cover.add_box(set.mark_views[m]->bounds());
          set.mark_views[m]->remove_from(set.scene.renderer());
          set.mark_shown[m] = false;
        }
      }
      for (std::size_t j = 0; j < p.probes.size() && j < set.probes.size(); ++j) {
        const std::array<double, 6> before = set.probes[j]->bounds();
        if (set.probes[j]->set_state(p.probes[j].world, p.probes[j].axis, p.probes[j].force, p.probes[j].in_contact,
                                     j == 0)) {
          cover.add_box(before);
          cover.add_box(set.probes[j]->bounds());
        }
      }
      if (cover.whole())
        set.whole = true;
      else
        set.pending.unite(cover.rect(damage_margin));
    }
    Timer tm(render_stage);
    if (set.scene.take_in_visible_props()) {
      // The clipping range grew (a prop left its box): every scene takes the
      // new one and redraws in full, as one scene drawing every frame would.
      set.whole = true;
      for (auto& other : scenes)
        if (other.get() != &set) {
          other->scene.hold_clipping_range(set.scene.clipping_box());
          other->whole = true;
        }
    }
    const bool whole = set.whole || !damage;
    if (whole)
      set.view.draw_all();
    else
      set.view.draw_only_near(projection, set.pending);
    set.scene.render(whole ? whole_frame : set.pending);
    set.pending = {};
    set.whole = false;
    set.scene.window().flush();
  };
  auto read = [&](SceneSet& set, Packet& p, FrameBuffer& b) {
    {
      Timer tm(finish_stage);
      set.scene.window().finish();
    }
    Timer tm(read_stage);
    b.rgba.resize(std::size_t{4} * o.width * o.height);
    set.scene.window().read_rgba(b.rgba);
    b.packet = &p;
  };

  // Stage 3 (encoding): the frame top row first in BGR, the overlays, the outputs.
  auto encode = [&](FrameBuffer& b) {
    const Packet& p = *b.packet;
    {
      Timer tm(convert_stage);
      for (int y = 0; y < o.height; ++y) {
        const cv::Mat src(1, o.width, CV_8UC4, b.rgba.data() + std::size_t{4} * o.width * (o.height - 1 - y));
        cv::Mat dst = frame.row(y);
        cv::cvtColor(src, dst, cv::COLOR_RGBA2BGR);
      }
    }
    {
      Timer tm(overlay_stage);
      if (o.overlays.count("force"))
        app::draw_force_strip(frame, cv::Rect(0, o.height - strip_h - bar_h, o.width, strip_h), p.force, p.now, 5.0,
                              s.force_limit);
      if (o.overlays.count("timeline"))
        app::draw_timeline(frame, cv::Rect(0, o.height - bar_h, o.width, bar_h), p.now, duration, o.from, to,
                           snapshot_times, mark_times, p.over_limit);
      if (with_levels) app::draw_text_block(frame, p.level_lines, {16, 28});
      if (p.coverage_map) {
        const int side = map_side;
        p.coverage_map->copyTo(frame(cv::Rect(o.width - side - 10, 10, side, side)));
        cv::putText(frame, "coverage", {o.width - side - 4, 26}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {230, 230, 230}, 1,
                    cv::LINE_AA);
      }
    }
    Timer tm(encode_stage);
    if (writer.isOpened()) writer.write(frame);
    if (!o.frames.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%06zu.png", p.index + 1);
      const auto path = std::filesystem::path(o.frames) / name;
      if (!cv::imwrite(path.string(), frame)) throw std::runtime_error(path.string() + ": cannot write");
    }
    const double wall = std::chrono::duration<double>(Clock::now() - start).count();
    progress((p.now - o.from) / std::max(1e-9, to - o.from), p.index + 1, wall > 0 ? (p.now - o.from) / wall : 0);
  };

  auto each = [&](const haptics::TickRecord& t, std::span<const haptics::ProbeTickResult> r,
                  const deform::DeformableSurface& surface) {
    const double now = t.time - t0;
    bool over = false;
    for (std::size_t j = 0; j < r.size(); ++j) {
      const double f = haptics::to_vec(r[j].force_world).norm();
      over = over || (s.force_limit > 0 && f > s.force_limit);
      if (r[j].in_contact) axis[j] = haptics::to_vec(r[j].contact_normal);
      if (coverage_map && r[j].in_contact && r[j].depth > 0) {
        if (!was_in[j]) episode[j] = next_episode++;
        coverage->add(haptics::to_vec(r[j].contact_point), r[j].depth, episode[j]);
      }
      was_in[j] = r[j].in_contact != 0;
      if (t.tick >= from_tick && t.tick % std::max<std::uint64_t>(1, static_cast<std::uint64_t>(rate / 200)) == 0) {
        force[j].emplace_back(now, f);
        while (!force[j].empty() && now - force[j].front().first > 5.0) force[j].pop_front();
      }
    }
    if (over) {
      if (!over_limit.empty() && now - over_limit.back().second < 2.0 / rate)
        over_limit.back().second = now;
      else
        over_limit.emplace_back(now, now);
    }
    if (t.tick < from_tick || now + 0.5 / rate < next_frame) return;
    next_frame += 1.0 / o.fps;
    Packet* p = nullptr;
    {
      Timer tm(sim_stage.wait);
      if (!free_packets.pop(p)) throw Cancelled();
    }
    {
      Timer tm(pack_stage);
      fill(*p, t, r, surface, now);
    }
    if (o.pipeline) {
      to_render.push(p);
      return;
    }
    // One stage after the other on this thread (--pipeline off).
    FrameBuffer* b = nullptr;
    free_buffers.pop(b);
    take(*p);
    submit(*p, *scenes[0]);
    read(*scenes[0], *p, *b);
    encode(*b);
    free_packets.push(p);
    free_buffers.push(b);
  };

  if (!o.pipeline) {
    Timer tm(sim_stage);
    make_coverage();
    app::replay_session(s, replay_from, to_tick, each, check);
  } else {
    // Three threads: re-simulation ahead of rendering (this thread: the GL
    // context is current here) ahead of encoding, with bounded queues of
    // recycled packets and frame buffers between them. An error in any
    // stage closes every queue so the others stop, and is rethrown here.
    std::exception_ptr error;
    std::mutex error_mutex;
    auto fail = [&](std::exception_ptr e) {
      {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = e;
      }
      free_packets.close();
      to_render.close();
      free_buffers.close();
      to_encode.close();
    };
    std::thread simulate([&] {
      pthread_setname_np(pthread_self(), "replay-sim");
      try {
        Timer tm(sim_stage);
        make_coverage();
        app::replay_session(s, replay_from, to_tick, each, check);
      } catch (const Cancelled&) {
      } catch (...) {
        fail(std::current_exception());
      }
      to_render.close();
    });
    std::thread encoding([&] {
      pthread_setname_np(pthread_self(), "replay-encode");
      try {
        FrameBuffer* b = nullptr;
        for (;;) {
          {
            Timer tm(encode_stage.wait);
            if (!to_encode.pop(b)) break;
          }
          encode(*b);
          free_packets.push(b->packet);
          free_buffers.push(b);
        }
      } catch (...) {
        fail(std::current_exception());
      }
    });
    try {
      // While the re-simulation makes its first packet (the coverage's rays
      // through the organ), each scene draws once: the software renderer
      // compiles its shaders then, not in the first frames.
      for (auto& set : scenes) {
        Timer tm(warm_stage);
        set->scene.render();
        set->scene.window().finish();
        // The probes had no pose yet: the range they grew is not the one the
        // frames are drawn with (one stage at a time there is no such draw).
        set->scene.hold_clipping_range(held_box);
        set->whole = true;
      }
      // Frame n is drawn in scene n % 2 and read back after frame n + 1 was
      // submitted in the other scene.
      Packet* p = nullptr;
      FrameBuffer* b = nullptr;
      Packet* drawn = nullptr;
      FrameBuffer* drawn_buffer = nullptr;
      SceneSet* drawn_scene = nullptr;
      std::size_t turn = 0;
      for (;;) {
        {
          Timer tm(render_stage.wait);
          if (!to_render.pop(p)) break;
          if (!free_buffers.pop(b)) break;
        }
        take(*p);
        SceneSet& set = *scenes[turn++ % scenes.size()];
        submit(*p, set);
        if (drawn) {
          read(*drawn_scene, *drawn, *drawn_buffer);
          to_encode.push(drawn_buffer);
        }
        drawn = p;
        drawn_buffer = b;
        drawn_scene = &set;
      }
      if (drawn) {
        read(*drawn_scene, *drawn, *drawn_buffer);
        to_encode.push(drawn_buffer);
      }
    } catch (...) {
      fail(std::current_exception());
    }
    to_encode.close();
    simulate.join();
    encoding.join();
    if (error) std::rethrow_exception(error);
  }
  writer.release();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  const double covered = to - o.from;
  std::fprintf(stderr, "\n");
  std::string where;
  if (!o.video.empty()) where += " to " + o.video;
  if (!o.frames.empty()) where += (where.empty() ? " to " : " and ") + o.frames;
  std::printf("wrote %zu frames%s in %.1f s: %.2f frames/s, %.2fx real time (%.1f s of session)\n", frames,
              where.c_str(), wall, frames / wall, covered / wall, covered);
  // The re-simulation alone: its stage's time less packing, waiting and (one
  // thread) the other stages run inside it.
  const double other = o.pipeline ? 0.0
                                   : upload_stage.s + render_stage.s + finish_stage.s + read_stage.s + convert_stage.s +
                                         overlay_stage.s + encode_stage.s;
  const double sim_only = sim_stage.s - pack_stage.s - sim_stage.wait.s - other;
  if (frames > 0) {
    const double f = 1e3 / static_cast<double>(frames);
    std::printf("per frame: render and read back %.1f ms, overlays %.1f ms, encode and write %.1f ms; "
                "re-simulation (%llu ticks) %.1f s\n",
                f * (render_stage.s + finish_stage.s + read_stage.s), f * (convert_stage.s + overlay_stage.s),
                f * encode_stage.s, static_cast<unsigned long long>(check.ticks), sim_only);
  }
  if (o.timings && frames > 0) {
    const double f = 1e3 / static_cast<double>(frames);
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    const double cpu = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                       1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
    std::printf("timings (ms per frame, %zu frames; %s):\n", frames,
                o.pipeline ? "three threads: re-simulation | rendering | encoding" : "one thread, stage after stage");
    std::printf("  re-simulation: ticks and deformation steps %.1f, packet (stream changes, overlay inputs) %.1f, "
                "waiting for a free packet %.1f\n",
                f * sim_only, f * pack_stage.s, f * sim_stage.wait.s);
    std::printf("  rendering: upload and scene %.1f, render (submit) %.1f, render (finish) %.1f, read back "
                "%.1f, waiting %.1f",
                f * upload_stage.s, f * render_stage.s, f * finish_stage.s, f * read_stage.s, f * render_stage.wait.s);
    // The scenes' first draw (shader compilation) is a stage of its own only
    // when pipelined; one stage at a time it is in the first frame's render.
    if (o.pipeline)
      std::printf("; first draw of the scenes %.0f ms in all\n", 1e3 * warm_stage.s);
    else
      std::printf("\n");
    std::printf("  encoding: RGBA to BGR %.1f, overlays %.1f, encode and write %.1f, waiting %.1f\n",
                f * convert_stage.s, f * overlay_stage.s, f * encode_stage.s, f * encode_stage.wait.s);
    std::printf("  process: %.2f s CPU over %.2f s wall since start (%.2f s before the first tick: loading, scene)\n",
                cpu, std::chrono::duration<double>(Clock::now() - process_start).count(),
                std::chrono::duration<double>(start - process_start).count());
  }
  std::printf("replay: %s\n", app::describe(check).c_str());
  return check.identical ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  // Mesa's software renderer frees and allocates its buffers every frame:
  // keep the freed heap in the process (render/heap.h).
  palpa::render::keep_freed_heap();
  Options o;
  try {
    o = parse(argc, argv);
  } catch (const Usage& e) {
    std::fprintf(stderr, "palpa-replay: %s\n%s", e.what(), kUsage);
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpa-replay: %s\n", e.what());
    return 2;
  }
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\npalpa-replay: %s\n", e.what());
    return 1;
  }
}
