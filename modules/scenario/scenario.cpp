// The scenario file (docs/SCENARIO.md): reading with validation that names
// the file and the JSON pointer of every fault, writing in one canonical
// form (fixed key order, numbers rounded to 12 significant digits in file
// units), atomic saving, and the summary `palpa scenario check` prints.

#include "scenario/scenario.h"

#include "mesh/organ.h"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <openssl/evp.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <set>
#include <sstream>
#include <string_view>

namespace palpa::scenario {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

std::string what_of(const std::string& file, const std::string& pointer, const std::string& message) {
  if (pointer.empty()) return file + ": " + message;
  return file + ": " + pointer + ": " + message;
}

}  // namespace

ScenarioError::ScenarioError(const std::string& file, const std::string& pointer, const std::string& message)
    : std::runtime_error(what_of(file, pointer, message)), file_(file), pointer_(pointer), message_(message) {}

namespace {

// ---------------------------------------------------------------------------
// Names of enumerations as the file writes them.

constexpr const char* kVisibilityNames[] = {"hidden", "shown", "after_exam"};
constexpr const char* kShapeNames[] = {"gaussian", "wendland", "volume_conserving"};
constexpr const char* kRegionKindNames[] = {"sphere",        "ellipsoid",    "box",          "half_space",
                                            "geodesic_disk", "vertex_array", "planar_image", "cylindrical_image"};
constexpr const char* kUnitNames[] = {"m", "cm", "mm"};

template <std::size_t N>
std::string join_names(const char* const (&names)[N], const char* sep = ", ") {
  std::string out;
  for (std::size_t i = 0; i < N; ++i) out += (i ? sep : "") + std::string(names[i]);
  return out;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) out += (i ? ", " : "") + names[i];
  return out;
}

// A JSON value as the message shows it (compact, cut at 60 characters).
std::string shown(const Json& v) {
  std::string s = v.dump();
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

// JSON pointer of a child (RFC 6901 escapes).
std::string child(const std::string& ptr, const std::string& key) {
  std::string k;
  for (char c : key) {
    if (c == '~') k += "~0";
    else if (c == '/') k += "~1";
    else k += c;
  }
  return ptr + "/" + k;
}
std::string child(const std::string& ptr, std::size_t index) { return ptr + "/" + std::to_string(index); }

// ---------------------------------------------------------------------------
// The reader: every check names the pointer, what was expected and what was found.

class Reader {
 public:
  Reader(std::string file, fs::path dir) : file_(std::move(file)), dir_(std::move(dir)) {}

  [[noreturn]] void fail(const std::string& ptr, const std::string& message) const {
    throw ScenarioError(file_, ptr, message);
  }
  [[noreturn]] void expected(const std::string& ptr, const std::string& what, const Json& got) const {
    fail(ptr, "expected " + what + ", got " + shown(got));
  }

  // An object whose keys are all in `allowed`.
  void object(const Json& v, const std::string& ptr, std::initializer_list<const char*> allowed) const {
    if (!v.is_object()) expected(ptr, "an object", v);
    for (auto it = v.begin(); it != v.end(); ++it) {
      bool ok = false;
      for (const char* a : allowed) ok |= it.key() == a;
      if (!ok) {
        std::string list;
        for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        fail(child(ptr, it.key()), "unknown key (expected one of: " + list + ")");
      }
    }
  }
  const Json* find(const Json& obj, const char* key) const {
    auto it = obj.find(key);
    return it == obj.end() ? nullptr : &*it;
  }
  const Json& need(const Json& obj, const std::string& ptr, const char* key) const {
    const Json* v = find(obj, key);
    if (!v) fail(ptr, std::string("missing required key \"") + key + "\"");
    return *v;
  }

  // Numbers with a condition; `what` says what was expected ("a positive number of millimetres").
  double number(const Json& v, const std::string& ptr, const std::string& what,
                const std::function<bool(double)>& ok) const {
    if (!v.is_number()) expected(ptr, what, v);
    double x = v.get<double>();
    if (!std::isfinite(x) || !ok(x)) expected(ptr, what, v);
    return x;
  }
  double positive(const Json& v, const std::string& ptr, const std::string& unit) const {
    return number(v, ptr, "a positive number" + unit, [](double x) { return x > 0; });
  }
  double non_negative(const Json& v, const std::string& ptr, const std::string& unit) const {
    return number(v, ptr, "a number >= 0" + unit, [](double x) { return x >= 0; });
  }
  double any(const Json& v, const std::string& ptr, const std::string& unit) const {
    return number(v, ptr, "a number" + unit, [](double) { return true; });
  }
  std::uint64_t unsigned_integer(const Json& v, const std::string& ptr, const std::string& what) const {
    if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0)) expected(ptr, what, v);
    return v.get<std::uint64_t>();
  }
  std::string string(const Json& v, const std::string& ptr, const std::string& what = "a string") const {
    if (!v.is_string()) expected(ptr, what, v);
    return v.get<std::string>();
  }
  std::string name(const Json& v, const std::string& ptr) const {
    std::string s = string(v, ptr, "a non-empty name");
    if (s.empty()) expected(ptr, "a non-empty name", v);
    return s;
  }
  bool boolean(const Json& v, const std::string& ptr) const {
    if (!v.is_boolean()) expected(ptr, "true or false", v);
    return v.get<bool>();
  }
  // Three numbers, scaled by `factor` to SI.
  Vec3 vec3(const Json& v, const std::string& ptr, const std::string& unit, double factor) const {
    const std::string what = "an array of 3 numbers" + unit;
    if (!v.is_array() || v.size() != 3) expected(ptr, what, v);
    Vec3 out;
    for (int i = 0; i < 3; ++i) {
      if (!v[i].is_number() || !std::isfinite(v[i].get<double>())) expected(ptr, what, v);
      out[i] = v[i].get<double>() * factor;
    }
    return out;
  }
  Vec3 positive_vec3(const Json& v, const std::string& ptr, const std::string& unit, double factor) const {
    const std::string what = "an array of 3 positive numbers" + unit;
    if (!v.is_array() || v.size() != 3) expected(ptr, what, v);
    for (int i = 0; i < 3; ++i)
      if (!v[i].is_number() || !(v[i].get<double>() > 0) || !std::isfinite(v[i].get<double>())) expected(ptr, what, v);
    return vec3(v, ptr, unit, factor);
  }
  // A direction: three numbers, not all zero; normalised.
  Vec3 direction(const Json& v, const std::string& ptr) const {
    const std::string what = "a direction (an array of 3 numbers, not all 0)";
    if (!v.is_array() || v.size() != 3) expected(ptr, what, v);
    Vec3 d = vec3(v, ptr, " (a direction, not all 0)", 1.0);
    if (!(d.norm() > 0)) expected(ptr, what, v);
    return d / d.norm();
  }
  // A [min, max] range with min <= max, each passing `ok`.
  std::pair<double, double> range(const Json& v, const std::string& ptr, const std::string& what_each,
                                  const std::function<bool(double)>& ok) const {
    const std::string what = "[min, max] with min <= max, each " + what_each;
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number()) expected(ptr, what, v);
    double a = v[0].get<double>(), b = v[1].get<double>();
    if (!ok(a) || !ok(b) || a > b) expected(ptr, what, v);
    return {a, b};
  }
  template <std::size_t N>
  std::size_t choice(const Json& v, const std::string& ptr, const char* const (&names)[N]) const {
    const std::string what = "one of " + join_names(names);
    if (!v.is_string()) expected(ptr, what, v);
    for (std::size_t i = 0; i < N; ++i)
      if (v.get<std::string>() == names[i]) return i;
    expected(ptr, what, v);
  }
  // A path relative to the scenario file's folder, made absolute; the file must exist.
  fs::path existing_file(const Json& v, const std::string& ptr) const {
    std::string s = string(v, ptr, "a file path (relative to the scenario file)");
    if (s.empty()) expected(ptr, "a file path (relative to the scenario file)", v);
    fs::path p = fs::path(s).is_absolute() ? fs::path(s).lexically_normal() : (dir_ / s).lexically_normal();
    std::error_code ec;
    auto st = fs::status(p, ec);
    if (ec || !fs::exists(st)) fail(ptr, "file not found: " + p.string());
    if (!fs::is_regular_file(st)) fail(ptr, "not a regular file: " + p.string());
    return p;
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
  fs::path dir_;
};

// SHA-256 of a file's bytes, lower-case hex (OpenSSL's libcrypto).
std::string sha256_of(const fs::path& path, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = std::strerror(errno);
    return {};
  }
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  std::vector<char> buf(1 << 16);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    if (in.gcount() > 0) EVP_DigestUpdate(ctx, buf.data(), static_cast<std::size_t>(in.gcount()));
  }
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned len = 0;
  EVP_DigestFinal_ex(ctx, md, &len);
  EVP_MD_CTX_free(ctx);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned i = 0; i < len; ++i) {
    out += hex[md[i] >> 4];
    out += hex[md[i] & 15];
  }
  return out;
}

