// load_mesh / from_polygons / save_mesh: format dispatch, the checks every
// input goes through, SOFA's .trian reader and our own writers.

#include "mesh/internal_io.h"

#include "core/input_file.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <system_error>

namespace palpa::mesh {
namespace internal {

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw MeshError(source + ": " + what);
}

namespace {
// A number for a message: shortest %g form that reads back the same (1e+30, 0.001).
std::string number(double v) {
  char buf[40];
  for (int digits = 6; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}
}  // namespace

// ---------------------------------------------------------------------------
// Checks a raw soup, fan-triangulates it, cleans it and converts it to metres.
SurfaceMesh build_mesh(RawMesh raw, const LoadOptions& options, const std::string& source,
                       CleanReport* report_out) {
  const long long base = raw.index_base;
  if (!(options.unit_m > 0) || !std::isfinite(options.unit_m))
    fail(source, "LoadOptions::unit_m must be a positive length in metres");
  if (!(options.weld_tolerance >= 0) || !std::isfinite(options.weld_tolerance))
    fail(source, "LoadOptions::weld_tolerance must be zero or a positive length in file units");

  // Size limits.
  const std::size_t nv = raw.vertices.size();
  if (nv > options.max_vertices)
    fail(source, "has more than " + std::to_string(options.max_vertices) + " vertices (LoadOptions::max_vertices)");

  // Finite coordinates within the stated magnitude, and a mesh that is not a speck.
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i = 0; i < nv; ++i) {
    const Vec3& p = raw.vertices[i];
    if (!p.allFinite())
      fail(source, "vertex " + std::to_string(i + base) + " has a coordinate that is not a finite number");
    for (int c = 0; c < 3; ++c)
      if (std::abs(p[c]) > options.max_coordinate)
        fail(source, "vertex " + std::to_string(i + base) + " has the coordinate " + number(p[c]) +
                         ", beyond the limit of " + number(options.max_coordinate) +
                         " file units (LoadOptions::max_coordinate)");
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }

  // Every face has at least three vertices, all in range.
  std::size_t n_triangles = 0;
  for (std::size_t f = 0; f < raw.face_count(); ++f) {
    const std::size_t begin = raw.face_offsets[f], end = raw.face_offsets[f + 1];
    if (end - begin < 3)
      fail(source, "face " + std::to_string(f + base) + " has " + std::to_string(end - begin) +
                       " vertices; a face needs at least 3");
    if (end - begin > options.max_face_vertices)
      fail(source, "face " + std::to_string(f + base) + " has " + std::to_string(end - begin) +
                       " vertices, more than the limit of " + std::to_string(options.max_face_vertices) +
                       " (LoadOptions::max_face_vertices)");
    for (std::size_t k = begin; k < end; ++k) {
      const std::int64_t v = raw.face_indices[k];
      if (v < 0 || std::uint64_t(v) >= nv)
        fail(source, "face " + std::to_string(f + base) + " uses vertex " + std::to_string(v + base) +
                         ", but the vertices are numbered " + std::to_string(base) + " to " +
                         std::to_string(static_cast<long long>(nv) - 1 + base));
    }
    n_triangles += end - begin - 2;
  }
  if (n_triangles > options.max_triangles)
    fail(source, "has more than " + std::to_string(options.max_triangles) +
                     " triangles (LoadOptions::max_triangles)");
  if (n_triangles == 0) fail(source, "has no triangles");
  const double extent_m = (hi - lo).maxCoeff() * options.unit_m;
  if (!(extent_m >= options.min_extent_m))
    fail(source, "is " + number(extent_m) + " m across, less than the smallest size of " +
                     number(options.min_extent_m) + " m (LoadOptions::min_extent_m)");

  // Fan triangulation (polygons are assumed convex enough for a fan).
  SurfaceMesh mesh;
  mesh.positions = std::move(raw.vertices);
  mesh.triangles.reserve(n_triangles);
  for (std::size_t f = 0; f < raw.face_count(); ++f) {
    const std::size_t begin = raw.face_offsets[f], end = raw.face_offsets[f + 1];
    for (std::size_t k = begin + 1; k + 1 < end; ++k)
      mesh.triangles.push_back({Index(raw.face_indices[begin]), Index(raw.face_indices[k]),
                                Index(raw.face_indices[k + 1])});
  }

  // Clean (in file units: the weld tolerance is given in them).
  CleanReport report;
  report.input_vertices = nv + raw.premerged_vertices;
  report.input_triangles = n_triangles + raw.predropped_degenerate;
  report.welded_vertices = raw.premerged_vertices;
  report.degenerate_triangles = raw.predropped_degenerate;
  clean_triangles(mesh.positions, mesh.triangles, options, report);
  if (mesh.triangles.empty())
    fail(source, "has no triangles left after cleaning (" + std::to_string(report.degenerate_triangles) +
                     " degenerate, " + std::to_string(report.duplicate_triangles) + " duplicate)");

