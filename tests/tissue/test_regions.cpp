// Region weights and the layered tissue map (modules/tissue/regions.cpp):
// primitives against their closed forms, geodesic disks against great-circle
// distance, VTP/PLY arrays and PNG maps written here and sampled at known
// points, the layer order by hand, and the error messages exactly.

#include "tissue/regions.h"

#include "common/test_support.h"
#include "mesh/generate.h"
#include "tissue/internal_regions.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <vtkDoubleArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkXMLPolyDataWriter.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <numbers>
#include <numeric>
#include <queue>
#include <random>
#include <stdexcept>

namespace palpa::tissue {
namespace {

namespace fs = std::filesystem;
using internal::sample_region;

constexpr double mm = 1e-3;
// Weights are float32.
constexpr double kWeightTol = 1e-6;

double smooth(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3 - 2 * t);
}
// The documented feather rule, written out: smoothstep(-d / f + 1/2).
double expected_weight(double d, double f) { return f > 0 ? smooth(-d / f + 0.5) : (d <= 0 ? 1.0 : 0.0); }

// A flat grid, 1 mm spacing, 81 x 81 vertices centred on the origin.
const mesh::SurfaceMesh& plane() {
  static const mesh::SurfaceMesh m = mesh::make_plane(81, 81, 1 * mm);
  return m;
}

// A mesh of just these points (region maps read positions only).
mesh::SurfaceMesh points(std::vector<Vec3> p) {
  mesh::SurfaceMesh m;
  m.positions = std::move(p);
  return m;
}

// The index of the vertex at p (to 1e-9 m).
std::size_t vertex_at(const mesh::SurfaceMesh& m, const Vec3& p) {
  for (std::size_t i = 0; i < m.vertex_count(); ++i)
    if ((m.positions[i] - p).norm() < 1e-9) return i;
  ADD_FAILURE() << "no vertex at " << p.transpose();
  return 0;
}

Tissue tissue(const std::string& name, double e_kpa, double nu = 0.45) {
  Tissue t;
  t.name = name;
  t.youngs_modulus = e_kpa * 1e3;
  t.poisson = nu;
  return t;
}
double effective(const Tissue& t) { return t.youngs_modulus / (1 - t.poisson * t.poisson); }

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

// ---------------------------------------------------------------------------
// Primitives against their closed forms.

TEST(Regions, SphereWeightIsTheFeatheredDistanceToTheBall) {
  Region r;
  r.name = "ball";
  r.kind = RegionKind::Sphere;
  r.centre = Vec3(5 * mm, 0, 3 * mm);
  r.radius = 20 * mm;
  r.feather = 8 * mm;
  const auto w = region_weights(plane(), r);
  ASSERT_EQ(w.size(), plane().vertex_count());
  for (std::size_t i = 0; i < w.size(); ++i)
    EXPECT_NEAR(w[i], expected_weight((plane().positions[i] - r.centre).norm() - r.radius, r.feather), kWeightTol);
  // Inside, outside, and 0.5 where the ball's boundary crosses the x axis.
  const double xb = 5 * mm + std::sqrt(20.0 * 20.0 - 3.0 * 3.0) * mm;
  auto at_x = [&](double x) {
    Region q = r;
    return sample_region(points({Vec3(x, 0, 0)}), q).weight[0];
  };
  EXPECT_FLOAT_EQ(at_x(5 * mm), 1.0f);
  EXPECT_FLOAT_EQ(at_x(xb + 5 * mm), 0.0f);  // d > 4 mm there (it is not radial)
  EXPECT_NEAR(at_x(xb), 0.5, kWeightTol);
  // Monotone across the feather.
  float last = 2;
  for (double x = xb - 6 * mm; x <= xb + 6 * mm; x += 0.25 * mm) {
    const float v = at_x(x);
    EXPECT_LE(v, last) << "x = " << x;
    last = v;
  }
}

TEST(Regions, HardEdgeWithoutFeather) {
  Region r;
  r.name = "ball";
  r.radius = 10 * mm;
  const auto w = region_weights(plane(), r);
  for (std::size_t i = 0; i < w.size(); ++i)
    EXPECT_EQ(w[i], plane().positions[i].norm() <= r.radius ? 1.0f : 0.0f);
  // On the boundary: inside.
  EXPECT_EQ(sample_region(points({Vec3(0.01, 0, 0), Vec3(0.0101, 0, 0)}), r).weight, (std::vector<float>{1, 0}));
}

TEST(Regions, EllipsoidIsExactOnItsAxesAndRightSidedEverywhere) {
  Region r;
  r.name = "egg";
  r.kind = RegionKind::Ellipsoid;
  r.semi_axes = Vec3(30 * mm, 15 * mm, 10 * mm);
  r.feather = 6 * mm;
  // Along each axis the approximation is the exact distance x - a.
  for (int k = 0; k < 3; ++k) {
    const double a = r.semi_axes[k];
    for (double s : {0.2, 0.9, 1.0, 1.05, 1.1, 1.5}) {
      Vec3 p = Vec3::Zero();
      p[k] = s * a;
      EXPECT_NEAR(internal::ellipsoid_signed_distance(p, r.centre, r.semi_axes), s * a - a, 1e-15);
      EXPECT_NEAR(sample_region(points({p}), r).weight[0], expected_weight(s * a - a, r.feather), kWeightTol);
    }
    Vec3 b = Vec3::Zero();
    b[k] = a;
    EXPECT_NEAR(sample_region(points({b}), r).weight[0], 0.5, kWeightTol);
  }
  // Off the axes: w > 1/2 exactly inside the implicit surface (feathered), 1
  // / 0 with no feather; monotone along a ray through the boundary.
  Region hard = r;
  hard.feather = 0;
  const auto wf = region_weights(plane(), r), wh = region_weights(plane(), hard);
  for (std::size_t i = 0; i < wf.size(); ++i) {
    const Vec3 q = plane().positions[i].cwiseQuotient(r.semi_axes);
    const double f = q.squaredNorm();
    if (std::abs(f - 1) > 1e-9) {  // (not the points on the surface, to roundoff)
      EXPECT_EQ(wh[i], f < 1 ? 1.0f : 0.0f) << i;
      EXPECT_EQ(wf[i] > 0.5f, f < 1) << i;
    }
  }
  const Vec3 dir = Vec3(1, 1, 0).normalized();
  float last = 2;
  for (double t = 0; t < 40 * mm; t += 0.5 * mm) {
    const float v = sample_region(points({t * dir}), r).weight[0];
    EXPECT_LE(v, last);
    last = v;
  }
  EXPECT_EQ(last, 0.0f);
}

// The exact signed distance to an ellipsoid (for points off its centre):
// outside, the closest point is a_i^2 q_i / (a_i^2 + t) with t > 0 the root
// of sum (a_i q_i / (a_i^2 + t))^2 = 1 (bisection); inside, t in (-min a^2, 0).
double exact_ellipsoid_distance(const Vec3& q, const Vec3& a) {
  auto f = [&](double t) {
    double s = 0;
    for (int k = 0; k < 3; ++k) s += std::pow(a[k] * q[k] / (a[k] * a[k] + t), 2);
    return s - 1;
  };
  const bool outside = q.cwiseQuotient(a).squaredNorm() > 1;
  double lo = outside ? 0 : -a.minCoeff() * a.minCoeff() * (1 - 1e-15), hi = outside ? 1.0 : 0;
  while (outside && f(hi) > 0) hi *= 2;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) > 0 ? lo : hi) = mid;
  }
  const double t = 0.5 * (lo + hi);
  Vec3 p;
  for (int k = 0; k < 3; ++k) p[k] = a[k] * a[k] * q[k] / (a[k] * a[k] + t);
  return (outside ? 1 : -1) * (q - p).norm();
}