constexpr double kMm = 1e-3;    // m per mm
constexpr double kKpa = 1e3;    // Pa per kPa
const std::string kMmUnit = " of millimetres";

// ---------------------------------------------------------------------------
// Sections of the file, read in the order they are written.

// The organ's "prep" object: one rule per number (file units: mm, degrees,
// fractions, counts), shared by the reader and prep_spec_error().
struct PrepRule {
  const char* key;
  const char* what;
  double lo, hi;
  bool lo_open, hi_open, integer;
};
constexpr PrepRule kPrepRules[] = {
    {"edge_mm", "a length from 0.1 to 100 millimetres", kMinPrepEdge * 1e3, kMaxPrepEdge * 1e3, false, false, false},
    {"probe_radius_mm", "a positive length up to 100 millimetres", 0, kMaxPrepProbeRadius * 1e3, true, false, false},
    {"lesion_radius_mm", "a positive length up to 100 millimetres", 0, kMaxPrepProbeRadius * 1e3, true, false, false},
    {"speck_area_fraction", "a fraction in [0, 1)", 0, 1, false, true, false},
    {"max_hole_area_fraction", "a fraction in (0, 1]", 0, 1, true, false, false},
    {"remesh_iterations", "an integer from 1 to 50", 1, 50, false, false, true},
    {"relaxation_steps", "an integer from 0 to 50", 0, 50, false, false, true},
    {"feature_angle_deg", "an angle in [0, 180) degrees (0: no creases)", 0, 180, false, true, false},
    {"refine_rounds", "an integer from 0 to 10", 0, 10, false, false, true},
    {"fit_rounds", "an integer from 0 to 10", 0, 10, false, false, true},
    {"fit_factor", "a factor in (0, 1)", 0, 1, true, true, false},
    {"fit_max_triangles", "an integer from 1000 to 5000000", 1000, 5e6, false, false, true},
};

bool prep_ok(const PrepRule& rule, double x) {
  if (!std::isfinite(x) || (rule.integer && x != std::floor(x))) return false;
  return (rule.lo_open ? x > rule.lo : x >= rule.lo) && (rule.hi_open ? x < rule.hi : x <= rule.hi);
}

// A PrepSpec's value of a rule's key, in file units.
double prep_value(const PrepSpec& p, std::string_view key) {
  if (key == "edge_mm") return p.edge * 1e3;
  if (key == "probe_radius_mm") return p.probe_radius * 1e3;
  if (key == "lesion_radius_mm") return p.lesion_radius * 1e3;
  if (key == "speck_area_fraction") return p.speck_area_fraction;
  if (key == "max_hole_area_fraction") return p.max_hole_area_fraction;
  if (key == "remesh_iterations") return p.remesh_iterations;
  if (key == "relaxation_steps") return p.relaxation_steps;
  if (key == "feature_angle_deg") return p.feature_angle_deg;
  if (key == "refine_rounds") return p.refine_rounds;
  if (key == "fit_rounds") return p.fit_rounds;
  if (key == "fit_factor") return p.fit_factor;
  return static_cast<double>(p.fit_max_triangles);  // fit_max_triangles
}

void set_prep_value(PrepSpec& p, std::string_view key, double x) {
  if (key == "edge_mm") p.edge = x * 1e-3;
  else if (key == "probe_radius_mm") p.probe_radius = x * 1e-3;
  else if (key == "lesion_radius_mm") p.lesion_radius = x * 1e-3;
  else if (key == "speck_area_fraction") p.speck_area_fraction = x;
  else if (key == "max_hole_area_fraction") p.max_hole_area_fraction = x;
  else if (key == "remesh_iterations") p.remesh_iterations = static_cast<int>(x);
  else if (key == "relaxation_steps") p.relaxation_steps = static_cast<int>(x);
  else if (key == "feature_angle_deg") p.feature_angle_deg = x;
  else if (key == "refine_rounds") p.refine_rounds = static_cast<int>(x);
  else if (key == "fit_rounds") p.fit_rounds = static_cast<int>(x);
  else if (key == "fit_factor") p.fit_factor = x;
  else p.fit_max_triangles = static_cast<std::uint64_t>(x);
}

const char* const kPrepLengthChoice = "missing required key \"edge_mm\" (or \"probe_radius_mm\")";
const char* const kPrepLengthBoth = "expected \"edge_mm\" or \"probe_radius_mm\", not both";
const char* const kPrepLesionWithEdge =
    "\"lesion_radius_mm\" chooses the edge with \"probe_radius_mm\"; with \"edge_mm\" the edge is given";

PrepSpec read_prep(const Reader& r, const Json& v, const std::string& ptr) {
  r.object(v, ptr,
           {"edge_mm", "probe_radius_mm", "lesion_radius_mm", "speck_area_fraction", "max_hole_area_fraction", "autorefine", "local_repair",
            "remesh_iterations", "relaxation_steps", "feature_angle_deg", "refine_rounds", "fit_rounds", "fit_factor",
            "fit_max_triangles"});
  const bool edge = r.find(v, "edge_mm") != nullptr, probe = r.find(v, "probe_radius_mm") != nullptr;
  if (!edge && !probe) r.fail(ptr, kPrepLengthChoice);
  if (edge && probe) r.fail(ptr, kPrepLengthBoth);
  if (edge && r.find(v, "lesion_radius_mm")) r.fail(ptr, kPrepLesionWithEdge);
  PrepSpec p;
  for (const PrepRule& rule : kPrepRules) {
    const Json* x = r.find(v, rule.key);
    if (!x) continue;
    const std::string kp = child(ptr, rule.key);
    if (rule.integer && !x->is_number_integer()) r.expected(kp, rule.what, *x);
    set_prep_value(p, rule.key, r.number(*x, kp, rule.what, [&](double n) { return prep_ok(rule, n); }));
  }
  if (const Json* x = r.find(v, "autorefine")) p.autorefine = r.boolean(*x, child(ptr, "autorefine"));
  if (const Json* x = r.find(v, "local_repair")) p.local_repair = r.boolean(*x, child(ptr, "local_repair"));
  return p;
}

