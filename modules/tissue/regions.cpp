// Heterogeneous tissue: region weights (primitives, geodesic disks, vertex
// arrays from VTP/PLY, planar and cylindrical PNG maps) and the layered
// tissue map over the base tissue (docs/TISSUE.md, Region maps).

#include "tissue/regions.h"

#include "tissue/internal_regions.h"

#include <Eigen/Geometry>
#include <nanoflann.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkExecutive.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkXMLPolyDataReader.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <numbers>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <unordered_map>

namespace palpa::tissue {

namespace internal {
namespace {

// ---------------------------------------------------------------------------
// Errors: every message starts with the region's name.

std::string region_what(const Region& r) { return "region '" + r.name + "'"; }

// Limits of the files a region reads (docs/TISSUE.md, "Region maps").
constexpr std::uintmax_t kMaxRegionFileBytes = std::uintmax_t(256) << 20;  // bytes
constexpr std::uint64_t kMaxMapPixels = std::uint64_t(8192) * 8192;         // pixels of a PNG map
constexpr std::size_t kMaxRegionPoints = 20'000'000;                         // points of a PLY array file

[[noreturn]] void refuse(const std::string& what, const std::string& fault) {
  throw std::runtime_error(what + ": " + fault);
}

[[noreturn]] void refuse_value(const std::string& what, const char* field, const char* rule, double value,
                               const char* unit) {
  std::ostringstream msg;
  msg << field << " must be " << rule << ", got " << value << unit;
  refuse(what, msg.str());
}

bool finite(const Vec3& v) { return v.allFinite(); }

void check_positive(const std::string& what, const char* field, double v, const char* unit) {
  if (!(v > 0) || !std::isfinite(v)) refuse_value(what, field, "positive and finite", v, unit);
}

void check_vector(const std::string& what, const char* field, const Vec3& v) {
  if (!finite(v) || v.norm() == 0) {
    std::ostringstream msg;
    msg << field << " must be a finite non-zero vector, got (" << v.x() << ", " << v.y() << ", " << v.z() << ")";
    refuse(what, msg.str());
  }
}

void check_point(const std::string& what, const char* field, const Vec3& v) {
  if (!finite(v)) {
    std::ostringstream msg;
    msg << field << " must be finite, got (" << v.x() << ", " << v.y() << ", " << v.z() << ")";
    refuse(what, msg.str());
  }
}

// The file a region reads must exist and be a regular file.
void check_file(const std::string& what, const std::filesystem::path& file, const char* kind) {
  std::error_code ec;
  const auto st = std::filesystem::status(file, ec);
  if (file.empty()) refuse(what, std::string("no ") + kind + " file given");
  if (!std::filesystem::exists(st)) refuse(what, "cannot read " + std::string(kind) + " '" + file.string() + "': no such file");
  if (!std::filesystem::is_regular_file(st))
    refuse(what, "cannot read " + std::string(kind) + " '" + file.string() + "': not a regular file");
  const std::uintmax_t size = std::filesystem::file_size(file, ec);
  if (size == 0 && !ec)
    refuse(what, "cannot read " + std::string(kind) + " '" + file.string() + "': the file is empty");
  if (!ec && size > kMaxRegionFileBytes)
    refuse(what, "cannot read " + std::string(kind) + " '" + file.string() + "': it is " + std::to_string(size) +
                     " bytes, more than the limit of " + std::to_string(kMaxRegionFileBytes) + " (256 MiB)");
}

// A PNG's width and height from its IHDR chunk, read before any decoding so
// that an image too large to hold is refused before it is allocated.
void check_png_size(const std::string& what, const std::filesystem::path& file) {
  unsigned char h[24] = {};
  std::ifstream in(file, std::ios::binary);
  in.read(reinterpret_cast<char*>(h), sizeof h);
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const std::string name = "'" + file.string() + "'";
  if (in.gcount() < 24 || std::memcmp(h, kSignature, 8) != 0 || std::memcmp(h + 12, "IHDR", 4) != 0)
    refuse(what, "cannot read image " + name + ": not a PNG file (maps are 8- or 16-bit PNG)");
  auto be32 = [](const unsigned char* p) {
    return (std::uint64_t{p[0]} << 24) | (std::uint64_t{p[1]} << 16) | (std::uint64_t{p[2]} << 8) | p[3];
  };
  const std::uint64_t w = be32(h + 16), hgt = be32(h + 20);
  if (w * hgt > kMaxMapPixels)
    refuse(what, "image " + name + " is " + std::to_string(w) + " x " + std::to_string(hgt) +
                     " pixels, more than the limit of " + std::to_string(kMaxMapPixels) + " (8192 x 8192)");
}

// ---------------------------------------------------------------------------
// Geometric primitives: signed distance (m, negative inside) -> weight.

template <class SignedDistance>
std::vector<float> weights_from_distance(const mesh::SurfaceMesh& mesh, double feather, SignedDistance&& sd) {
  std::vector<float> w(mesh.vertex_count());
  for (std::size_t i = 0; i < w.size(); ++i)
    w[i] = static_cast<float>(feathered_weight(sd(mesh.positions[i]), feather));
  return w;
}

double box_signed_distance(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const Vec3 c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  const Vec3 q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// ---------------------------------------------------------------------------
// Nearest point of a point set, for vertex arrays (nanoflann's k-d tree).

struct PointCloud {
  const std::vector<Vec3>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*pts)[i][static_cast<Eigen::Index>(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointCloud>, PointCloud, 3,
                                                   std::size_t>;

// ---------------------------------------------------------------------------
// VTP point data through VTK's XML reader, its errors caught (not printed).

struct FirstVtkMessage {
  std::string text;
  static void on_event(vtkObject*, unsigned long, void* client, void* call) {
    auto* self = static_cast<FirstVtkMessage*>(client);
    if (call == nullptr || !self->text.empty()) return;
    std::string t = static_cast<const char*>(call);
    if (const auto tag = t.find("): "); tag != std::string::npos) t = t.substr(tag + 3);
    while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.pop_back();
    std::replace(t.begin(), t.end(), '\n', ' ');
    self->text = t;
  }
};

PointArray read_vtp(const std::filesystem::path& file, const std::string& array, const std::string& what) {
  const std::string name = "'" + file.string() + "'";
  // VTK's XML parser logs its syntax errors itself: look at the start first.
  {
    std::ifstream in(file, std::ios::binary);
    std::string head(1024, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    if (head.find("<VTKFile") == std::string::npos || head.find("PolyData") == std::string::npos)
      refuse(what, "cannot read VTP " + name + ": not a VTK XML PolyData file");
  }
  vtkNew<vtkXMLPolyDataReader> reader;
  FirstVtkMessage error, warning;
  vtkNew<vtkCallbackCommand> on_error, on_warning;
  on_error->SetCallback(&FirstVtkMessage::on_event);
  on_error->SetClientData(&error);
  on_warning->SetCallback(&FirstVtkMessage::on_event);
  on_warning->SetClientData(&warning);
  reader->AddObserver(vtkCommand::ErrorEvent, on_error);
  reader->AddObserver(vtkCommand::WarningEvent, on_warning);
  reader->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, on_error);
  reader->SetFileName(file.c_str());
  reader->Update();
  if (!error.text.empty()) refuse(what, "cannot read VTP " + name + ": " + error.text);
  vtkPolyData* poly = reader->GetOutput();
  if (poly == nullptr || poly->GetNumberOfPoints() == 0) refuse(what, "VTP " + name + " has no points");
  vtkDataArray* data = poly->GetPointData()->GetArray(array.c_str());
  if (data == nullptr) {
    std::string names;
    for (int k = 0; k < poly->GetPointData()->GetNumberOfArrays(); ++k) {
      const char* n = poly->GetPointData()->GetArrayName(k);
      names += (names.empty() ? "" : ", ") + std::string(n ? n : "(unnamed)");
    }
    refuse(what, "VTP " + name + " has no point-data array '" + array + "' (it has: " +
                     (names.empty() ? "none" : names) + ")");
  }
  if (data->GetNumberOfComponents() != 1)
    refuse(what, "VTP " + name + ": array '" + array + "' has " + std::to_string(data->GetNumberOfComponents()) +
                     " components, expected 1");
  PointArray out;
  const vtkIdType n = poly->GetNumberOfPoints();
  out.points.resize(static_cast<std::size_t>(n));
  out.values.resize(static_cast<std::size_t>(n));
  for (vtkIdType i = 0; i < n; ++i) {
    double p[3];
    poly->GetPoint(i, p);
    out.points[static_cast<std::size_t>(i)] = Vec3(p[0], p[1], p[2]);
    out.values[static_cast<std::size_t>(i)] = data->GetComponent(i, 0);
  }
  return out;
}

// ---------------------------------------------------------------------------
// PLY point data: VTK 9.1's vtkPLYReader reads only positions, normals,
// colours and texture coordinates, so the header and the vertex element are
// parsed here (ascii, binary_little_endian, binary_big_endian; scalar
// properties of any PLY type; elements before the vertices are skipped).

enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

bool ply_type(const std::string& s, PlyType& t) {
  static const std::pair<const char*, PlyType> names[] = {
      {"char", PlyType::I8},    {"int8", PlyType::I8},     {"uchar", PlyType::U8},   {"uint8", PlyType::U8},
      {"short", PlyType::I16},  {"int16", PlyType::I16},   {"ushort", PlyType::U16}, {"uint16", PlyType::U16},
      {"int", PlyType::I32},    {"int32", PlyType::I32},   {"uint", PlyType::U32},   {"uint32", PlyType::U32},
      {"float", PlyType::F32},  {"float32", PlyType::F32}, {"double", PlyType::F64}, {"float64", PlyType::F64}};
  for (const auto& [n, v] : names)
    if (s == n) {
      t = v;
      return true;
    }
  return false;
}

std::size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::I8: case PlyType::U8: return 1;
    case PlyType::I16: case PlyType::U16: return 2;
    case PlyType::I32: case PlyType::U32: case PlyType::F32: return 4;
    case PlyType::F64: return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::F32;
  bool list = false;
  PlyType count_type = PlyType::U8;
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

class PlyReader {
 public:
  PlyReader(const std::filesystem::path& file, const std::string& what) : what_(what), name_("PLY '" + file.string() + "'") {
    std::ifstream in(file, std::ios::binary);
    if (!in) fail("cannot open the file");
    bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }

  PointArray read(const std::string& array) {
    header();
    // The vertex element, its x, y, z and the array.
    std::size_t e = 0;
    while (e < elements_.size() && elements_[e].name != "vertex") ++e;
    if (e == elements_.size()) fail("no vertex element");
    const PlyElement& v = elements_[e];
    int ix = -1, iy = -1, iz = -1, ia = -1;
    for (std::size_t k = 0; k < v.properties.size(); ++k) {
      const auto& p = v.properties[k];
      const int ki = static_cast<int>(k);
      if (p.name == "x") ix = ki;
      if (p.name == "y") iy = ki;
      if (p.name == "z") iz = ki;
      if (p.name == array) ia = ki;
    }
    if (ix < 0 || iy < 0 || iz < 0) fail("the vertex element has no x, y and z properties");
    if (ia < 0) {
      std::string names;
      for (const auto& p : v.properties)
        if (p.name != "x" && p.name != "y" && p.name != "z") names += (names.empty() ? "" : ", ") + p.name;
      fail("no vertex property '" + array + "' (it has: " + (names.empty() ? "none" : names) + ")");
    }
    if (v.properties[static_cast<std::size_t>(ia)].list) fail("vertex property '" + array + "' is a list, expected a scalar");
    if (v.count == 0) fail("no vertices");
    // Nothing is sized from a count the file cannot hold: every property of a
    // vertex takes at least one byte (ascii) or its size (binary).
    if (v.count > kMaxRegionPoints)
      fail("the header announces " + std::to_string(v.count) + " vertices, more than the limit of " +
           std::to_string(kMaxRegionPoints));
    std::size_t row_bytes = 0;
    for (const auto& p : v.properties)
      row_bytes += format_ == Format::Ascii ? 1 : ply_size(p.list ? p.count_type : p.type);
    const std::size_t left = bytes_.size() - pos_;
    if (v.count > left / std::max<std::size_t>(row_bytes, 1))
      fail("the header announces " + std::to_string(v.count) + " vertices, but only " + std::to_string(left) +
           " bytes follow it");
    for (std::size_t k = 0; k < e; ++k) skip_element(elements_[k]);
    PointArray out;
    out.points.resize(v.count);
    out.values.resize(v.count);
    std::vector<double> row(v.properties.size());
    for (std::size_t i = 0; i < v.count; ++i) {
      for (std::size_t k = 0; k < v.properties.size(); ++k) {
        const auto& p = v.properties[k];
        if (p.list) {
          const auto n = static_cast<std::size_t>(scalar(p.count_type, "a list count"));
          for (std::size_t j = 0; j < n; ++j) scalar(p.type, "a list item");
          row[k] = 0;
        } else {
          row[k] = scalar(p.type, "a vertex property");
        }
      }
      out.points[i] = Vec3(row[static_cast<std::size_t>(ix)], row[static_cast<std::size_t>(iy)],
                           row[static_cast<std::size_t>(iz)]);
      out.values[i] = row[static_cast<std::size_t>(ia)];
    }
    return out;
  }

 private:
  enum class Format { Ascii, Little, Big };

  [[noreturn]] void fail(const std::string& fault) const { refuse(what_, name_ + ": " + fault); }

  // The header, up to and including the end_header line.
  void header() {
    std::size_t pos = 0;
    auto line = [&](std::string& out) -> bool {
      if (pos >= bytes_.size()) return false;
      const auto nl = bytes_.find('\n', pos);
      const auto end = nl == std::string::npos ? bytes_.size() : nl;
      out = bytes_.substr(pos, end - pos);
      if (!out.empty() && out.back() == '\r') out.pop_back();
      pos = nl == std::string::npos ? bytes_.size() : nl + 1;
      return true;
    };
    std::string l;
    if (!line(l) || l != "ply") fail("not a PLY file (no 'ply' line)");
    bool have_format = false;
    for (;;) {
      if (!line(l)) fail("the header has no end_header line");
      std::istringstream s(l);
      std::string key;
      s >> key;
      if (key == "end_header") break;
      if (key == "comment" || key == "obj_info" || key.empty()) continue;
      if (key == "format") {
        std::string f;
        s >> f;
        if (f == "ascii") format_ = Format::Ascii;
        else if (f == "binary_little_endian") format_ = Format::Little;
        else if (f == "binary_big_endian") format_ = Format::Big;
        else fail("unknown format '" + f + "'");
        have_format = true;
      } else if (key == "element") {
        PlyElement e;
        long long n = -1;
        s >> e.name >> n;
        if (!s || n < 0) fail("bad element line '" + l + "'");
        e.count = static_cast<std::size_t>(n);
        elements_.push_back(e);
      } else if (key == "property") {
        if (elements_.empty()) fail("a property before any element");
        PlyProperty p;
        std::string t;
        s >> t;
        if (t == "list") {
          std::string ct, it;
          s >> ct >> it >> p.name;
          if (!ply_type(ct, p.count_type) || !ply_type(it, p.type)) fail("bad property line '" + l + "'");
          p.list = true;
        } else {
          s >> p.name;
          if (!ply_type(t, p.type)) fail("bad property line '" + l + "'");
        }
        if (!s) fail("bad property line '" + l + "'");
        elements_.back().properties.push_back(p);
      } else {
        fail("unknown header line '" + l + "'");
      }
    }
    if (!have_format) fail("the header has no format line");
    pos_ = pos;
  }

  void skip_element(const PlyElement& e) {
    for (std::size_t i = 0; i < e.count; ++i)
      for (const auto& p : e.properties) {
        if (p.list) {
          const auto n = static_cast<std::size_t>(scalar(p.count_type, "a list count"));
          for (std::size_t j = 0; j < n; ++j) scalar(p.type, "a list item");
        } else {
          scalar(p.type, "a property");
        }
      }
  }

  // The next value of type t (ascii: the next token).
  double scalar(PlyType t, const char* what) {
    if (format_ == Format::Ascii) {
      while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
      if (pos_ >= bytes_.size()) fail(std::string("the file ends before ") + what);
      const char* begin = bytes_.c_str() + pos_;
      char* end = nullptr;
      const double v = std::strtod(begin, &end);
      if (end == begin) fail(std::string("expected a number for ") + what + " at byte " + std::to_string(pos_));
      pos_ += static_cast<std::size_t>(end - begin);
      return v;
    }
    const std::size_t n = ply_size(t);
    if (pos_ + n > bytes_.size()) fail(std::string("the file ends before ") + what);
    unsigned char b[8];
    std::memcpy(b, bytes_.data() + pos_, n);
    pos_ += n;
    if ((format_ == Format::Big) == (std::endian::native == std::endian::little)) std::reverse(b, b + n);
    switch (t) {
      case PlyType::I8: { std::int8_t v; std::memcpy(&v, b, 1); return v; }
      case PlyType::U8: return b[0];
      case PlyType::I16: { std::int16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::U16: { std::uint16_t v; std::memcpy(&v, b, 2); return v; }
      case PlyType::I32: { std::int32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::U32: { std::uint32_t v; std::memcpy(&v, b, 4); return v; }
      case PlyType::F32: { float v; std::memcpy(&v, b, 4); return v; }
      case PlyType::F64: { double v; std::memcpy(&v, b, 8); return v; }
    }
    return 0;
  }

  std::string what_, name_;
  std::string bytes_;
  std::size_t pos_ = 0;
  Format format_ = Format::Ascii;
  std::vector<PlyElement> elements_;
};

// ---------------------------------------------------------------------------
// Image maps: an 8- or 16-bit PNG as v in [0, 1], sampled bilinearly.

class ValueImage {
 public:
  ValueImage(const std::filesystem::path& file, const std::string& what) {
    check_file(what, file, "image");
    check_png_size(what, file);
    const cv::Mat raw = cv::imread(file.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
    const std::string name = "'" + file.string() + "'";
    if (raw.empty()) refuse(what, "cannot read image " + name + ": not an image OpenCV can decode, or empty");
    double unit = 0;
    if (raw.depth() == CV_8U) unit = 1.0 / 255.0;
    else if (raw.depth() == CV_16U) unit = 1.0 / 65535.0;
    else refuse(what, "image " + name + " is neither 8- nor 16-bit");
    raw.convertTo(v_, CV_32F, unit);
    width_ = v_.cols;
    height_ = v_.rows;
  }

  int width() const { return width_; }
  int height() const { return height_; }

  /// v at image coordinates (x, y) in pixels, pixel (i, j) covering
  /// [i, i+1) x [j, j+1) with its value at its centre; bilinear between
  /// centres, clamped to the edge pixels in y (and in x unless wrap_x).
  double sample(double x, double y, bool wrap_x) const {
    const double fx = x - 0.5, fy = std::clamp(y - 0.5, 0.0, static_cast<double>(height_ - 1));
    int y0 = static_cast<int>(std::floor(fy));
    y0 = std::min(y0, height_ - 1);
    const int y1 = std::min(y0 + 1, height_ - 1);
    const double ty = fy - y0;
    int x0, x1;
    double tx;
    if (wrap_x) {
      const double f = std::floor(fx);
      tx = fx - f;
      x0 = static_cast<int>(((static_cast<long long>(f) % width_) + width_) % width_);
      x1 = (x0 + 1) % width_;
    } else {
      const double c = std::clamp(fx, 0.0, static_cast<double>(width_ - 1));
      x0 = std::min(static_cast<int>(std::floor(c)), width_ - 1);
      x1 = std::min(x0 + 1, width_ - 1);
      tx = c - x0;
    }
    const float* r0 = v_.ptr<float>(y0);
    const float* r1 = v_.ptr<float>(y1);
    const double a = r0[x0] + tx * (r0[x1] - r0[x0]);
    const double b = r1[x0] + tx * (r1[x1] - r1[x0]);
    return a + ty * (b - a);
  }

 private:
  cv::Mat v_;
  int width_ = 0, height_ = 0;
};

RegionSample sample_planar(const mesh::SurfaceMesh& mesh, const Region& r, const std::string& what) {
  check_point(what, "origin", r.origin);
  check_vector(what, "u_axis", r.u_axis);
  check_vector(what, "v_axis", r.v_axis);
  if (r.u_axis.cross(r.v_axis).norm() <= 1e-12 * r.u_axis.norm() * r.v_axis.norm())
    refuse(what, "u_axis and v_axis must not be parallel");
  const ValueImage img(r.file, what);
  // (p - origin) = a u + b v + c (u x v): a, b from the 2x2 Gram system.
  const double uu = r.u_axis.dot(r.u_axis), uv = r.u_axis.dot(r.v_axis), vv = r.v_axis.dot(r.v_axis);
  const double det = uu * vv - uv * uv;
  const std::size_t n = mesh.vertex_count();
  RegionSample s{std::vector<float>(n, 0.0f), std::vector<float>(n, 0.0f)};
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 d = mesh.positions[i] - r.origin;
    const double du = d.dot(r.u_axis), dv = d.dot(r.v_axis);
    const double a = (vv * du - uv * dv) / det, b = (uu * dv - uv * du) / det;
    if (!(a >= 0 && a <= 1 && b >= 0 && b <= 1)) continue;
    s.weight[i] = 1.0f;
    s.value[i] = static_cast<float>(img.sample(a * img.width(), b * img.height(), false));
  }
  return s;
}

RegionSample sample_cylindrical(const mesh::SurfaceMesh& mesh, const Region& r, const std::string& what) {
  check_point(what, "origin", r.origin);
  check_vector(what, "axis", r.axis);
  check_vector(what, "reference", r.reference);
  check_positive(what, "height", r.height, " m");
  const Vec3 axis = r.axis.normalized();
  Vec3 e1 = r.reference - r.reference.dot(axis) * axis;
  if (e1.norm() <= 1e-9 * r.reference.norm()) refuse(what, "reference must not be parallel to axis");
  e1.normalize();
  const Vec3 e2 = axis.cross(e1);
  const ValueImage img(r.file, what);
  const std::size_t n = mesh.vertex_count();
  RegionSample s{std::vector<float>(n, 0.0f), std::vector<float>(n, 0.0f)};
  constexpr double two_pi = 2 * std::numbers::pi;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 d = mesh.positions[i] - r.origin;
    const double t = d.dot(axis);
    if (!(t >= 0 && t <= r.height)) continue;
    double theta = std::atan2(d.dot(e2), d.dot(e1));
    if (theta < 0) theta += two_pi;
    s.weight[i] = 1.0f;
    s.value[i] = static_cast<float>(img.sample(theta / two_pi * img.width(), t / r.height * img.height(), true));
  }
  return s;
}

RegionSample sample_vertex_array(const mesh::SurfaceMesh& mesh, const Region& r, const std::string& what) {
  if (r.array.empty()) refuse(what, "no array name given");
  const PointArray pa = read_point_array(r.file, r.array, what);
  const bool labels = !r.label_tissues.empty();
  if (labels)
    for (std::size_t i = 0; i < pa.values.size(); ++i)
      if (pa.values[i] != std::round(pa.values[i]) || std::abs(pa.values[i]) > 16777216) {
        // (labels travel as float32, exact up to 2^24)
        std::ostringstream msg;
        msg << "'" << r.file.string() << "': array '" << r.array << "' holds " << pa.values[i] << " at point " << i
            << ", not an integer label of at most 16777216";
        refuse(what, msg.str());
      }
  // Each vertex takes its nearest file point's value.
  const PointCloud cloud{&pa.points};
  KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  tree.buildIndex();
  const std::size_t n = mesh.vertex_count();
  RegionSample s{std::vector<float>(n, 0.0f), std::vector<float>(n, 0.0f)};
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t k = 0;
    double d2 = 0;
    tree.knnSearch(mesh.positions[i].data(), 1, &k, &d2);
    const double v = pa.values[k];
    s.value[i] = static_cast<float>(v);
    s.weight[i] = (!labels || r.label_tissues.count(static_cast<int>(v)) > 0) ? 1.0f : 0.0f;
  }
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------

double ellipsoid_signed_distance(const Vec3& p, const Vec3& c, const Vec3& a) {
  const Vec3 q = p - c;
  const double k0 = q.cwiseQuotient(a).norm();
  const double k1 = q.cwiseQuotient(a.cwiseProduct(a)).norm();
  if (k1 == 0) return -a.minCoeff();  // the centre
  return k0 * (k0 - 1.0) / k1;
}

std::vector<double> geodesic_distances(const mesh::SurfaceMesh& mesh, Index source, double max_distance) {
  const std::size_t n = mesh.vertex_count();
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::vector<double> dist(n, inf);
  std::vector<std::uint8_t> accepted(n, 0);
  using Item = std::pair<double, Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> trial;
  dist[source] = 0;
  trial.push({0.0, source});
  const auto& P = mesh.positions;

  // The distance at C from the planar wavefront through edge AB, unfolded
  // into C's triangle: the virtual source S with |SA| = dA, |SB| = dB on the
  // far side of AB; |SC| when the ray S -> C crosses AB, else along an edge.
  auto through_edge = [&](Index A, Index B, Index C) {
    const double dA = dist[A], dB = dist[B];
    const Vec3 e = P[B] - P[A];
    const double L = e.norm();
    const double edge = std::min(dA + (P[C] - P[A]).norm(), dB + (P[C] - P[B]).norm());
    if (L <= 0) return edge;
    const Vec3 ac = P[C] - P[A];
    const double cx = ac.dot(e) / L;
    const double cy = (ac - cx / L * e).norm();
    const double sx = (dA * dA - dB * dB + L * L) / (2 * L);
    const double sy2 = dA * dA - sx * sx;
    if (sy2 < 0 || cy <= 0) return edge;
    const double sy = std::sqrt(sy2);  // S = (sx, -sy)
    const double x = sx + (cx - sx) * (sy / (sy + cy));
    if (x < 0 || x > L) return edge;
    return std::min(edge, std::hypot(cx - sx, cy + sy));
  };

  while (!trial.empty()) {
    const auto [d, v] = trial.top();
    trial.pop();
    if (accepted[v] || d > dist[v]) continue;
    accepted[v] = 1;
    if (d > max_distance) break;
    for (Index t : mesh.vertex_triangles.row(v)) {
      const auto& tri = mesh.triangles[t];
      for (int k = 0; k < 3; ++k) {
        const Index w = tri[static_cast<std::size_t>(k)];
        if (w == v || accepted[w]) continue;
        Index other = v;
        for (Index c : tri)
          if (c != v && c != w) other = c;
        const double cand = accepted[other] && other != v ? through_edge(v, other, w) : d + (P[w] - P[v]).norm();
        if (cand < dist[w]) {
          dist[w] = cand;
          trial.push({cand, w});
        }
      }
    }
  }
  return dist;
}

PointArray read_point_array(const std::filesystem::path& file, const std::string& array, const std::string& what) {
  check_file(what, file, "vertex array");
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".vtp") return read_vtp(file, array, what);
  if (ext == ".ply") return PlyReader(file, what).read(array);
  refuse(what, "'" + file.string() + "': expected a .vtp or .ply file");
}

RegionSample sample_region(const mesh::SurfaceMesh& mesh, const Region& r) {
  const std::string what = region_what(r);
  if (!(r.feather >= 0) || !std::isfinite(r.feather)) refuse_value(what, "feather", "non-negative and finite", r.feather, " m");
  const double f = r.feather;
  switch (r.kind) {
    case RegionKind::Sphere: {
      check_point(what, "centre", r.centre);
      check_positive(what, "radius", r.radius, " m");
      const Vec3 c = r.centre;
      const double R = r.radius;
      return {weights_from_distance(mesh, f, [&](const Vec3& p) { return (p - c).norm() - R; }), {}};
    }
    case RegionKind::Ellipsoid: {
      check_point(what, "centre", r.centre);
      for (int k = 0; k < 3; ++k) check_positive(what, "each semi-axis", r.semi_axes[k], " m");
      return {weights_from_distance(mesh, f, [&](const Vec3& p) { return ellipsoid_signed_distance(p, r.centre, r.semi_axes); }),
              {}};
    }
    case RegionKind::Box: {
      if (!finite(r.box_min) || !finite(r.box_max) || !(r.box_max.array() > r.box_min.array()).all())
        refuse(what, "box_max must be above box_min on every axis");
      return {weights_from_distance(mesh, f, [&](const Vec3& p) { return box_signed_distance(p, r.box_min, r.box_max); }), {}};
    }
    case RegionKind::HalfSpace: {
      check_point(what, "point", r.point);
      check_vector(what, "normal", r.normal);
      const Vec3 nrm = r.normal.normalized();
      return {weights_from_distance(mesh, f, [&](const Vec3& p) { return (p - r.point).dot(nrm); }), {}};
    }
    case RegionKind::GeodesicDisk: {
      check_point(what, "centre", r.centre);
      check_positive(what, "radius", r.radius, " m");
      const std::size_t n = mesh.vertex_count();
      std::vector<float> w(n, 0.0f);
      if (n == 0) return {w, {}};
      Index source = 0;
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < n; ++i)
        if (const double d2 = (mesh.positions[i] - r.centre).squaredNorm(); d2 < best) {
          best = d2;
          source = static_cast<Index>(i);
        }
      const auto dist = geodesic_distances(mesh, source, r.radius + 0.5 * f);
      for (std::size_t i = 0; i < n; ++i)
        if (std::isfinite(dist[i])) w[i] = static_cast<float>(feathered_weight(dist[i] - r.radius, f));
      return {w, {}};
    }
    case RegionKind::VertexArray: return sample_vertex_array(mesh, r, what);
    case RegionKind::PlanarImage: return sample_planar(mesh, r, what);
    case RegionKind::CylindricalImage: return sample_cylindrical(mesh, r, what);
  }
  refuse(what, "unknown region kind " + std::to_string(static_cast<int>(r.kind)));
}

}  // namespace internal

std::vector<float> region_weights(const mesh::SurfaceMesh& mesh, const Region& region) {
  return internal::sample_region(mesh, region).weight;
}

TissueMap evaluate_tissue_map(const mesh::SurfaceMesh& mesh, const std::vector<Tissue>& tissues, std::size_t base,
                              const std::vector<Region>& regions) {
  if (tissues.empty()) throw std::runtime_error("tissue map: no tissues");
  if (tissues.size() > std::numeric_limits<std::uint16_t>::max())
    throw std::runtime_error("tissue map: " + std::to_string(tissues.size()) + " tissues, at most 65535");
  if (base >= tissues.size())
    throw std::runtime_error("tissue map: base tissue " + std::to_string(base) + " out of range (" +
                             std::to_string(tissues.size()) + " tissues)");
  // Effective moduli E / (1 - nu^2), Pa, and the tissues by name.
  std::vector<double> eff(tissues.size());
  std::unordered_map<std::string, std::uint16_t> by_name;
  for (std::size_t t = 0; t < tissues.size(); ++t) {
    validate_tissue(tissues[t], "tissue '" + tissues[t].name + "'");
    eff[t] = tissues[t].youngs_modulus / (1.0 - tissues[t].poisson * tissues[t].poisson);
    by_name.try_emplace(tissues[t].name, static_cast<std::uint16_t>(t));
  }
  auto tissue_index = [&](const Region& r, const std::string& name, const std::string& context) {
    const auto it = by_name.find(name);
    if (it != by_name.end()) return it->second;
    std::string known;
    for (const auto& t : tissues) known += (known.empty() ? "'" : ", '") + t.name + "'";
    throw std::runtime_error("region '" + r.name + "': " + context + "unknown tissue '" + name + "' (tissues: " +
                             known + ")");
  };

  // The state while layering: each vertex's tissue and effective modulus (Pa).
  const std::size_t n = mesh.vertex_count();
  TissueMap out;
  out.tissue_of.assign(n, static_cast<std::uint16_t>(base));
  std::vector<double> modulus(n, eff[base]);

  for (const Region& r : regions) {
    const std::string what = "region '" + r.name + "'";
    const bool is_map = r.kind == RegionKind::VertexArray || r.kind == RegionKind::PlanarImage ||
                        r.kind == RegionKind::CylindricalImage;
    if (is_map && !r.tissue.empty())
      throw std::runtime_error(what + ": a map scales the modulus and holds no tissue (got tissue '" + r.tissue +
                               "'; label arrays name tissues in label_tissues)");
    if (!is_map && r.tissue.empty() && (!(r.scale > 0) || !std::isfinite(r.scale))) {
      std::ostringstream msg;
      msg << what << ": scale must be positive and finite, got " << r.scale;
      throw std::runtime_error(msg.str());
    }
    // Resolve names before reading anything.
    std::uint16_t target = 0;
    if (!is_map && !r.tissue.empty()) target = tissue_index(r, r.tissue, "");
    std::unordered_map<int, std::uint16_t> label_target;
    const bool labels = r.kind == RegionKind::VertexArray && !r.label_tissues.empty();
    for (const auto& [label, name] : r.label_tissues)
      label_target[label] = tissue_index(r, name, "label " + std::to_string(label) + ": ");
    if (is_map && !labels) {
      if (!std::isfinite(r.scale_min) || !std::isfinite(r.scale_max) ||
          (r.kind != RegionKind::VertexArray && !(r.scale_min > 0 && r.scale_max > 0))) {
        std::ostringstream msg;
        msg << what << ": scale_min and scale_max must be positive and finite, got " << r.scale_min << " and "
            << r.scale_max;
        throw std::runtime_error(msg.str());
      }
    }

    const internal::RegionSample s = internal::sample_region(mesh, r);
    if (labels) {
      // A listed label: the vertex becomes that tissue, at its own modulus.
      for (std::size_t i = 0; i < n; ++i) {
        if (s.weight[i] <= 0) continue;
        const std::uint16_t t = label_target.at(static_cast<int>(s.value[i]));
        out.tissue_of[i] = t;
        modulus[i] = eff[t];
      }
    } else if (is_map) {
      // A covered vertex: modulus times scale_min + (scale_max - scale_min) v.
      const double lo = r.scale_min, span = r.scale_max - r.scale_min;
      for (std::size_t i = 0; i < n; ++i) {
        if (s.weight[i] <= 0) continue;
        const double k = lo + span * s.value[i];
        if (!(k > 0) || !std::isfinite(k)) {
          std::ostringstream msg;
          msg << what << ": value " << s.value[i] << " at vertex " << i << " gives modulus scale " << k
              << ", which must be positive";
          throw std::runtime_error(msg.str());
        }
        modulus[i] *= k;
      }
    } else if (!r.tissue.empty()) {
      // Blend the effective modulus towards the tissue's (times scale) by w;
      // the vertex takes the tissue where w >= 1/2.
      const double m_target = eff[target] * r.scale;
      for (std::size_t i = 0; i < n; ++i) {
        const double w = s.weight[i];
        if (w <= 0) continue;
        modulus[i] = (1 - w) * modulus[i] + w * m_target;
        if (w >= 0.5) out.tissue_of[i] = target;
      }
    } else {
      // A scale region: modulus times 1 + w (scale - 1).
      const double k = r.scale - 1;
      for (std::size_t i = 0; i < n; ++i)
        if (s.weight[i] > 0) modulus[i] *= 1 + s.weight[i] * k;
    }
  }

  // Scales relative to each vertex's tissue.
  out.scale.resize(n);
  for (std::size_t i = 0; i < n; ++i) out.scale[i] = static_cast<float>(modulus[i] / eff[out.tissue_of[i]]);
  return out;
}

}  // namespace palpa::tissue