TEST(Regions, EllipsoidDistanceApproximationNearTheSurface) {
  // Points within 3 mm of a 30 x 15 x 10 mm ellipsoid: the approximation
  // k0 (k0 - 1) / k1 against the exact distance.
  const Vec3 a(30 * mm, 15 * mm, 10 * mm);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0, worst_rel = 0;
  int n = 0;
  while (n < 20000) {
    const Vec3 dir = Vec3(u(rng), u(rng), u(rng));
    if (dir.norm() < 1e-3) continue;
    const Vec3 on = dir.cwiseQuotient(dir.cwiseQuotient(a).norm() * Vec3::Ones());  // on the surface
    const Vec3 q = on * (1 + 0.3 * u(rng));
    const double exact = exact_ellipsoid_distance(q, a);
    if (std::abs(exact) > 3 * mm) continue;
    ++n;
    const double approx = internal::ellipsoid_signed_distance(q, Vec3::Zero(), a);
    EXPECT_EQ(approx > 0, exact > 0);
    worst = std::max(worst, std::abs(approx - exact));
    worst_rel = std::max(worst_rel, std::abs(approx - exact) / std::abs(exact));
  }
  std::printf("ellipsoid 30 x 15 x 10 mm, %d points within 3 mm of it: max |approx - exact| %.3f mm, max relative "
              "%.1f%%\n",
              n, worst / mm, 100 * worst_rel);
  // First order in the distance: 0.45 mm at most here, 16% of it.
  EXPECT_LT(worst, 0.6 * mm);
  EXPECT_LT(worst_rel, 0.2);
}

TEST(Regions, BoxWeightIsTheFeatheredDistanceToTheBox) {
  Region r;
  r.name = "slab";
  r.kind = RegionKind::Box;
  r.box_min = Vec3(-10 * mm, -5 * mm, -50 * mm);
  r.box_max = Vec3(20 * mm, 5 * mm, 50 * mm);
  r.feather = 4 * mm;
  // Points with hand distances: outside a face, outside an edge, inside.
  const std::vector<std::pair<Vec3, double>> cases = {
      {Vec3(22 * mm, 0, 0), 2 * mm},
      {Vec3(20 * mm, 0, 0), 0.0},
      {Vec3(19 * mm, 0, 0), -1 * mm},
      {Vec3(0, 4 * mm, 0), -1 * mm},
      {Vec3(21 * mm, 6 * mm, 0), std::sqrt(2.0) * mm},
      {Vec3(-13 * mm, -9 * mm, 0), 5 * mm},
      {Vec3(0, 0, 0), -5 * mm},
  };
  for (const auto& [p, d] : cases)
    EXPECT_NEAR(sample_region(points({p}), r).weight[0], expected_weight(d, r.feather), kWeightTol) << p.transpose();
  EXPECT_NEAR(sample_region(points({Vec3(20 * mm, 0, 0)}), r).weight[0], 0.5, kWeightTol);
  float last = 2;
  for (double x = 15 * mm; x <= 25 * mm; x += 0.25 * mm) {
    const float v = sample_region(points({Vec3(x, 0, 0)}), r).weight[0];
    EXPECT_LE(v, last);
    last = v;
  }
}

