// palpa-replay SESSION: re-simulates a recorded session from its inputs and
// commands, checks the forces against the recorded ones, and (with --video
// or --frames) renders it offscreen with overlays into an MP4 (OpenCV's
// VideoWriter, mp4v) or PNG frames. No display needed.

#include "app/replay/overlay.h"
#include "app/replay/session_job.h"
#include "assess/coverage.h"
#include "render/lesion_view.h"
#include "render/offscreen.h"
#include "render/probe_view.h"
#include "render/scene.h"
#include "render/surface_view.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace palpa;
using Clock = std::chrono::steady_clock;

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
    "  --gl auto|osmesa|egl  offscreen OpenGL (default auto)\n";

struct Options {
  std::string session, video, frames;
  int width = 1280, height = 720;
  double fps = 30;
  double from = 0, to = std::numeric_limits<double>::infinity();
  std::set<std::string> overlays{"force", "levels", "coverage", "marks", "timeline"};
  bool reveal = false;
  render::GlBackend gl = render::GlBackend::Auto;
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

  // The scene: the organ, the probes, the lesions to show, the marks.
  const double to = std::min(o.to, duration);
  const std::uint64_t from_tick = first + static_cast<std::uint64_t>(std::floor(o.from * rate));
  const std::uint64_t to_tick =
      std::min<std::uint64_t>(first + h.ticks, first + static_cast<std::uint64_t>(std::floor(to * rate)) + 1);
  const bool with_coverage = o.overlays.count("coverage") > 0;
  render::OffscreenScene scene(o.width, o.height, o.gl);
  std::printf("rendering %dx%d at %.0f fps with %s (%s)\n", o.width, o.height, o.fps,
              std::string(render::gl_backend_name(scene.window().backend())).c_str(),
              scene.window().gl_renderer().c_str());
  const auto& mesh = s.model->mesh;
  render::SurfaceView view(mesh);
  scene.add(view.actor());
  const tissue::TissueField* field = s.model->field.get();
  std::vector<std::unique_ptr<render::EllipsoidView>> lesion_views;
  for (const auto& l : s.lesions) {
    if (!(l.visibility == tissue::Visibility::Shown || o.reveal)) continue;
    lesion_views.push_back(std::make_unique<render::EllipsoidView>(l.centre, l.semi_axes));
    lesion_views.back()->add_to(scene.renderer());
  }
  const std::vector<record::EventRecord> events = s.file.events();
  std::vector<std::unique_ptr<render::EllipsoidView>> mark_views;
  std::vector<double> mark_times;
  for (const auto& e : events)
    if (e.kind == record::EventKind::Mark) {
      mark_times.push_back(e.time - t0);
      if (o.overlays.count("marks") == 0) continue;
      const double r = std::max(0.002, 0.5 * e.value);
      auto mv = std::make_unique<render::EllipsoidView>(haptics::to_vec(e.point), Vec3::Constant(r));
      mv->set_color(1.0, 0.85, 0.1, 0.9);
      mark_views.push_back(std::move(mv));
    }
  std::vector<bool> mark_shown(mark_views.size(), false);
  Vec3 lo = mesh->positions[0], hi = lo;
  for (const Vec3& p : mesh->positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double size = (hi - lo).norm();
  std::vector<std::unique_ptr<render::ProbeView>> probes;
  for (std::size_t j = 0; j < h.setups.size(); ++j) {
    auto pv = std::make_unique<render::ProbeView>(0.008 * size, 0.15 * size);
    pv->set_force_scale(0.25 * size / std::max(s.force_limit > 0 ? s.force_limit : 8.0, 1e-9));
    pv->add_to(scene.renderer());
    probes.push_back(std::move(pv));
  }
  const Vec3 view_dir = Vec3(0, -std::sin(0.61), std::cos(0.61)).normalized();
  view.update_all(haptics::Session(s.model, s.initial, h.setups).surface().stream());
  scene.look_at(view.bounds(), view_dir, Vec3::UnitZ());

  // Outputs.
  cv::VideoWriter writer;
  if (!o.video.empty()) {
    writer.open(o.video, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), o.fps, cv::Size(o.width, o.height), true);
    if (!writer.isOpened())
      throw std::runtime_error(o.video + ": cannot write an MP4 (mp4v) with this OpenCV; try --frames DIR");
  }
  if (!o.frames.empty()) std::filesystem::create_directories(o.frames);

  // State the overlays follow.
  std::unique_ptr<assess::Coverage> coverage;
  std::unique_ptr<app::CoverageMap> coverage_map;
  const int map_side = std::min(o.width, o.height) / 3;
  // The levels need the thickness the coverage computes; the map needs every tick.
  if (with_coverage || o.overlays.count("levels"))
    coverage = std::make_unique<assess::Coverage>(mesh, s.tip_radius, s.model->tree);
  if (with_coverage) coverage_map = std::make_unique<app::CoverageMap>(*mesh, view_dir, Vec3::UnitZ(), map_side);
  std::vector<std::uint32_t> episode(h.setups.size(), 0);
  std::vector<bool> was_in(h.setups.size(), false);
  std::uint32_t next_episode = 0;
  std::vector<std::deque<std::pair<double, double>>> force(h.setups.size());
  std::vector<std::pair<double, double>> over_limit;
  std::vector<Vec3> axis(h.setups.size(), Vec3::UnitZ());
  std::vector<double> snapshot_times;
  for (const auto& snap : s.file.snapshots()) snapshot_times.push_back(static_cast<double>(snap.tick - first) / rate);