OrganRef read_organ(const Reader& r, const Json& v, const std::string& ptr) {
  r.object(v, ptr, {"path", "unit", "sha256", "prep"});
  OrganRef o;
  const std::string pp = child(ptr, "path");
  o.path = r.string(r.need(v, ptr, "path"), pp, "a file path (relative to the scenario file) or \"default\"");
  if (o.path.empty()) r.expected(pp, "a file path (relative to the scenario file) or \"default\"", v["path"]);
  if (const Json* u = r.find(v, "unit")) o.unit = kUnitNames[r.choice(*u, child(ptr, "unit"), kUnitNames)];
  if (o.path == "default") {
    o.resolved = mesh::default_organ_path();
    if (!r.find(v, "unit")) o.unit = "m";
    if (o.unit != "m") r.expected(child(ptr, "unit"), "\"m\" for the bundled organ (it is in metres)", v["unit"]);
  } else {
    o.resolved = r.existing_file(v["path"], pp);
  }
  if (const Json* h = r.find(v, "sha256")) {
    const std::string hp = child(ptr, "sha256");
    std::string s = r.string(*h, hp, "64 hexadecimal digits");
    bool ok = s.size() == 64 && std::all_of(s.begin(), s.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
    if (!ok) r.expected(hp, "64 hexadecimal digits", *h);
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    o.sha256 = s;
    std::string error;
    std::string actual = sha256_of(o.resolved, &error);
    if (actual.empty()) r.fail(hp, "cannot read " + o.resolved.string() + " to check it: " + error);
    if (actual != s) r.fail(hp, "expected " + s + " (the SHA-256 given), got " + actual + " for " + o.resolved.string());
  }
  if (const Json* p = r.find(v, "prep")) o.prep = read_prep(r, *p, child(ptr, "prep"));
  return o;
}

ProbeSpec read_probe(const Reader& r, const Json& v, const std::string& ptr) {
  r.object(v, ptr, {"tip_radius_mm", "shape"});
  ProbeSpec p;
  if (const Json* t = r.find(v, "tip_radius_mm")) p.tip_radius = r.positive(*t, child(ptr, "tip_radius_mm"), kMmUnit) * kMm;
  if (const Json* s = r.find(v, "shape")) {
    const std::string sp = child(ptr, "shape");
    r.object(*s, sp, {"kind", "radius_mm"});
    if (const Json* k = r.find(*s, "kind"))
      p.shape.kind = static_cast<deform::ShapeKind>(r.choice(*k, child(sp, "kind"), kShapeNames));
    if (const Json* rad = r.find(*s, "radius_mm")) p.shape.radius = r.positive(*rad, child(sp, "radius_mm"), kMmUnit) * kMm;
  }
  return p;
}

// One tissue: a preset with overrides, or explicit values (youngs_modulus_kpa required).
tissue::Tissue read_tissue(const Reader& r, const Json& v, const std::string& ptr, std::string* preset_key) {
  r.object(v, ptr,
           {"name", "preset", "youngs_modulus_kpa", "poisson", "damping_ratio", "relaxation_time_s",
            "relaxation_fraction", "stiffening_per_mm", "source"});
  tissue::Tissue t;
  if (const Json* p = r.find(v, "preset")) {
    const std::string pp = child(ptr, "preset");
    std::string key = r.string(*p, pp, "a preset name");
    const tissue::Preset* found = nullptr;
    std::vector<std::string> keys;
    try {
      found = tissue::find_preset(key);
      for (const auto& pr : tissue::presets()) keys.push_back(pr.key);
    } catch (const std::exception& e) {
      r.fail(pp, std::string("cannot read the tissue presets: ") + e.what());
    }
    if (!found) r.fail(pp, "unknown preset " + shown(*p) + " (expected one of: " + join(keys) + ")");
    t = found->tissue;
    *preset_key = key;
  } else if (!r.find(v, "youngs_modulus_kpa")) {
    r.fail(ptr, "missing required key \"youngs_modulus_kpa\" (or \"preset\")");
  }
  t.name = r.name(r.need(v, ptr, "name"), child(ptr, "name"));
  if (const Json* x = r.find(v, "youngs_modulus_kpa"))
    t.youngs_modulus = r.positive(*x, child(ptr, "youngs_modulus_kpa"), " of kilopascals") * kKpa;
  if (const Json* x = r.find(v, "poisson"))
    t.poisson = r.number(*x, child(ptr, "poisson"), "a number in [0, 0.5)", [](double n) { return n >= 0 && n < 0.5; });
  if (const Json* x = r.find(v, "damping_ratio")) t.damping_ratio = r.non_negative(*x, child(ptr, "damping_ratio"), "");
  if (const Json* x = r.find(v, "relaxation_time_s"))
    t.relaxation_time = r.non_negative(*x, child(ptr, "relaxation_time_s"), " of seconds");
  if (const Json* x = r.find(v, "relaxation_fraction"))
    t.relaxation_fraction = r.non_negative(*x, child(ptr, "relaxation_fraction"), "");
  if (const Json* x = r.find(v, "stiffening_per_mm"))
    t.stiffening = r.non_negative(*x, child(ptr, "stiffening_per_mm"), " per millimetre") / kMm;
  if (const Json* x = r.find(v, "source")) t.source = r.string(*x, child(ptr, "source"));
  return t;
}

// A reference to a named tissue or region.
std::string reference(const Reader& r, const Json& v, const std::string& ptr, const std::vector<std::string>& names,
                      const char* what) {
  std::string s = r.string(v, ptr, std::string("the name of a ") + what);
  if (std::find(names.begin(), names.end(), s) == names.end())
    r.fail(ptr, std::string("unknown ") + what + " " + shown(v) + " (expected one of: " + join(names) + ")");
  return s;
}

tissue::Region read_region(const Reader& r, const Json& v, const std::string& ptr,
                           const std::vector<std::string>& tissue_names) {
  using tissue::RegionKind;
  if (!v.is_object()) r.expected(ptr, "an object", v);
  tissue::Region g;
  const auto kind = static_cast<RegionKind>(r.choice(r.need(v, ptr, "kind"), child(ptr, "kind"), kRegionKindNames));
  g.kind = kind;
  // Keys by kind: the geometry, then the effect.
  switch (kind) {
    case RegionKind::Sphere:
    case RegionKind::GeodesicDisk:
      r.object(v, ptr, {"name", "kind", "centre_mm", "radius_mm", "feather_mm", "tissue", "scale"});
      break;
    case RegionKind::Ellipsoid:
      r.object(v, ptr, {"name", "kind", "centre_mm", "semi_axes_mm", "feather_mm", "tissue", "scale"});
      break;
    case RegionKind::Box:
      r.object(v, ptr, {"name", "kind", "min_mm", "max_mm", "feather_mm", "tissue", "scale"});
      break;
    case RegionKind::HalfSpace:
      r.object(v, ptr, {"name", "kind", "point_mm", "normal", "feather_mm", "tissue", "scale"});
      break;
    case RegionKind::VertexArray:
      r.object(v, ptr, {"name", "kind", "file", "array", "label_tissues", "scale_min", "scale_max"});
      break;
    case RegionKind::PlanarImage:
      r.object(v, ptr, {"name", "kind", "file", "origin_mm", "u_axis_mm", "v_axis_mm", "scale_min", "scale_max"});
      break;
    case RegionKind::CylindricalImage:
      r.object(v, ptr,
               {"name", "kind", "file", "origin_mm", "axis", "reference", "height_mm", "scale_min", "scale_max"});
      break;
  }
  g.name = r.name(r.need(v, ptr, "name"), child(ptr, "name"));
  auto need = [&](const char* key) -> const Json& { return r.need(v, ptr, key); };
  switch (kind) {
    case RegionKind::Sphere:
    case RegionKind::GeodesicDisk:
      g.centre = r.vec3(need("centre_mm"), child(ptr, "centre_mm"), kMmUnit, kMm);
      g.radius = r.positive(need("radius_mm"), child(ptr, "radius_mm"), kMmUnit) * kMm;
      break;
    case RegionKind::Ellipsoid:
      g.centre = r.vec3(need("centre_mm"), child(ptr, "centre_mm"), kMmUnit, kMm);
      g.semi_axes = r.positive_vec3(need("semi_axes_mm"), child(ptr, "semi_axes_mm"), kMmUnit, kMm);
      break;
    case RegionKind::Box: {
      g.box_min = r.vec3(need("min_mm"), child(ptr, "min_mm"), kMmUnit, kMm);
      g.box_max = r.vec3(need("max_mm"), child(ptr, "max_mm"), kMmUnit, kMm);
      if (!(g.box_min.array() < g.box_max.array()).all())
        r.expected(child(ptr, "max_mm"), "every coordinate above min_mm's", v["max_mm"]);
      break;
    }
    case RegionKind::HalfSpace:
      g.point = r.vec3(need("point_mm"), child(ptr, "point_mm"), kMmUnit, kMm);
      g.normal = r.direction(need("normal"), child(ptr, "normal"));
      break;
    case RegionKind::VertexArray:
    case RegionKind::PlanarImage:
    case RegionKind::CylindricalImage:
      g.file = r.existing_file(need("file"), child(ptr, "file"));
      break;
  }
  if (kind == RegionKind::VertexArray) {
    g.array = r.name(need("array"), child(ptr, "array"));
    if (const Json* l = r.find(v, "label_tissues")) {
      const std::string lp = child(ptr, "label_tissues");
      if (!l->is_object() || l->empty()) r.expected(lp, "an object mapping integer labels to tissue names", *l);
      for (auto it = l->begin(); it != l->end(); ++it) {
        const std::string kp = child(lp, it.key());
        char* end = nullptr;
        errno = 0;
        long label = std::strtol(it.key().c_str(), &end, 10);
        if (it.key().empty() || *end != '\0' || errno != 0 || label < INT32_MIN || label > INT32_MAX ||
            std::to_string(label) != it.key())
          r.fail(kp, "expected an integer label, got \"" + it.key() + "\"");
        g.label_tissues[static_cast<int>(label)] = reference(r, it.value(), kp, tissue_names, "tissue");
      }
      if (r.find(v, "scale_min") || r.find(v, "scale_max"))
        r.fail(ptr, "expected \"label_tissues\" or \"scale_min\"/\"scale_max\", not both");
    }
  }
  if (kind == RegionKind::PlanarImage) {
    g.origin = r.vec3(need("origin_mm"), child(ptr, "origin_mm"), kMmUnit, kMm);
    g.u_axis = r.vec3(need("u_axis_mm"), child(ptr, "u_axis_mm"), kMmUnit, kMm);
    g.v_axis = r.vec3(need("v_axis_mm"), child(ptr, "v_axis_mm"), kMmUnit, kMm);
    if (!(g.u_axis.cross(g.v_axis).norm() > 0))
      r.expected(child(ptr, "v_axis_mm"), "an axis not parallel to u_axis_mm (and neither zero)", v["v_axis_mm"]);
  }
  if (kind == RegionKind::CylindricalImage) {
    g.origin = r.vec3(need("origin_mm"), child(ptr, "origin_mm"), kMmUnit, kMm);
    g.axis = r.direction(need("axis"), child(ptr, "axis"));
    g.reference = r.direction(need("reference"), child(ptr, "reference"));
    if (std::abs(g.axis.dot(g.reference)) > 1e-6)
      r.expected(child(ptr, "reference"), "a direction perpendicular to \"axis\"", v["reference"]);
    g.height = r.positive(need("height_mm"), child(ptr, "height_mm"), kMmUnit) * kMm;
  }
  if (kind >= RegionKind::VertexArray) {
    if (const Json* x = r.find(v, "scale_min")) g.scale_min = r.positive(*x, child(ptr, "scale_min"), "");
    if (const Json* x = r.find(v, "scale_max")) g.scale_max = r.positive(*x, child(ptr, "scale_max"), "");
  } else {
    if (const Json* x = r.find(v, "feather_mm")) g.feather = r.non_negative(*x, child(ptr, "feather_mm"), kMmUnit) * kMm;
    const Json* t = r.find(v, "tissue");
    const Json* s = r.find(v, "scale");
    if ((t == nullptr) == (s == nullptr)) r.fail(ptr, "expected exactly one of \"tissue\" or \"scale\"");
    if (t) g.tissue = reference(r, *t, child(ptr, "tissue"), tissue_names, "tissue");
    if (s) g.scale = r.positive(*s, child(ptr, "scale"), "");
  }
  return g;
}

LesionSpec read_lesion(const Reader& r, const Json& v, const std::string& ptr) {
  r.object(v, ptr,
           {"name", "centre_mm", "surface_point_mm", "depth_mm", "radius_mm", "semi_axes_mm", "modulus_ratio",
            "visibility"});
  LesionSpec l;
  if (const Json* n = r.find(v, "name")) l.lesion.name = r.string(*n, child(ptr, "name"));
  const Json* c = r.find(v, "centre_mm");
  const Json* sp = r.find(v, "surface_point_mm");
  if ((c == nullptr) == (sp == nullptr)) r.fail(ptr, "expected exactly one of \"centre_mm\" or \"surface_point_mm\"");
  if (c) {
    l.lesion.centre = r.vec3(*c, child(ptr, "centre_mm"), kMmUnit, kMm);
    if (r.find(v, "depth_mm")) r.fail(child(ptr, "depth_mm"), "allowed only with \"surface_point_mm\"");
  } else {
    l.from_surface = true;
    l.surface_point = r.vec3(*sp, child(ptr, "surface_point_mm"), kMmUnit, kMm);
    l.depth = r.positive(r.need(v, ptr, "depth_mm"), child(ptr, "depth_mm"), kMmUnit) * kMm;
  }
  const Json* rad = r.find(v, "radius_mm");
  const Json* ax = r.find(v, "semi_axes_mm");
  if ((rad == nullptr) == (ax == nullptr)) r.fail(ptr, "expected exactly one of \"radius_mm\" or \"semi_axes_mm\"");
  if (rad) l.lesion.semi_axes = Vec3::Constant(r.positive(*rad, child(ptr, "radius_mm"), kMmUnit) * kMm);
  else l.lesion.semi_axes = r.positive_vec3(*ax, child(ptr, "semi_axes_mm"), kMmUnit, kMm);
  l.lesion.modulus_ratio = r.positive(r.need(v, ptr, "modulus_ratio"), child(ptr, "modulus_ratio"), "");
  if (const Json* vis = r.find(v, "visibility"))
    l.lesion.visibility = static_cast<tissue::Visibility>(r.choice(*vis, child(ptr, "visibility"), kVisibilityNames));
  return l;
}

RandomLesions read_random(const Reader& r, const Json& v, const std::string& ptr,
                          const std::vector<std::string>& region_names) {
  r.object(v, ptr, {"count", "seed", "radius_mm", "depth_mm", "modulus_ratio", "region", "visibility"});
  RandomLesions g;
  g.count = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(r.unsigned_integer(r.need(v, ptr, "count"), child(ptr, "count"), "an integer >= 0"),
                              UINT32_MAX));
  if (const Json* s = r.find(v, "seed")) g.seed = r.unsigned_integer(*s, child(ptr, "seed"), "an integer >= 0");
  auto pos = [](double x) { return std::isfinite(x) && x > 0; };
  if (const Json* x = r.find(v, "radius_mm")) {
    auto [a, b] = r.range(*x, child(ptr, "radius_mm"), "a positive number of millimetres", pos);
    g.radius_min = a * kMm, g.radius_max = b * kMm;
  }
  if (const Json* x = r.find(v, "depth_mm")) {
    auto [a, b] = r.range(*x, child(ptr, "depth_mm"), "a positive number of millimetres", pos);
    g.depth_min = a * kMm, g.depth_max = b * kMm;
  }
  if (const Json* x = r.find(v, "modulus_ratio")) {
    auto [a, b] = r.range(*x, child(ptr, "modulus_ratio"), "a positive number", pos);
    g.ratio_min = a, g.ratio_max = b;
  }
  if (const Json* x = r.find(v, "region")) g.region = reference(r, *x, child(ptr, "region"), region_names, "region");
  if (const Json* x = r.find(v, "visibility"))
    g.visibility = static_cast<tissue::Visibility>(r.choice(*x, child(ptr, "visibility"), kVisibilityNames));
  return g;
}

