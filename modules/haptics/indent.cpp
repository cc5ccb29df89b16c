// The calibration press of indent.h.

#include "haptics/indent.h"

#include "mesh/thickness.h"

#include <cmath>
#include <stdexcept>

namespace palpa::haptics {

IndentSite indent_site(const SessionModel& model, const Vec3& near) {
  IndentSite s;
  s.vertex = model.tree->nearest(near).vertex;
  s.point = model.mesh->positions[s.vertex];
  s.normal = model.mesh->normals[s.vertex].normalized();
  const std::vector<double> thickness = mesh::inward_thickness(*model.mesh);
  s.thickness = thickness[s.vertex];
  return s;
}

std::vector<IndentSample> indent(std::shared_ptr<const SessionModel> model, const deform::Material& material,
                                 const IndentSite& site, const std::vector<double>& depths,
                                 const IndentOptions& options) {
  for (double d : depths)
    if (!(d >= 0) || !std::isfinite(d))
      throw std::invalid_argument("indent: depths must be finite and non-negative, got " + std::to_string(d));
  ProbeSetup probe;
  probe.name = "indenter";
  probe.spec.position_dof = 3;
  probe.safety.max_jump = 1e9;
  Session session(model, deform::MaterialArrays::uniform(model->mesh->vertex_count(), material), {probe});
  const tissue::TissueField* field = model->field.get();
  const double dt = model->config.period();

  std::vector<ProbeTickInput> in(1);
  std::vector<ProbeTickResult> out(1);
  std::uint64_t n = 0;
  // Steps the session with the probe at `depth` below the site (organ frame,
  // brought into the world where the organ is at each tick).
  auto step_at = [&](double depth) {
    const double t = static_cast<double>(n) * dt;
    Vec3 p = site.point - depth * site.normal;
    if (field) p = field->to_world(p, t);
    in[0].sample = position_sample(p, ++n, t);
    session.step(t, in, out);
  };

  std::vector<IndentSample> samples;
  double at = -options.start_gap;
  const double per_tick = options.approach_speed * dt;
  const auto settle_ticks = static_cast<std::uint64_t>(std::ceil(options.settle / dt));
  for (double target : depths) {
    while (at < target) {
      at = std::min(target, at + per_tick);
      step_at(at);
    }
    for (std::uint64_t k = 0; k < settle_ticks; ++k) step_at(target);
    IndentSample s;
    s.depth = target;
    s.force = out[0].normal_reaction;
    s.surface_point = to_vec(out[0].contact_point);
    s.in_contact = out[0].in_contact != 0;
    samples.push_back(s);
  }
  return samples;
}

}  // namespace palpa::haptics
