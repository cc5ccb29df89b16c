// Binary forms of the engine's plain data (state_io.h).

#include "record/state_io.h"

#include "record/internal_codec.h"

#include <bit>
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

std::vector<std::uint8_t> encode_state(const haptics::SessionState& s) {
  Writer w;
  w.put(s.tick);
  w.put(s.generation);
  w.put(s.model_time);
  // The core, its pending map's pointer replaced by the map itself.
  haptics::CoreState core = s.core;
  const deform::MaterialArrays* pending_map = core.pending.material == 2 ? core.pending.map : nullptr;
  core.pending.map = nullptr;
  w.put(core);
  w.put<std::uint8_t>(pending_map ? 1 : 0);
  if (pending_map) put_materials(w, *pending_map);
  // The surface and the contacts of its last step.
  w.put(s.surface.time);
  w.put_vector(s.surface.vertices);
  w.put_vector(s.contacts);
  // The material in force: 0 uniform, 1 a map (inline), 2 the model's tissue map.
  const haptics::MaterialSource& m = s.materials;
  if (m.uniform) {
    w.put<std::uint8_t>(0);
    w.put(m.material);
  } else if (m.tissue_map) {
    w.put<std::uint8_t>(2);
  } else {
    const deform::MaterialArrays* map = m.map ? m.map.get() : m.map_ptr;
    if (!map) throw std::invalid_argument("snapshot: a per-vertex material source without its map");
    w.put<std::uint8_t>(1);
    put_materials(w, *map);
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
  if (r.get<std::uint8_t>() != 0) {
    d.pending_map = std::make_shared<const deform::MaterialArrays>(get_materials(r, n));
    s.core.pending.map = d.pending_map.get();
  } else if (s.core.pending.material == 2) {
    throw DecodeError("snapshot: a pending material map is missing");
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
    s.materials.material = r.get<deform::Material>();
  } else if (kind == 1) {
    s.materials.uniform = false;
    s.materials.map = std::make_shared<const deform::MaterialArrays>(get_materials(r, n));
    s.materials.map_ptr = s.materials.map.get();
  } else if (kind == 2) {
    if (!model.tissue_map) throw DecodeError("snapshot uses a tissue map the session model lacks");
    s.materials.uniform = false;
    s.materials.tissue_map = model.tissue_map;
  } else {
    throw DecodeError("snapshot has an unknown material source " + std::to_string(kind));
  }
  if (!r.done()) throw DecodeError("snapshot has trailing bytes");
  return d;
}

std::vector<std::uint8_t> encode_command(const haptics::LoopCommand& c) {
  Writer w;
  haptics::LoopCommand copy = c;
  copy.materials = nullptr;
  w.put(copy);
  const bool map = c.kind == haptics::LoopCommandKind::SetMaterialMap && c.materials != nullptr;
  w.put<std::uint8_t>(map ? 1 : 0);
  if (map) put_materials(w, *c.materials);
  return internal::pack(w.bytes(), kCommandMagic);
}

haptics::LoopCommand decode_command(std::span<const std::uint8_t> blob, std::size_t vertices,
                                    std::vector<std::shared_ptr<const deform::MaterialArrays>>& keep) {
  const auto bytes = internal::unpack(blob, kCommandMagic, "command");
  Reader r(bytes, "command");
  auto c = r.get<haptics::LoopCommand>();
  if (static_cast<unsigned>(c.kind) > static_cast<unsigned>(haptics::LoopCommandKind::ResetSurface))
    throw DecodeError("command has an unknown kind " + std::to_string(static_cast<unsigned>(c.kind)));
  if (r.get<std::uint8_t>() != 0) {
    keep.push_back(std::make_shared<const deform::MaterialArrays>(get_materials(r, vertices)));
    c.materials = keep.back().get();
  } else if (c.kind == haptics::LoopCommandKind::SetMaterialMap) {
    throw DecodeError("a material-map command without its map");
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
