// The headless render job: organ, probes, settling, offscreen picture.

#include "app/render/render_job.h"

#include "collision/contact.h"
#include "collision/vertex_tree.h"
#include "deform/surface.h"
#include "haptics/session.h"
#include "scenario/resolve.h"
#include "render/lesion_view.h"
#include "render/probe_view.h"
#include "render/scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace palpa::app {

// What the job uses of mesh/ and render/, by its short names.
using mesh::load_default_organ;
using mesh::load_organ;
using mesh::Organ;
using mesh::parse_mesh_unit;
using render::gl_backend_name;
using render::GlBackend;
using render::Image;
using render::OffscreenScene;
using render::parse_gl_backend;
using render::ProbeView;
using render::RenderError;
using render::SurfaceView;
using render::UploadPath;
using render::write_png;

namespace {

// Parses "a,b,c,..." into exactly n finite numbers.
std::optional<std::vector<double>> numbers(const std::string& s, std::size_t n) {
  std::vector<double> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const double x = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(x)) return std::nullopt;
    v.push_back(x);
  }
  if (v.size() != n || (!s.empty() && s.back() == ',')) return std::nullopt;
  return v;
}

std::string shortest(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// One finite number in [lo, hi]; refused (never clamped) outside it, naming the range and unit.
double in_range(const std::string& option, const std::string& value, double lo, double hi, const char* unit) {
  auto v = numbers(value, 1);
  if (!v || !((*v)[0] >= lo && (*v)[0] <= hi))
    throw RenderError(option + ": expected a number in " + shortest(lo) + " .. " + shortest(hi) + unit + ", got '" +
                      value + "'");
  return (*v)[0];
}

// Where a probe may point: within this distance of the origin on each axis, m,
// and pressing at most this deep, m (a huge coordinate gave a wrong depth).
constexpr double kMaxProbeCoordinate = 10.0;
constexpr double kMaxProbeDepth = 0.1;

}  // namespace

std::string render_usage(const std::string& program) {
  return "usage: " + program +
         " [options]\n"
         "Renders an organ pressed by probes to a PNG, with no display.\n"
         "  --mesh FILE            organ mesh (default: the bundled default organ)\n"
         "  --unit auto|m|cm|mm    unit of the mesh file (default auto)\n"
         "  --probe X,Y,Z,DEPTH    press DEPTH m (0 .. 0.1) into the surface point nearest (X,Y,Z) m\n"
         "                         (|X|, |Y|, |Z| <= 10; repeatable, at most 8; default: one probe\n"
         "                         0.006 m into the organ's highest point)\n"
         "  --output FILE.png      picture to write (default palpa-render.png)\n"
         "  --size WxH             pixels (default 960x720)\n"
         "  --gl auto|osmesa|egl   OpenGL backend (default auto: EGL on a GPU, else OSMesa)\n"
         "  --path partial|vtk|cpu stream upload path (default partial)\n"
         "  --settle SECONDS       simulated time before the picture, 0.001 .. 60 (default 1)\n"
         "  --scenario FILE        a scenario: its organ, tissues, lesions, pulse and breathing\n"
         "  --reveal               also draw the scenario's hidden and after-exam lesions and the force\n"
         "                         arrows (debriefing; without it a scenario's picture shows no force)\n"
         "  --stiffness N_PER_M    vertex stiffness, 0.001 .. 1e+06 (default 200)\n"
         "  --damping NS_PER_M     vertex damping, 1e-06 .. 10000 (default 2)\n"
         "  --mass KG              vertex mass, 1e-09 .. 10 (default 0.001)\n"
         "  --model linear|exponential|viscoelastic  local model (default linear)\n"
         "  --shape gaussian|wendland|volume        shape function (default wendland)\n"
         "  --radius M             shape-function support radius, 0.0001 .. 0.5 (default 0.025)\n"
         "  --view X,Y,Z           direction from the organ to the eye (default: along the first probe)\n"
         "  --help                 this text\n"
         "Every number outside its range is refused (never clamped).\n";
}