tissue::Pulse read_pulse(const Reader& r, const Json& v, const std::string& ptr) {
  r.object(v, ptr, {"name", "path_mm", "radius_mm", "rate_bpm", "amplitude_mm"});
  tissue::Pulse p;
  if (const Json* n = r.find(v, "name")) p.name = r.string(*n, child(ptr, "name"));
  const std::string pp = child(ptr, "path_mm");
  const Json& path = r.need(v, ptr, "path_mm");
  if (!path.is_array() || path.size() < 2) r.expected(pp, "an array of at least 2 points (each 3 numbers of millimetres)", path);
  for (std::size_t i = 0; i < path.size(); ++i) p.path.push_back(r.vec3(path[i], child(pp, i), kMmUnit, kMm));
  p.radius = r.positive(r.need(v, ptr, "radius_mm"), child(ptr, "radius_mm"), kMmUnit) * kMm;
  p.rate_bpm = r.positive(r.need(v, ptr, "rate_bpm"), child(ptr, "rate_bpm"), " of beats per minute");
  p.amplitude = r.positive(r.need(v, ptr, "amplitude_mm"), child(ptr, "amplitude_mm"), kMmUnit) * kMm;
  return p;
}

tissue::Breathing read_breathing(const Reader& r, const Json& v, const std::string& ptr) {
  r.object(v, ptr, {"enabled", "rate_bpm", "translation_mm", "axis", "centre_mm", "scale"});
  tissue::Breathing b;
  b.enabled = true;
  if (const Json* x = r.find(v, "enabled")) b.enabled = r.boolean(*x, child(ptr, "enabled"));
  if (const Json* x = r.find(v, "rate_bpm")) b.rate_bpm = r.positive(*x, child(ptr, "rate_bpm"), " of breaths per minute");
  if (const Json* x = r.find(v, "translation_mm")) b.translation = r.vec3(*x, child(ptr, "translation_mm"), kMmUnit, kMm);
  if (const Json* x = r.find(v, "axis")) b.axis = r.direction(*x, child(ptr, "axis"));
  if (const Json* x = r.find(v, "centre_mm")) b.centre = r.vec3(*x, child(ptr, "centre_mm"), kMmUnit, kMm);
  if (const Json* x = r.find(v, "scale"))
    b.scale = r.number(*x, child(ptr, "scale"), "a fraction in (-1, 1)", [](double s) { return s > -1 && s < 1; });
  return b;
}

tissue::DynamicRegion read_dynamic(const Reader& r, const Json& v, const std::string& ptr,
                                   const std::vector<std::string>& region_names) {
  r.object(v, ptr, {"region", "keyframes", "guarding"});
  tissue::DynamicRegion d;
  d.region = reference(r, r.need(v, ptr, "region"), child(ptr, "region"), region_names, "region");
  if (const Json* k = r.find(v, "keyframes")) {
    const std::string kp = child(ptr, "keyframes");
    if (!k->is_array()) r.expected(kp, "an array of keyframes", *k);
    if (k->size() > tissue::kMaxKeyframes)
      r.fail(kp, "expected at most " + std::to_string(tissue::kMaxKeyframes) + " keyframes, got " + std::to_string(k->size()));
    for (std::size_t i = 0; i < k->size(); ++i) {
      const std::string ip = child(kp, i);
      const Json& f = (*k)[i];
      r.object(f, ip, {"time_s", "scale", "ramp_s"});
      tissue::Keyframe key;
      key.time = r.non_negative(r.need(f, ip, "time_s"), child(ip, "time_s"), " of seconds");
      if (!d.keyframes.empty() && key.time < d.keyframes.back().time)
        r.expected(child(ip, "time_s"), "keyframes in time order (a time >= the previous keyframe's)", f["time_s"]);
      key.scale = r.positive(r.need(f, ip, "scale"), child(ip, "scale"), "");
      if (const Json* x = r.find(f, "ramp_s")) key.ramp = r.non_negative(*x, child(ip, "ramp_s"), " of seconds");
      d.keyframes.push_back(key);
    }
  }
  if (const Json* g = r.find(v, "guarding")) {
    const std::string gp = child(ptr, "guarding");
    r.object(*g, gp, {"enabled", "threshold_n", "factor", "duration_s", "release_s"});
    d.guarding.enabled = true;
    if (const Json* x = r.find(*g, "enabled")) d.guarding.enabled = r.boolean(*x, child(gp, "enabled"));
    if (const Json* x = r.find(*g, "threshold_n")) d.guarding.threshold = r.positive(*x, child(gp, "threshold_n"), " of newtons");
    if (const Json* x = r.find(*g, "factor")) d.guarding.factor = r.positive(*x, child(gp, "factor"), "");
    if (const Json* x = r.find(*g, "duration_s")) d.guarding.duration = r.non_negative(*x, child(gp, "duration_s"), " of seconds");
    if (const Json* x = r.find(*g, "release_s")) d.guarding.release = r.non_negative(*x, child(gp, "release_s"), " of seconds");
  }
  return d;
}

