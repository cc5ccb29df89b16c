// Prepared meshes cached by the hash of the input bytes and the parameters.

#include "prep/prep.h"

#include "mesh/io.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <system_error>

namespace palpa::prep {

namespace {

// Two 64-bit FNV-1a hashes with different offset bases: a 128-bit key (not
// cryptographic; the cache only needs to tell inputs apart).
struct Hash128 {
  std::uint64_t a = 0xcbf29ce484222325ull;
  std::uint64_t b = 0x84222325cbf29ce4ull;
  void add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) {
      a = (a ^ p[i]) * 0x100000001b3ull;
      b = (b ^ p[i]) * 0x100000001b3ull;
      b ^= b >> 29;
    }
  }
  std::string hex() const {
    char s[40];
    std::snprintf(s, sizeof s, "%016llx%016llx", static_cast<unsigned long long>(a), static_cast<unsigned long long>(b));
    return s;
  }
};

std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return {};
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Writes a sibling, then renames it over `p` (never a half-written file).
bool write_atomic(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::path tmp = p;
  tmp += ".palpa-tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return false;
    out << text;
    out.flush();
    if (!out) return false;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, p, ec);
  if (ec) std::filesystem::remove(tmp, ec);
  return !ec;
}

}  // namespace

std::filesystem::path default_cache_dir() {
  if (const char* d = std::getenv("PALPA_PREP_CACHE"); d && *d) return d;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::filesystem::path(x) / "palpa" / "prep";
  if (const char* h = std::getenv("HOME"); h && *h) return std::filesystem::path(h) / ".cache" / "palpa" / "prep";
  return std::filesystem::temp_directory_path() / "palpa" / "prep";
}

std::string cache_key(const std::filesystem::path& path, const PrepOptions& o) {
  const std::string bytes = read_all(path);
  if (bytes.empty() && !std::filesystem::exists(path)) throw mesh::MeshError(path.string() + ": file not found");
  Hash128 h;
  h.add(bytes.data(), bytes.size());
  // The extension picks the reader, so it is part of the input.
  std::ostringstream params;
  params.precision(17);
  params << "palpa.prep/1 ext=" << path.extension().string() << " unit=" << o.unit_m << " edge=" << o.edge_m
         << " probe=" << o.probe_radius_m << " speck=" << o.speck_area_fraction
         << " hole=" << o.max_hole_area_fraction << " it=" << o.remesh_iterations << " relax=" << o.relaxation_steps
         << " refine=" << o.refine_rounds << " feature=" << o.feature_angle_deg
         << " si=" << o.allow_autorefine << o.allow_local_repair << " fit=" << o.fit_rounds << "," << o.fit_factor << "," << o.fit_max_triangles;
  if (o.edge_m == 0 && o.lesion_radius_m > 0) params << " lesion=" << o.lesion_radius_m;  // absent: the keys made before it
  const std::string p = params.str();
  h.add(p.data(), p.size());
  return h.hex();
}

mesh::SurfaceMesh prepare_cached(const std::filesystem::path& path, const PrepOptions& options, PrepReport* report,
                                 const std::filesystem::path& cache_dir) {
  const std::string key = cache_key(path, options);
  const std::filesystem::path mesh_file = cache_dir / (key + ".ply");
  const std::filesystem::path report_file = cache_dir / (key + ".json");

  // A hit: both files (the report is written last), the report readable.
  std::error_code ec;
  if (std::filesystem::is_regular_file(report_file, ec) && std::filesystem::is_regular_file(mesh_file, ec)) {
    try {
      PrepReport r = report_from_json(read_all(report_file));
      mesh::SurfaceMesh m = mesh::load_mesh(mesh_file);
      r.from_cache = true;
      r.cache_key = key;
      r.input = path.string();
      if (options.progress) options.progress("cache hit", 0, 1, 1.0);
      if (report) *report = std::move(r);
      return m;
    } catch (const std::exception&) {
      // A damaged entry: prepare again and overwrite it.
    }
  }

  // A miss: prepare, store, and return what a later hit will load (the
  // float32 positions of the stored PLY), so hits and misses agree exactly.
  PrepReport r;
  mesh::SurfaceMesh m = prepare_file(path, options, &r);
  r.cache_key = key;
  std::filesystem::create_directories(cache_dir, ec);
  bool stored = false;
  try {
    mesh::save_mesh(m, mesh_file);
    stored = write_atomic(report_file, report_json(r));
  } catch (const std::exception&) {
    stored = false;
  }
  if (stored) {
    m = mesh::load_mesh(mesh_file);
  } else {
    r.warnings.push_back("the prepared mesh could not be stored in the cache " + cache_dir.string());
  }
  if (report) *report = std::move(r);
  return m;
}

}  // namespace palpa::prep
