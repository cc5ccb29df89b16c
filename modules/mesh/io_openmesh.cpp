// STL through OpenMesh 9's reader. (OBJ, OFF and PLY have our own readers,
// io_text.cpp: OpenMesh's believed the counts in a header, followed an OBJ's
// mtllib anywhere, and went on with stale values after a parse error.)
//
// OpenMesh builds a half-edge mesh by default and silently drops faces that
// would make it non-manifold, so we hand its reader our own importer that
// records the raw polygon soup instead. OpenMesh also hides some input errors
// (it drops facets with repeated corners and merges a NaN STL vertex into
// another one), so STL files get a scan of their own before OpenMesh reads them.

#include "mesh/internal_io.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <locale>
#include <mutex>
#include <sstream>
#include <string_view>
#include <type_traits>

namespace palpa::mesh::internal {
namespace {

namespace OM = OpenMesh;
namespace OMIO = OpenMesh::IO;

// ---------------------------------------------------------------------------
// The importer: records vertices and polygons exactly as the reader delivers
// them. Everything else OpenMesh may pass on (normals, colours, texture
// coordinates) is ignored.
class SoupImporter final : public OMIO::BaseImporter {
 public:
  SoupImporter(RawMesh& raw, const LoadOptions& options) : raw_(raw), options_(options) {}

  /// Watch this stream: the first vertex or face at which it has failed is
  /// remembered (OpenMesh's OFF and PLY readers go on after a parse error).
  void watch(std::istream* stream) { stream_ = stream; }

  // What went wrong while reading, for read_openmesh to report.
  bool too_many_vertices = false;
  bool too_many_triangles = false;
  enum class Failed { none, vertex, face } failed = Failed::none;
  std::size_t failed_index = 0;
  bool failed_at_eof = false;

  // Vertices.
  OM::VertexHandle add_vertex(const OM::Vec3f& p) override { return push_vertex(Vec3(p[0], p[1], p[2])); }
  OM::VertexHandle add_vertex(const OM::Vec3d& p) override { return push_vertex(Vec3(p[0], p[1], p[2])); }
  OM::VertexHandle add_vertex() override { return push_vertex(Vec3::Zero(), /*check=*/false); }
  void set_point(OM::VertexHandle vh, const OM::Vec3f& p) override {
    check_stream(Failed::vertex, static_cast<std::size_t>(vh.idx()));
    const auto i = static_cast<std::size_t>(vh.idx());
    if (vh.is_valid() && i < raw_.vertices.size()) raw_.vertices[i] = Vec3(p[0], p[1], p[2]);
  }

  // Faces: the indices exactly as read (an invalid handle has idx() == -1).
  OM::FaceHandle add_face(const VHandles& ids) override {
    check_stream(Failed::face, faces_);
    const std::size_t face = faces_++;
    triangles_ += ids.size() >= 3 ? ids.size() - 2 : 1;
    if (triangles_ > options_.max_triangles) too_many_triangles = true;
    if (too_many_triangles || too_many_vertices) return OM::FaceHandle(static_cast<int>(face));
    for (const auto& vh : ids) raw_.face_indices.push_back(vh.idx());
    raw_.face_offsets.push_back(raw_.face_indices.size());
    return OM::FaceHandle(static_cast<int>(face));
  }

  std::size_t n_vertices() const override { return vertices_; }
  std::size_t n_faces() const override { return faces_; }
  std::size_t n_edges() const override { return 0; }