Task read_task(const Reader& r, const Json& v, const std::string& ptr) {
  r.object(v, ptr, {"instructions", "time_limit_s", "force_limit_n", "report", "scoring"});
  Task t;
  if (const Json* x = r.find(v, "instructions")) t.instructions = r.string(*x, child(ptr, "instructions"));
  if (const Json* x = r.find(v, "time_limit_s")) t.time_limit = r.non_negative(*x, child(ptr, "time_limit_s"), " of seconds (0: none)");
  if (const Json* x = r.find(v, "force_limit_n")) t.force_limit = r.positive(*x, child(ptr, "force_limit_n"), " of newtons");
  if (const Json* rep = r.find(v, "report")) {
    const std::string rp = child(ptr, "report");
    r.object(*rep, rp, {"position", "size", "consistency"});
    if (const Json* x = r.find(*rep, "position")) t.report.position = r.boolean(*x, child(rp, "position"));
    if (const Json* x = r.find(*rep, "size")) t.report.size = r.boolean(*x, child(rp, "size"));
    if (const Json* x = r.find(*rep, "consistency")) t.report.consistency = r.boolean(*x, child(rp, "consistency"));
  }
  if (const Json* s = r.find(v, "scoring")) {
    const std::string sp = child(ptr, "scoring");
    r.object(*s, sp, {"position_tolerance_mm", "size_tolerance", "pass_score", "weights"});
    Scoring& c = t.scoring;
    if (const Json* x = r.find(*s, "position_tolerance_mm"))
      c.position_tolerance = r.positive(*x, child(sp, "position_tolerance_mm"), kMmUnit) * kMm;
    if (const Json* x = r.find(*s, "size_tolerance"))
      c.size_tolerance = r.positive(*x, child(sp, "size_tolerance"), " (a fraction of the diameter)");
    if (const Json* x = r.find(*s, "pass_score"))
      c.pass_score = r.number(*x, child(sp, "pass_score"), "a number in [0, 1]", [](double p) { return p >= 0 && p <= 1; });
    if (const Json* w = r.find(*s, "weights")) {
      const std::string wp = child(sp, "weights");
      r.object(*w, wp, {"found", "size", "consistency", "force", "coverage"});
      if (const Json* x = r.find(*w, "found")) c.weight_found = r.non_negative(*x, child(wp, "found"), "");
      if (const Json* x = r.find(*w, "size")) c.weight_size = r.non_negative(*x, child(wp, "size"), "");
      if (const Json* x = r.find(*w, "consistency")) c.weight_consistency = r.non_negative(*x, child(wp, "consistency"), "");
      if (const Json* x = r.find(*w, "force")) c.weight_force = r.non_negative(*x, child(wp, "force"), "");
      if (const Json* x = r.find(*w, "coverage")) c.weight_coverage = r.non_negative(*x, child(wp, "coverage"), "");
      double sum = c.weight_found + c.weight_size + c.weight_consistency + c.weight_force + c.weight_coverage;
      if (!(sum > 0)) r.expected(wp, "weights with a positive sum", *w);
    }
  }
  return t;
}

// Finds the first key that appears twice in one object while parsing (the
// parser keeps one of them silently) and the JSON pointer of the second.
struct DuplicateKeys {
  struct Frame {
    bool object = false;
    std::set<std::string> keys;
    std::string key;        // object: the key being read
    std::size_t index = 0;  // array: elements finished
  };
  std::vector<Frame> frames;
  std::string pointer;  // of the first duplicate; empty: none

  std::string path() const {
    std::string p;
    for (std::size_t i = 0; i + 1 < frames.size(); ++i)
      p = frames[i].object ? child(p, frames[i].key) : child(p, frames[i].index);
    return p;
  }
  void finished_element() {
    if (!frames.empty() && !frames.back().object) ++frames.back().index;
  }
  bool operator()(int, nlohmann::detail::parse_event_t event, Json& parsed) {
    using E = nlohmann::detail::parse_event_t;
    switch (event) {
      case E::object_start:
      case E::array_start:
        frames.push_back(Frame{event == E::object_start, {}, {}, 0});
        break;
      case E::object_end:
      case E::array_end:
        if (!frames.empty()) frames.pop_back();
        finished_element();
        break;
      case E::key: {
        Frame& f = frames.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second && pointer.empty()) pointer = child(path(), f.key);
        break;
      }
      case E::value:
        finished_element();
        break;
    }
    return true;
  }
};

// Line and column (1-based) of a byte offset.
std::pair<std::size_t, std::size_t> line_column(const std::string& text, std::size_t byte) {
  std::size_t line = 1, col = 1;
  for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') ++line, col = 1;
    else ++col;
  }
  return {line, col};
}

// nlohmann's message without its "[json.exception...] parse error at line L, column C: " prefix.
std::string parse_reason(const std::string& what) {
  auto p = what.find("column ");
  if (p != std::string::npos) {
    auto c = what.find(": ", p);
    if (c != std::string::npos) return what.substr(c + 2);
  }
  p = what.find("] ");
  return p == std::string::npos ? what : what.substr(p + 2);
}

// ---------------------------------------------------------------------------
// Writing: fixed key order, file units, numbers rounded to 12 significant
// digits (so load-save-load is byte-identical), integers written as integers.

Json num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.12g", v);
  double r = std::strtod(buf, nullptr);
  if (r == std::floor(r) && std::abs(r) < 1e15) return Json(static_cast<std::int64_t>(r));
  return Json(r);
}
// The prep object: the edge or the probe radius, then every other
// parameter (all of them, so the file alone says how its mesh was made).
Json prep_json(const PrepSpec& p) {
  Json o;
  for (const PrepRule& rule : kPrepRules) {
    const std::string_view key = rule.key;
    if ((key == "edge_mm" && p.edge <= 0) || (key == "probe_radius_mm" && (p.edge > 0 || p.probe_radius <= 0))) continue;
    if (key == "lesion_radius_mm" && (p.edge > 0 || p.lesion_radius <= 0)) continue;  // none: not written
    o[rule.key] = num(prep_value(p, key));
    if (key == "max_hole_area_fraction") {  // the booleans after the repair limits
      o["autorefine"] = p.autorefine;
      o["local_repair"] = p.local_repair;
    }
  }
  return o;
}

Json vec(const Vec3& v, double per_unit) {
  return Json::array({num(v.x() / per_unit), num(v.y() / per_unit), num(v.z() / per_unit)});
}

std::string rel_path(const fs::path& resolved, const std::string& written, const fs::path& base_dir) {
  if (resolved.empty()) return written;
  if (base_dir.empty()) return resolved.generic_string();
  fs::path r = resolved.lexically_normal().lexically_relative(base_dir.lexically_normal());
  return r.empty() ? resolved.generic_string() : r.generic_string();
}

Json tissue_json(const tissue::Tissue& t, const std::string& preset_key) {
  Json o;
  o["name"] = t.name;
  const tissue::Preset* p = preset_key.empty() ? nullptr : tissue::find_preset(preset_key);
  if (p) o["preset"] = preset_key;
  const tissue::Tissue base = p ? p->tissue : tissue::Tissue{};
  // With a preset only what differs is written; without one every value.
  auto put = [&](const char* key, double value, double preset_value, double per_unit) {
    if (!p || num(value / per_unit) != num(preset_value / per_unit)) o[key] = num(value / per_unit);
  };
  put("youngs_modulus_kpa", t.youngs_modulus, base.youngs_modulus, kKpa);
  put("poisson", t.poisson, base.poisson, 1);
  put("damping_ratio", t.damping_ratio, base.damping_ratio, 1);
  put("relaxation_time_s", t.relaxation_time, base.relaxation_time, 1);
  put("relaxation_fraction", t.relaxation_fraction, base.relaxation_fraction, 1);
  put("stiffening_per_mm", t.stiffening, base.stiffening, 1 / kMm);
  if (p ? t.source != base.source : !t.source.empty()) o["source"] = t.source;
  return o;
}

