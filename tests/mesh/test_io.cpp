// load_mesh / save_mesh: every format, the exact error message for each kind
// of bad input, round trips and the bundled default organ.

#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <utility>

#include <sys/stat.h>

namespace palpa::mesh {
namespace {

namespace fs = std::filesystem;

void write_file(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
}

// Little- and big-endian binary helpers for hand-made binary files.
std::string le32(std::uint32_t v) {
  return {char(v), char(v >> 8), char(v >> 16), char(v >> 24)};
}
std::string le_float(float f) { return le32(std::bit_cast<std::uint32_t>(f)); }
std::string be32(std::uint32_t v) {
  return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
}
std::string be_float(float f) { return be32(std::bit_cast<std::uint32_t>(f)); }

// The corner tetrahedron, outward, in a few formats.
const float kTet[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
const int kTetFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

// Binary STL of the given facets (corners as floats).
std::string binary_stl(const std::vector<std::array<std::array<float, 3>, 3>>& facets) {
  std::string s(80, ' ');
  s += le32(std::uint32_t(facets.size()));
  for (const auto& f : facets) {
    for (int i = 0; i < 3; ++i) s += le_float(0);
    for (const auto& c : f)
      for (float x : c) s += le_float(x);
    s += std::string(2, '\0');
  }
  return s;
}

std::vector<std::array<std::array<float, 3>, 3>> tet_facets() {
  std::vector<std::array<std::array<float, 3>, 3>> out;
  for (const auto& f : kTetFaces) {
    std::array<std::array<float, 3>, 3> t;
    for (int k = 0; k < 3; ++k) t[k] = {kTet[f[k]][0], kTet[f[k]][1], kTet[f[k]][2]};
    out.push_back(t);
  }
  return out;
}

// Legacy VTK BINARY (big-endian) POLYDATA of the tetrahedron; `points` lets a test spoil a value.
std::string binary_vtk(const std::function<float(int, int)>& points) {
  std::string s = "# vtk DataFile Version 3.0\ntet\nBINARY\nDATASET POLYDATA\nPOINTS 4 float\n";
  for (int v = 0; v < 4; ++v)
    for (int c = 0; c < 3; ++c) s += be_float(points(v, c));
  s += "\nPOLYGONS 4 16\n";
  for (const auto& f : kTetFaces) {
    s += be32(3);
    for (int v : f) s += be32(std::uint32_t(v));
  }
  return s + "\n";
}

const char* kPlyHeader =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";

// ---------------------------------------------------------------------------
// Every kind of bad input, with the exact message after "<path>: ".
struct BadInput {
  const char* name;      // test label
  const char* file;      // file name inside the temp folder
  std::string content;   // bytes written (ignored when `make` is "none")
  std::string expected;  // message after "<path>: "
  std::function<void(LoadOptions&)> tweak = nullptr;
  bool create = true;
};

std::vector<BadInput> bad_inputs() {
  const std::string tet_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  std::string nan_stl = binary_stl(tet_facets());
  {
    // Corner 2 of facet 1 becomes NaN: header 84, one facet 50, normal 12, two corners 24.
    const std::string nan = le_float(std::numeric_limits<float>::quiet_NaN());
    nan_stl.replace(84 + 50 + 12 + 24, 4, nan);
  }
  std::string short_stl = binary_stl(tet_facets());
  short_stl.resize(short_stl.size() - 10);
  short_stl.replace(0, 5, "xxxxx");
  return {
      // The file itself.
      {"missing", "missing.obj", "", "file not found", nullptr, false},
      {"directory", "folder.obj", "", "is a directory, not a mesh file", nullptr, false},
      {"unknown extension", "mesh.xyz", "x", "has an unknown extension '.xyz'; expected .obj, .stl, .ply, .off, .vtk, .vtp or .trian"},
      {"no extension", "mesh", "x", "has no file extension; expected .obj, .stl, .ply, .off, .vtk, .vtp or .trian"},
      // Empty.
      {"empty obj", "empty.obj", "", "has no triangles"},
      {"obj without faces", "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "has no triangles"},
      {"all degenerate", "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
       "has no triangles left after cleaning (1 degenerate, 0 duplicate)"},
      {"empty stl", "empty.stl", "solid x\nendsolid x\n", "has no triangles"},
      // Non-finite coordinates.
      {"obj nan", "nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n",
       "vertex 3 has a coordinate that is not a finite number"},
      {"obj inf", "inf.obj", "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n",
       "vertex 2 has a coordinate that is not a finite number"},
      {"obj overflow", "big.obj", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n",
       "vertex 2 has a coordinate that is not a finite number"},
      {"obj short vertex", "shortv.obj", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", "vertex 2 has fewer than 3 coordinates"},
      {"off nan", "nan.off", "OFF\n3 1 0\n0 0 0\n1 0 0\nnan 1 0\n3 0 1 2\n",
       "vertex 2 has a coordinate that is not a finite number"},
      {"ply nan", "nan.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n",
       "vertex 2 has a coordinate that is not a finite number"},
      {"stl ascii nan", "nan_ascii.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 nan 0\nendloop\nendfacet\nendsolid\n",
       "facet 0, vertex 2 has a coordinate that is not a finite number"},
      {"stl binary nan", "nan_binary.stl", nan_stl, "facet 1, vertex 2 has a coordinate that is not a finite number"},
      {"vtk binary nan", "nan.vtk", binary_vtk([](int v, int c) {
         return v == 3 && c == 1 ? std::numeric_limits<float>::infinity() : kTet[v][c];
       }),
       "vertex 3 has a coordinate that is not a finite number"},
      {"trian nan", "nan.trian", "3\n0 0 0\n1 0 0\n0 1 nan\n1\n0 1 2 -1 -1 -1\n",
       "vertex 2 has a coordinate that is not a finite number"},
      // Index out of range.
      {"obj index", "range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
       "face 1 uses vertex 9, but the vertices are numbered 1 to 3"},
      {"obj index zero", "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
       "face 1 uses vertex 0, but the vertices are numbered 1 to 3"},
      {"off index", "range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
       "face 0 uses vertex 7, but the vertices are numbered 0 to 2"},
      {"ply index", "range.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n",
       "face 0 uses vertex 5, but the vertices are numbered 0 to 2"},
      {"vtk index", "range.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 5\n",
       "face 0 uses vertex 5, but the vertices are numbered 0 to 2"},
      {"trian index", "range.trian", "3\n0 0 0\n1 0 0\n0 1 0\n1\n0 1 3 -1 -1 -1\n",
       "face 0 uses vertex 3, but the vertices are numbered 0 to 2"},
      // Faces that cannot be triangulated.
      {"obj two-vertex face", "two.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
       "face 1 has 2 vertices; a face needs at least 3"},
      {"obj bad reference", "ref.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
       "face 1: cannot read vertex reference 'x'"},
      {"off two-vertex face", "two.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
       "face 0 has 2 vertices; a face needs at least 3"},
      {"ply two-vertex face", "two.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
       "face 0 has 2 vertices; a face needs at least 3"},
      {"stl two-corner facet", "two.stl",
       "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid\n",
       "facet 0 has 2 vertices; STL facets are triangles"},
      {"vtk two-vertex polygon", "two.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 3\n2 0 1\n",
       "face 0 has 2 vertices; a face needs at least 3"},
      {"trian two-vertex face", "two.trian", "3\n0 0 0\n1 0 0\n0 1 0\n1\n0 1\n",
       "face 0 has 2 vertices; a face needs at least 3"},
      // Truncated or malformed files.
      {"off ends early", "short.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n",
       "the file ends before face 1 is complete"},
      {"off word for a coordinate", "word.off", "OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
       "cannot read 'zero' as a number"},
      // After a failed number OpenMesh's PLY reader used a stale face size; this must stop at once.
      {"ply word for an index", "word.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 two\n",
       "cannot read 'two' as a number"},
      {"ply ends early", "short.ply", std::string(kPlyHeader) + "0 0 0\n1 0 0\n0 1 0\n",
       "the file ends before face 0 is complete"},
      {"ply bad header", "bad.ply", "not a ply file\n", "is not a PLY file (its first line is not 'ply')"},
      {"stl neither", "short.stl", short_stl,
       "is neither ASCII STL (no 'solid' at the start) nor binary STL (the header announces 4 triangles, "
       "which take 284 bytes, but the file has 274)"},
      {"vtk no header", "junk.vtk", "hello\n", "is not a legacy VTK file (no '# vtk DataFile' header)"},
      {"vtk not polydata", "grid.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n",
       "is a legacy VTK file but its dataset is UNSTRUCTURED_GRID, not POLYDATA"},
      // VTK 9.1 itself crashes on this one; we must refuse it first.
      {"vtk truncated cells", "cut.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1\n",
       "the file ends inside its POLYGONS block"},
      {"vtk binary truncated", "cut_binary.vtk", binary_vtk([](int v, int c) { return kTet[v][c]; }).substr(0, 150),
       "the file ends inside its POLYGONS block"},
      {"vtp not xml", "junk.vtp", "hello", "is not a VTK XML PolyData file"},
      {"trian ends early", "short.trian", "3\n0 0 0\n1 0 0\n", "the file ends before vertex 2"},
      {"trian bad count", "count.trian", "three\n", "expected the vertex count, found 'three'"},
      // Size limits.
      {"too many vertices", "big.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n",
       "has more than 3 vertices (LoadOptions::max_vertices)", [](LoadOptions& o) { o.max_vertices = 3; }},
      {"too many triangles", "big.obj", tet_obj, "has more than 3 triangles (LoadOptions::max_triangles)",
       [](LoadOptions& o) { o.max_triangles = 3; }},
      {"too many stl triangles", "big.stl", binary_stl(tet_facets()),
       "has more than 2 triangles (LoadOptions::max_triangles)", [](LoadOptions& o) { o.max_triangles = 2; }},
      {"too many vtk points", "big.vtk", binary_vtk([](int v, int c) { return kTet[v][c]; }),
       "has more than 2 vertices (LoadOptions::max_vertices)", [](LoadOptions& o) { o.max_vertices = 2; }},
      {"too many trian vertices", "big.trian", "3\n0 0 0\n1 0 0\n0 1 0\n1\n0 1 2\n",
       "has more than 2 vertices (LoadOptions::max_vertices)", [](LoadOptions& o) { o.max_vertices = 2; }},
      // Hardening (issue 12): counts that would cost memory, refused before allocating.
      {"empty off", "empty.off", "", "has no triangles"},
      {"off header only", "header.off", "OFF\n", "the file ends before its vertex and face counts"},
      {"off absurd counts", "absurd.off", "OFF\n4000000000 4000000000 0\n",
       "has more than 20000000 vertices (LoadOptions::max_vertices)"},
      {"off counts beyond the file", "short_counts.off", "OFF\n19000000 1 0\n0 0 0\n",
       "the file ends before vertex 1 is complete"},
      {"off billion-vertex face", "huge_face.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n1000000000 0 1 2\n",
       "face 0 has 1000000000 vertices, more than the limit of 256 (LoadOptions::max_face_vertices)"},
      {"off face short of its count", "short_face.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
       "face 0 lists 3 of its 4 vertex indices"},
      {"off binary", "binary.off", "OFF BINARY\n", "is a binary OFF file, which Palpa does not read; save it as ASCII OFF or PLY"},
      {"obj huge face", "huge_face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf" + [] { std::string f; for (int i = 0; i < 300; ++i) f += " 1"; return f; }() + "\n",
       "face 1 has 300 vertices, more than the limit of 256 (LoadOptions::max_face_vertices)"},
      {"ply absurd vertex count", "absurd.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n",
       "has more than 20000000 vertices (LoadOptions::max_vertices)"},
      {"ply count beyond the file", "short_counts.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n" + std::string(24, '\0'),
       "the header announces 1000 'vertex' elements, but only 24 bytes follow it"},
      {"ply billion-vertex face", "huge_face.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n" + std::string(36, '\0') +
           le32(1000000000) + le32(0) + le32(1) + le32(2),
       "face 0 has 1000000000 vertices, more than the limit of 256 (LoadOptions::max_face_vertices)"},
      // A float index list: 1e30 was cast to an integer (undefined behaviour).
      {"ply float index", "float_index.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1e30\n",
       "face 0 has the vertex index 1e+30, which is not a whole number"},
      {"trian absurd count", "absurd.trian", "19999999\n0 0 0\n", "the file ends before vertex 1"},
      // Legacy VTK cells whose counts disagree with the data (VTK's reader crashed or read outside the cell).
      {"vtk cell count beyond its block", "cell_over.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n9 0 1 2\n",
       "its POLYGONS cell 0 has 9 vertices, but only 3 values of its block of 4 are left"},
      {"vtk cells short of the block", "cell_under.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 6\n3 0 1 2 0 0\n",
       "its POLYGONS block holds 4 values for its 1 cells, but its header says 6"},
      {"vtk block ends before a cell", "cell_missing.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 2 4\n3 0 1 2\n",
       "its POLYGONS block of 4 values ends before cell 1"},
      {"vtk negative cell count", "cell_negative.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n-3 0 1 2\n",
       "its POLYGONS cell 0 has -3 vertices"},
      {"vtk huge cell", "cell_huge.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n1000000000 0 1 2\n",
       "face 0 has 1000000000 vertices, more than the limit of 256 (LoadOptions::max_face_vertices)"},
      {"vtk 5.1 offsets out of order", "offsets.vtk",
       "# vtk DataFile Version 5.1\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 2 3\n"
       "OFFSETS vtktypeint64\n0 5\nCONNECTIVITY vtktypeint64\n0 1 2\n",
       "its POLYGONS offsets must rise from 0 to 3, but offset 1 is 5"},
      {"vtk absurd points", "absurd_points.vtk",
       "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET POLYDATA\nPOINTS 19000000 float\n",
       "the file ends inside its POINTS block"},
      // Finite but absurd coordinates, and specks.
      {"trian 1e300", "huge.trian", "3\n0 0 0\n1e300 0 0\n0 1 0\n1\n0 1 2\n",
       "vertex 1 has the coordinate 1e+300, beyond the limit of 1e+06 file units (LoadOptions::max_coordinate)"},
      {"vtk 1e30", "huge.vtk",
       "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n0 0 0 1e30 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n",
       "vertex 1 has the coordinate 1e+30, beyond the limit of 1e+06 file units (LoadOptions::max_coordinate)"},
      {"obj 1e-30 speck", "speck.obj", "v 0 0 0\nv 1e-30 0 0\nv 0 1e-30 0\nf 1 2 3\n",
       "is 1e-30 m across, less than the smallest size of 1e-06 m (LoadOptions::min_extent_m)"},
      // Options.
      {"bad unit", "unit.obj", tet_obj, "LoadOptions::unit_m must be a positive length in metres",
       [](LoadOptions& o) { o.unit_m = -1; }},
  };
}

TEST(LoadErrors, EachBadInputGetsItsExactMessage) {
  const fs::path dir = test::temp_dir("mesh_io_bad");
  fs::create_directory(dir / "folder.obj");
  for (const BadInput& c : bad_inputs()) {
    SCOPED_TRACE(c.name);
    const fs::path path = dir / c.file;
    if (c.create) write_file(path, c.content);
    LoadOptions options;
    if (c.tweak) c.tweak(options);
    try {
      load_mesh(path, options);
      ADD_FAILURE() << "no error for " << c.name;
    } catch (const MeshError& e) {
      EXPECT_EQ(std::string(e.what()), path.string() + ": " + c.expected);
    }
  }
}

void expect_tetrahedron(const SurfaceMesh& m, double scale = 1.0);

// Only regular files are read: a FIFO would hang, /dev/zero would fill memory.
TEST(LoadErrors, NonRegularFilesAreRefusedBeforeReading) {
  const fs::path dir = test::temp_dir("mesh_io_special");
  const fs::path fifo = dir / "pipe.obj", zero = dir / "zero.off";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  fs::create_symlink("/dev/zero", zero);
  for (const auto& [path, kind] : {std::pair{fifo, "a FIFO"}, std::pair{zero, "a character device"}}) {
    try {
      load_mesh(path);
      ADD_FAILURE() << "no error for " << path;
    } catch (const MeshError& e) {
      EXPECT_EQ(std::string(e.what()), path.string() + ": is not a regular file (" + kind + ")");
    }
  }
}

TEST(LoadErrors, FileSizeLimitIsCheckedBeforeReading) {
  const fs::path path = test::temp_dir("mesh_io_size") / "tet.obj";
  write_file(path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  LoadOptions o;
  o.max_file_bytes = 10;
  try {
    load_mesh(path, o);
    ADD_FAILURE();
  } catch (const MeshError& e) {
    EXPECT_EQ(std::string(e.what()),
              path.string() + ": is 32 bytes, more than the limit of 10 bytes (LoadOptions::max_file_bytes)");
  }
}

// An OBJ's mtllib is never followed: pointing it at a FIFO or /dev/zero changes nothing.
TEST(Load, ObjMtllibIsIgnored) {
  const fs::path dir = test::temp_dir("mesh_io_mtllib");
  ASSERT_EQ(::mkfifo((dir / "hang.mtl").c_str(), 0600), 0);
  write_file(dir / "tet.obj",
             "mtllib hang.mtl\nmtllib /dev/zero\nmtllib ../../../../dev/zero\nusemtl x\n"
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  expect_tetrahedron(load_mesh(dir / "tet.obj"));
}

// Binary PLY big-endian and COFF with colours read like the others.
TEST(Load, PlyBigEndianAndColouredOff) {
  const fs::path dir = test::temp_dir("mesh_io_variants");
  std::string ply = "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nproperty uchar red\nelement face 4\nproperty list uchar uint vertex_indices\n"
                    "property list uchar float texcoord\nend_header\n";
  std::string off = "COFF\n# comment\n4 4 6\n";
  for (const auto& v : kTet) {
    ply += be_float(v[0]) + be_float(v[1]) + be_float(v[2]) + std::string(1, '\x7f');
    off += std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]) + " 255 0 0 255\n";
  }
  for (const auto& f : kTetFaces) {
    ply += std::string(1, '\3') + be32(f[0]) + be32(f[1]) + be32(f[2]) + std::string(1, '\1') + be_float(0.5f);
    off += "3 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + " 0.5 0.5 0.5\n";
  }
  write_file(dir / "be.ply", ply);
  write_file(dir / "c.off", off);
  expect_tetrahedron(load_mesh(dir / "be.ply"));
  expect_tetrahedron(load_mesh(dir / "c.off"));
}

TEST(LoadErrors, FromPolygonsNamesTheSource) {
  try {
    from_polygons({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, {{0, 1, 3}}, {}, "probe scan");
    ADD_FAILURE();
  } catch (const MeshError& e) {
    EXPECT_STREQ(e.what(), "probe scan: face 0 uses vertex 3, but the vertices are numbered 0 to 2");
  }
  try {
    from_polygons({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, std::nan(""), 0)}, {{0, 1, 2}}, {}, "probe scan");
    ADD_FAILURE();
  } catch (const MeshError& e) {
    EXPECT_STREQ(e.what(), "probe scan: vertex 2 has a coordinate that is not a finite number");
  }
}

// ---------------------------------------------------------------------------
// Good input in every format gives the same closed, outward tetrahedron.
void expect_tetrahedron(const SurfaceMesh& m, double scale) {
  const MeshFacts f = analyse(m);
  EXPECT_EQ(f.vertices, 4u);
  EXPECT_EQ(f.triangles, 4u);
  EXPECT_TRUE(f.closed());
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_NEAR(f.signed_volume, scale * scale * scale / 6.0, 1e-12);
}

TEST(Load, EveryFormatReadsTheTetrahedron) {
  const fs::path dir = test::temp_dir("mesh_io_formats");
  std::string obj = "# tetrahedron\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n", off = "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
  std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
  std::string trian = "4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n4\n";
  std::string vtk51 = "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n"
                      "0 0 0 1 0 0 0 1 0\n0 0 1\nPOLYGONS 5 12\nOFFSETS vtktypeint64\n0 3 6 9 12\n"
                      "CONNECTIVITY vtktypeint64\n";
  std::string vtp_conn;
  for (const auto& v : kTet) ply += le_float(v[0]) + le_float(v[1]) + le_float(v[2]);
  for (const auto& f : kTetFaces) {
    obj += "f " + std::to_string(f[0] + 1) + "//1 " + std::to_string(f[1] + 1) + "//1 " + std::to_string(f[2] + 1) + "//1\n";
    off += "3 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\n";
    ply += std::string(1, '\3') + le32(f[0]) + le32(f[1]) + le32(f[2]);
    trian += std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + " -1 -1 -1\n";
    vtk51 += std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\n";
    vtp_conn += std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + " ";
  }
  obj += "vn 0 0 1\n";
  const std::string vtp =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
      "<PolyData><Piece NumberOfPoints=\"4\" NumberOfPolys=\"4\">\n"
      "<Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0 0 0 1"
      "</DataArray></Points>\n<Polys><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">" +
      vtp_conn +
      "</DataArray><DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">3 6 9 12</DataArray></Polys>\n"
      "</Piece></PolyData></VTKFile>\n";

  const std::pair<const char*, std::string> files[] = {
      {"tet.obj", obj},     {"TET.OBJ", obj},  {"tet.off", off},         {"tet.ply", ply},
      {"tet.trian", trian}, {"tet.vtk", vtk51}, {"tet_binary.vtk", binary_vtk([](int v, int c) { return kTet[v][c]; })},
      {"tet.vtp", vtp},     {"tet.stl", binary_stl(tet_facets())}};
  for (const auto& [name, bytes] : files) {
    SCOPED_TRACE(name);
    write_file(dir / name, bytes);
    expect_tetrahedron(load_mesh(dir / name));
  }
}

// OpenMesh's own mesh importer would drop the third triangle on the edge 0-1;
// ours must keep the raw soup so analyse() can report the non-manifold edge.
TEST(Load, NonManifoldFacesAreKept) {
  const fs::path path = test::temp_dir("mesh_io_nonmanifold") / "fan.obj";
  write_file(path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
  LoadOptions o;
  o.orient_outward = false;
  const MeshFacts f = analyse(load_mesh(path, o));
  EXPECT_EQ(f.triangles, 3u);
  EXPECT_EQ(f.nonmanifold_edges, 1u);
}

TEST(Load, ObjRelativeIndicesAndQuads) {
  const fs::path path = test::temp_dir("mesh_io_obj") / "cube.obj";
  // A unit cube of quads, faces written with negative (relative) indices.
  write_file(path,
             "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
             "f -8 -5 -6 -7\nf -4 -3 -2 -1\nf -8 -7 -3 -4\nf -7 -6 -2 -3\nf -6 -5 -1 -2\nf -5 -8 -4 -1\n");
  const MeshFacts f = analyse(load_mesh(path));
  EXPECT_EQ(f.vertices, 8u);
  EXPECT_EQ(f.triangles, 12u);
  EXPECT_TRUE(f.closed());
  EXPECT_NEAR(f.signed_volume, 1.0, 1e-12);
}

TEST(Load, UnitsConvertToMetres) {
  const fs::path path = test::temp_dir("mesh_io_units") / "tet_mm.off";
  write_file(path, "OFF\n4 4 0\n0 0 0\n20 0 0\n0 20 0\n0 0 20\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  LoadOptions o;
  o.unit_m = 1e-3;
  expect_tetrahedron(load_mesh(path, o), 0.02);
}

// The same cube as ASCII and as binary STL loads to identical meshes.
TEST(Load, AsciiAndBinaryStlAgree) {
  const fs::path dir = test::temp_dir("mesh_io_stl");
  const SurfaceMesh sphere = make_sphere(200, 0.05);
  std::vector<std::array<std::array<float, 3>, 3>> facets;
  std::string ascii = "solid sphere\n";
  char buf[128];
  for (const Triangle& t : sphere.triangles) {
    std::array<std::array<float, 3>, 3> f;
    ascii += "facet normal 0 0 0\n outer loop\n";
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = sphere.positions[t[k]];
      f[k] = {float(p.x()), float(p.y()), float(p.z())};
      std::snprintf(buf, sizeof buf, "  vertex %.9g %.9g %.9g\n", f[k][0], f[k][1], f[k][2]);
      ascii += buf;
    }
    ascii += " endloop\nendfacet\n";
    facets.push_back(f);
  }
  ascii += "endsolid sphere\n";
  write_file(dir / "a.stl", ascii);
  write_file(dir / "b.stl", binary_stl(facets));
  const SurfaceMesh a = load_mesh(dir / "a.stl"), b = load_mesh(dir / "b.stl");
  ASSERT_EQ(a.vertex_count(), sphere.vertex_count());
  ASSERT_EQ(a.vertex_count(), b.vertex_count());
  ASSERT_EQ(a.triangles, b.triangles);
  for (std::size_t i = 0; i < a.vertex_count(); ++i) EXPECT_EQ(a.positions[i], b.positions[i]);
  EXPECT_TRUE(analyse(a).closed());
}

// ---------------------------------------------------------------------------
// save_mesh then load_mesh gives back the mesh (float32 precision).
TEST(Save, RoundTripsInEveryFormat) {
  const fs::path dir = test::temp_dir("mesh_io_save");
  const SurfaceMesh sphere = make_sphere(500, 0.05, Vec3(0.1, 0.2, 0.3));
  for (const char* name : {"s.ply", "s.obj", "s.stl"}) {
    SCOPED_TRACE(name);
    save_mesh(sphere, dir / name);
    EXPECT_FALSE(fs::exists(dir / (std::string(name) + ".palpa-tmp")));
    const SurfaceMesh back = load_mesh(dir / name);
    ASSERT_EQ(back.vertex_count(), sphere.vertex_count());
    ASSERT_EQ(back.triangle_count(), sphere.triangle_count());
    // STL has no vertex order of its own; match by nearest position.
    double worst = 0;
    for (const Vec3& p : back.positions) {
      double best = 1e9;
      for (const Vec3& q : sphere.positions) best = std::min(best, (p - q).norm());
      worst = std::max(worst, best);
    }
    EXPECT_LT(worst, 0.4 * 1e-7);  // float32 rounding of coordinates below 0.4 m
    const MeshFacts f = analyse(back), g = analyse(sphere);
    EXPECT_TRUE(f.closed());
    EXPECT_NEAR(f.signed_volume, g.signed_volume, 1e-6 * g.signed_volume);
  }
}

TEST(Save, Errors) {
  const fs::path dir = test::temp_dir("mesh_io_save_errors");
  const SurfaceMesh sphere = make_sphere(50, 1.0);
  const fs::path xyz = dir / "s.xyz";
  try {
    save_mesh(sphere, xyz);
    ADD_FAILURE();
  } catch (const MeshError& e) {
    EXPECT_EQ(std::string(e.what()), xyz.string() + ": cannot save as '.xyz'; use .ply, .obj or .stl");
  }
  const fs::path nowhere = dir / "no_such_folder" / "s.ply";
  try {
    save_mesh(sphere, nowhere);
    ADD_FAILURE();
  } catch (const MeshError& e) {
    EXPECT_EQ(std::string(e.what()),
              nowhere.string() + ": cannot be written (cannot create " + nowhere.string() + ".palpa-tmp)");
  }
  // A failed save leaves an existing file as it was.
  const fs::path keep = dir / "keep.ply";
  write_file(keep, "old");
  SurfaceMesh broken = sphere;
  broken.triangles.push_back({0, 1, Index(broken.positions.size())});
  EXPECT_THROW(save_mesh(broken, keep), MeshError);
  std::ifstream in(keep);
  std::string content;
  in >> content;
  EXPECT_EQ(content, "old");
}

// ---------------------------------------------------------------------------
// The bundled default organ.
TEST(DefaultOrgan, LoadsClosedGenusZeroOutward) {
  const fs::path path = test::project_data_dir() / "default_organ.ply";
  ASSERT_TRUE(fs::exists(path)) << path << " is missing (make it with palpa-make-organ --vertices 40000)";
  EXPECT_LT(fs::file_size(path), 2'000'000u);
  CleanReport r;
  const SurfaceMesh m = load_mesh(path, {}, &r);
  const MeshFacts f = analyse(m);
  EXPECT_GT(f.vertices, 35'000u);
  EXPECT_LT(f.vertices, 45'000u);
  EXPECT_TRUE(f.closed());
  EXPECT_TRUE(f.consistently_oriented);
  EXPECT_EQ(f.components, 1u);
  EXPECT_EQ(f.euler_characteristic, 2);
  EXPECT_GT(f.signed_volume, 0.0);
  EXPECT_EQ(r.flipped_triangles, 0u);  // stored outward already
  EXPECT_EQ(r.welded_vertices, 0u);
  // Organ-sized, in metres: between 5 and 30 cm in every direction.
  const Vec3 size = f.bbox_max - f.bbox_min;
  EXPECT_GT(size.minCoeff(), 0.05);
  EXPECT_LT(size.maxCoeff(), 0.30);
}

}  // namespace
}  // namespace palpa::mesh