TEST(Regions, HalfSpaceOnAPlaneAndOnASphere) {
  Region r;
  r.name = "right";
  r.kind = RegionKind::HalfSpace;
  r.point = Vec3(5 * mm, 0, 0);
  r.normal = Vec3(2, 0, 0);  // not unit: normalised
  r.feather = 4 * mm;
  const auto w = region_weights(plane(), r);
  for (std::size_t i = 0; i < w.size(); ++i)
    EXPECT_NEAR(w[i], expected_weight(plane().positions[i].x() - 5 * mm, r.feather), kWeightTol);
  EXPECT_NEAR(w[vertex_at(plane(), Vec3(5 * mm, 0, 0))], 0.5, kWeightTol);

  const auto sphere = mesh::make_sphere(2000, 0.05);
  Region top;
  top.name = "top";
  top.kind = RegionKind::HalfSpace;
  top.point = Vec3(0, 0, 0.02);
  top.normal = -Vec3::UnitZ();  // inside: z >= 0.02
  top.feather = 0.01;
  const auto ws = region_weights(sphere, top);
  for (std::size_t i = 0; i < ws.size(); ++i)
    EXPECT_NEAR(ws[i], expected_weight(0.02 - sphere.positions[i].z(), top.feather), kWeightTol);
}

// ---------------------------------------------------------------------------
// Geodesic disks.

// Plain Dijkstra over the mesh edges, the baseline fast marching improves on.
std::vector<double> dijkstra(const mesh::SurfaceMesh& m, Index s) {
  std::vector<double> d(m.vertex_count(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> q;
  d[s] = 0;
  q.push({0, s});
  while (!q.empty()) {
    const auto [dv, v] = q.top();
    q.pop();
    if (dv > d[v]) continue;
    for (Index w : m.vertex_neighbors.row(v)) {
      const double c = dv + (m.positions[w] - m.positions[v]).norm();
      if (c < d[w]) {
        d[w] = c;
        q.push({c, w});
      }
    }
  }
  return d;
}

TEST(Regions, GeodesicDistanceOnASphereIsTheGreatCircleDistance) {
  const double R = 0.1;
  const auto sphere = mesh::make_sphere(60000, R);
  // The source: a vertex well inside a cube face, and one near a cube corner.
  for (const Vec3& dir : {Vec3(0.1, 0.05, 1).normalized(), Vec3(1, 1, 1).normalized()}) {
    Index src = 0;
    for (std::size_t i = 0; i < sphere.vertex_count(); ++i)
      if ((sphere.positions[i] - R * dir).norm() < (sphere.positions[src] - R * dir).norm()) src = static_cast<Index>(i);
    const Vec3 c = sphere.positions[src];
    const auto fmm = internal::geodesic_distances(sphere, src, 0.1);
    const auto dij = dijkstra(sphere, src);
    double worst_fmm = 0, worst_dij = 0;
    for (std::size_t i = 0; i < sphere.vertex_count(); ++i) {
      const double g = R * std::acos(std::clamp(sphere.positions[i].dot(c) / (R * R), -1.0, 1.0));
      if (g > 0.08) continue;
      ASSERT_TRUE(std::isfinite(fmm[i]));
      worst_fmm = std::max(worst_fmm, std::abs(fmm[i] - g));
      worst_dij = std::max(worst_dij, std::abs(dij[i] - g));
    }
    // 60k vertices: edges about 1.4 mm. Fast marching is well under a tenth of
    // an edge off over 80 mm; Dijkstra's zigzag paths several times more.
    RecordProperty("fmm_max_error_m", std::to_string(worst_fmm));
    RecordProperty("dijkstra_max_error_m", std::to_string(worst_dij));
    std::printf("geodesic on a sphere R = 0.1 m, %zu vertices, within 80 mm of %s: fast marching max |error| %.3f mm, "
                "Dijkstra %.3f mm\n",
                sphere.vertex_count(), dir.z() > 0.9 ? "a face centre" : "a cube corner", worst_fmm / mm,
                worst_dij / mm);
    EXPECT_LT(worst_fmm, 0.25 * mm);
    EXPECT_LT(worst_fmm, 0.5 * worst_dij);
  }
}

TEST(Regions, GeodesicDiskWeightFollowsTheGreatCircleDistance) {
  const double R = 0.05;
  const auto sphere = mesh::make_sphere(20000, R);
  Region r;
  r.name = "patch";
  r.kind = RegionKind::GeodesicDisk;
  r.centre = sphere.positions[123] * 1.2;  // off the surface: the nearest vertex is the source
  r.radius = 30 * mm;  // more than a quarter of the way round
  r.feather = 10 * mm;
  const auto w = region_weights(sphere, r);
  const Vec3 c = sphere.positions[123];
  const double slope = 1.5 / r.feather;  // smoothstep's steepest slope
  for (std::size_t i = 0; i < w.size(); ++i) {
    const double g = R * std::acos(std::clamp(sphere.positions[i].dot(c) / (R * R), -1.0, 1.0));
    EXPECT_NEAR(w[i], expected_weight(g - r.radius, r.feather), 0.4 * mm * slope) << i;
    if (g < r.radius - 6 * mm) {
      EXPECT_EQ(w[i], 1.0f);
    }
    if (g > r.radius + 6 * mm) {
      EXPECT_EQ(w[i], 0.0f);
    }
  }
  EXPECT_EQ(w[123], 1.0f);
}

// ---------------------------------------------------------------------------
// Vertex arrays from VTP and PLY, in another vertex order.

struct ArrayCase {
  mesh::SurfaceMesh mesh = mesh::make_sphere(3000, 0.05);
  std::vector<std::size_t> order;  // file point k is mesh vertex order[k]
  ArrayCase() {
    order.resize(mesh.vertex_count());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), std::mt19937(7));
  }
  // The values the file holds: smooth in position, and a label by the sign of z.
  static double value_at(const Vec3& p) { return 0.5 + 0.5 * p.x() / 0.05; }
  static int label_at(const Vec3& p) { return p.z() > 0 ? 3 : 1; }
};

