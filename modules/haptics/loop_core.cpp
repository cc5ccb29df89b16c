#include "haptics/loop_core.h"

#include "core/subnormals.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace palpa::haptics {

namespace {

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void require_range(const char* field, double v, double lo, double hi) {
  if (!(std::isfinite(v) && v >= lo && v <= hi))
    throw std::invalid_argument(std::string("loop configuration: ") + field + " must be in [" + number(lo) + ", " +
                                number(hi) + "], got " + number(v));
}

bool finite3(const double* p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

}  // namespace

// Ranges chosen so that every accepted value keeps the loop well defined.
void CoreConfig::validate() const {
  require_range("rate_hz", rate_hz, 100, 10000);
  if (deform_rate_hz != 0) require_range("deform_rate_hz", deform_rate_hz, 1, 10000);
  require_range("watchdog_periods", watchdog_periods, 1.5, 1000);
  require_range("model_timeout_periods", model_timeout_periods, 1.5, 1e6);
  require_range("velocity_cutoff_hz", velocity_cutoff_hz, 0.1, 1e5);
  require_range("force.friction", force.friction, 0, 10);
  require_range("force.slip_speed", force.slip_speed, 1e-9, 10);
  require_range("force.max_force", force.max_force, 1e-6, 1e4);
  require_range("shape.radius", shape.radius, 1e-6, 10);
  const auto k = static_cast<int>(shape.kind);
  if (k < 0 || k > 2) throw std::invalid_argument("loop configuration: shape.kind is not a known shape function");
}

void to_contacts(const ContactSet& set, std::vector<deform::Contact>& out) {
  out.resize(std::min<std::size_t>(set.count, kMaxProbes));
  for (std::size_t i = 0; i < out.size(); ++i) {
    const ContactRecord& r = set.contacts[i];
    out[i].point = to_vec(r.point);
    out[i].normal = to_vec(r.normal);
    out[i].vertex = r.vertex;
    out[i].depth = r.depth;
    out[i].shape = r.shape;
  }
}

void validate_tissue(const TissueModel& t, std::size_t n) {
  if (t.map) {
    const deform::MaterialMap& m = *t.map;
    if (m.tissues.empty()) throw std::invalid_argument("tissue: the map has no tissues");
    if (m.tissues.size() > 65536)
      throw std::invalid_argument("tissue: the map has " + std::to_string(m.tissues.size()) + " tissues, at most 65536");
    for (std::size_t k = 0; k < m.tissues.size(); ++k)
      deform::validate_material(m.tissues[k], "tissue: the map's tissue " + std::to_string(k));
    if (m.tissue_of.size() != n)
      throw std::invalid_argument("tissue: the map has " + std::to_string(m.tissue_of.size()) + " tissue indices for " +
                                  std::to_string(n) + " vertices");
    for (std::size_t i = 0; i < n; ++i)
      if (m.tissue_of[i] >= m.tissues.size())
        throw std::invalid_argument("tissue: the map's tissue of vertex " + std::to_string(i) + " is " +
                                    std::to_string(m.tissue_of[i]) + ", but there are " +
                                    std::to_string(m.tissues.size()) + " tissues");
    if (!m.scale.empty() && m.scale.size() != n)
      throw std::invalid_argument("tissue: the map has " + std::to_string(m.scale.size()) + " scales for " +
                                  std::to_string(n) + " vertices");
    for (std::size_t i = 0; i < m.scale.size(); ++i)
      if (!(std::isfinite(m.scale[i]) && m.scale[i] > 0))
        throw std::invalid_argument("tissue: the map's scale of vertex " + std::to_string(i) +
                                    " must be positive and finite, got " + number(m.scale[i]));
  }
  if (!t.field) return;
  const tissue::TissueField& f = *t.field;
  auto finite = [](std::initializer_list<double> v) {
    for (double x : v)
      if (!std::isfinite(x)) return false;
    return true;
  };
  for (std::size_t k = 0; k < f.lesion_count && k < tissue::kMaxLesions; ++k) {
    const tissue::LesionData& l = f.lesions[k];
    if (!l.centre.allFinite() || !l.inv_axes.allFinite() || !finite({l.size2, l.excess}))
      throw std::invalid_argument("tissue: the field's lesion " + std::to_string(k) + " has a value that is not finite");
  }
  for (std::size_t p = 0; p < f.pulse_count && p < tissue::kMaxPulses; ++p)
    if (!finite({f.pulses[p].rate_hz, f.pulses[p].amplitude}))
      throw std::invalid_argument("tissue: the field's pulse " + std::to_string(p) + " has a value that is not finite");
  const tissue::Breathing& b = f.breathing;
  if (!finite({b.rate_bpm, b.scale}) || !b.translation.allFinite() || !b.axis.allFinite() || !b.centre.allFinite())
    throw std::invalid_argument("tissue: the field's breathing has a value that is not finite");
  for (std::size_t r = 0; r < f.dynamic_count && r < tissue::kMaxDynamicRegions; ++r) {
    const auto& d = f.dynamic[r];
    const auto& g = d.guarding;
    bool ok = finite({g.threshold, g.factor, g.duration, g.release});
    for (std::size_t k = 0; k < d.keyframe_count && k < tissue::kMaxKeyframes; ++k)
      ok = ok && finite({d.keyframes[k].time, d.keyframes[k].scale, d.keyframes[k].ramp});
    if (!ok)
      throw std::invalid_argument("tissue: the field's dynamic region " + std::to_string(r) +
                                  " has a value that is not finite");
  }
  if (!(std::isfinite(f.tip_radius) && f.tip_radius > 0))
    throw std::invalid_argument("tissue: the field's tip radius must be positive and finite, got " +
                                number(f.tip_radius) + " m");
  if (f.lesion_count > tissue::kMaxLesions)
    throw std::invalid_argument("tissue: the field has " + std::to_string(f.lesion_count) + " lesions, at most " +
                                std::to_string(tissue::kMaxLesions));
  if (f.pulse_count > tissue::kMaxPulses)
    throw std::invalid_argument("tissue: the field has " + std::to_string(f.pulse_count) + " pulses, at most " +
                                std::to_string(tissue::kMaxPulses));
  if (f.dynamic_count > tissue::kMaxDynamicRegions)
    throw std::invalid_argument("tissue: the field has " + std::to_string(f.dynamic_count) +
                                " dynamic regions, at most " + std::to_string(tissue::kMaxDynamicRegions));
  for (std::size_t p = 0; p < f.pulse_count; ++p)
    if (f.pulse_weight[p].size() != n)
      throw std::invalid_argument("tissue: the field's pulse " + std::to_string(p) + " has " +
                                  std::to_string(f.pulse_weight[p].size()) + " weights for " + std::to_string(n) +
                                  " vertices");
  for (Index v : f.pulse_vertices)
    if (v >= n) throw std::invalid_argument("tissue: the field's pulse vertex " + std::to_string(v) + " is out of range");
  if (f.pulse_count == 0 && !f.pulse_vertices.empty())
    throw std::invalid_argument("tissue: the field has pulse vertices but no pulse");
  for (std::size_t r = 0; r < f.dynamic_count; ++r) {
    if (f.dynamic_weight[r].size() != n)
      throw std::invalid_argument("tissue: the field's dynamic region " + std::to_string(r) + " has " +
                                  std::to_string(f.dynamic_weight[r].size()) + " weights for " + std::to_string(n) +
                                  " vertices");
    if (f.dynamic[r].keyframe_count > tissue::kMaxKeyframes)
      throw std::invalid_argument("tissue: the field's dynamic region " + std::to_string(r) + " has " +
                                  std::to_string(f.dynamic[r].keyframe_count) + " keyframes, at most " +
                                  std::to_string(tissue::kMaxKeyframes));
  }
}

void merge_requests(DeformRequest& into, const DeformRequest& later) {
  into.edits.reset = into.edits.reset || later.edits.reset;
  if (later.edits.material != 0) {
    into.edits.material = later.edits.material;
    into.edits.uniform = later.edits.uniform;
    into.edits.map = later.edits.map;
    into.edits.tissue_map = later.edits.tissue_map;
  }
  if (later.edits.tissue) into.edits.tissue = later.edits.tissue;
  into.generation = later.generation;
  into.tick = later.tick;
  into.time = later.time;
  into.dt += later.dt;
  into.contacts = later.contacts;
}

void set_field_drives(deform::DeformableSurface& surface, const tissue::TissueField* field) {
  if (!field || field->pulse_count == 0) {
    surface.set_drives({}, {});
    surface.set_drive_values({});
    return;
  }
  std::vector<Index> vertices = field->pulse_vertices;
  std::vector<std::array<float, 4>> weights(vertices.size());
  for (std::size_t j = 0; j < vertices.size(); ++j)
    for (std::size_t p = 0; p < field->pulse_count; ++p) weights[j][p] = field->pulse_weight[p][vertices[j]];
  surface.set_drives(std::move(vertices), std::move(weights));
}

void apply_deform_edits(deform::DeformableSurface& surface, const DeformEdits& e) {
  if (e.reset) surface.reset();
  if (e.material == 1) surface.set_uniform_material(e.uniform);
  if (e.material == 2 && e.map != nullptr) surface.set_materials(*e.map);
  if (e.material == 3 && e.tissue_map != nullptr) surface.set_tissue_map(*e.tissue_map);
  if (e.tissue) set_field_drives(surface, e.tissue->field.get());
}

void apply_deform_request(deform::DeformableSurface& surface, const DeformRequest& r,
                          std::vector<deform::Contact>& scratch, const tissue::TissueField* field) {
  apply_deform_edits(surface, r.edits);
  field = field_after(r.edits, field);
  to_contacts(r.contacts, scratch);
  surface.set_contacts(scratch);
  if (field && field->pulse_count > 0) {
    std::array<double, 4> values{};
    for (std::size_t p = 0; p < field->pulse_count && p < values.size(); ++p) values[p] = field->pulse_value(p, r.time);
    surface.set_drive_values(values);
  }
  if (r.dt > 0) surface.step(r.dt);
}

PreparedProbe LoopCore::prepare(ProbeSetup s, const CoreConfig& config) {
  s.mapping.validate(s.name);
  if (s.spec.force_dof > 0) {
    if (!(std::isfinite(s.spec.max_force) && s.spec.max_force > 0))
      throw std::invalid_argument("device " + s.name + " declares force output but no valid max_force");
    if (s.safety.max_force == 0) s.safety.max_force = s.spec.max_force;
    s.safety.max_force = std::min(s.safety.max_force, s.spec.max_force);
  } else if (s.safety.max_force == 0) {
    s.safety.max_force = config.force.max_force;  // no output; the value only has to be valid
  }
  s.safety.validate(s.name);
  PreparedProbe p;
  p.spec = s.spec;
  p.safety = SafetyFilter(s.safety, config.period());
  p.mapping = ClutchedMapping(s.mapping);
  return p;
}

LoopCore::LoopCore(const collision::VertexTree& tree, const mesh::SurfaceMesh& mesh, const CoreConfig& config,
                   std::vector<ProbeSetup> probes, const tissue::TissueField* field)
    : tree_(tree), base_field_(field), field_(field), config_(config), setups_(std::move(probes)) {
  tissue_tick_.field = field_;
  config_.validate();
  if (setups_.empty()) throw std::invalid_argument("loop configuration: no probes");
  if (setups_.size() > kMaxProbes)
    throw std::invalid_argument("loop configuration: " + std::to_string(setups_.size()) + " probes, at most " +
                                std::to_string(kMaxProbes) + " are supported");
  if (mesh.vertex_count() == 0) throw std::invalid_argument("loop configuration: the surface has no vertices");

  // Resolve each probe's force limit from its device and check everything.
  for (std::size_t i = 0; i < setups_.size(); ++i) {
    const PreparedProbe p = prepare(setups_[i], config_);
    setups_[i].safety = p.safety.limits();
    CoreProbeState& st = state_.probes[i];
    st.active = true;
    st.spec = p.spec;
    st.safety = p.safety;
    st.mapping = p.mapping;
  }
  state_.force = config_.force;
  state_.shape = config_.shape;
  step_fraction_ = config_.deform_rate_hz / config_.rate_hz;

  // Positions farther than `margin` from the surface's box cannot touch it:
  // they are clamped onto the enlarged box so that collision never sees an
  // absurd (huge) coordinate.
  Vec3 lo = mesh.positions[0], hi = mesh.positions[0];
  for (const auto& p : mesh.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double margin = std::max({1.0, (hi - lo).norm(), 4.0 * config_.shape.radius});
  range_lo_ = lo - Vec3::Constant(margin);
  range_hi_ = hi + Vec3::Constant(margin);
  parking_ = range_hi_;
}

std::size_t LoopCore::probe_count() const {
  for (std::size_t i = kMaxProbes; i > 0; --i)
    if (state_.probes[i - 1].active) return i;
  return 0;
}

void LoopCore::apply(const LoopCommand& c, double t) noexcept {
  switch (c.kind) {
    case LoopCommandKind::SetShape: state_.shape = c.shape; return;
    case LoopCommandKind::SetForce: state_.force = c.force; return;
    case LoopCommandKind::SetMaterial:
      state_.pending.material = 1;
      state_.pending.uniform = c.material;
      state_.pending.map = nullptr;
      state_.pending.tissue_map = nullptr;
      return;
    case LoopCommandKind::SetMaterialMap:
      if (c.materials == nullptr) return;
      state_.pending.material = 2;
      state_.pending.map = c.materials;
      state_.pending.tissue_map = nullptr;
      return;
    case LoopCommandKind::SetTissue:
      // The ticks read the new field from this one on; the surface gets
      // the map and the pulse drives with the next (edits-only) request.
      if (c.tissue == nullptr) return;
      state_.tissue = c.tissue;
      state_.pending.tissue = c.tissue;
      if (const deform::MaterialMap* map = c.tissue->map.get()) {
        state_.pending.material = 3;
        state_.pending.tissue_map = map;
        state_.pending.map = nullptr;
      }
      state_.reactions = tissue::ReactionState{};  // the new field's regions have not reacted yet
      use_field(c.tissue->field.get());
      return;
    case LoopCommandKind::ResetSurface:
      state_.pending.reset = true;
      for (auto& m : state_.memory) forget(m);  // every contact starts afresh
      return;
    default: break;
  }
  if (c.probe >= kMaxProbes) return;
  CoreProbeState& st = state_.probes[c.probe];
  if (c.kind == LoopCommandKind::AddProbe) {
    st = CoreProbeState{};
    forget(state_.memory[c.probe]);
    st.active = true;
    st.spec = c.prepared.spec;
    st.safety = c.prepared.safety;
    st.mapping = c.prepared.mapping;
    return;
  }
  if (!st.active) return;
  switch (c.kind) {
    case LoopCommandKind::Enable: st.safety.enable(t); break;
    case LoopCommandKind::Disable: st.safety.disable(); break;
    case LoopCommandKind::ClutchOn: st.clutch_command = true; break;
    case LoopCommandKind::ClutchOff: st.clutch_command = false; break;
    case LoopCommandKind::SetMapping: st.mapping.set_mapping(c.mapping); break;
    case LoopCommandKind::RemoveProbe:
      st = CoreProbeState{};
      forget(state_.memory[c.probe]);
      break;
    default: break;
  }
}

bool LoopCore::tick(std::uint64_t tick, double t, const deform::DeformableSurface& surface, double model_time,
                    std::span<const ProbeTickInput> inputs, std::span<ProbeTickResult> results,
                    ContactSet& contacts) noexcept {
  // Subnormal values as zero (core/subnormals.h): a probe held still has
  // its filtered velocity decay into the subnormal range about 2.6 s later
  // and stay there, where every tick took twice as long.
  const SubnormalsAsZero flush;
  const std::size_t n = std::min({probe_count(), inputs.size(), results.size()});
  const double period = config_.period();

  // Watchdogs: the loop itself late, or the deformation model too old.
  std::uint32_t common = 0;
  if (state_.have_last_tick && !(t - state_.last_tick_time <= config_.watchdog_periods * period))
    common |= kSafetyLoopLate;
  if (config_.deform_rate_hz > 0 && !(t - model_time <= config_.model_timeout_periods / config_.deform_rate_hz))
    common |= kSafetyModelLate;
  state_.last_tick_time = t;
  state_.have_last_tick = true;

  // Per probe: check the sample, map it, estimate the velocity.
  std::array<std::uint32_t, kMaxProbes> cond{};
  std::size_t dense = 0;
  for (std::size_t i = 0; i < n; ++i) {
    CoreProbeState& st = state_.probes[i];
    if (!st.active) continue;
    const PalpaDeviceSample& s = inputs[i].sample;
    std::uint32_t c = common;
    if (!inputs[i].read_ok || (s.status & PALPA_STATUS_FAULT)) c |= kSafetyDeviceFault;
    if ((s.status & PALPA_STATUS_NOT_READY) || !(s.status & PALPA_STATUS_VALID)) c |= kSafetyNotReady;
    if (s.status & PALPA_STATUS_STALE) c |= kSafetyStale;

    const bool finite_input = finite3(s.position);
    if (!finite_input) c |= kSafetyBadInput;
    const int button = st.mapping.mapping().clutch_button;
    const bool clutch = st.clutch_command || (button >= 0 && ((s.buttons >> button) & 1u));
    Vec3 world = st.mapping.update(Vec3(s.position[0], s.position[1], s.position[2]), clutch);
    if (st.mapping.engaged()) c |= kSafetyClutch;
    if (!world.allFinite()) {
      c |= kSafetyBadInput;
    } else {
      world = world.cwiseMax(range_lo_).cwiseMin(range_hi_);
    }

    const bool usable = !(c & (kSafetyBadInput | kSafetyDeviceFault | kSafetyNotReady));
    if (usable) {
      // A jump farther than max_jump within one tick is a glitch, not a motion.
      if (st.have_world && !((world - st.world).norm() <= st.safety.limits().max_jump)) {
        c |= kSafetyJump;
        st.velocity.setZero();
        st.have_sample = false;
      }
      // Velocity from consecutive new samples, low-pass filtered.
      if (s.sequence != st.last_sequence || !st.have_sample) {
        const double dts = s.time - st.last_sample_time;
        if (st.have_sample && std::isfinite(dts) && dts > 0) {
          const Vec3 raw = (world - st.last_sample_world) / dts;
          const double tau = 1.0 / (2.0 * std::numbers::pi * config_.velocity_cutoff_hz);
          const double alpha = dts / (dts + tau);
          if (raw.allFinite()) st.velocity += alpha * (raw - st.velocity);
        }
        st.last_sequence = s.sequence;
        st.last_sample_time = s.time;
        st.last_sample_world = world;
        st.have_sample = std::isfinite(s.time);
      }
      if (!st.velocity.allFinite()) st.velocity.setZero();
      st.world = world;
      st.have_world = true;
    }
    cond[i] = c;
    probe_inputs_[dense].position = st.have_world ? st.world : parking_;
    probe_inputs_[dense].velocity = st.velocity;
    if (field_ && field_->breathing.enabled && st.have_world) {
      // Into the organ frame: where the breathing organ is now, and the
      // probe's velocity relative to the organ point under it.
      probe_inputs_[dense].velocity = st.velocity - field_->organ_velocity(st.world, t);
      probe_inputs_[dense].position = field_->to_organ(st.world, t);
    }
    slot_of_[dense] = static_cast<std::uint8_t>(i);
    ++dense;
  }

  // Collision and eq. (4) force for every probe (section III.C, III.E). The
  // memories are used in place, through the slots where these have holes.
  const bool packed = dense == n;
  const TissueTick* tissue = nullptr;
  if (field_ && !field_->empty()) {
    for (std::size_t p = 0; p < field_->pulse_count; ++p) tissue_tick_.pulse_value[p] = field_->pulse_value(p, t);
    for (std::size_t r = 0; r < field_->dynamic_count; ++r)
      tissue_tick_.dynamic_factor[r] = field_->dynamic_factor(r, t, state_.reactions);
    tissue = &tissue_tick_;
  }
  last_dense_ = dense;
  last_tissue_ = tissue != nullptr;
  ProbeMemory* const memory = rehearsing_ ? warm_memory_.data() : state_.memory.data();
  haptic_tick(surface, tree_, std::span<const ProbeInput>(probe_inputs_.data(), dense),
              std::span<ProbeMemory>(memory, packed ? dense : state_.memory.size()),
              std::span<ProbeOutput>(probe_outputs_.data(), dense), state_.force, state_.shape, tissue,
              packed ? std::span<const std::uint8_t>() : std::span<const std::uint8_t>(slot_of_.data(), dense));

  // Safety per device, results, and the contacts for the deformation model.
  contacts.tick = tick;
  contacts.count = 0;
  if (!packed)
    for (std::size_t i = 0; i < n; ++i)
      if (!state_.probes[i].active) results[i] = ProbeTickResult{};  // a free slot
  for (std::size_t d = 0; d < dense; ++d) {
    const std::size_t i = slot_of_[d];
    const ProbeOutput& out = probe_outputs_[d];
    CoreProbeState& st = state_.probes[i];
    ProbeTickResult& r = results[i];
    const std::uint32_t c = cond[i];
    const bool input_ok = !(c & (kSafetyBadInput | kSafetyDeviceFault | kSafetyNotReady | kSafetyStale | kSafetyJump));
    const bool touching = input_ok && out.in_contact;
    const auto& mapping = st.mapping.mapping();

    r.sample = inputs[i].sample;
    r.world = to_triple(st.have_world ? st.world : parking_);
    r.velocity = to_triple(st.velocity);
    if (st.spec.force_dof > 0) {
      std::uint32_t flags = 0;
      const Vec3 device = st.safety.apply(mapping.force_to_device(out.force), c, t, flags);
      r.force_device = to_triple(device);
      r.force_world = to_triple(mapping.force_to_world(device));
      r.flags = flags;
    } else {
      // No force output: show the model's (already clamped) force.
      const Vec3 f = out.force.allFinite() && touching ? out.force : Vec3::Zero();
      r.force_device = {0, 0, 0};
      r.force_world = to_triple(f);
      r.flags = c;
    }
    r.in_contact = touching ? 1 : 0;
    r.contact_point = to_triple(out.surface.point);
    r.contact_normal = to_triple(out.surface.normal);
    r.depth = out.height.depth;
    r.normal_reaction = std::isfinite(out.normal_reaction) ? out.normal_reaction : 0.0;
    r.enabled = st.safety.enabled() ? 1 : 0;
    r.clutched = st.mapping.engaged() ? 1 : 0;
    r.fault = static_cast<std::uint8_t>(st.safety.fault());
    r.path = static_cast<std::uint8_t>(out.path);

    // Guarding: a press harder than the threshold inside a dynamic region
    // (weight >= 1/2 at the contact point) sets it off, unless it is still on.
    if (tissue && touching) {
      for (std::size_t g = 0; g < field_->dynamic_count; ++g) {
        const tissue::Guarding& gd = field_->dynamic[g].guarding;
        double& at = state_.reactions.triggered_at[g];
        const bool on = at >= 0 && t - at < gd.duration + gd.release;
        if (gd.enabled && !on && out.region_weight[g] >= 0.5f && out.normal_reaction > gd.threshold) at = t;
      }
    }
    if (touching && contacts.count < kMaxProbes) {
      ContactRecord& cr = contacts.contacts[contacts.count++];
      cr.point = to_triple(out.contact.point);
      cr.normal = to_triple(out.contact.normal);
      cr.vertex = out.contact.vertex;
      cr.depth = out.contact.depth;
      cr.shape = out.contact.shape;
    }
  }

  // The deformation schedule: deform_rate_hz / rate_hz steps per tick.
  bool due = false;
  double dt = 0;
  if (config_.deform_rate_hz > 0) {
    state_.deform_phase += step_fraction_;
    if (state_.deform_phase >= 1.0) {
      state_.deform_phase -= 1.0;
      due = true;
      dt = 1.0 / config_.deform_rate_hz;
    }
  }
  // Edits do not wait for the next step: they go at once, with no
  // integration (dt = 0), so the next tick already feels them.
  if (!due && state_.pending.any()) due = true;
  if (due) {
    request_.generation = ++state_.generations;
    request_.tick = tick;
    request_.time = t;
    request_.dt = dt;
    request_.contacts.tick = contacts.tick;
    request_.contacts.count = contacts.count;
    for (std::uint32_t k = 0; k < contacts.count; ++k) request_.contacts.contacts[k] = contacts.contacts[k];
    request_.edits = state_.pending;
    state_.pending = DeformEdits{};
  }
  return due;
}

// tick() once more, on the copies of the memories; what it writes put back.
// Not the probes' memories (it reads copies in warm_memory_, by slot) nor
// probe_outputs_ (only tick() reads them, after writing them).
void LoopCore::rehearse_tick(const deform::DeformableSurface& surface, std::span<const ProbeTickInput> inputs,
                             std::span<ProbeTickResult> results) noexcept {
  if (last_dense_ == 0 || !state_.have_last_tick) return;
  const std::size_t n = std::min({probe_count(), inputs.size(), results.size()});
  Rehearsal& k = rehearsal_;
  for (std::size_t i = 0; i < n; ++i) {
    if (!state_.probes[i].active) continue;
    k.probes[i] = state_.probes[i];
    set_warm_up_memory(state_.memory[i], warm_memory_[i]);
  }
  k.last_tick_time = state_.last_tick_time;
  k.deform_phase = state_.deform_phase;
  k.generations = state_.generations;
  k.pending = state_.pending;
  k.reactions = state_.reactions;
  k.request = request_;
  const std::size_t dense = last_dense_;
  std::copy_n(probe_inputs_.begin(), dense, k.inputs.begin());
  k.slot_of = slot_of_;
  k.last_tissue = last_tissue_;
  k.tissue_tick = tissue_tick_;

  rehearsing_ = true;
  const double t = state_.last_tick_time;
  (void)tick(request_.tick, t, surface, t, inputs.first(n), results.first(n), k.contacts);
  rehearsing_ = false;

  for (std::size_t i = 0; i < n; ++i)  // tick() leaves which slots are active as they were
    if (state_.probes[i].active) state_.probes[i] = k.probes[i];
  state_.last_tick_time = k.last_tick_time;
  state_.have_last_tick = true;
  state_.deform_phase = k.deform_phase;
  state_.generations = k.generations;
  state_.pending = k.pending;
  state_.reactions = k.reactions;
  request_ = k.request;
  std::copy_n(k.inputs.begin(), dense, probe_inputs_.begin());
  slot_of_ = k.slot_of;
  last_dense_ = dense;
  last_tissue_ = k.last_tissue;
  tissue_tick_ = k.tissue_tick;
}

// The last tick's haptic_tick again, from copies of the memories it left,
// then (rehearse_corners) a crossing past each probe's nearest corner on
// those copies: same reads, nothing kept.
void LoopCore::warm_caches(const deform::DeformableSurface& surface, bool rehearse_corners) noexcept {
  const SubnormalsAsZero flush;  // as tick(), which it rehearses
  const std::size_t dense = last_dense_;
  for (std::size_t d = 0; d < dense; ++d) set_warm_up_memory(state_.memory[slot_of_[d]], warm_memory_[d]);
  haptic_tick(surface, tree_, std::span<const ProbeInput>(probe_inputs_.data(), dense),
              std::span<ProbeMemory>(warm_memory_.data(), dense), std::span<ProbeOutput>(warm_outputs_.data(), dense),
              state_.force, state_.shape, last_tissue_ ? &tissue_tick_ : nullptr);
  const mesh::SurfaceMesh& mesh = surface.mesh();
  // A probe in contact leaves it on a tick that asks the tree from its
  // root: the nearest vertex, then the clearance bound (track_contact, past
  // the proxy). Asked here too, at the probe's place, on the copy, whose
  // state is put back after; only for a probe that may leave within a few
  // ticks (its depth below the undeformed surface within kLeaveTicks ticks
  // of its speed, or kLeaveMargin), as those questions cost a few
  // microseconds a probe.
  constexpr double kLeaveTicks = 4;
  constexpr double kLeaveMargin = 1e-4;  // m
  for (std::size_t d = 0; d < dense; ++d) {
    ProbeMemory& m = warm_memory_[d];
    if (!m.in_contact) continue;
    const double reach = kLeaveTicks * probe_inputs_[d].velocity.norm() * config_.period() + kLeaveMargin;
    if (!(warm_outputs_[d].height.depth <= reach)) continue;
    const Vec3& at = probe_inputs_[d].position;
    const collision::ContactCursorState kept = m.cursor;
    (void)collision::query_contact_from_root(mesh, tree_, at, m.cursor);
    (void)tree_.clearance(at, collision::kMaxClearance);
    static_cast<collision::ContactCursorState&>(m.cursor) = kept;
  }
  if (!rehearse_corners) return;
  for (std::size_t d = 0; d < dense; ++d) {
    Vec3 past = Vec3::Zero();
    if (corner_rehearsal_point(mesh, warm_memory_[d], past))
      (void)collision::track_contact(mesh, tree_, past, warm_memory_[d].cursor, true);
  }
}

}  // namespace palpa::haptics