  // Metres, normals, adjacency.
  if (options.unit_m != 1.0)
    for (Vec3& p : mesh.positions) p *= options.unit_m;
  finalize(mesh);
  if (report_out) *report_out = report;
  return mesh;
}

// ---------------------------------------------------------------------------
// SOFA .trian: N, N lines "x y z", M, M lines "i j k n0 n1 n2" (0-based vertex
// ids, then neighbour-triangle ids we ignore). Blank lines are skipped.
RawMesh read_trian(const std::string& bytes, const std::string& source, const LoadOptions& options) {
  std::istringstream in(bytes);

  // Next non-blank line, split into tokens; false at the end of the file.
  std::string line;
  std::vector<std::string> tok;
  auto next_line = [&]() {
    while (std::getline(in, line)) {
      std::istringstream ss(line);
      tok.clear();
      for (std::string t; ss >> t;) tok.push_back(t);
      if (!tok.empty()) return true;
    }
    return false;
  };
  auto count = [&](const char* what, const char* plural, std::size_t limit, const char* option) {
    if (!next_line()) fail(source, std::string("the file ends before the ") + what + " count");
    char* end = nullptr;
    const long long n = std::strtoll(tok[0].c_str(), &end, 10);
    if (end != tok[0].c_str() + tok[0].size() || n < 0 || tok.size() != 1)
      fail(source, std::string("expected the ") + what + " count, found '" + line + "'");
    if (std::uint64_t(n) > limit)
      fail(source, "has more than " + std::to_string(limit) + " " + plural + " (LoadOptions::" + option + ")");
    return std::size_t(n);
  };

  RawMesh raw;
  const std::size_t nv = count("vertex", "vertices", options.max_vertices, "max_vertices");
  // Grown as lines arrive, never sized from the count (a short file claiming 20M vertices costs nothing).
  for (std::size_t i = 0; i < nv; ++i) {
    // One vertex: three numbers (a non-number counts as not finite).
    if (!next_line()) fail(source, "the file ends before vertex " + std::to_string(i));
    if (tok.size() < 3) fail(source, "vertex " + std::to_string(i) + " has fewer than 3 coordinates");
    Vec3 p;
    for (int c = 0; c < 3; ++c) {
      char* end = nullptr;
      const double x = std::strtod(tok[c].c_str(), &end);
      if (end != tok[c].c_str() + tok[c].size() || !std::isfinite(x))
        fail(source, "vertex " + std::to_string(i) + " has a coordinate that is not a finite number");
      p[c] = x;
    }
    raw.vertices.push_back(p);
  }
  const std::size_t nt = count("triangle", "triangles", options.max_triangles, "max_triangles");
  for (std::size_t f = 0; f < nt; ++f) {
    // One triangle: three vertex ids, then (ignored) neighbour ids.
    if (!next_line()) fail(source, "the file ends before face " + std::to_string(f));
    if (tok.size() < 3)
      fail(source, "face " + std::to_string(f) + " has " + std::to_string(tok.size()) +
                       " vertices; a face needs at least 3");
    std::int64_t id[3];
    for (int c = 0; c < 3; ++c) {
      char* end = nullptr;
      id[c] = std::strtoll(tok[c].c_str(), &end, 10);
      if (end != tok[c].c_str() + tok[c].size())
        fail(source, "face " + std::to_string(f) + ": cannot read its vertex indices");
    }
    raw.add_face({id[0], id[1], id[2]});
  }
  return raw;
}

}  // namespace internal

namespace {

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// ---------------------------------------------------------------------------
// Writers. All positions are written as float32 (about 1e-8 m resolution for
// organ-sized meshes) except OBJ, which gets 9 significant digits.

void put_u32(std::ostream& out, std::uint32_t v) {
  const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8),
                              static_cast<unsigned char>(v >> 16), static_cast<unsigned char>(v >> 24)};
  out.write(reinterpret_cast<const char*>(b), 4);
}
void put_f32(std::ostream& out, double v) { put_u32(out, std::bit_cast<std::uint32_t>(static_cast<float>(v))); }

// Binary little-endian PLY: float x y z, faces as uchar-counted int lists.
void write_ply(std::ostream& out, const SurfaceMesh& m) {
  out << "ply\nformat binary_little_endian 1.0\ncomment Palpa surface mesh, metres\n"
      << "element vertex " << m.positions.size() << "\nproperty float x\nproperty float y\nproperty float z\n"
      << "element face " << m.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Vec3& p : m.positions) {
    put_f32(out, p.x());
    put_f32(out, p.y());
    put_f32(out, p.z());
  }
  for (const Triangle& t : m.triangles) {
    out.put(3);
    for (Index v : t) put_u32(out, v);
  }
}