void write_vtp(const fs::path& file, const ArrayCase& c) {
  vtkNew<vtkPoints> pts;
  vtkNew<vtkDoubleArray> value, label;
  value->SetName("stiffness");
  label->SetName("label");
  for (std::size_t k : c.order) {
    const Vec3& p = c.mesh.positions[k];
    pts->InsertNextPoint(p.x(), p.y(), p.z());
    value->InsertNextValue(ArrayCase::value_at(p));
    label->InsertNextValue(ArrayCase::label_at(p));
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(pts);
  poly->GetPointData()->AddArray(value);
  poly->GetPointData()->AddArray(label);
  vtkNew<vtkXMLPolyDataWriter> w;
  w->SetFileName(file.c_str());
  w->SetInputData(poly);
  ASSERT_EQ(w->Write(), 1);
}

// A PLY with a face element after the vertices (and, binary, one before).
enum class Ply { Ascii, Little, Big };
void write_ply(const fs::path& file, const ArrayCase& c, Ply format) {
  std::ofstream out(file, std::ios::binary);
  const bool binary = format != Ply::Ascii;
  out << "ply\nformat "
      << (format == Ply::Ascii ? "ascii" : format == Ply::Little ? "binary_little_endian" : "binary_big_endian")
      << " 1.0\ncomment written by test_regions\n";
  if (binary) out << "element material 2\nproperty list uchar int ids\nproperty double k\n";
  out << "element vertex " << c.order.size()
      << "\nproperty float x\nproperty float y\nproperty double z\nproperty float stiffness\nproperty uchar label\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  auto put = [&](const auto v) {
    char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    if (format == Ply::Big) std::reverse(b, b + sizeof v);  // (this machine is little-endian)
    out.write(b, sizeof v);
  };
  if (binary) {
    put(std::uint8_t{2}), put(std::int32_t{4}), put(std::int32_t{5}), put(1.5);
    put(std::uint8_t{0}), put(2.5);
  }
  for (std::size_t k : c.order) {
    const Vec3& p = c.mesh.positions[k];
    const auto v = static_cast<float>(ArrayCase::value_at(p));
    const auto l = static_cast<std::uint8_t>(ArrayCase::label_at(p));
    if (binary) {
      put(static_cast<float>(p.x())), put(static_cast<float>(p.y())), put(p.z()), put(v), put(l);
    } else {
      out.precision(9);
      out << static_cast<float>(p.x()) << ' ' << static_cast<float>(p.y()) << ' ' << p.z() << ' ' << v << ' '
          << int(l) << "\n";
    }
  }
  if (binary) put(std::uint8_t{3}), put(std::int32_t{0}), put(std::int32_t{1}), put(std::int32_t{2});
  else out << "3 0 1 2\n";
}

void expect_array_maps(const ArrayCase& c, const fs::path& file) {
  SCOPED_TRACE(file.string());
  Region r;
  r.name = "stiffness map";
  r.kind = RegionKind::VertexArray;
  r.file = file;
  r.array = "stiffness";
  r.scale_min = 1;
  r.scale_max = 3;
  const auto s = sample_region(c.mesh, r);
  for (std::size_t i = 0; i < c.mesh.vertex_count(); ++i) {
    EXPECT_EQ(s.weight[i], 1.0f);
    EXPECT_NEAR(s.value[i], ArrayCase::value_at(c.mesh.positions[i]), 1e-6) << i;
  }
  const std::vector<Tissue> tissues = {tissue("liver", 4), tissue("tumour", 40, 0.3)};
  const TissueMap m = evaluate_tissue_map(c.mesh, tissues, 0, {r});
  for (std::size_t i = 0; i < c.mesh.vertex_count(); ++i) {
    EXPECT_EQ(m.tissue_of[i], 0);
    EXPECT_NEAR(m.scale[i], 1 + 2 * ArrayCase::value_at(c.mesh.positions[i]), 1e-5) << i;
  }
  // Labels: 3 (z > 0) is tumour; 1 is not listed and keeps the base.
  Region l;
  l.name = "labels";
  l.kind = RegionKind::VertexArray;
  l.file = file;
  l.array = "label";
  l.label_tissues = {{3, "tumour"}, {7, "liver"}};
  const TissueMap ml = evaluate_tissue_map(c.mesh, tissues, 0, {r, l});
  for (std::size_t i = 0; i < c.mesh.vertex_count(); ++i) {
    const bool up = c.mesh.positions[i].z() > 0;
    EXPECT_EQ(ml.tissue_of[i], up ? 1 : 0) << i;
    EXPECT_NEAR(ml.scale[i], up ? 1.0 : 1 + 2 * ArrayCase::value_at(c.mesh.positions[i]), 1e-5) << i;
  }
}