  // Everything below is ignored: we only need positions and polygons.
  OM::HalfedgeHandle add_edge(OM::VertexHandle, OM::VertexHandle) override { return OM::HalfedgeHandle(); }
  OM::FaceHandle add_face(OM::HalfedgeHandle) override { return OM::FaceHandle(); }
  void add_face_texcoords(OM::FaceHandle, OM::VertexHandle, const std::vector<OM::Vec2f>&) override {}
  void add_face_texcoords(OM::FaceHandle, OM::VertexHandle, const std::vector<OM::Vec3f>&) override {}
  void set_face_texindex(OM::FaceHandle, int) override {}
  void set_halfedge(OM::VertexHandle, OM::HalfedgeHandle) override {}
  void set_normal(OM::VertexHandle, const OM::Vec3f&) override {}
  void set_normal(OM::VertexHandle, const OM::Vec3d&) override {}
  void set_color(OM::VertexHandle, const OM::Vec3uc&) override {}
  void set_color(OM::VertexHandle, const OM::Vec4uc&) override {}
  void set_color(OM::VertexHandle, const OM::Vec3f&) override {}
  void set_color(OM::VertexHandle, const OM::Vec4f&) override {}
  void set_texcoord(OM::VertexHandle, const OM::Vec2f&) override {}
  void set_status(OM::VertexHandle, const OM::Attributes::StatusInfo&) override {}
  void set_next(OM::HalfedgeHandle, OM::HalfedgeHandle) override {}
  void set_face(OM::HalfedgeHandle, OM::FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(OM::HalfedgeHandle, const OM::Vec2f&) override {}
  void set_texcoord(OM::VertexHandle, const OM::Vec3f&) override {}
  void set_texcoord(OM::HalfedgeHandle, const OM::Vec3f&) override {}
  void set_status(OM::HalfedgeHandle, const OM::Attributes::StatusInfo&) override {}
  void set_color(OM::EdgeHandle, const OM::Vec3uc&) override {}
  void set_color(OM::EdgeHandle, const OM::Vec4uc&) override {}
  void set_color(OM::EdgeHandle, const OM::Vec3f&) override {}
  void set_color(OM::EdgeHandle, const OM::Vec4f&) override {}
  void set_status(OM::EdgeHandle, const OM::Attributes::StatusInfo&) override {}
  void set_normal(OM::FaceHandle, const OM::Vec3f&) override {}
  void set_normal(OM::FaceHandle, const OM::Vec3d&) override {}
  void set_color(OM::FaceHandle, const OM::Vec3uc&) override {}
  void set_color(OM::FaceHandle, const OM::Vec4uc&) override {}
  void set_color(OM::FaceHandle, const OM::Vec3f&) override {}
  void set_color(OM::FaceHandle, const OM::Vec4f&) override {}
  void set_status(OM::FaceHandle, const OM::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}

 private:
  OM::VertexHandle push_vertex(const Vec3& p, bool check = true) {
    if (check) check_stream(Failed::vertex, vertices_);
    const std::size_t i = vertices_++;
    if (vertices_ > options_.max_vertices) too_many_vertices = true;
    if (!too_many_vertices) raw_.vertices.push_back(p);
    return OM::VertexHandle(static_cast<int>(i));
  }

  // Remember the first element at which the watched stream had failed.
  void check_stream(Failed what, std::size_t index) {
    if (stream_ == nullptr || failed != Failed::none || !stream_->fail()) return;
    failed = what;
    failed_index = index;
    failed_at_eof = stream_->eof();
  }

  RawMesh& raw_;
  const LoadOptions& options_;
  std::istream* stream_ = nullptr;
  std::size_t vertices_ = 0;
  std::size_t faces_ = 0;
  std::size_t triangles_ = 0;
};

// ---------------------------------------------------------------------------
// While alive, what OpenMesh's error stream says is collected in a string
// (to be put into our error message). OpenMesh's multiplex_streambuf leaks
// the wrapper it allocates on every connect() (found by fuzz_mesh under
// LeakSanitizer), so the stream is redirected once for the process: from then
// on OpenMesh writes into our buffer, which each read clears (reads hold the
// OpenMesh mutex).
class CaptureOpenMeshErrors {
 public:
  CaptureOpenMeshErrors() : was_enabled_(::omerr().is_enabled()) {
    static std::once_flag once;
    std::call_once(once, [] {
      ::omerr().disconnect(std::cerr);
      ::omerr().connect(buffer());
    });
    ::omerr().flush();
    buffer().str("");
  }
  ~CaptureOpenMeshErrors() {
    // Undo a reader's omerr().disable() that an exception skipped past.
    was_enabled_ ? ::omerr().enable() : ::omerr().disable();
  }
  CaptureOpenMeshErrors(const CaptureOpenMeshErrors&) = delete;
  CaptureOpenMeshErrors& operator=(const CaptureOpenMeshErrors&) = delete;