Json region_json(const tissue::Region& g, const fs::path& base_dir) {
  using tissue::RegionKind;
  Json o;
  o["name"] = g.name;
  o["kind"] = kRegionKindNames[static_cast<int>(g.kind)];
  switch (g.kind) {
    case RegionKind::Sphere:
    case RegionKind::GeodesicDisk:
      o["centre_mm"] = vec(g.centre, kMm);
      o["radius_mm"] = num(g.radius / kMm);
      break;
    case RegionKind::Ellipsoid:
      o["centre_mm"] = vec(g.centre, kMm);
      o["semi_axes_mm"] = vec(g.semi_axes, kMm);
      break;
    case RegionKind::Box:
      o["min_mm"] = vec(g.box_min, kMm);
      o["max_mm"] = vec(g.box_max, kMm);
      break;
    case RegionKind::HalfSpace:
      o["point_mm"] = vec(g.point, kMm);
      o["normal"] = vec(g.normal, 1);
      break;
    case RegionKind::VertexArray:
    case RegionKind::PlanarImage:
    case RegionKind::CylindricalImage:
      o["file"] = rel_path(g.file, g.file.generic_string(), base_dir);
      break;
  }
  if (g.kind == RegionKind::VertexArray) {
    o["array"] = g.array;
    if (!g.label_tissues.empty()) {
      Json l = Json::object();
      for (const auto& [label, name] : g.label_tissues) l[std::to_string(label)] = name;
      o["label_tissues"] = l;
    }
  } else if (g.kind == RegionKind::PlanarImage) {
    o["origin_mm"] = vec(g.origin, kMm);
    o["u_axis_mm"] = vec(g.u_axis, kMm);
    o["v_axis_mm"] = vec(g.v_axis, kMm);
  } else if (g.kind == RegionKind::CylindricalImage) {
    o["origin_mm"] = vec(g.origin, kMm);
    o["axis"] = vec(g.axis, 1);
    o["reference"] = vec(g.reference, 1);
    o["height_mm"] = num(g.height / kMm);
  }
  if (g.kind >= RegionKind::VertexArray) {
    if (g.label_tissues.empty()) {
      o["scale_min"] = num(g.scale_min);
      o["scale_max"] = num(g.scale_max);
    }
  } else {
    o["feather_mm"] = num(g.feather / kMm);
    if (!g.tissue.empty()) o["tissue"] = g.tissue;
    else o["scale"] = num(g.scale);
  }
  return o;
}

Json lesion_json(const LesionSpec& l) {
  Json o;
  if (!l.lesion.name.empty()) o["name"] = l.lesion.name;
  if (l.from_surface) {
    o["surface_point_mm"] = vec(l.surface_point, kMm);
    o["depth_mm"] = num(l.depth / kMm);
  } else {
    o["centre_mm"] = vec(l.lesion.centre, kMm);
  }
  const Vec3& a = l.lesion.semi_axes;
  if (a.x() == a.y() && a.y() == a.z()) o["radius_mm"] = num(a.x() / kMm);
  else o["semi_axes_mm"] = vec(a, kMm);
  o["modulus_ratio"] = num(l.lesion.modulus_ratio);
  o["visibility"] = kVisibilityNames[static_cast<int>(l.lesion.visibility)];
  return o;
}

Json random_json(const RandomLesions& g) {
  Json o;
  o["count"] = g.count;
  o["seed"] = g.seed;
  o["radius_mm"] = Json::array({num(g.radius_min / kMm), num(g.radius_max / kMm)});
  o["depth_mm"] = Json::array({num(g.depth_min / kMm), num(g.depth_max / kMm)});
  o["modulus_ratio"] = Json::array({num(g.ratio_min), num(g.ratio_max)});
  if (!g.region.empty()) o["region"] = g.region;
  o["visibility"] = kVisibilityNames[static_cast<int>(g.visibility)];
  return o;
}

Json pulse_json(const tissue::Pulse& p) {
  Json o;
  if (!p.name.empty()) o["name"] = p.name;
  Json path = Json::array();
  for (const Vec3& x : p.path) path.push_back(vec(x, kMm));
  o["path_mm"] = path;
  o["radius_mm"] = num(p.radius / kMm);
  o["rate_bpm"] = num(p.rate_bpm);
  o["amplitude_mm"] = num(p.amplitude / kMm);
  return o;
}

Json breathing_json(const tissue::Breathing& b) {
  Json o;
  if (!b.enabled) o["enabled"] = false;
  o["rate_bpm"] = num(b.rate_bpm);
  o["translation_mm"] = vec(b.translation, kMm);
  o["axis"] = vec(b.axis, 1);
  o["centre_mm"] = vec(b.centre, kMm);
  o["scale"] = num(b.scale);
  return o;
}

Json dynamic_json(const tissue::DynamicRegion& d) {
  Json o;
  o["region"] = d.region;
  if (!d.keyframes.empty()) {
    Json k = Json::array();
    for (const auto& f : d.keyframes) {
      Json j;
      j["time_s"] = num(f.time);
      j["scale"] = num(f.scale);
      j["ramp_s"] = num(f.ramp);
      k.push_back(j);
    }
    o["keyframes"] = k;
  }
  if (d.guarding.enabled || !(d.guarding == tissue::Guarding{})) {
    Json g;
    if (!d.guarding.enabled) g["enabled"] = false;
    g["threshold_n"] = num(d.guarding.threshold);
    g["factor"] = num(d.guarding.factor);
    g["duration_s"] = num(d.guarding.duration);
    g["release_s"] = num(d.guarding.release);
    o["guarding"] = g;
  }
  return o;
}

Json task_json(const Task& t) {
  Json o;
  o["instructions"] = t.instructions;
  o["time_limit_s"] = num(t.time_limit);
  o["force_limit_n"] = num(t.force_limit);
  o["report"] = {{"position", t.report.position}, {"size", t.report.size}, {"consistency", t.report.consistency}};
  const Scoring& c = t.scoring;
  Json s;
  s["position_tolerance_mm"] = num(c.position_tolerance / kMm);
  s["size_tolerance"] = num(c.size_tolerance);
  s["pass_score"] = num(c.pass_score);
  Json w;
  w["found"] = num(c.weight_found);
  w["size"] = num(c.weight_size);
  w["consistency"] = num(c.weight_consistency);
  w["force"] = num(c.weight_force);
  w["coverage"] = num(c.weight_coverage);
  s["weights"] = w;
  o["scoring"] = s;
  return o;
}

// The file's layout: nlohmann's 2-space indentation, except that an array
// of plain values (a point, a range) stays on one line.
void pretty(const Json& v, int depth, std::string& out) {
  const std::string pad(2 * (depth + 1), ' '), end_pad(2 * depth, ' ');
  if (v.is_object() && !v.empty()) {
    out += "{\n";
    std::size_t i = 0;
    for (auto it = v.begin(); it != v.end(); ++it, ++i) {
      out += pad + Json(it.key()).dump() + ": ";
      pretty(it.value(), depth + 1, out);
      out += i + 1 < v.size() ? ",\n" : "\n";
    }
    out += end_pad + "}";
  } else if (v.is_array() && !v.empty()) {
    const bool flat = std::none_of(v.begin(), v.end(), [](const Json& e) { return e.is_structured(); });
    if (flat) {
      out += "[";
      for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + v[i].dump();
      out += "]";
      return;
    }
    out += "[\n";
    for (std::size_t i = 0; i < v.size(); ++i) {
      out += pad;
      pretty(v[i], depth + 1, out);
      out += i + 1 < v.size() ? ",\n" : "\n";
    }
    out += end_pad + "]";
  } else {
    out += v.dump();
  }
}

std::string mm(double metres) {
  std::ostringstream o;
  o << num(metres / kMm).dump();
  return o.str();
}
std::string mm3(const Vec3& v) {
  std::ostringstream o;
  o << '(' << mm(v.x()) << ", " << mm(v.y()) << ", " << mm(v.z()) << ") mm";
  return o.str();
}
std::string plain(double x) { return num(x).dump(); }

}  // namespace

// ---------------------------------------------------------------------------