TEST(Regions, VtpArrayInAnotherVertexOrderMapsByNearestPoint) {
  const ArrayCase c;
  const auto file = test::temp_dir("regions_vtp") / "organ.vtp";
  write_vtp(file, c);
  expect_array_maps(c, file);
}

TEST(Regions, PlyArrayAsciiAndBinaryBothEndiansInAnotherVertexOrderMapsByNearestPoint) {
  const ArrayCase c;
  const auto dir = test::temp_dir("regions_ply");
  write_ply(dir / "ascii.ply", c, Ply::Ascii);
  write_ply(dir / "little.ply", c, Ply::Little);
  write_ply(dir / "big.ply", c, Ply::Big);
  expect_array_maps(c, dir / "ascii.ply");
  expect_array_maps(c, dir / "little.ply");
  expect_array_maps(c, dir / "big.ply");
}

// ---------------------------------------------------------------------------
// PNG maps.

// A 4 x 3 image whose pixel (i, j) is pix(i, j).
template <class T>
cv::Mat image(T (*pix)(int, int)) {
  cv::Mat m(3, 4, cv::DataType<T>::type);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) m.at<T>(j, i) = pix(i, j);
  return m;
}
std::uint8_t pix8(int i, int j) { return static_cast<std::uint8_t>(10 + 60 * i + 7 * j); }
std::uint16_t pix16(int i, int j) { return static_cast<std::uint16_t>(1000 + 16000 * i + 333 * j); }

TEST(Regions, PlanarPngSampledAtPixelCentresAndBetween) {
  const auto dir = test::temp_dir("regions_planar");
  ASSERT_TRUE(cv::imwrite((dir / "m8.png").string(), image(&pix8)));
  ASSERT_TRUE(cv::imwrite((dir / "m16.png").string(), image(&pix16)));
  // A colour image with equal channels reads as the same gray.
  cv::Mat colour;
  cv::Mat planes[] = {image(&pix8), image(&pix8), image(&pix8)};
  cv::merge(planes, 3, colour);
  ASSERT_TRUE(cv::imwrite((dir / "c8.png").string(), colour));
  cv::Mat colour16;
  cv::Mat planes16[] = {image(&pix16), image(&pix16), image(&pix16)};
  cv::merge(planes16, 3, colour16);
  ASSERT_TRUE(cv::imwrite((dir / "c16.png").string(), colour16));

  // 40 x 30 mm at z = 0, pixels 10 mm; vertices at pixel centres, 7 mm above
  // the plane (projection along u x v), midway between two centres, outside.
  Region r;
  r.name = "map";
  r.kind = RegionKind::PlanarImage;
  r.origin = Vec3(-0.02, -0.015, 0);
  r.u_axis = Vec3(0.04, 0, 0);
  r.v_axis = Vec3(0, 0.03, 0);
  r.scale_min = 0.5;
  r.scale_max = 4.5;
  auto centre = [&](double i, double j) -> Vec3 { return r.origin + Vec3((i + 0.5) * 10 * mm, (j + 0.5) * 10 * mm, 7 * mm); };
  std::vector<Vec3> p;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) p.push_back(centre(i, j));
  p.push_back(centre(1.5, 1));        // 12: between (1, 1) and (2, 1)
  p.push_back(centre(0.25, 0.5));     // 13: a quarter between (0, 0)..(1, 1)
  p.push_back(centre(-0.4, 0));       // 14: inside the image, left of the first centre: the edge pixel
  p.push_back(centre(4.6, 1));        // 15: outside
  const auto m = points(p);
  struct Depth {
    std::string file;
    double unit;
    std::function<double(int, int)> pix;
  };
  const std::vector<Depth> depths = {{"m8.png", 255.0, [](int i, int j) { return double(pix8(i, j)); }},
                                     {"m16.png", 65535.0, [](int i, int j) { return double(pix16(i, j)); }},
                                     {"c8.png", 255.0, [](int i, int j) { return double(pix8(i, j)); }},
                                     {"c16.png", 65535.0, [](int i, int j) { return double(pix16(i, j)); }}};
  for (const auto& d : depths) {
    SCOPED_TRACE(d.file);
    r.file = dir / d.file;
    const auto s = sample_region(m, r);
    auto v = [&](int i, int j) { return d.pix(i, j) / d.unit; };
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(s.weight[j * 4 + i], 1.0f);
        EXPECT_NEAR(s.value[j * 4 + i], v(i, j), 1e-6) << i << "," << j;
      }
    EXPECT_NEAR(s.value[12], 0.5 * (v(1, 1) + v(2, 1)), 1e-6);
    const double top = 0.75 * v(0, 0) + 0.25 * v(1, 0), bottom = 0.75 * v(0, 1) + 0.25 * v(1, 1);
    EXPECT_NEAR(s.value[13], 0.5 * (top + bottom), 1e-6);
    EXPECT_NEAR(s.value[14], v(0, 0), 1e-6);
    EXPECT_EQ(s.weight[15], 0.0f);
    // The map: scale_min + (scale_max - scale_min) v; outside unaffected.
    const TissueMap tm = evaluate_tissue_map(m, {tissue("fat", 2)}, 0, {r});
    EXPECT_NEAR(tm.scale[5], 0.5 + 4 * v(1, 1), 1e-6);
    EXPECT_EQ(tm.scale[15], 1.0f);
  }
}