RenderJobOptions parse_render_args(const std::vector<std::string>& args, bool* help) {
  RenderJobOptions o;
  if (help) *help = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw RenderError(a + ": needs a value");
      return args[++i];
    };
    if (a == "--help" || a == "-h") {
      if (help) *help = true;
    } else if (a == "--mesh") {
      o.mesh = value();
    } else if (a == "--scenario") {
      o.scenario = value();
    } else if (a == "--reveal") {
      o.reveal = true;
    } else if (a == "--unit") {
      const std::string& v = value();
      try {
        o.unit = parse_mesh_unit(v);
      } catch (const std::invalid_argument& e) {
        throw RenderError("--unit: " + std::string(e.what()));
      }
    } else if (a == "--probe") {
      const std::string& v = value();
      auto n = numbers(v, 4);
      bool ok = n && (*n)[3] >= 0 && (*n)[3] <= kMaxProbeDepth;
      for (int k = 0; ok && k < 3; ++k) ok = std::abs((*n)[k]) <= kMaxProbeCoordinate;
      if (!ok)
        throw RenderError("--probe: expected X,Y,Z,DEPTH in metres with |X|, |Y|, |Z| <= 10 and DEPTH 0 .. 0.1, got '" +
                          v + "'");
      o.probes.push_back({Vec3((*n)[0], (*n)[1], (*n)[2]), (*n)[3]});
    } else if (a == "--output") {
      o.output = value();
    } else if (a == "--size") {
      const std::string& v = value();
      // Two whole numbers of decimal digits (no overflow: at most 5 digits each).
      const auto x = v.find('x');
      auto pixels = [&](const std::string& d) {
        const bool digits = !d.empty() && d.size() <= 5 &&
                            std::all_of(d.begin(), d.end(), [](char c) { return c >= '0' && c <= '9'; });
        return digits ? std::stoi(d) : -1;
      };
      const int w = x == std::string::npos ? -1 : pixels(v.substr(0, x));
      const int h = x == std::string::npos ? -1 : pixels(v.substr(x + 1));
      if (w < 16 || h < 16 || w > 8192 || h > 8192)
        throw RenderError("--size: expected WxH with 16..8192 pixels each, got '" + v + "'");
      o.width = w;
      o.height = h;
    } else if (a == "--gl") {
      o.backend = parse_gl_backend(value());
    } else if (a == "--path") {
      const std::string& v = value();
      if (v == "partial")
        o.path = UploadPath::PartialTextureBuffer;
      else if (v == "vtk")
        o.path = UploadPath::VtkModified;
      else if (v == "cpu")
        o.path = UploadPath::CpuDisplaced;
      else
        throw RenderError("--path: expected partial, vtk or cpu, got '" + v + "'");
    } else if (a == "--settle") {
      o.settle_time = in_range(a, value(), 1e-3, 60.0, " s");
    } else if (a == "--stiffness") {
      o.material.stiffness = in_range(a, value(), 1e-3, 1e6, " N/m");
    } else if (a == "--damping") {
      o.material.damping = in_range(a, value(), 1e-6, 1e4, " N s/m");
    } else if (a == "--mass") {
      o.material.mass = in_range(a, value(), 1e-9, 10.0, " kg");
    } else if (a == "--model") {
      const std::string& v = value();
      if (v == "linear")
        o.material.model = deform::LocalModelKind::Linear;
      else if (v == "exponential")
        o.material.model = deform::LocalModelKind::Exponential;
      else if (v == "viscoelastic")
        o.material.model = deform::LocalModelKind::Viscoelastic;
      else
        throw RenderError("--model: expected linear, exponential or viscoelastic, got '" + v + "'");
    } else if (a == "--shape") {
      const std::string& v = value();
      if (v == "gaussian")
        o.shape.kind = deform::ShapeKind::Gaussian;
      else if (v == "wendland")
        o.shape.kind = deform::ShapeKind::Wendland;
      else if (v == "volume")
        o.shape.kind = deform::ShapeKind::VolumeConserving;
      else
        throw RenderError("--shape: expected gaussian, wendland or volume, got '" + v + "'");
    } else if (a == "--radius") {
      o.shape.radius = in_range(a, value(), 1e-4, 0.5, " m");
    } else if (a == "--view") {
      const std::string& v = value();
      auto n = numbers(v, 3);
      // Any finite direction but zero; scaled by its largest component so that
      // 1e-200,0,0 is not taken for zero (its norm underflows) nor 1e300 for infinite.
      const Vec3 d = n ? Vec3((*n)[0], (*n)[1], (*n)[2]) : Vec3::Zero();
      const double largest = d.cwiseAbs().maxCoeff();
      if (!n || !(largest > 0)) throw RenderError("--view: expected a non-zero direction X,Y,Z, got '" + v + "'");
      o.view_dir = d / largest;
    } else {
      throw RenderError("unknown option '" + a + "' (see --help)");
    }
  }
  if (o.probes.size() > haptics::kMaxProbes)
    throw RenderError("--probe: at most " + std::to_string(haptics::kMaxProbes) + " probes, got " +
                      std::to_string(o.probes.size()));
  return o;
}

