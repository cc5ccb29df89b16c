#pragma once
// The headless render job behind `palpa-render` and `palpa` with no display:
// load an organ, press probes into it, let the surface settle under the
// haptic loop's physics, render it offscreen and write a PNG.

#include "core/types.h"
#include "deform/material.h"
#include "deform/shape_function.h"
#include "haptics/force.h"
#include "mesh/organ.h"
#include "render/offscreen.h"
#include "render/surface_view.h"

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace palpa::app {

/// One probe: pressed `depth` (m) into the surface at the surface point
/// nearest to `point` (m), along the inward surface normal there.
struct ProbeSpec {
  Vec3 point = Vec3::Zero();
  double depth = 0.006;
};

struct RenderJobOptions {
  std::filesystem::path mesh;            ///< empty: the bundled default organ
  /// A scenario (docs/SCENARIO.md): its organ, tissues, lesions, pulse and
  /// breathing replace mesh, unit, material and shape. Hidden lesions are
  /// never drawn; shown ones are, and every lesion with `reveal`. A
  /// scenario's picture has no force arrows unless revealed (their length
  /// would give hidden lesions away).
  std::filesystem::path scenario;
  bool reveal = false;
  mesh::MeshUnit unit = mesh::MeshUnit::Auto;
  std::vector<ProbeSpec> probes;         ///< empty: one probe 6 mm into the organ's highest point
  std::filesystem::path output = "palpa-render.png";
  int width = 960, height = 720;         ///< pixels
  render::GlBackend backend = render::GlBackend::Auto;
  render::UploadPath path = render::UploadPath::PartialTextureBuffer;
  double settle_time = 1.0;              ///< s of simulated time before the picture
  double dt = 1e-3;                      ///< haptic and deformation step, s
  deform::Material material{.model = deform::LocalModelKind::Linear, .mass = 1e-3, .damping = 2.0,
                            .stiffness = 200.0};
  deform::ShapeFunction shape{.kind = deform::ShapeKind::Wendland, .radius = 0.025};
  haptics::ForceParams force{.friction = 0.2, .slip_speed = 1e-3, .max_force = 8.0};
  std::optional<Vec3> view_dir;          ///< from the organ towards the eye; default: along the first probe's normal, tilted
};

/// What the job did.
struct RenderJobResult {
  std::string organ;                     ///< name and size
  render::GlBackend backend = render::GlBackend::Auto;
  std::string gl_renderer;
  struct Probe {
    Vec3 tip = Vec3::Zero();             ///< m
    Vec3 force = Vec3::Zero();           ///< N, on the probe
    double depth = 0;                    ///< m below the undeformed surface
    bool in_contact = false;
  };
  std::vector<Probe> probes;
  double max_displacement = 0;           ///< m
  std::size_t lesions_drawn = 0;
  double render_ms = 0;                  ///< the final frame, ms
};

/// Parses command-line arguments (without the program name). Throws
/// render::RenderError with a message naming the option, e.g.
/// "--probe: expected X,Y,Z,DEPTH in metres, got '1,2'". "--help" sets *help.
RenderJobOptions parse_render_args(const std::vector<std::string>& args, bool* help = nullptr);
/// The option summary printed by --help.
std::string render_usage(const std::string& program);

/// Runs the job, printing progress to `log`. Throws render::RenderError or
/// mesh::MeshError with a message naming what failed.
RenderJobResult run_render_job(const RenderJobOptions& options, std::ostream& log);

}  // namespace palpa::app