// Binary STL: 80-byte header, count, then normal + corners + attribute per facet.
void write_stl(std::ostream& out, const SurfaceMesh& m) {
  char header[80] = {};
  std::snprintf(header, sizeof header, "Palpa binary STL, metres");
  out.write(header, 80);
  put_u32(out, static_cast<std::uint32_t>(m.triangles.size()));
  for (const Triangle& t : m.triangles) {
    const Vec3& a = m.positions[t[0]];
    Vec3 n = (m.positions[t[1]] - a).cross(m.positions[t[2]] - a);
    if (n.norm() > 0) n.normalize();
    for (int c = 0; c < 3; ++c) put_f32(out, n[c]);
    for (Index v : t)
      for (int c = 0; c < 3; ++c) put_f32(out, m.positions[v][c]);
    out.put(0);
    out.put(0);
  }
}

// Wavefront OBJ: "v x y z" and 1-based "f a b c".
void write_obj(std::ostream& out, const SurfaceMesh& m) {
  out << "# Palpa surface mesh, metres\n";
  char buf[96];
  for (const Vec3& p : m.positions) {
    std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", p.x(), p.y(), p.z());
    out << buf;
  }
  for (const Triangle& t : m.triangles) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
}

}  // namespace

// ---------------------------------------------------------------------------
SurfaceMesh load_mesh(const std::filesystem::path& path, const LoadOptions& options, CleanReport* report) {
  const std::string source = path.string();

  // The file itself: it exists, has a known extension, and is a regular file
  // within the size limit (never a FIFO or a device: read on the descriptor
  // that was checked).
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) internal::fail(source, "file not found");
  if (std::filesystem::is_directory(path, ec)) internal::fail(source, "is a directory, not a mesh file");
  const std::string ext = lower_extension(path);
  static const char* const kKnown[] = {"obj", "stl", "ply", "off", "vtk", "vtp", "trian"};
  if (std::find(std::begin(kKnown), std::end(kKnown), ext) == std::end(kKnown))
    internal::fail(source, (ext.empty() ? std::string("has no file extension") : "has an unknown extension '." + ext + "'") +
                               "; expected .obj, .stl, .ply, .off, .vtk, .vtp or .trian");
  std::string bytes;
  const std::string problem = read_regular_file(path, options.max_file_bytes, "LoadOptions::max_file_bytes", bytes);
  if (!problem.empty()) internal::fail(source, problem);

  // Read the raw soup, then check, clean and finalize it. STL and VTP are
  // handed to their libraries by name (the file was checked just now).
  internal::RawMesh raw;
  if (ext == "obj") raw = internal::read_obj(bytes, source, options);
  else if (ext == "off") raw = internal::read_off(bytes, source, options);
  else if (ext == "ply") raw = internal::read_ply(bytes, source, options);
  else if (ext == "vtk") raw = internal::read_legacy_vtk(bytes, source, options);
  else if (ext == "trian") raw = internal::read_trian(bytes, source, options);
  else if (ext == "stl") raw = internal::read_stl(path, options);
  else raw = internal::read_vtp(path, options);
  return internal::build_mesh(std::move(raw), options, source, report);
}

SurfaceMesh from_polygons(std::vector<Vec3> vertices, const std::vector<std::vector<long long>>& polygons,
                          const LoadOptions& options, const std::string& source, CleanReport* report) {
  internal::RawMesh raw;
  raw.vertices = std::move(vertices);
  for (const auto& poly : polygons) {
    raw.face_indices.insert(raw.face_indices.end(), poly.begin(), poly.end());
    raw.face_offsets.push_back(raw.face_indices.size());
  }
  return internal::build_mesh(std::move(raw), options, source, report);
}

void save_mesh(const SurfaceMesh& mesh, const std::filesystem::path& path) {
  const std::string source = path.string();
  const std::string ext = lower_extension(path);
  if (ext != "ply" && ext != "obj" && ext != "stl")
    internal::fail(source, "cannot save as '." + ext + "'; use .ply, .obj or .stl");
  for (const Triangle& t : mesh.triangles)
    for (Index v : t)
      if (v >= mesh.positions.size()) internal::fail(source, "cannot save: a triangle uses a vertex that does not exist");

  // Write next to the target, then rename over it.
  std::filesystem::path tmp = path;
  tmp += ".palpa-tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) internal::fail(source, "cannot be written (cannot create " + tmp.string() + ")");
    if (ext == "ply") write_ply(out, mesh);
    if (ext == "stl") write_stl(out, mesh);
    if (ext == "obj") write_obj(out, mesh);
    out.flush();
    if (!out) {
      out.close();
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      internal::fail(source, "cannot be written (writing " + tmp.string() + " failed)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    internal::fail(source, "cannot be written (" + ec.message() + ")");
  }
}

}  // namespace palpa::mesh
