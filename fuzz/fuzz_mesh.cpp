// libFuzzer target: every mesh reader through load_mesh. The first byte picks
// the format (its extension), the rest is the file. A MeshError is the
// expected answer to bad input; anything else (a crash, a sanitizer report,
// another exception, a hang or unbounded memory) is a finding.

#include "mesh/io.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

const char* const kExtensions[] = {"obj", "off", "ply", "vtk", "trian", "stl", "vtp"};

// A private folder for this process's input file (in memory when /dev/shm exists).
const std::filesystem::path& folder() {
  static const std::filesystem::path dir = [] {
    std::string base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : "/tmp";
    std::string tmpl = base + "/palpa-fuzz-XXXXXX";
    if (!::mkdtemp(tmpl.data())) std::abort();
    return std::filesystem::path(tmpl);
  }();
  return dir;
}

}  // namespace

// One-time allocations (VTK's logger on its first error message) would look
// like a leak of the first input that triggers them: trigger them here.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const std::filesystem::path path = folder() / "warm.vtp";
  std::ofstream(path) << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\">\n"
                         "<PolyData><Piece NumberOfPoints=\"1\" NumberOfPolys=\"0\"><Points>"
                         "<DataArray type=\"Float32\" NumberOfComponents=\"2\" format=\"ascii\">0 0</DataArray>"
                         "</Points></Piece></PolyData></VTKFile>\n";
  const std::filesystem::path stl = folder() / "warm.stl";  // OpenMesh's error stream is redirected once
  std::ofstream(stl) << "solid x\nendsolid x\n";
  for (const auto& p : {path, stl}) {
    try {
      palpa::mesh::load_mesh(p);
    } catch (const palpa::mesh::MeshError&) {
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const char* ext = kExtensions[data[0] % (sizeof kExtensions / sizeof *kExtensions)];
  const std::filesystem::path path = folder() / (std::string("input.") + ext);
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  // Limits small enough that a legal but large input stays fast.
  palpa::mesh::LoadOptions options;
  options.max_vertices = 100'000;
  options.max_triangles = 200'000;
  options.max_file_bytes = 1 << 20;
  try {
    palpa::mesh::load_mesh(path, options);
  } catch (const palpa::mesh::MeshError&) {
  }
  return 0;
}