Scenario parse_scenario(const std::string& text, const fs::path& file) {
  const std::string name = file.empty() ? std::string("scenario") : file.string();
  const fs::path dir = fs::absolute(file).parent_path().lexically_normal();
  Reader r(name, dir);

  Json doc;
  DuplicateKeys dup;
  try {
    doc = Json::parse(text, std::ref(dup));
  } catch (const Json::parse_error& e) {
    auto [line, col] = line_column(text, e.byte == 0 ? 0 : e.byte - 1);
    r.fail("", "invalid JSON at line " + std::to_string(line) + ", column " + std::to_string(col) + ": " +
                   parse_reason(e.what()));
  } catch (const Json::exception& e) {
    // A number beyond a double's range (nlohmann's out_of_range 406) has no position.
    r.fail("", "invalid JSON: " + parse_reason(e.what()) + " (a number beyond the range of a double)");
  }
  r.object(doc, "",
           {"version", "units", "title", "description", "organ", "probe", "tissues", "base_tissue", "regions",
            "lesions", "random_lesions", "pulses", "breathing", "dynamic_regions", "task"});
  if (!dup.pointer.empty()) r.fail(dup.pointer, "duplicate key (each key may appear once in an object)");

  Scenario s;
  s.file = file;
  // The version and the units first: nothing else means anything without them.
  const Json& version = r.need(doc, "", "version");
  if (!version.is_number_integer() || version.get<std::int64_t>() != kScenarioVersion)
    r.expected("/version", std::to_string(kScenarioVersion) + " (the version this build reads)", version);
  const Json& units = r.need(doc, "", "units");
  r.object(units, "/units", {"length", "modulus", "force", "time"});
  const std::pair<const char*, const char*> kUnits[] = {{"length", "mm"}, {"modulus", "kPa"}, {"force", "N"}, {"time", "s"}};
  for (auto [key, unit] : kUnits) {
    const Json& u = r.need(units, "/units", key);
    if (!u.is_string() || u.get<std::string>() != unit) r.expected(child("/units", key), std::string("\"") + unit + "\"", u);
  }
  if (const Json* x = r.find(doc, "title")) s.title = r.string(*x, "/title");
  if (const Json* x = r.find(doc, "description")) s.description = r.string(*x, "/description");
  s.organ = read_organ(r, r.need(doc, "", "organ"), "/organ");
  if (const Json* x = r.find(doc, "probe")) s.probe = read_probe(r, *x, "/probe");

  // Tissues, named and unique; the base tissue one of them.
  const Json& tissues = r.need(doc, "", "tissues");
  if (!tissues.is_array() || tissues.empty()) r.expected("/tissues", "a non-empty array of tissues", tissues);
  std::vector<std::string> tissue_names;
  for (std::size_t i = 0; i < tissues.size(); ++i) {
    std::string preset;
    tissue::Tissue t = read_tissue(r, tissues[i], child("/tissues", i), &preset);
    if (std::find(tissue_names.begin(), tissue_names.end(), t.name) != tissue_names.end())
      r.fail(child(child("/tissues", i), "name"), "duplicate tissue name " + shown(Json(t.name)));
    tissue_names.push_back(t.name);
    s.tissues.push_back(t);
    s.tissue_presets.push_back(preset);
  }
  if (tissue_names.size() > 65535) r.fail("/tissues", "expected at most 65535 tissues");
  s.base_tissue = reference(r, r.need(doc, "", "base_tissue"), "/base_tissue", tissue_names, "tissue");

  std::vector<std::string> region_names;
  if (const Json* regions = r.find(doc, "regions")) {
    if (!regions->is_array()) r.expected("/regions", "an array of regions", *regions);
    for (std::size_t i = 0; i < regions->size(); ++i) {
      tissue::Region g = read_region(r, (*regions)[i], child("/regions", i), tissue_names);
      if (std::find(region_names.begin(), region_names.end(), g.name) != region_names.end())
        r.fail(child(child("/regions", i), "name"), "duplicate region name " + shown(Json(g.name)));
      region_names.push_back(g.name);
      s.regions.push_back(std::move(g));
    }
  }

  if (const Json* lesions = r.find(doc, "lesions")) {
    if (!lesions->is_array()) r.expected("/lesions", "an array of lesions", *lesions);
    for (std::size_t i = 0; i < lesions->size(); ++i) s.lesions.push_back(read_lesion(r, (*lesions)[i], child("/lesions", i)));
  }
  if (const Json* x = r.find(doc, "random_lesions")) s.random_lesions = read_random(r, *x, "/random_lesions", region_names);
  if (s.lesions.size() + s.random_lesions.count > tissue::kMaxLesions)
    r.fail(s.random_lesions.count ? "/random_lesions/count" : "/lesions",
           "expected at most " + std::to_string(tissue::kMaxLesions) + " lesions in all, got " +
               std::to_string(s.lesions.size() + s.random_lesions.count));

  if (const Json* pulses = r.find(doc, "pulses")) {
    if (!pulses->is_array()) r.expected("/pulses", "an array of pulses", *pulses);
    if (pulses->size() > tissue::kMaxPulses)
      r.fail("/pulses", "expected at most " + std::to_string(tissue::kMaxPulses) + " pulses, got " + std::to_string(pulses->size()));
    for (std::size_t i = 0; i < pulses->size(); ++i) s.pulses.push_back(read_pulse(r, (*pulses)[i], child("/pulses", i)));
  }
  if (const Json* x = r.find(doc, "breathing")) s.breathing = read_breathing(r, *x, "/breathing");
  if (const Json* dyn = r.find(doc, "dynamic_regions")) {
    if (!dyn->is_array()) r.expected("/dynamic_regions", "an array of dynamic regions", *dyn);
    if (dyn->size() > tissue::kMaxDynamicRegions)
      r.fail("/dynamic_regions", "expected at most " + std::to_string(tissue::kMaxDynamicRegions) +
                                     " dynamic regions, got " + std::to_string(dyn->size()));
    for (std::size_t i = 0; i < dyn->size(); ++i)
      s.dynamic_regions.push_back(read_dynamic(r, (*dyn)[i], child("/dynamic_regions", i), region_names));
  }
  if (const Json* x = r.find(doc, "task")) s.task = read_task(r, *x, "/task");
  return s;
}