TEST(Regions, PlanarPngWithSkewAxesProjectsAlongTheirNormal) {
  const auto dir = test::temp_dir("regions_skew");
  ASSERT_TRUE(cv::imwrite((dir / "m8.png").string(), image(&pix8)));
  Region r;
  r.name = "skew";
  r.kind = RegionKind::PlanarImage;
  r.file = dir / "m8.png";
  r.origin = Vec3(0.01, 0.02, 0.03);
  r.u_axis = Vec3(0.04, 0.01, 0);    // 4 pixels along u
  r.v_axis = Vec3(0.01, 0.03, 0.01); // 3 pixels along v, not perpendicular to u
  const Vec3 n = r.u_axis.cross(r.v_axis).normalized();
  std::vector<Vec3> p;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i)
      p.push_back(r.origin + (i + 0.5) / 4 * r.u_axis + (j + 0.5) / 3 * r.v_axis + (0.01 * i - 0.02) * n);
  const auto s = sample_region(points(p), r);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(s.value[j * 4 + i], pix8(i, j) / 255.0, 1e-6) << i << "," << j;
}

TEST(Regions, CylindricalPngWrapsRoundTheAxis) {
  const auto dir = test::temp_dir("regions_cylinder");
  ASSERT_TRUE(cv::imwrite((dir / "m8.png").string(), image(&pix8)));
  ASSERT_TRUE(cv::imwrite((dir / "m16.png").string(), image(&pix16)));
  // Axis z through (0.01, 0, 0), angle from +y; 4 columns of 90 degrees, 3
  // rows of 10 mm up the axis.
  Region r;
  r.name = "wrap";
  r.kind = RegionKind::CylindricalImage;
  r.origin = Vec3(0.01, 0, -0.01);
  r.axis = Vec3(0, 0, 2);
  r.reference = Vec3(0, 1, 0.3);  // not perpendicular: its part along the axis is dropped
  r.height = 0.03;
  auto at = [&](double col, double row, double radius) -> Vec3 {
    const double theta = (col + 0.5) * std::numbers::pi / 2;
    // e1 = +y, e2 = axis x e1 = -x.
    return r.origin + radius * (std::cos(theta) * Vec3::UnitY() - std::sin(theta) * Vec3::UnitX()) +
           Vec3(0, 0, (row + 0.5) * 10 * mm);
  };
  std::vector<Vec3> p;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) p.push_back(at(i, j, 0.02 + 0.005 * i));
  p.push_back(at(-0.5, 1, 0.02));  // 12: angle 0, between column 3 and column 0 (wraps)
  p.push_back(at(1, 3.2, 0.02));   // 13: above the top
  p.push_back(at(1, -0.7, 0.02));  // 14: below the origin
  const auto m = points(p);
  for (const auto& [file, unit] : {std::pair{"m8.png", 255.0}, std::pair{"m16.png", 65535.0}}) {
    SCOPED_TRACE(file);
    r.file = dir / file;
    auto v = [&](int i, int j) { return (unit == 255.0 ? pix8(i, j) : pix16(i, j)) / unit; };
    const auto s = sample_region(m, r);
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) EXPECT_NEAR(s.value[j * 4 + i], v(i, j), 1e-6) << i << "," << j;
    EXPECT_NEAR(s.value[12], 0.5 * (v(3, 1) + v(0, 1)), 1e-6);
    EXPECT_EQ(s.weight[13], 0.0f);
    EXPECT_EQ(s.weight[14], 0.0f);
  }
}

// ---------------------------------------------------------------------------
// The layers.

TEST(Regions, NoRegionsGiveTheBaseTissue) {
  const auto m = evaluate_tissue_map(plane(), {tissue("a", 1), tissue("b", 2)}, 1, {});
  EXPECT_TRUE(std::all_of(m.tissue_of.begin(), m.tissue_of.end(), [](auto t) { return t == 1; }));
  EXPECT_TRUE(std::all_of(m.scale.begin(), m.scale.end(), [](float s) { return s == 1.0f; }));
}