  std::size_t frames = 0;
  double next_frame = o.from;
  double render_s = 0, overlay_s = 0, write_s = 0;  // wall time per part, s
  const auto start = Clock::now();
  const std::uint64_t replay_from = with_coverage ? first : from_tick;  // coverage needs every tick before the window
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

    // The 3D frame.
    const Eigen::Matrix4d X = field ? field->organ_to_world(t.time) : Eigen::Matrix4d::Identity();
    view.update_all(surface.stream());
    view.set_transform(X);
    for (auto& lv : lesion_views) lv->set_transform(X);
    for (std::size_t k = 0; k < mark_views.size(); ++k)
      if (!mark_shown[k] && mark_times[k] <= now) {
        mark_views[k]->set_transform(X);
        mark_views[k]->add_to(scene.renderer());
        mark_shown[k] = true;
      }
    for (std::size_t j = 0; j < r.size() && j < probes.size(); ++j)
      probes[j]->set_state(haptics::to_vec(r[j].world), axis[j], haptics::to_vec(r[j].force_world), r[j].in_contact != 0,
                           j == 0);
    const auto c0 = Clock::now();
    const render::Image img = scene.render_image();
    const auto c1 = Clock::now();
    render_s += std::chrono::duration<double>(c1 - c0).count();
    cv::Mat frame;
    cv::cvtColor(cv::Mat(img.height, img.width, CV_8UC3, const_cast<std::uint8_t*>(img.rgb.data())), frame,
                 cv::COLOR_RGB2BGR);

    // The overlays.
    const int strip_h = std::max(80, o.height / 6), bar_h = 22;
    if (o.overlays.count("force"))
      app::draw_force_strip(frame, cv::Rect(0, o.height - strip_h - bar_h, o.width, strip_h), force, now, 5.0,
                            s.force_limit);
    if (o.overlays.count("timeline"))
      app::draw_timeline(frame, cv::Rect(0, o.height - bar_h, o.width, bar_h), now, duration, o.from, to,
                         snapshot_times, mark_times, over_limit);
    if (o.overlays.count("levels")) {
      std::vector<std::string> lines;
      for (std::size_t j = 0; j < r.size(); ++j) {
        const double th = coverage ? coverage->thickness()[coverage->nearest(haptics::to_vec(r[j].contact_point))] : 0;
        const auto level = assess::level_of(r[j].depth, th, r[j].in_contact != 0);
        lines.push_back(cv::format("probe %zu: %s, depth %.1f mm, %.2f N", j + 1, assess::level_name(level),
                                   1e3 * (r[j].in_contact ? r[j].depth : 0.0), haptics::to_vec(r[j].force_world).norm()));
      }
      app::draw_text_block(frame, lines, {16, 28});
    }
    if (coverage_map) {
      const int side = map_side;
      cv::Mat map = coverage_map->draw(*coverage);
      map.copyTo(frame(cv::Rect(o.width - side - 10, 10, side, side)));
      cv::putText(frame, "coverage", {o.width - side - 4, 26}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {230, 230, 230}, 1,
                  cv::LINE_AA);
    }
    const auto c2 = Clock::now();
    overlay_s += std::chrono::duration<double>(c2 - c1).count();
    if (writer.isOpened()) writer.write(frame);
    if (!o.frames.empty()) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%06zu.png", frames + 1);
      const auto path = std::filesystem::path(o.frames) / name;
      if (!cv::imwrite(path.string(), frame)) throw std::runtime_error(path.string() + ": cannot write");
    }
    write_s += std::chrono::duration<double>(Clock::now() - c2).count();
    ++frames;
    const double wall = std::chrono::duration<double>(Clock::now() - start).count();
    progress((now - o.from) / std::max(1e-9, to - o.from), frames, wall > 0 ? (now - o.from) / wall : 0);
  };
  app::replay_session(s, replay_from, to_tick, each, check);
  writer.release();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  const double covered = to - o.from;
  std::fprintf(stderr, "\n");
  std::string where;
  if (!o.video.empty()) where += " to " + o.video;
  if (!o.frames.empty()) where += (where.empty() ? " to " : " and ") + o.frames;
  std::printf("wrote %zu frames%s in %.1f s: %.2f frames/s, %.2fx real time (%.1f s of session)\n", frames,
              where.c_str(), wall, frames / wall, covered / wall, covered);
  if (frames > 0)
    std::printf("per frame: render and read back %.1f ms, overlays %.1f ms, encode and write %.1f ms; the rest "
                "(re-simulation, %llu ticks) %.1f s\n",
                1e3 * render_s / frames, 1e3 * overlay_s / frames, 1e3 * write_s / frames,
                static_cast<unsigned long long>(check.ticks), wall - render_s - overlay_s - write_s);
  std::printf("replay: %s\n", app::describe(check).c_str());
  return check.identical ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
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