Scenario load_scenario(const fs::path& file) {
  const std::string name = file.string();
  std::error_code ec;
  auto st = fs::status(file, ec);
  if (ec || !fs::exists(st)) throw ScenarioError(name, "", "cannot open: no such file");
  if (!fs::is_regular_file(st)) throw ScenarioError(name, "", "not a regular file");
  const std::uintmax_t size = fs::file_size(file, ec);
  if (ec) throw ScenarioError(name, "", "cannot read its size: " + ec.message());
  if (size > kMaxScenarioBytes)
    throw ScenarioError(name, "", "file is " + std::to_string(size) + " bytes, over the limit of 16 MiB (" +
                                      std::to_string(kMaxScenarioBytes) + " bytes)");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ScenarioError(name, "", std::string("cannot open: ") + std::strerror(errno));
  std::string text(static_cast<std::size_t>(size), '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) throw ScenarioError(name, "", "cannot read the whole file");
  return parse_scenario(text, file);
}

std::string to_json_text(const Scenario& s, const fs::path& base_dir) {
  Json o;
  o["version"] = kScenarioVersion;
  o["units"] = {{"length", "mm"}, {"modulus", "kPa"}, {"force", "N"}, {"time", "s"}};
  if (!s.title.empty()) o["title"] = s.title;
  if (!s.description.empty()) o["description"] = s.description;
  Json organ;
  organ["path"] = s.organ.path == "default" ? std::string("default") : rel_path(s.organ.resolved, s.organ.path, base_dir);
  organ["unit"] = s.organ.unit;
  if (!s.organ.sha256.empty()) organ["sha256"] = s.organ.sha256;
  if (s.organ.prep) organ["prep"] = prep_json(*s.organ.prep);
  o["organ"] = organ;
  Json probe;
  probe["tip_radius_mm"] = num(s.probe.tip_radius / kMm);
  probe["shape"] = {{"kind", kShapeNames[static_cast<int>(s.probe.shape.kind)]}, {"radius_mm", num(s.probe.shape.radius / kMm)}};
  o["probe"] = probe;
  Json tissues = Json::array();
  for (std::size_t i = 0; i < s.tissues.size(); ++i)
    tissues.push_back(tissue_json(s.tissues[i], i < s.tissue_presets.size() ? s.tissue_presets[i] : std::string()));
  o["tissues"] = tissues;
  o["base_tissue"] = s.base_tissue;
  if (!s.regions.empty()) {
    Json a = Json::array();
    for (const auto& g : s.regions) a.push_back(region_json(g, base_dir));
    o["regions"] = a;
  }
  if (!s.lesions.empty()) {
    Json a = Json::array();
    for (const auto& l : s.lesions) a.push_back(lesion_json(l));
    o["lesions"] = a;
  }
  if (!(s.random_lesions == RandomLesions{})) o["random_lesions"] = random_json(s.random_lesions);
  if (!s.pulses.empty()) {
    Json a = Json::array();
    for (const auto& p : s.pulses) a.push_back(pulse_json(p));
    o["pulses"] = a;
  }
  if (s.breathing.enabled || !(s.breathing == tissue::Breathing{})) o["breathing"] = breathing_json(s.breathing);
  if (!s.dynamic_regions.empty()) {
    Json a = Json::array();
    for (const auto& d : s.dynamic_regions) a.push_back(dynamic_json(d));
    o["dynamic_regions"] = a;
  }
  o["task"] = task_json(s.task);
  std::string text;
  pretty(o, 0, text);
  return text + "\n";
}

std::string to_json_text(const Scenario& s) {
  return to_json_text(s, s.file.empty() ? fs::path() : fs::absolute(s.file).parent_path().lexically_normal());
}

void save_scenario(const Scenario& s, const fs::path& file) {
  const std::string name = file.string();
  const fs::path target = fs::absolute(file).lexically_normal();
  const fs::path dir = target.parent_path();
  std::string text;
  try {
    text = to_json_text(s, dir);
  } catch (const std::exception& e) {  // e.g. a string that is not UTF-8
    throw ScenarioError(name, "", std::string("cannot save: ") + e.what() + "; the previous file is unchanged");
  }
  const fs::path tmp = target.string() + ".tmp";
  auto fail = [&](const std::string& step, int err, bool remove_tmp) {
    if (remove_tmp) ::unlink(tmp.c_str());
    throw ScenarioError(name, "", "cannot save (" + step + " " + tmp.string() + "): " + std::strerror(err) +
                                      "; the previous file is unchanged");
  };
  // Write the sibling, flush it to disk, then rename it over the file.
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("creating", errno, false);
  std::size_t done = 0;
  while (done < text.size()) {
    ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      int err = errno;
      ::close(fd);
      fail("writing", err, true);
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    int err = errno;
    ::close(fd);
    fail("flushing", err, true);
  }
  if (::close(fd) != 0) fail("closing", errno, true);
  if (::rename(tmp.c_str(), target.c_str()) != 0) fail("renaming", errno, true);
  // The rename itself is durable once the folder is flushed.
  int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

double smallest_lesion_radius(const Scenario& s) {
  double r = 0;
  auto take = [&r](double x) {
    if (x > 0 && (r == 0 || x < r)) r = x;
  };
  for (const LesionSpec& l : s.lesions) take(l.lesion.semi_axes.minCoeff());
  if (s.random_lesions.count > 0) take(s.random_lesions.radius_min);
  return r;
}

std::string prep_spec_error(const PrepSpec& p) {
  if (p.edge > 0 && p.probe_radius > 0) return kPrepLengthBoth;
  if (p.edge == 0 && p.probe_radius == 0) return kPrepLengthChoice;
  if (p.edge > 0 && p.lesion_radius != 0) return kPrepLesionWithEdge;
  for (const PrepRule& rule : kPrepRules) {
    const std::string_view key = rule.key;
    if ((key == "edge_mm" && p.edge == 0) || (key == "probe_radius_mm" && p.probe_radius == 0) ||
        (key == "lesion_radius_mm" && p.lesion_radius == 0))
      continue;
    const double x = prep_value(p, key);
    if (!prep_ok(rule, x)) return std::string(rule.key) + ": expected " + rule.what + ", got " + shown(num(x));
  }
  return {};
}

PrepSpec as_written(const PrepSpec& p) {
  PrepSpec out = p;
  for (const PrepRule& rule : kPrepRules) set_prep_value(out, rule.key, num(prep_value(p, rule.key)).get<double>());
  return out;
}

std::string summary(const Scenario& s) {
  std::ostringstream o;
  o << (s.title.empty() ? s.file.filename().string() : s.title) << " (scenario version " << s.version << ")\n";
  if (!s.description.empty()) o << "  " << s.description << "\n";
  o << "organ: " << s.organ.path << " (" << s.organ.unit << ") -> " << s.organ.resolved.string()
    << (s.organ.sha256.empty() ? ", SHA-256 not given" : ", SHA-256 checked") << "\n";
  if (const auto& p = s.organ.prep) {
    o << "organ preparation: ";
    if (p->edge > 0) o << "edge " << mm(p->edge) << " mm";
    else o << "edge from a probe radius of " << mm(p->probe_radius) << " mm";
    if (p->edge <= 0 && p->lesion_radius > 0) o << " and a smallest lesion radius of " << mm(p->lesion_radius) << " mm";
    o << ", " << p->remesh_iterations << " remeshing iterations, " << p->fit_rounds << " fit rounds\n";
  }
  o << "probe: tip radius " << mm(s.probe.tip_radius) << " mm, " << kShapeNames[static_cast<int>(s.probe.shape.kind)]
    << " shape function, support radius " << mm(s.probe.shape.radius) << " mm\n";
  o << "tissues (" << s.tissues.size() << "):\n";
  for (std::size_t i = 0; i < s.tissues.size(); ++i) {
    const auto& t = s.tissues[i];
    o << "  " << t.name << ": E " << plain(t.youngs_modulus / kKpa) << " kPa, nu " << plain(t.poisson);
    if (t.stiffening > 0) o << ", stiffening " << plain(t.stiffening * kMm) << "/mm";
    if (t.relaxation_time > 0) o << ", relaxation " << plain(t.relaxation_time) << " s";
    if (i < s.tissue_presets.size() && !s.tissue_presets[i].empty()) o << ", preset " << s.tissue_presets[i];
    if (t.name == s.base_tissue) o << " (base)";
    o << "\n";
  }
  o << "regions (" << s.regions.size() << (s.regions.empty() ? "):" : "), combined in this order:") << "\n";
  for (const auto& g : s.regions) {
    o << "  " << g.name << ": " << kRegionKindNames[static_cast<int>(g.kind)];
    if (!g.file.empty()) o << " " << g.file.string();
    if (g.kind < tissue::RegionKind::VertexArray) {
      if (!g.tissue.empty()) o << ", tissue " << g.tissue;
      else o << ", modulus x" << plain(g.scale);
    } else if (g.label_tissues.empty()) {
      o << ", modulus x" << plain(g.scale_min) << " .. x" << plain(g.scale_max);
    }
    o << "\n";
  }
  o << "lesions (" << s.lesions.size() << "):\n";
  for (std::size_t i = 0; i < s.lesions.size(); ++i) {
    const auto& l = s.lesions[i];
    o << "  " << (l.lesion.name.empty() ? "lesion " + std::to_string(i) : l.lesion.name) << ": ";
    const Vec3& a = l.lesion.semi_axes;
    if (a.x() == a.y() && a.y() == a.z()) o << "radius " << mm(a.x()) << " mm";
    else o << "semi-axes " << mm3(a);
    if (l.from_surface) o << ", centre " << mm(l.depth) << " mm below the surface near " << mm3(l.surface_point);
    else o << ", centre " << mm3(l.lesion.centre);
    o << ", modulus ratio " << plain(l.lesion.modulus_ratio) << ", "
      << kVisibilityNames[static_cast<int>(l.lesion.visibility)] << "\n";
  }
  const auto& rl = s.random_lesions;
  if (rl.count > 0)
    o << "random lesions: " << rl.count << " (seed " << rl.seed << "), radius " << mm(rl.radius_min) << ".."
      << mm(rl.radius_max) << " mm, depth " << mm(rl.depth_min) << ".." << mm(rl.depth_max) << " mm, ratio "
      << plain(rl.ratio_min) << ".." << plain(rl.ratio_max) << ", " << (rl.region.empty() ? "anywhere" : "in " + rl.region)
      << ", " << kVisibilityNames[static_cast<int>(rl.visibility)] << "\n";
  o << "pulses (" << s.pulses.size() << "):\n";
  for (const auto& p : s.pulses)
    o << "  " << (p.name.empty() ? "pulse" : p.name) << ": " << p.path.size() << "-point path, radius " << mm(p.radius)
      << " mm, " << plain(p.rate_bpm) << " bpm, amplitude " << mm(p.amplitude) << " mm\n";
  if (s.breathing.enabled)
    o << "breathing: " << plain(s.breathing.rate_bpm) << " breaths/min, translation " << mm3(s.breathing.translation)
      << ", scale " << plain(s.breathing.scale) << "\n";
  else
    o << "breathing: off\n";
  o << "dynamic regions (" << s.dynamic_regions.size() << "):\n";
  for (const auto& d : s.dynamic_regions)
    o << "  " << d.region << ": " << d.keyframes.size() << " keyframes"
      << (d.guarding.enabled ? ", guarding above " + plain(d.guarding.threshold) + " N" : std::string()) << "\n";
  const Task& t = s.task;
  o << "task: time limit " << (t.time_limit > 0 ? plain(t.time_limit) + " s" : std::string("none")) << ", force limit "
    << plain(t.force_limit) << " N; reports";
  std::string rep;
  if (t.report.position) rep += " position,";
  if (t.report.size) rep += " size,";
  if (t.report.consistency) rep += " consistency,";
  if (!rep.empty()) rep.pop_back();
  o << (rep.empty() ? " nothing" : rep) << "; pass score " << plain(t.scoring.pass_score) << ", position tolerance "
    << mm(t.scoring.position_tolerance) << " mm\n";
  if (!t.instructions.empty()) o << "instructions: " << t.instructions << "\n";
  return o.str();
}

}  // namespace palpa::scenario