RenderJobResult run_render_job(const RenderJobOptions& o, std::ostream& log) {
  RenderJobResult result;

  // The organ (a scenario's, with its tissues and field).
  std::optional<scenario::Resolved> scen;
  if (!o.scenario.empty()) {
    scen = scenario::resolve(scenario::load_scenario(o.scenario));
    log << "scenario " << o.scenario.string() << ": " << scen->scenario.title << "\n";
  }
  Organ organ = scen ? scen->organ : o.mesh.empty() ? load_default_organ() : load_organ(o.mesh, o.unit);
  const auto& mesh = *organ.mesh;
  {
    std::ostringstream s;
    const Vec3 ext = organ.facts.bbox_max - organ.facts.bbox_min;
    s << organ.name << ": " << mesh.vertex_count() << " vertices, " << mesh.triangle_count() << " triangles, "
      << ext.x() * 1e3 << " x " << ext.y() * 1e3 << " x " << ext.z() * 1e3 << " mm";
    if (organ.unit_guessed) s << " (file unit guessed: " << organ.unit_m << " m)";
    result.organ = s.str();
  }
  log << result.organ << "\n";
  if (!organ.note.empty()) log << organ.note << "\n";

  // The probes: tips below the surface points nearest to the requested ones.
  haptics::CoreConfig config;
  config.rate_hz = 1.0 / o.dt;
  config.deform_rate_hz = 1.0 / o.dt;  // a deformation step every tick
  config.force = o.force;
  config.shape = o.shape;
  if (scen) config.shape = scen->scenario.probe.shape;
  const auto model = scen ? scenario::session_model(*scen, config) : haptics::SessionModel::make(organ.mesh, {}, config);
  const tissue::TissueField* field = model->field.get();
  const deform::Material material = scen ? scen->tissues[scen->base] : o.material;
  const collision::VertexTree& tree = *model->tree;
  std::vector<ProbeSpec> specs = o.probes;
  if (specs.empty()) {
    Index top = 0;
    for (Index i = 1; i < mesh.vertex_count(); ++i)
      if (mesh.positions[i].z() > mesh.positions[top].z()) top = i;
    specs.push_back({mesh.positions[top], 0.006});
  }
  std::vector<Vec3> tips(specs.size());
  std::vector<Vec3> axes(specs.size());
  for (std::size_t k = 0; k < specs.size(); ++k) {
    const auto nearest = tree.nearest(specs[k].point);
    const auto sp = collision::locate_surface_point(mesh, specs[k].point, nearest.vertex);
    tips[k] = sp.point - specs[k].depth * sp.normal;
    axes[k] = sp.normal;
  }

  // Settle: the session steps (haptic tick of every probe, then the
  // deformation step with their contacts). The probes have no force output:
  // the session reports the model's force.
  if (specs.size() > haptics::kMaxProbes)
    throw RenderError("at most " + std::to_string(haptics::kMaxProbes) + " probes, got " + std::to_string(specs.size()));
  std::vector<haptics::ProbeSetup> setups(specs.size());
  for (std::size_t k = 0; k < specs.size(); ++k) {
    setups[k].name = "probe " + std::to_string(k + 1);
    setups[k].spec.position_dof = 3;
  }
  haptics::Session session(model, deform::MaterialArrays::uniform(mesh.vertex_count(), material), setups);
  std::vector<haptics::ProbeTickInput> inputs(specs.size());
  std::vector<haptics::ProbeTickResult> outputs(specs.size());
  const long steps = std::max(1L, std::lround(o.settle_time / o.dt));
  for (long s = 0; s < steps; ++s) {
    const double t = static_cast<double>(s) * o.dt;
    for (std::size_t k = 0; k < specs.size(); ++k) {
      // With breathing the tip rides on the organ (the press is relative to it).
      const Vec3 tip = field ? field->to_world(tips[k], t) : tips[k];
      inputs[k].sample = haptics::position_sample(tip, static_cast<std::uint64_t>(s) + 1, t);
    }
    session.step(t, inputs, outputs);
  }
  deform::DeformableSurface& surface = session.surface();

  // Offscreen scene: the surface, the probes, a camera looking at the first probe.
  OffscreenScene scene(o.width, o.height, o.backend);
  result.backend = scene.window().backend();
  result.gl_renderer = scene.window().gl_renderer();
  log << "rendering with " << gl_backend_name(result.backend) << " (" << result.gl_renderer << ")\n";
  SurfaceView view(organ.mesh, o.path);
  view.sync(surface);
  const double t_end = static_cast<double>(steps - 1) * o.dt;
  const Eigen::Matrix4d organ_to_world = field ? field->organ_to_world(t_end) : Eigen::Matrix4d::Identity();
  view.set_transform(organ_to_world);
  scene.add(view.actor());
  // Shown lesions (and after-exam ones when revealed); hidden ones never.
  std::vector<std::unique_ptr<render::EllipsoidView>> lesion_views;
  if (scen) {
    for (const auto& l : scen->lesions) {
      const bool draw = l.visibility == tissue::Visibility::Shown ||
                        (o.reveal && l.visibility == tissue::Visibility::AfterExam) || (o.reveal && l.visibility == tissue::Visibility::Hidden);
      if (!draw) continue;
      auto lv = std::make_unique<render::EllipsoidView>(l.centre, l.semi_axes);
      lv->set_transform(organ_to_world);
      lv->add_to(scene.renderer());
      lesion_views.push_back(std::move(lv));
    }
    result.lesions_drawn = lesion_views.size();
  }
  // A scenario's picture shows no force arrow (its length would give hidden
  // lesions away: the trainee finds them by feel) unless revealed.
  const bool hide_force = scen && !o.reveal;
  std::vector<std::unique_ptr<ProbeView>> probe_views;
  const double size = (organ.facts.bbox_max - organ.facts.bbox_min).norm();
  for (std::size_t k = 0; k < specs.size(); ++k) {
    auto pv = std::make_unique<ProbeView>(0.008 * size, 0.15 * size);
    pv->set_force_scale(0.25 * size / std::max(o.force.max_force, 1e-9));
    const Vec3 tip = field ? field->to_world(tips[k], t_end) : tips[k];
    const Vec3 arrow = hide_force ? Vec3::Zero() : haptics::to_vec(outputs[k].force_world);
    pv->set_state(tip, axes[k], arrow, outputs[k].in_contact != 0, k == 0);
    pv->add_to(scene.renderer());
    probe_views.push_back(std::move(pv));
  }
  Vec3 view_dir;
  if (o.view_dir) {
    view_dir = o.view_dir->normalized();
  } else {
    // Along the first probe's normal, tilted 35 degrees so the dent shows in profile.
    const Vec3 n = axes[0];
    Vec3 t = Vec3::UnitZ() - Vec3::UnitZ().dot(n) * n;
    if (t.norm() < 1e-6) t = Vec3::UnitY() - Vec3::UnitY().dot(n) * n;
    view_dir = (std::cos(0.61) * n - std::sin(0.61) * t.normalized()).normalized();
  }
  scene.look_at(view.bounds(), view_dir, Vec3::UnitZ());
  const auto t0 = std::chrono::steady_clock::now();
  Image img = scene.render_image();
  result.render_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  write_png(img, o.output);

  // Report.
  result.max_displacement = view.max_displacement();
  for (std::size_t k = 0; k < specs.size(); ++k) {
    RenderJobResult::Probe p;
    p.tip = tips[k];
    p.force = haptics::to_vec(outputs[k].force_world);
    p.depth = outputs[k].depth;
    p.in_contact = outputs[k].in_contact != 0;
    result.probes.push_back(p);
    log << "probe " << k + 1 << ": depth " << p.depth * 1e3 << " mm, force " << p.force.norm() << " N"
        << (p.in_contact ? "" : " (no contact)") << "\n";
  }
  log << "max displacement " << result.max_displacement * 1e3 << " mm; wrote " << o.output.string() << " ("
      << o.width << "x" << o.height << ", frame " << result.render_ms << " ms)\n";
  return result;
}

}  // namespace palpa::app