TEST(Regions, LayerOrderMattersAndEachOrderFollowsTheRule) {
  const std::vector<Tissue> tissues = {tissue("gland", 10, 0.45), tissue("tumour", 60, 0.3)};
  const double m_gland = effective(tissues[0]), m_tumour = effective(tissues[1]);
  Region lump;  // tumour, feathered: weights strictly between 0 and 1 near its edge
  lump.name = "lump";
  lump.kind = RegionKind::Sphere;
  lump.radius = 10 * mm;
  lump.feather = 10 * mm;
  lump.tissue = "tumour";
  Region stiff;  // twice as stiff right of x = 8 mm, feathered
  stiff.name = "stiff side";
  stiff.kind = RegionKind::HalfSpace;
  stiff.point = Vec3(8 * mm, 0, 0);
  stiff.normal = -Vec3::UnitX();
  stiff.feather = 6 * mm;
  stiff.scale = 2;
  // Vertices on the x axis, from the lump's centre out past both edges.
  std::vector<Vec3> p;
  for (double x = 0; x <= 20 * mm; x += 1 * mm) p.push_back(Vec3(x, 0, 0));
  const auto m = points(p);
  const auto wls = region_weights(m, lump), wss = region_weights(m, stiff);
  const TissueMap ab = evaluate_tissue_map(m, tissues, 0, {lump, stiff});
  const TissueMap ba = evaluate_tissue_map(m, tissues, 0, {stiff, lump});
  bool differ = false;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double x = p[i].x();
    // The regions' weights (float; the closed forms are checked above).
    const double wl = wls[i], ws = wss[i];
    EXPECT_NEAR(wl, expected_weight(x - 10 * mm, 10 * mm), kWeightTol);
    EXPECT_NEAR(ws, expected_weight(8 * mm - x, 6 * mm), kWeightTol);
    const int t = wl >= 0.5 ? 1 : 0;
    const double e = t == 1 ? m_tumour : m_gland;
    // lump then scale: blend towards the tumour, then times 1 + ws (2 - 1).
    const double m_ab = ((1 - wl) * m_gland + wl * m_tumour) * (1 + ws);
    // scale then lump: times 1 + ws, then blend towards the tumour.
    const double m_ba = (1 - wl) * m_gland * (1 + ws) + wl * m_tumour;
    EXPECT_EQ(ab.tissue_of[i], t) << x;
    EXPECT_EQ(ba.tissue_of[i], t) << x;
    EXPECT_NEAR(ab.scale[i], m_ab / e, 2e-6 * m_ab / e) << x;
    EXPECT_NEAR(ba.scale[i], m_ba / e, 2e-6 * m_ba / e) << x;
    differ = differ || std::abs(ab.scale[i] - ba.scale[i]) > 1e-3;
  }
  EXPECT_TRUE(differ);
  // At the lump's centre: tumour at its own modulus, before the scale reaches it.
  EXPECT_EQ(ab.tissue_of[0], 1);
  EXPECT_FLOAT_EQ(ab.scale[0], 1.0f);
  // Far right: gland times 2 in one order; in the other the lump is 0 there too.
  EXPECT_FLOAT_EQ(ab.scale.back(), 2.0f);
  EXPECT_FLOAT_EQ(ba.scale.back(), 2.0f);
}

TEST(Regions, TissueRegionWithAScaleHoldsThatTissueScaled) {
  const std::vector<Tissue> tissues = {tissue("gland", 10, 0.45), tissue("tumour", 60, 0.3)};
  Region r;
  r.name = "hard lump";
  r.radius = 5 * mm;
  r.feather = 4 * mm;
  r.tissue = "tumour";
  r.scale = 2;
  // Inside (w = 1), on the edge (w = 1/2), outside (w = 0).
  const auto m = points({Vec3::Zero(), Vec3(5 * mm, 0, 0), Vec3(8 * mm, 0, 0)});
  const TissueMap tm = evaluate_tissue_map(m, tissues, 0, {r});
  EXPECT_EQ(tm.tissue_of, (std::vector<std::uint16_t>{1, 1, 0}));
  EXPECT_FLOAT_EQ(tm.scale[0], 2.0f);
  EXPECT_NEAR(tm.scale[1], (0.5 * effective(tissues[0]) + 0.5 * 2 * effective(tissues[1])) / effective(tissues[1]),
              1e-6);
  EXPECT_FLOAT_EQ(tm.scale[2], 1.0f);
}

// ---------------------------------------------------------------------------
// Error messages, exactly.

