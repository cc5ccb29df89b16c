// Binary forms of the engine's plain data (state_io.h).

#include "record/state_io.h"

#include "record/internal_codec.h"

#include <bit>
#include <cmath>
#include <type_traits>

namespace palpa::record {

using internal::Reader;
using internal::Writer;

namespace {

constexpr std::uint32_t kStateMagic = 0x31535350;     // "PSS1"
constexpr std::uint32_t kMaterialMagic = 0x314d5350;  // "PSM1"
constexpr std::uint32_t kCommandMagic = 0x31435350;   // "PSC1"
constexpr std::uint32_t kSetupMagic = 0x31555350;     // "PSU1"
constexpr std::size_t kMaxVertices = std::size_t{1} << 28;

// The structs written byte for byte hold no pointer but those replaced below.
static_assert(std::is_trivially_destructible_v<haptics::CoreState>);
static_assert(std::is_trivially_destructible_v<haptics::LoopCommand>);
static_assert(std::is_trivially_destructible_v<deform::Contact>);
static_assert(std::is_trivially_destructible_v<deform::VertexState>);

void put_materials(Writer& w, const deform::MaterialArrays& m) {
  w.put_vector(m.model);
  w.put_vector(m.mass);
  w.put_vector(m.damping);
  w.put_vector(m.stiffness);
  w.put_vector(m.alpha);
  w.put_vector(m.k2);
  w.put_vector(m.tau);
  w.put_vector(m.hertz);
  w.put_vector(m.relaxation);
}

deform::MaterialArrays get_materials(Reader& r, std::size_t vertices) {
  deform::MaterialArrays m;
  m.model = r.get_vector<deform::LocalModelKind>(kMaxVertices);
  m.mass = r.get_vector<double>(kMaxVertices);
  m.damping = r.get_vector<double>(kMaxVertices);
  m.stiffness = r.get_vector<double>(kMaxVertices);
  m.alpha = r.get_vector<double>(kMaxVertices);
  m.k2 = r.get_vector<double>(kMaxVertices);
  m.tau = r.get_vector<double>(kMaxVertices);
  m.hertz = r.get_vector<double>(kMaxVertices);
  m.relaxation = r.get_vector<double>(kMaxVertices);
  for (std::size_t n : {m.model.size(), m.damping.size(), m.stiffness.size(), m.alpha.size(), m.k2.size(),
                        m.tau.size(), m.hertz.size(), m.relaxation.size()})
    if (n != m.mass.size()) throw DecodeError("material map has arrays of different lengths");
  if (m.mass.size() != vertices)
    throw DecodeError("material map has " + std::to_string(m.mass.size()) + " vertices, the mesh " +
                      std::to_string(vertices));
  for (auto k : m.model)
    if (static_cast<unsigned>(k) > 8) throw DecodeError("material map has an unknown model kind");
  return m;
}

// A tissue (SetTissue's payload): its map and field, each behind a flag.
// The fixed-size parts of the field are written field by field (no bool
// or padding byte is copied), its per-vertex arrays as vectors.
constexpr std::size_t kMaxTissues = 65536;

// A vector whose count is checked against its limit and the bytes left,
// naming it: "SetTissue command: the field's pulse 0 weights end early (...)".
template <class T>
std::vector<T> get_array(Reader& r, std::size_t max_count, const std::string& what, const std::string& name) {
  const auto n = r.get<std::uint64_t>();
  if (n > max_count)
    throw DecodeError(what + ": " + name + " has " + std::to_string(n) + " entries, at most " + std::to_string(max_count));
  if (n * sizeof(T) > r.left())
    throw DecodeError(what + ": " + name + " end early (" + std::to_string(n) + " entries, " +
                      std::to_string(r.left()) + " bytes left)");
  std::vector<T> v(n);
  if (n) r.get_bytes(v.data(), n * sizeof(T));
  return v;
}

void put_tissue_map(Writer& w, const deform::MaterialMap& m) {
  w.put_vector(m.tissues);
  w.put_vector(m.tissue_of);
  w.put_vector(m.scale);
}

std::shared_ptr<const deform::MaterialMap> get_tissue_map(Reader& r, std::size_t vertices, const std::string& what) {
  auto m = std::make_shared<deform::MaterialMap>();
  const auto tissues = r.get<std::uint64_t>();
  if (tissues == 0 || tissues > kMaxTissues)
    throw DecodeError(what + ": a tissue map with " + std::to_string(tissues) + " tissues (1 .. 65536)");
  if (tissues * sizeof(deform::Material) > r.left()) throw DecodeError(what + ": a tissue map ends early");
  m->tissues.resize(tissues);
  r.get_bytes(m->tissues.data(), tissues * sizeof(deform::Material));
  for (std::size_t k = 0; k < m->tissues.size(); ++k)
    if (static_cast<unsigned>(m->tissues[k].model) > 8)
      throw DecodeError(what + ": tissue " + std::to_string(k) + " of a tissue map has an unknown model kind");
  m->tissue_of = get_array<std::uint16_t>(r, kMaxVertices, what, "a tissue map's tissue indices");
  if (m->tissue_of.size() != vertices)
    throw DecodeError(what + ": a tissue map has " + std::to_string(m->tissue_of.size()) + " tissue indices, the mesh " +
                      std::to_string(vertices) + " vertices");
  m->scale = get_array<float>(r, kMaxVertices, what, "a tissue map's scales");
  if (!m->scale.empty() && m->scale.size() != vertices)
    throw DecodeError(what + ": a tissue map has " + std::to_string(m->scale.size()) + " scales, the mesh " +
                      std::to_string(vertices) + " vertices");
  return m;
}

void put_vec(Writer& w, const Vec3& v) {
  for (int k = 0; k < 3; ++k) w.put(v[k]);
}
Vec3 get_vec(Reader& r) {
  Vec3 v;
  for (int k = 0; k < 3; ++k) v[k] = r.get<double>();
  return v;
}
bool get_flag(Reader& r, const std::string& what, const char* name) {
  const auto b = r.get<std::uint8_t>();
  if (b > 1) throw DecodeError(what + ": " + name + " is " + std::to_string(b) + ", not 0 or 1");
  return b != 0;
}

void put_field(Writer& w, const tissue::TissueField& f) {
  w.put(f.tip_radius);
  w.put(f.lesion_count);
  for (std::size_t k = 0; k < f.lesion_count && k < tissue::kMaxLesions; ++k) {
    const tissue::LesionData& l = f.lesions[k];
    put_vec(w, l.centre);
    put_vec(w, l.inv_axes);
    w.put(l.size2);
    w.put(l.excess);
  }
  w.put(f.pulse_count);
  for (std::size_t p = 0; p < f.pulse_count && p < tissue::kMaxPulses; ++p) {
    w.put(f.pulses[p].rate_hz);
    w.put(f.pulses[p].amplitude);
    w.put_vector(f.pulse_weight[p]);
  }
  w.put_vector(f.pulse_vertices);
  const tissue::Breathing& b = f.breathing;
  w.put<std::uint8_t>(b.enabled ? 1 : 0);
  w.put(b.rate_bpm);
  put_vec(w, b.translation);
  put_vec(w, b.axis);
  put_vec(w, b.centre);
  w.put(b.scale);
  w.put(f.dynamic_count);
  for (std::size_t r = 0; r < f.dynamic_count && r < tissue::kMaxDynamicRegions; ++r) {
    const auto& d = f.dynamic[r];
    w.put(d.keyframe_count);
    for (std::size_t k = 0; k < d.keyframe_count && k < tissue::kMaxKeyframes; ++k) {
      w.put(d.keyframes[k].time);
      w.put(d.keyframes[k].scale);
      w.put(d.keyframes[k].ramp);
    }
    w.put<std::uint8_t>(d.guarding.enabled ? 1 : 0);
    w.put(d.guarding.threshold);
    w.put(d.guarding.factor);
    w.put(d.guarding.duration);
    w.put(d.guarding.release);
    w.put_vector(f.dynamic_weight[r]);
  }
}

std::shared_ptr<const tissue::TissueField> get_field(Reader& r, std::size_t n, const std::string& what) {
  auto f = std::make_shared<tissue::TissueField>();
  f->tip_radius = r.get<double>();
  f->lesion_count = r.get<std::uint32_t>();
  if (f->lesion_count > tissue::kMaxLesions)
    throw DecodeError(what + ": the field has " + std::to_string(f->lesion_count) + " lesions, at most " +
                      std::to_string(tissue::kMaxLesions));
  for (std::size_t k = 0; k < f->lesion_count; ++k) {
    tissue::LesionData& l = f->lesions[k];
    l.centre = get_vec(r);
    l.inv_axes = get_vec(r);
    l.size2 = r.get<double>();
    l.excess = r.get<double>();
  }
  f->pulse_count = r.get<std::uint32_t>();
  if (f->pulse_count > tissue::kMaxPulses)
    throw DecodeError(what + ": the field has " + std::to_string(f->pulse_count) + " pulses, at most " +
                      std::to_string(tissue::kMaxPulses));
  for (std::size_t p = 0; p < f->pulse_count; ++p) {
    f->pulses[p].rate_hz = r.get<double>();
    f->pulses[p].amplitude = r.get<double>();
    f->pulse_weight[p] = get_array<float>(r, kMaxVertices, what, "the field's pulse " + std::to_string(p) + " weights");
    if (f->pulse_weight[p].size() != n)
      throw DecodeError(what + ": the field's pulse " + std::to_string(p) + " has " +
                        std::to_string(f->pulse_weight[p].size()) + " weights, the mesh " + std::to_string(n) +
                        " vertices");
  }
  f->pulse_vertices = get_array<Index>(r, n, what, "the field's pulse vertices");
  for (Index v : f->pulse_vertices)
    if (v >= n) throw DecodeError(what + ": the field's pulse vertex " + std::to_string(v) + " is out of range");
  tissue::Breathing& b = f->breathing;
  b.enabled = get_flag(r, what, "the field's breathing flag");
  b.rate_bpm = r.get<double>();
  b.translation = get_vec(r);
  b.axis = get_vec(r);
  b.centre = get_vec(r);
  b.scale = r.get<double>();
  f->dynamic_count = r.get<std::uint32_t>();
  if (f->dynamic_count > tissue::kMaxDynamicRegions)
    throw DecodeError(what + ": the field has " + std::to_string(f->dynamic_count) + " dynamic regions, at most " +
                      std::to_string(tissue::kMaxDynamicRegions));
  for (std::size_t k = 0; k < f->dynamic_count; ++k) {
    auto& d = f->dynamic[k];
    d.keyframe_count = r.get<std::uint32_t>();
    if (d.keyframe_count > tissue::kMaxKeyframes)
      throw DecodeError(what + ": the field's dynamic region " + std::to_string(k) + " has " +
                        std::to_string(d.keyframe_count) + " keyframes, at most " +
                        std::to_string(tissue::kMaxKeyframes));
    for (std::size_t j = 0; j < d.keyframe_count; ++j) {
      d.keyframes[j].time = r.get<double>();
      d.keyframes[j].scale = r.get<double>();
      d.keyframes[j].ramp = r.get<double>();
    }
    d.guarding.enabled = get_flag(r, what, "a guarding flag");
    d.guarding.threshold = r.get<double>();
    d.guarding.factor = r.get<double>();
    d.guarding.duration = r.get<double>();
    d.guarding.release = r.get<double>();
    f->dynamic_weight[k] =
        get_array<float>(r, kMaxVertices, what, "the field's dynamic region " + std::to_string(k) + " weights");
    if (f->dynamic_weight[k].size() != n)
      throw DecodeError(what + ": the field's dynamic region " + std::to_string(k) + " has " +
                        std::to_string(f->dynamic_weight[k].size()) + " weights, the mesh " + std::to_string(n) +
                        " vertices");
  }
  return f;
}

void put_tissue(Writer& w, const haptics::TissueModel& t) {
  w.put<std::uint8_t>(t.map ? 1 : 0);
  if (t.map) put_tissue_map(w, *t.map);
  w.put<std::uint8_t>(t.field ? 1 : 0);
  if (t.field) put_field(w, *t.field);
}

// A tissue back, checked as the loop checks one it is given (validate_tissue).
std::shared_ptr<const haptics::TissueModel> get_tissue(Reader& r, std::size_t n, const std::string& what) {
  auto t = std::make_shared<haptics::TissueModel>();
  if (get_flag(r, what, "the tissue map flag")) t->map = get_tissue_map(r, n, what);
  if (get_flag(r, what, "the field flag")) t->field = get_field(r, n, what);
  try {
    haptics::validate_tissue(*t, n);
  } catch (const std::invalid_argument& e) {
    throw DecodeError(what + ": " + e.what());
  }
  return t;
}

}  // namespace

std::string layout_tag() {
  std::string s;
#if defined(__x86_64__)
  s = "x86_64";
#elif defined(__aarch64__)
  s = "aarch64";
#else
  s = "other";
#endif
  s += std::endian::native == std::endian::little ? "-le" : "-be";
  s += " CoreState=" + std::to_string(sizeof(haptics::CoreState));
  s += " LoopCommand=" + std::to_string(sizeof(haptics::LoopCommand));
  s += " Contact=" + std::to_string(sizeof(deform::Contact));
  s += " Material=" + std::to_string(sizeof(deform::Material));
  s += " Spec=" + std::to_string(sizeof(PalpaDeviceSpec));
  s += " Mapping=" + std::to_string(sizeof(haptics::DeviceMapping));
  s += " Safety=" + std::to_string(sizeof(haptics::SafetyLimits));
  s += " CoreConfig=" + std::to_string(sizeof(haptics::CoreConfig));
  return s;
}

std::vector<std::uint8_t> encode_materials(const deform::MaterialArrays& m) {
  Writer w;
  put_materials(w, m);
  return internal::pack(w.bytes(), kMaterialMagic);
}

deform::MaterialArrays decode_materials(std::span<const std::uint8_t> blob, std::size_t vertices) {
  const auto bytes = internal::unpack(blob, kMaterialMagic, "material map");
  Reader r(bytes, "material map");
  auto m = get_materials(r, vertices);
  if (!r.done()) throw DecodeError("material map has trailing bytes");
  return m;
}

namespace {

// A tissue map a snapshot names: 1 the core's tissue's, 2 the surface's
// tissue's, 3 written here.
void put_map_ref(Writer& w, const deform::MaterialMap* m, const haptics::TissueModel* core,
                 const haptics::TissueModel* surface) {
  if (core && core->map.get() == m) {
    w.put<std::uint8_t>(1);
  } else if (surface && surface->map.get() == m) {
    w.put<std::uint8_t>(2);
  } else {
    w.put<std::uint8_t>(3);
    put_tissue_map(w, *m);
  }
}

std::shared_ptr<const deform::MaterialMap> get_map_ref(Reader& r, std::size_t n, const haptics::SessionState& s) {
  const auto code = r.get<std::uint8_t>();
  if (code == 1 && s.tissue && s.tissue->map) return s.tissue->map;
  if (code == 2 && s.surface_tissue && s.surface_tissue->map) return s.surface_tissue->map;
  if (code == 3) return get_tissue_map(r, n, "snapshot");
  throw DecodeError("snapshot names a tissue map it does not hold (reference " + std::to_string(code) + ")");
}

// A material read from a snapshot, checked as the model checks one it is
// given (a damaged one would otherwise fail later, without the file's name).
deform::Material get_material(Reader& r, const std::string& what) {
  const auto m = r.get<deform::Material>();
  try {
    deform::validate_material(m, what);
  } catch (const std::invalid_argument& e) {
    throw DecodeError(std::string("snapshot: ") + e.what());
  }
  return m;
}

// A pending step's contacts, checked before a deformation step uses them:
// at most kMaxProbes, at vertices of the mesh, finite, a known shape with a
// radius > 0 (m).
void check_contacts(const haptics::ContactSet& set, std::size_t vertices) {
  if (set.count > haptics::kMaxProbes)
    throw DecodeError("snapshot has a pending step with " + std::to_string(set.count) + " contacts, at most " +
                      std::to_string(haptics::kMaxProbes));
  for (std::uint32_t i = 0; i < set.count; ++i) {
    const haptics::ContactRecord& c = set.contacts[i];
    const std::string which = "snapshot has a pending step whose contact " + std::to_string(i);
    if (c.vertex != kNoIndex && c.vertex >= vertices)
      throw DecodeError(which + " is at vertex " + std::to_string(c.vertex) + " of " + std::to_string(vertices));
    bool finite = std::isfinite(c.depth);
    for (int k = 0; k < 3; ++k) finite = finite && std::isfinite(c.point[k]) && std::isfinite(c.normal[k]);
    if (!finite) throw DecodeError(which + " has a position, normal or depth that is not finite");
    if (static_cast<unsigned>(c.shape.kind) > static_cast<unsigned>(deform::ShapeKind::VolumeConserving) ||
        !(c.shape.radius > 0) || !std::isfinite(c.shape.radius))
      throw DecodeError(which + " has an unknown shape or a radius that is not > 0 m");
  }
}

}  // namespace

bool storable(const std::deque<haptics::DeformRequest>& pending) {
  if (pending.size() > kMaxPendingSteps) return false;
  for (const auto& q : pending)
    if (q.edits.material > 1 || q.edits.map || q.edits.tissue_map || q.edits.tissue) return false;
  return true;
}

std::vector<std::uint8_t> encode_state(const haptics::SessionState& s,
                                       const std::deque<haptics::DeformRequest>& pending) {
  if (pending.size() > kMaxPendingSteps)
    throw std::invalid_argument("snapshot: " + std::to_string(pending.size()) + " pending deformation steps, at most " +
                                std::to_string(kMaxPendingSteps));
  if (!storable(pending))
    throw std::invalid_argument("snapshot: a pending deformation step with a material map or tissue edit");
  Writer w;
  w.put(s.tick);
  w.put(s.generation);
  w.put(s.model_time);
  // The core, its pointers replaced by what they point to.
  haptics::CoreState core = s.core;
  const deform::MaterialArrays* pending_map = core.pending.material == 2 ? core.pending.map : nullptr;
  const deform::MaterialMap* pending_tissue_map = core.pending.material == 3 ? core.pending.tissue_map : nullptr;
  const haptics::TissueModel* tissue = core.tissue;
  const haptics::TissueModel* surface_tissue = s.surface_tissue.get();
  if (core.pending.tissue && core.pending.tissue != tissue)
    throw std::invalid_argument("snapshot: the pending tissue is not the core's");
  if (core.pending.material == 3 && !pending_tissue_map)
    throw std::invalid_argument("snapshot: a pending tissue map edit without its map");
  core.pending.map = nullptr;
  core.pending.tissue_map = nullptr;
  core.pending.tissue = nullptr;
  core.tissue = nullptr;
  // The walks' prepared triangles are a cache of this process's mesh (they
  // hold its address): written empty, as a fresh cursor's.
  for (haptics::ProbeMemory& m : core.memory) m.cursor.frames = collision::FrameCache{};
  w.put(core);
  w.put<std::uint8_t>(pending_map ? 1 : 0);
  if (pending_map) put_materials(w, *pending_map);
  // The tissues (SetTissue's): the core's, whether it is still pending,
  // the surface's (0 the model's, 1 the core's, 2 written here), the
  // pending tissue map.
  w.put<std::uint8_t>(tissue ? 1 : 0);
  if (tissue) put_tissue(w, *tissue);
  w.put<std::uint8_t>(s.core.pending.tissue ? 1 : 0);
  w.put<std::uint8_t>(!surface_tissue ? 0 : surface_tissue == tissue ? 1 : 2);
  if (surface_tissue && surface_tissue != tissue) put_tissue(w, *surface_tissue);
  if (pending_tissue_map) put_map_ref(w, pending_tissue_map, tissue, surface_tissue);
  // The surface and the contacts of its last step.
  w.put(s.surface.time);
  w.put_vector(s.surface.vertices);
  w.put_vector(s.contacts);
  // The material in force: 0 uniform, 1 a map (inline), 2 the model's
  // tissue map, 3 a SetTissue's tissue map (a reference or inline).
  const haptics::MaterialSource& m = s.materials;
  if (m.uniform) {
    w.put<std::uint8_t>(0);
    w.put(m.material);
  } else if (m.tissue_map && !m.edited_tissue_map) {
    w.put<std::uint8_t>(2);
  } else if (m.tissue_map) {
    w.put<std::uint8_t>(3);
    put_map_ref(w, m.tissue_map.get(), tissue, surface_tissue);
  } else {
    const deform::MaterialArrays* map = m.map ? m.map.get() : m.map_ptr;
    if (!map) throw std::invalid_argument("snapshot: a per-vertex material source without its map");
    w.put<std::uint8_t>(1);
    put_materials(w, *map);
  }
  // A replay's pending steps (only when there are any: the bytes of a state
  // without them stay those of earlier builds).
  if (!pending.empty()) {
    w.put(static_cast<std::uint32_t>(pending.size()));
    for (const auto& q : pending) {
      w.put(q.generation);
      w.put(q.tick);
      w.put(q.time);
      w.put(q.dt);
      w.put(q.contacts);
      w.put<std::uint8_t>(q.edits.reset ? 1 : 0);
      w.put(q.edits.material);
      w.put(q.edits.uniform);
    }
  }
  return internal::pack(w.bytes(), kStateMagic);
}

DecodedState decode_state(std::span<const std::uint8_t> blob, const haptics::SessionModel& model) {
  const auto bytes = internal::unpack(blob, kStateMagic, "snapshot");
  Reader r(bytes, "snapshot");
  const std::size_t n = model.mesh->vertex_count();
  DecodedState d;
  haptics::SessionState& s = d.state;
  s.tick = r.get<std::uint64_t>();
  s.generation = r.get<std::uint64_t>();
  s.model_time = r.get<double>();
  s.core = r.get<haptics::CoreState>();
  // Its pointers were written as null; they are set from what follows. The
  // prepared triangles were written empty: whatever a file holds there is
  // dropped (a frame names its mesh by address, and its corners are used as
  // vertex indices).
  s.core.pending.map = nullptr;
  s.core.pending.tissue_map = nullptr;
  s.core.pending.tissue = nullptr;
  s.core.tissue = nullptr;
  for (haptics::ProbeMemory& m : s.core.memory) m.cursor.frames = collision::FrameCache{};
  if (s.core.pending.material > 3)
    throw DecodeError("snapshot has an unknown pending material edit " + std::to_string(s.core.pending.material));
  if (s.core.pending.material == 1) {
    try {
      deform::validate_material(s.core.pending.uniform, "its pending material edit");
    } catch (const std::invalid_argument& e) {
      throw DecodeError(std::string("snapshot: ") + e.what());
    }
  }
  if (r.get<std::uint8_t>() != 0) {
    d.pending_map = std::make_shared<const deform::MaterialArrays>(get_materials(r, n));
    s.core.pending.map = d.pending_map.get();
  } else if (s.core.pending.material == 2) {
    throw DecodeError("snapshot: a pending material map is missing");
  }
  if (get_flag(r, "snapshot", "the tissue flag")) {
    s.tissue = get_tissue(r, n, "snapshot: its tissue");
    s.core.tissue = s.tissue.get();
  }
  if (get_flag(r, "snapshot", "the pending tissue flag")) {
    if (!s.tissue) throw DecodeError("snapshot: a pending tissue edit without its tissue");
    s.core.pending.tissue = s.tissue.get();
  }
  const auto surface = r.get<std::uint8_t>();
  if (surface == 1) {
    if (!s.tissue) throw DecodeError("snapshot: its surface's tissue refers to a tissue it does not hold");
    s.surface_tissue = s.tissue;
  } else if (surface == 2) {
    s.surface_tissue = get_tissue(r, n, "snapshot: its surface's tissue");
  } else if (surface != 0) {
    throw DecodeError("snapshot has an unknown surface tissue code " + std::to_string(surface));
  }
  if (s.core.pending.material == 3) {
    s.pending_tissue_map = get_map_ref(r, n, s);
    s.core.pending.tissue_map = s.pending_tissue_map.get();
  }
  s.surface.time = r.get<double>();
  s.surface.vertices = r.get_vector<deform::VertexState>(kMaxVertices);
  if (s.surface.vertices.size() != n)
    throw DecodeError("snapshot has " + std::to_string(s.surface.vertices.size()) + " vertices, the mesh " +
                      std::to_string(n));
  s.contacts = r.get_vector<deform::Contact>(1u << 16);
  for (const auto& c : s.contacts)
    if (c.vertex != kNoIndex && c.vertex >= n) throw DecodeError("snapshot has a contact at a vertex out of range");
  const auto kind = r.get<std::uint8_t>();
  if (kind == 0) {
    s.materials.uniform = true;
    s.materials.material = get_material(r, "its material in force");
  } else if (kind == 1) {
    s.materials.uniform = false;
    s.materials.map = std::make_shared<const deform::MaterialArrays>(get_materials(r, n));
    s.materials.map_ptr = s.materials.map.get();
  } else if (kind == 2) {
    if (!model.tissue_map) throw DecodeError("snapshot uses a tissue map the session model lacks");
    s.materials.uniform = false;
    s.materials.tissue_map = model.tissue_map;
  } else if (kind == 3) {
    s.materials.uniform = false;
    s.materials.tissue_map = get_map_ref(r, n, s);
    s.materials.edited_tissue_map = true;
    try {
      haptics::validate_tissue(haptics::TissueModel{s.materials.tissue_map, nullptr}, n);
    } catch (const std::invalid_argument& e) {
      throw DecodeError(std::string("snapshot: its tissue map in force: ") + e.what());
    }
  } else {
    throw DecodeError("snapshot has an unknown material source " + std::to_string(kind));
  }
  if (s.core.pending.material == 3) {
    try {
      haptics::validate_tissue(haptics::TissueModel{s.pending_tissue_map, nullptr}, n);
    } catch (const std::invalid_argument& e) {
      throw DecodeError(std::string("snapshot: its pending tissue map: ") + e.what());
    }
  }
  if (!r.done()) {
    const auto count = r.get<std::uint32_t>();
    if (count == 0 || count > kMaxPendingSteps)
      throw DecodeError("snapshot has " + std::to_string(count) + " pending deformation steps (1 to " +
                        std::to_string(kMaxPendingSteps) + " expected)");
    for (std::uint32_t k = 0; k < count; ++k) {
      haptics::DeformRequest q;
      q.generation = r.get<std::uint64_t>();
      q.tick = r.get<std::uint64_t>();
      q.time = r.get<double>();
      q.dt = r.get<double>();
      q.contacts = r.get<haptics::ContactSet>();
      check_contacts(q.contacts, n);
      q.edits.reset = get_flag(r, "snapshot", "a pending step's reset flag");
      q.edits.material = r.get<std::uint8_t>();
      if (q.edits.material > 1)
        throw DecodeError("snapshot has a pending step with material edit " + std::to_string(q.edits.material) +
                          " (0 or 1 expected)");
      q.edits.uniform = q.edits.material == 1 ? get_material(r, "a pending step's material") : r.get<deform::Material>();
      d.pending.push_back(q);
    }
  }
  if (!r.done()) throw DecodeError("snapshot has trailing bytes");
  return d;
}

std::vector<std::uint8_t> encode_command(const haptics::LoopCommand& c) {
  Writer w;
  haptics::LoopCommand copy = c;
  copy.materials = nullptr;
  copy.tissue = nullptr;
  w.put(copy);
  const bool map = c.kind == haptics::LoopCommandKind::SetMaterialMap && c.materials != nullptr;
  w.put<std::uint8_t>(map ? 1 : 0);
  if (map) put_materials(w, *c.materials);
  const bool tissue = c.kind == haptics::LoopCommandKind::SetTissue && c.tissue != nullptr;
  w.put<std::uint8_t>(tissue ? 1 : 0);
  if (tissue) put_tissue(w, *c.tissue);
  return internal::pack(w.bytes(), kCommandMagic);
}

haptics::LoopCommand decode_command(std::span<const std::uint8_t> blob, std::size_t vertices,
                                    std::vector<std::shared_ptr<const deform::MaterialArrays>>& keep) {
  const auto bytes = internal::unpack(blob, kCommandMagic, "command");
  Reader r(bytes, "command");
  auto c = r.get<haptics::LoopCommand>();
  c.materials = nullptr;
  c.tissue = nullptr;
  if (static_cast<unsigned>(c.kind) > static_cast<unsigned>(haptics::LoopCommandKind::SetTissue))
    throw DecodeError("command has an unknown kind " + std::to_string(static_cast<unsigned>(c.kind)));
  if (r.get<std::uint8_t>() != 0) {
    keep.push_back(std::make_shared<const deform::MaterialArrays>(get_materials(r, vertices)));
    c.materials = keep.back().get();
  } else if (c.kind == haptics::LoopCommandKind::SetMaterialMap) {
    throw DecodeError("a material-map command without its map");
  }
  if (get_flag(r, "command", "the tissue flag")) {
    if (c.kind != haptics::LoopCommandKind::SetTissue) throw DecodeError("command: a tissue on a command that is not SetTissue");
    const auto tissue = get_tissue(r, vertices, "SetTissue command");
    // Kept by an aliasing pointer: it owns the tissue and points to no map.
    keep.push_back(std::shared_ptr<const deform::MaterialArrays>(tissue, nullptr));
    c.tissue = tissue.get();
  } else if (c.kind == haptics::LoopCommandKind::SetTissue) {
    throw DecodeError("a SetTissue command without its tissue");
  }
  if (!r.done()) throw DecodeError("command has trailing bytes");
  return c;
}

std::vector<std::uint8_t> encode_setup(const std::vector<haptics::ProbeSetup>& setups, const haptics::CoreConfig& config,
                                       const deform::SurfaceOptions& o) {
  Writer w;
  w.put(config);
  w.put(o.propagation);
  w.put(o.min_normal_cosine);
  w.put(o.limit_drawn_displacement);
  w.put(o.thickness_fraction);
  w.put(o.curvature_fraction);
  w.put(o.rest_threshold);
  w.put<std::uint8_t>(o.drawn_limits ? 1 : 0);
  if (o.drawn_limits) w.put_vector(*o.drawn_limits);
  w.put<std::uint64_t>(setups.size());
  for (const auto& s : setups) {
    w.put_string(s.name);
    w.put(s.spec);
    w.put(s.mapping);
    w.put(s.safety);
  }
  return internal::pack(w.bytes(), kSetupMagic);
}

void decode_setup(std::span<const std::uint8_t> blob, std::vector<haptics::ProbeSetup>& setups,
                  haptics::CoreConfig& config, deform::SurfaceOptions& o) {
  const auto bytes = internal::unpack(blob, kSetupMagic, "probe setup");
  Reader r(bytes, "probe setup");
  config = r.get<haptics::CoreConfig>();
  o.propagation = r.get<deform::Propagation>();
  o.min_normal_cosine = r.get<double>();
  o.limit_drawn_displacement = r.get<bool>();
  o.thickness_fraction = r.get<double>();
  o.curvature_fraction = r.get<double>();
  o.rest_threshold = r.get<double>();
  if (r.get<std::uint8_t>() != 0) o.drawn_limits = std::make_shared<const std::vector<double>>(r.get_vector<double>(kMaxVertices));
  const auto n = r.get<std::uint64_t>();
  if (n > haptics::kMaxProbes) throw DecodeError("probe setup has " + std::to_string(n) + " probes");
  setups.clear();
  for (std::uint64_t k = 0; k < n; ++k) {
    haptics::ProbeSetup s;
    s.name = r.get_string();
    s.spec = r.get<PalpaDeviceSpec>();
    s.mapping = r.get<haptics::DeviceMapping>();
    s.safety = r.get<haptics::SafetyLimits>();
    setups.push_back(std::move(s));
  }
  if (!r.done()) throw DecodeError("probe setup has trailing bytes");
}

}  // namespace palpa::record
