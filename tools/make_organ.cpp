// palpa-make-organ: writes a procedural organ shape (metres) to a file: the
// default organ, or the breast or abdomen of the training scenarios.
// Usage: palpa-make-organ [--shape organ|breast|abdomen] --vertices N --out FILE
//        (FILE: .ply, .obj or .stl)
// data/README.md lists the command line each bundled file in data/ was made with.

#include "mesh/generate.h"
#include "mesh/io.h"

#include <cstdlib>
#include <iostream>
#include <string>
#include <string_view>

namespace {

constexpr std::string_view kUsage =
    "usage: palpa-make-organ [--shape SHAPE] --vertices N --out FILE\n"
    "  --shape SHAPE  organ (default): the liver-like default organ, about 0.21 x 0.14 x 0.09 m\n"
    "                 breast: a breast on a flat chest wall (z = 0), about 0.14 x 0.14 x 0.06 m\n"
    "                 abdomen: a belly-up abdomen slab centred at the origin, about 0.30 x 0.22 x 0.12 m\n"
    "  --vertices N   vertex count (rounded to the nearest 6 n^2 + 2), 8 to 20000000\n"
    "  --out FILE     file to write, in metres; FILE ends in .ply (binary), .obj or .stl\n";

int usage(const std::string& problem) {
  std::cerr << "palpa-make-organ: " << problem << "\n" << kUsage;
  return 2;
}

// The generator of each shape name, or nullptr for an unknown name.
using Generator = palpa::mesh::SurfaceMesh (*)(std::size_t);
Generator generator_for(std::string_view shape) {
  if (shape == "organ") return palpa::mesh::make_organ;
  if (shape == "breast") return palpa::mesh::make_breast;
  if (shape == "abdomen") return palpa::mesh::make_abdomen;
  return nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  // Arguments.
  long long vertices = -1;
  std::string out;
  std::string shape = "organ";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << "palpa-make-organ: writes a procedural organ shape (metres)\n" << kUsage;
      return 0;
    }
    if (i + 1 >= argc) return usage("missing value after " + arg);
    const std::string value = argv[++i];
    if (arg == "--vertices") {
      char* end = nullptr;
      vertices = std::strtoll(value.c_str(), &end, 10);
      if (end != value.c_str() + value.size() || vertices < 8 || vertices > 20'000'000)
        return usage("--vertices must be a whole number from 8 to 20000000, got '" + value + "'");
    } else if (arg == "--out") {
      out = value;
    } else if (arg == "--shape") {
      if (!generator_for(value)) return usage("unknown shape '" + value + "' (expected organ, breast or abdomen)");
      shape = value;
    } else {
      return usage("unknown argument " + arg);
    }
  }
  if (vertices < 0) return usage("--vertices is required");
  if (out.empty()) return usage("--out is required");

  // Generate, check, write.
  const palpa::mesh::SurfaceMesh organ = generator_for(shape)(static_cast<std::size_t>(vertices));
  const palpa::mesh::MeshFacts facts = palpa::mesh::analyse(organ);
  if (!facts.closed() || !facts.consistently_oriented || facts.signed_volume <= 0) {
    std::cerr << "palpa-make-organ: the generated surface is not closed and outward; not written\n";
    return 1;
  }
  try {
    palpa::mesh::save_mesh(organ, out);
  } catch (const palpa::mesh::MeshError& e) {
    std::cerr << "palpa-make-organ: " << e.what() << "\n";
    return 1;
  }
  const palpa::Vec3 size = facts.bbox_max - facts.bbox_min;
  std::cout << out << ": " << shape << ", " << facts.vertices << " vertices, " << facts.triangles << " triangles, "
            << size.x() << " x " << size.y() << " x " << size.z() << " m, volume " << facts.signed_volume * 1e6
            << " cm^3\n";
  return 0;
}