TEST(Regions, ErrorMessagesNameTheRegionAndTheFault) {
  const auto dir = test::temp_dir("regions_errors");
  const std::vector<Tissue> tissues = {tissue("liver", 4), tissue("tumour", 40)};
  const auto m = points({Vec3::Zero(), Vec3(0.01, 0, 0)});
  {
    std::ofstream(dir / "empty.png");
    std::ofstream(dir / "text.png") << "not a png\n";
    // A PNG signature and IHDR chunk claiming 100000 x 100000 pixels (nothing after it).
    const unsigned char ihdr[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                                  0, 1, 0x86, 0xa0, 0, 1, 0x86, 0xa0, 8, 0, 0, 0, 0};
    std::ofstream(dir / "huge.png", std::ios::binary).write(reinterpret_cast<const char*>(ihdr), sizeof ihdr);
    // 4 x 4 pixels, then no image data: passes the size check, OpenCV refuses it.
    unsigned char small[sizeof ihdr];
    std::memcpy(small, ihdr, sizeof ihdr);
    small[16] = small[17] = small[18] = 0, small[19] = 4;
    small[20] = small[21] = small[22] = 0, small[23] = 4;
    std::ofstream(dir / "broken.png", std::ios::binary).write(reinterpret_cast<const char*>(small), sizeof small);
    std::ofstream(dir / "billion.ply") << "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n"
                                          "property float x\nproperty float y\nproperty float z\nproperty float s\nend_header\n";
    std::ofstream(dir / "claims.ply") << "ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
                                         "property float x\nproperty float y\nproperty float z\nproperty float s\nend_header\n"
                                         "0123456789abcdef";
    std::ofstream(dir / "organ.xyz") << "1 2 3\n";
    std::ofstream(dir / "bad.vtp") << "not xml\n";
    std::ofstream(dir / "bad.ply") << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n";
    fs::create_directories(dir / "folder.png");
    ArrayCase c;
    write_ply(dir / "a.ply", c, Ply::Ascii);
    write_vtp(dir / "a.vtp", c);
    std::ofstream(dir / "short.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                                        "property float z\nproperty float s\nend_header\n0 0 0 1\n1 1\n";
    std::ofstream(dir / "labels.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                                         "property float z\nproperty float s\nend_header\n0 0 0 1\n1 1 1 2.5\n";
  }
  auto image = [&](const fs::path& f) {
    Region r;
    r.name = "picture";
    r.kind = RegionKind::PlanarImage;
    r.file = f;
    return r;
  };
  auto array = [&](const fs::path& f, const std::string& a) {
    Region r;
    r.name = "paint";
    r.kind = RegionKind::VertexArray;
    r.file = f;
    r.array = a;
    return r;
  };
  Region unknown;
  unknown.name = "lump";
  unknown.tissue = "tumor";
  Region bad_label = array(dir / "a.vtp", "label");
  bad_label.label_tissues = {{3, "tumour"}, {1, "fat"}};
  Region radius;
  radius.name = "lump";
  radius.radius = -0.002;
  Region feather;
  feather.name = "lump";
  feather.feather = -1;
  Region box;
  box.name = "slab";
  box.kind = RegionKind::Box;
  box.box_min = Vec3(0, 0, 0);
  box.box_max = Vec3(1, 0, 1);
  Region map_tissue = image(dir / "text.png");
  map_tissue.tissue = "tumour";
  Region zero_scale;
  zero_scale.name = "soft";
  zero_scale.scale = 0;
  Region nan_centre;
  nan_centre.name = "lump";
  nan_centre.centre = Vec3(0, std::nan(""), 0);
  Region flat_image = image(dir / "text.png");
  flat_image.v_axis = 2 * flat_image.u_axis;
  Region labels_ply = array(dir / "labels.ply", "s");
  labels_ply.label_tissues = {{1, "tumour"}};

  const std::string d = dir.string();
  const std::vector<std::pair<Region, std::string>> cases = {
      {unknown, "region 'lump': unknown tissue 'tumor' (tissues: 'liver', 'tumour')"},
      {bad_label, "region 'paint': label 1: unknown tissue 'fat' (tissues: 'liver', 'tumour')"},
      {radius, "region 'lump': radius must be positive and finite, got -0.002 m"},
      {feather, "region 'lump': feather must be non-negative and finite, got -1 m"},
      {box, "region 'slab': box_max must be above box_min on every axis"},
      {nan_centre, "region 'lump': centre must be finite, got (0, nan, 0)"},
      {flat_image, "region 'picture': u_axis and v_axis must not be parallel"},
      {zero_scale, "region 'soft': scale must be positive and finite, got 0"},
      {map_tissue, "region 'picture': a map scales the modulus and holds no tissue (got tissue 'tumour'; label "
                   "arrays name tissues in label_tissues)"},
      {image(dir / "missing.png"), "region 'picture': cannot read image '" + d + "/missing.png': no such file"},
      {image(dir / "folder.png"), "region 'picture': cannot read image '" + d + "/folder.png': not a regular file"},
      {image(dir / "empty.png"), "region 'picture': cannot read image '" + d + "/empty.png': the file is empty"},
      {image(dir / "text.png"),
       "region 'picture': cannot read image '" + d + "/text.png': not a PNG file (maps are 8- or 16-bit PNG)"},
      {image(dir / "huge.png"),
       "region 'picture': image '" + d + "/huge.png' is 100000 x 100000 pixels, more than the limit of 67108864 (8192 x 8192)"},
      {image(dir / "broken.png"),
       "region 'picture': cannot read image '" + d + "/broken.png': not an image OpenCV can decode, or empty"},
      {array(dir / "billion.ply", "s"),
       "region 'paint': PLY '" + d + "/billion.ply': the header announces 1000000000 vertices, more than the limit of 20000000"},
      {array(dir / "claims.ply", "s"),
       "region 'paint': PLY '" + d + "/claims.ply': the header announces 1000 vertices, but only 16 bytes follow it"},
      {array(dir / "missing.vtp", "s"), "region 'paint': cannot read vertex array '" + d + "/missing.vtp': no such file"},
      {array(dir / "bad.vtp", "s"), "region 'paint': cannot read VTP '" + d + "/bad.vtp': not a VTK XML PolyData file"},
      {array(dir / "bad.ply", "s"), "region 'paint': PLY '" + d + "/bad.ply': the header has no end_header line"},
      {array(dir / "organ.xyz", "s"), "region 'paint': '" + d + "/organ.xyz': expected a .vtp or .ply file"},
      {array(dir / "a.vtp", "stiff"),
       "region 'paint': VTP '" + d + "/a.vtp' has no point-data array 'stiff' (it has: stiffness, label)"},
      {array(dir / "a.ply", "stiff"),
       "region 'paint': PLY '" + d + "/a.ply': no vertex property 'stiff' (it has: stiffness, label)"},
      {array(dir / "short.ply", "s"), "region 'paint': PLY '" + d + "/short.ply': the file ends before a vertex property"},
      {array(dir / "a.ply", ""), "region 'paint': no array name given"},
      {labels_ply, "region 'paint': '" + d + "/labels.ply': array 's' holds 2.5 at point 1, not an integer label of at most 16777216"},
  };
  for (const auto& [r, msg] : cases) EXPECT_EQ(error_of([&] { evaluate_tissue_map(m, tissues, 0, {r}); }), msg);
  // region_weights says the same for faults of the region itself.
  EXPECT_EQ(error_of([&] { region_weights(m, radius); }), cases[2].second);
  EXPECT_EQ(error_of([&] { evaluate_tissue_map(m, tissues, 2, {}); }),
            "tissue map: base tissue 2 out of range (2 tissues)");
}

}  // namespace
}  // namespace palpa::tissue
