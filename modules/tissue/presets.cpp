// The tissue presets of data/tissues.json (values from the published sources
// listed in ../shared/data/organs/MATERIALS.md, each preset naming its own).
// The file states its modulus unit once (kPa); SI inside.

#include "tissue/tissue.h"

#include "mesh/organ.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace palpa::tissue {

namespace {

using Json = nlohmann::ordered_json;

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& ptr, const std::string& msg) {
  throw std::runtime_error(file.string() + ": " + (ptr.empty() ? "" : ptr + ": ") + msg);
}

std::string shown(const Json& v) {
  std::string s = v.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

}  // namespace

std::vector<Preset> load_presets(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, "", "cannot open the tissue presets");
  std::stringstream buf;
  buf << in.rdbuf();
  Json doc;
  try {
    doc = Json::parse(buf.str());
  } catch (const Json::exception& e) {
    // parse_error, or out_of_range for a number beyond a double's range.
    fail(file, "", std::string("invalid JSON: ") + e.what());
  }
  // Keys of an object must be among `allowed`.
  auto keys = [&](const Json& o, const std::string& ptr, std::initializer_list<const char*> allowed) {
    if (!o.is_object()) fail(file, ptr, "expected an object, got " + shown(o));
    for (auto it = o.begin(); it != o.end(); ++it) {
      bool ok = false;
      std::string list;
      for (const char* a : allowed) ok |= it.key() == a, list += (list.empty() ? "" : ", ") + std::string(a);
      if (!ok) fail(file, ptr + "/" + it.key(), "unknown key (expected one of: " + list + ")");
    }
  };
  keys(doc, "", {"version", "units", "presets"});
  if (!doc.contains("version") || doc["version"] != 1)
    fail(file, "/version", "expected 1, got " + (doc.contains("version") ? shown(doc["version"]) : "nothing"));
  if (!doc.contains("units") || doc["units"] != Json{{"modulus", "kPa"}})
    fail(file, "/units", "expected {\"modulus\":\"kPa\"}, got " + (doc.contains("units") ? shown(doc["units"]) : "nothing"));
  if (!doc.contains("presets") || !doc["presets"].is_array() || doc["presets"].empty())
    fail(file, "/presets", "expected a non-empty array of presets");

  std::vector<Preset> out;
  const Json& list = doc["presets"];
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string ptr = "/presets/" + std::to_string(i);
    const Json& p = list[i];
    keys(p, ptr,
         {"key", "name", "youngs_modulus_kpa", "poisson", "damping_ratio", "relaxation_time_s", "relaxation_fraction",
          "stiffening_per_mm", "source", "note"});
    // A string that must be present and non-empty.
    auto text = [&](const char* key) {
      if (!p.contains(key) || !p[key].is_string() || p[key].get<std::string>().empty())
        fail(file, ptr + "/" + key, "expected a non-empty string, got " + (p.contains(key) ? shown(p[key]) : "nothing"));
      return p[key].get<std::string>();
    };
    auto number = [&](const char* key, double fallback) {
      if (!p.contains(key)) return fallback;
      if (!p[key].is_number()) fail(file, ptr + "/" + key, "expected a number, got " + shown(p[key]));
      return p[key].get<double>();
    };
    Preset pr;
    pr.key = text("key");
    for (const Preset& q : out)
      if (q.key == pr.key) fail(file, ptr + "/key", "duplicate preset key \"" + pr.key + "\"");
    Tissue& t = pr.tissue;
    t.name = text("name");
    t.source = text("source");
    if (!p.contains("youngs_modulus_kpa")) fail(file, ptr, "missing required key \"youngs_modulus_kpa\"");
    t.youngs_modulus = number("youngs_modulus_kpa", 0) * 1e3;
    t.poisson = number("poisson", t.poisson);
    t.damping_ratio = number("damping_ratio", t.damping_ratio);
    t.relaxation_time = number("relaxation_time_s", t.relaxation_time);
    t.relaxation_fraction = number("relaxation_fraction", t.relaxation_fraction);
    t.stiffening = number("stiffening_per_mm", t.stiffening / 1e3) * 1e3;
    if (p.contains("note")) text("note");
    try {
      validate_tissue(t, "preset \"" + pr.key + "\"");
    } catch (const std::invalid_argument& e) {
      fail(file, ptr, e.what());
    }
    out.push_back(std::move(pr));
  }
  return out;
}

const std::vector<Preset>& presets() {
  // Read once; a failure is thrown again on every call (not cached).
  static std::mutex mutex;
  static std::vector<Preset> cached;
  static bool loaded = false;
  std::lock_guard<std::mutex> lock(mutex);
  if (!loaded) {
    cached = load_presets(mesh::data_dir() / "tissues.json");
    loaded = true;
  }
  return cached;
}

const Preset* find_preset(const std::string& key) {
  for (const Preset& p : presets())
    if (p.key == key) return &p;
  return nullptr;
}

}  // namespace palpa::tissue