  /// What OpenMesh printed, on one line.
  std::string text() {
    ::omerr().flush();
    std::string s = buffer().str();
    std::replace(s.begin(), s.end(), '\n', ' ');
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
  }

 private:
  static std::ostringstream& buffer() {
    static std::ostringstream* text = new std::ostringstream;  // lives as long as OpenMesh's stream
    return *text;
  }
  bool was_enabled_ = true;
};

// OpenMesh's readers are singletons with state; one read at a time.
std::mutex& openmesh_mutex() {
  static std::mutex m;
  return m;
}

// ---------------------------------------------------------------------------
// Small text helpers for the scans.

// Splits a line at white space: its first `most` tokens (the scan needs no
// more, and a line may hold millions).
std::vector<std::string_view> tokens(std::string_view line, std::size_t most = 5) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size() && out.size() < most) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

// A whole token as a finite float (OpenMesh reads coordinates as float; a
// value beyond float range becomes inf here and fails its parse there).
bool finite_float(std::string_view token) {
  const std::string s(token);
  char* end = nullptr;
  const float v = std::strtof(s.c_str(), &end);
  return !s.empty() && end == s.c_str() + s.size() && std::isfinite(v);
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// ---------------------------------------------------------------------------
// STL scan: decides ASCII or binary the way OpenMesh does (binary when the
// size matches the triangle count in the header), checks coordinates, and
// counts facets with repeated corners (OpenMesh drops them).
struct StlScan {
  std::size_t facets = 0;
  std::size_t degenerate = 0;
};

float le_float(const unsigned char* p) {
  std::uint32_t u = std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
                    std::uint32_t(p[3]) << 24;
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

StlScan scan_stl(const std::filesystem::path& path, const std::string& source, const LoadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(source, "cannot be opened for reading");
  const std::uintmax_t size = std::filesystem::file_size(path);
  unsigned char header[84] = {};
  in.read(reinterpret_cast<char*>(header), 84);
  const std::uint32_t announced = std::uint32_t(header[80]) | std::uint32_t(header[81]) << 8 |
                                  std::uint32_t(header[82]) << 16 | std::uint32_t(header[83]) << 24;
  const bool binary = size >= 84 && size == 84 + 50 * std::uintmax_t(announced);
  StlScan scan;

  if (binary) {
    // Binary: 50-byte records of normal, three corners, attribute.
    if (announced > options.max_triangles)
      fail(source, "has more than " + std::to_string(options.max_triangles) +
                       " triangles (LoadOptions::max_triangles)");
    unsigned char rec[50];
    for (std::uint32_t f = 0; f < announced; ++f) {
      in.read(reinterpret_cast<char*>(rec), 50);
      float c[9];
      for (int i = 0; i < 9; ++i) c[i] = le_float(rec + 12 + 4 * i);
      for (int v = 0; v < 3; ++v)
        if (!std::isfinite(c[3 * v]) || !std::isfinite(c[3 * v + 1]) || !std::isfinite(c[3 * v + 2]))
          fail(source, "facet " + std::to_string(f) + ", vertex " + std::to_string(v) +
                           " has a coordinate that is not a finite number");
      auto same = [&](int a, int b) {
        return c[3 * a] == c[3 * b] && c[3 * a + 1] == c[3 * b + 1] && c[3 * a + 2] == c[3 * b + 2];
      };
      if (same(0, 1) || same(0, 2) || same(1, 2)) ++scan.degenerate;
    }
    scan.facets = announced;
    return scan;
  }

  // Not binary: it must be ASCII, starting with "solid".
  const std::string start(reinterpret_cast<const char*>(header), std::min<std::uintmax_t>(size, 84));
  const auto first = tokens(start);
  if (first.empty() || lower(first[0]) != "solid") {
    if (size < 84) fail(source, "is neither ASCII STL (no 'solid' at the start) nor binary STL (too short)");
    fail(source, "is neither ASCII STL (no 'solid' at the start) nor binary STL (the header announces " +
                     std::to_string(announced) + " triangles, which take " +
                     std::to_string(84 + 50 * std::uintmax_t(announced)) + " bytes, but the file has " +
                     std::to_string(size) + ")");
  }
  in.clear();
  in.seekg(0);
  std::string line;
  std::size_t corners = 0;
  float c[9] = {};
  bool in_loop = false;
  while (std::getline(in, line)) {
    const auto tok = tokens(line);
    if (tok.empty()) continue;
    const std::string key = lower(tok[0]);
    if (key == "outer") {
      in_loop = true;
      corners = 0;
    } else if (key == "vertex" && in_loop) {
      // One corner: three finite coordinates.
      if (tok.size() < 4 || !finite_float(tok[1]) || !finite_float(tok[2]) || !finite_float(tok[3]))
        fail(source, "facet " + std::to_string(scan.facets) + ", vertex " + std::to_string(corners) +
                         " has a coordinate that is not a finite number");
      if (corners < 3)
        for (int i = 0; i < 3; ++i) c[3 * corners + i] = std::strtof(std::string(tok[1 + i]).c_str(), nullptr);
      ++corners;
    } else if (key == "endloop" && in_loop) {
      // End of a facet: exactly three corners.
      if (corners != 3)
        fail(source, "facet " + std::to_string(scan.facets) + " has " + std::to_string(corners) +
                         " vertices; STL facets are triangles");
      auto same = [&](int a, int b) {
        return c[3 * a] == c[3 * b] && c[3 * a + 1] == c[3 * b + 1] && c[3 * a + 2] == c[3 * b + 2];
      };
      if (same(0, 1) || same(0, 2) || same(1, 2)) ++scan.degenerate;
      ++scan.facets;
      in_loop = false;
      if (scan.facets > options.max_triangles)
        fail(source, "has more than " + std::to_string(options.max_triangles) +
                         " triangles (LoadOptions::max_triangles)");
    }
  }
  return scan;
}

}  // namespace

// ---------------------------------------------------------------------------
// Reads one STL file into a raw soup: our scan first (it decides ASCII or
// binary, checks the size and every coordinate), then OpenMesh's reader.
RawMesh read_stl(const std::filesystem::path& path, const LoadOptions& options) {
  const std::string source = path.string();
  const StlScan stl = scan_stl(path, source, options);

  RawMesh raw;
  SoupImporter importer(raw, options);
  bool ok = false;
  std::string said;
  {
    std::lock_guard<std::mutex> lock(openmesh_mutex());
    CaptureOpenMeshErrors capture;
    OMIO::Options opt = OMIO::Options::Default;
    ok = OMIO::IOManager().read(path.string(), importer, opt);
    said = capture.text();
  }
  if (importer.too_many_vertices)
    fail(source, "has more than " + std::to_string(options.max_vertices) + " vertices (LoadOptions::max_vertices)");
  if (importer.too_many_triangles)
    fail(source, "has more than " + std::to_string(options.max_triangles) +
                     " triangles (LoadOptions::max_triangles)");
  if (!ok) fail(source, "OpenMesh cannot read it as STL" + (said.empty() ? std::string() : " (" + said + ")"));

  // Cross-check against the scan: every facet it accepted must have arrived.
  if (importer.n_faces() != stl.facets - stl.degenerate)
    fail(source, "OpenMesh read " + std::to_string(importer.n_faces()) + " of its " +
                     std::to_string(stl.facets - stl.degenerate) + " non-degenerate facets");
  raw.predropped_degenerate = stl.degenerate;
  raw.premerged_vertices = 3 * stl.facets - raw.vertices.size();
  return raw;
}

}  // namespace palpa::mesh::internal
