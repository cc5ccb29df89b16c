// palpa-make-organ: writes the procedural default organ (metres) to a file.
// Usage: palpa-make-organ --vertices N --out FILE   (FILE: .ply, .obj or .stl)
// The bundled data/default_organ.ply was made with --vertices 40000.

#include "mesh/generate.h"
#include "mesh/io.h"

#include <cstdlib>
#include <iostream>
#include <string>

namespace {

int usage(const std::string& problem) {
  std::cerr << "palpa-make-organ: " << problem << "\n"
            << "usage: palpa-make-organ --vertices N --out FILE   (FILE ends in .ply, .obj or .stl)\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  // Arguments.
  long long vertices = -1;
  std::string out;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      usage("writes the default organ");
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
    } else {
      return usage("unknown argument " + arg);
    }
  }
  if (vertices < 0) return usage("--vertices is required");
  if (out.empty()) return usage("--out is required");

  // Generate, check, write.
  const palpa::mesh::SurfaceMesh organ = palpa::mesh::make_organ(static_cast<std::size_t>(vertices));
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
  std::cout << out << ": " << facts.vertices << " vertices, " << facts.triangles << " triangles, "
            << size.x() << " x " << size.y() << " x " << size.z() << " m, volume " << facts.signed_volume * 1e6
            << " cm^3\n";
  return 0;
}
