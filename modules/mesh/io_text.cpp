// Our own readers for Wavefront OBJ, ASCII OFF, PLY (ASCII and binary) and
// legacy VTK POLYDATA (ASCII and BINARY). They read from the file's bytes
// (already checked to be a regular file within LoadOptions::max_file_bytes)
// and check every count against its limit, and against the bytes that are
// left, before it can cost memory: a header that announces a billion
// vertices, or a face that claims a billion corners, is refused at once
// instead of being believed. Nothing is ever read outside a block (VTK 9.1's
// own legacy reader crashed on cells whose counts disagree with the data).

#include "mesh/internal_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string_view>

namespace palpa::mesh::internal {
namespace {

using std::string_view;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

std::string upper(string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

string_view trim(string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

// A token quoted for a message (cut at 40 characters, non-printable bytes as '?').
std::string quoted(string_view t) {
  std::string out;
  for (char c : t.substr(0, 40)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  if (t.size() > 40) out += "...";
  return out;
}

// A whole token as a double: decimal or "nan"/"inf" (the finite check names
// the vertex later); out of double range becomes +-inf or the denormal/zero
// strtod gives. No locale (a GUI's locale never changes the decimal point).
bool parse_double(string_view t, double& v) {
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  if (t.empty() || t.size() > 400) return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (r.ptr != t.data() + t.size()) return false;
  if (r.ec == std::errc::result_out_of_range) {
    // from_chars leaves v unset: overflow or underflow; take the C library's answer.
    const std::string s(t);
    v = std::strtod(s.c_str(), nullptr);
  } else if (r.ec != std::errc()) {
    return false;
  }
  return true;
}

bool parse_int(string_view t, long long& v) {
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  if (t.empty()) return false;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

// Whitespace tokens of one piece of text, one at a time (never all at once:
// a line may hold a billion of them).
class Tokens {
 public:
  explicit Tokens(string_view s) : s_(s) {}
  bool next(string_view& t) {
    while (i_ < s_.size() && is_space(s_[i_])) ++i_;
    if (i_ >= s_.size()) return false;
    const std::size_t start = i_;
    while (i_ < s_.size() && !is_space(s_[i_])) ++i_;
    t = s_.substr(start, i_ - start);
    return true;
  }
  std::size_t count() const {
    Tokens copy = *this;
    std::size_t n = 0;
    for (string_view t; copy.next(t);) ++n;
    return n;
  }
  std::size_t position() const { return i_; }
  void seek(std::size_t i) { i_ = i; }

 private:
  string_view s_;
  std::size_t i_ = 0;
};

// Lines of the file, one at a time; `comment` cuts a line at that character.
class Lines {
 public:
  explicit Lines(string_view s, char comment = '\0') : s_(s), comment_(comment) {}
  // The next line (without its newline); false at the end.
  bool raw(string_view& out) {
    if (pos_ >= s_.size()) return false;
    std::size_t end = s_.find('\n', pos_);
    if (end == string_view::npos) end = s_.size();
    out = s_.substr(pos_, end - pos_);
    pos_ = std::min(end + 1, s_.size());
    if (comment_ != '\0') {
      const std::size_t c = out.find(comment_);
      if (c != string_view::npos) out = out.substr(0, c);
    }
    return true;
  }
  // The next line that holds anything, trimmed.
  bool next(string_view& out) {
    while (raw(out)) {
      out = trim(out);
      if (!out.empty()) return true;
    }
    return false;
  }
  std::size_t position() const { return pos_; }
  void seek(std::size_t p) { pos_ = p; }
  std::size_t remaining() const { return s_.size() - pos_; }

 private:
  string_view s_;
  char comment_;
  std::size_t pos_ = 0;
};

// The limit messages every reader shares.
[[noreturn]] void too_many_vertices(const std::string& source, const LoadOptions& o) {
  fail(source, "has more than " + std::to_string(o.max_vertices) + " vertices (LoadOptions::max_vertices)");
}
[[noreturn]] void too_many_triangles(const std::string& source, const LoadOptions& o) {
  fail(source, "has more than " + std::to_string(o.max_triangles) + " triangles (LoadOptions::max_triangles)");
}
[[noreturn]] void face_too_large(const std::string& source, const LoadOptions& o, std::size_t face,
                                 unsigned long long n) {
  fail(source, "face " + std::to_string(face) + " has " + std::to_string(n) + " vertices, more than the limit of " +
                   std::to_string(o.max_face_vertices) + " (LoadOptions::max_face_vertices)");
}

// Counts triangles as faces arrive and refuses past the limit.
struct TriangleBudget {
  const std::string& source;
  const LoadOptions& options;
  std::size_t triangles = 0;
  void add(std::size_t face_vertices) {
    triangles += face_vertices >= 3 ? face_vertices - 2 : 1;
    if (triangles > options.max_triangles) too_many_triangles(source, options);
  }
};

}  // namespace

// ---------------------------------------------------------------------------
// Wavefront OBJ: "v x y z [...]" and "f a[/t[/n]] b c ..." (1-based, negative
// = relative to the last vertex). Everything else (vt, vn, g, o, s, usemtl,
// mtllib: no material file is ever opened) is ignored.
RawMesh read_obj(const std::string& bytes, const std::string& source, const LoadOptions& options) {
  RawMesh raw;
  raw.index_base = 1;
  TriangleBudget budget{source, options};
  Lines lines(bytes, '#');
  std::size_t face_lines = 0;
  for (string_view line; lines.next(line);) {
    Tokens tok(line);
    string_view key;
    tok.next(key);
    if (key == "v") {
      // Vertex line: three finite coordinates (colours after them are ignored).
      const std::size_t k = raw.vertices.size() + 1;
      if (raw.vertices.size() >= options.max_vertices) too_many_vertices(source, options);
      Vec3 p;
      for (int c = 0; c < 3; ++c) {
        string_view t;
        if (!tok.next(t)) fail(source, "vertex " + std::to_string(k) + " has fewer than 3 coordinates");
        if (!parse_double(t, p[c]) || !std::isfinite(p[c]))
          fail(source, "vertex " + std::to_string(k) + " has a coordinate that is not a finite number");
      }
      raw.vertices.push_back(p);
    } else if (key == "f") {
      // Face line: 3 .. max_face_vertices references "v", "v/t", "v//n" or "v/t/n".
      const std::size_t k = ++face_lines;
      const std::string name = "face " + std::to_string(k);
      const std::size_t n = tok.count();
      if (n < 3) fail(source, name + " has " + std::to_string(n) + " vertices; a face needs at least 3");
      if (n > options.max_face_vertices) face_too_large(source, options, k, n);
      budget.add(n);
      for (string_view t; tok.next(t);) {
        long long v = 0;
        if (!parse_int(t.substr(0, t.find('/')), v))
          fail(source, name + ": cannot read vertex reference '" + quoted(t) + "'");
        // 1-based, or relative (-1 is the last vertex so far); stored 0-based.
        v = v < 0 ? static_cast<long long>(raw.vertices.size()) + v : v - 1;
        raw.face_indices.push_back(v);
      }
      raw.face_offsets.push_back(raw.face_indices.size());
    }
  }
  return raw;
}

// ---------------------------------------------------------------------------
// ASCII OFF: "[ST][C][N]OFF", "nv nf [ne]", nv vertex lines (x y z first,
// anything after them ignored), nf face lines "n i1 .. in [colour]". '#'
// starts a comment. Binary and 4-D OFF are refused by name.
RawMesh read_off(const std::string& bytes, const std::string& source, const LoadOptions& options) {
  RawMesh raw;
  Lines lines(bytes, '#');
  string_view line;
  if (!lines.next(line)) fail(source, "has no triangles");
  Tokens head(line);
  string_view key;
  head.next(key);
  const std::string kw = upper(key);
  if (kw.size() < 3 || kw.substr(kw.size() - 3) != "OFF")
    fail(source, "is not an OFF file (its first word is '" + quoted(key) + "', not OFF)");
  std::string prefix = kw.substr(0, kw.size() - 3);
  if (prefix.rfind("ST", 0) == 0) prefix.erase(0, 2);
  if (!prefix.empty() && prefix[0] == 'C') prefix.erase(0, 1);
  if (!prefix.empty() && prefix[0] == 'N') prefix.erase(0, 1);
  if (!prefix.empty())
    fail(source, "is a '" + quoted(key) + "' file; Palpa reads OFF, COFF, NOFF and STOFF (3-D) only");

  // The counts: on the header line after the keyword, or on the next line.
  string_view t;
  std::size_t after = head.position();
  if (head.next(t)) {
    if (upper(t) == "BINARY")
      fail(source, "is a binary OFF file, which Palpa does not read; save it as ASCII OFF or PLY");
    head.seek(after);
  } else {
    if (!lines.next(line)) fail(source, "the file ends before its vertex and face counts");
    head = Tokens(line);
  }
  long long nv = -1, nf = -1;
  string_view a, b;
  if (!head.next(a) || !head.next(b) || !parse_int(a, nv) || !parse_int(b, nf) || nv < 0 || nf < 0)
    fail(source, "expected the vertex and face counts, found '" + quoted(line) + "'");
  if (static_cast<unsigned long long>(nv) > options.max_vertices) too_many_vertices(source, options);
  if (static_cast<unsigned long long>(nf) > options.max_triangles) too_many_triangles(source, options);

  // Vertices: the first three numbers of each line.
  for (long long i = 0; i < nv; ++i) {
    if (!lines.next(line)) fail(source, "the file ends before vertex " + std::to_string(i) + " is complete");
    Tokens tok(line);
    Vec3 p;
    for (int c = 0; c < 3; ++c) {
      if (!tok.next(t)) fail(source, "vertex " + std::to_string(i) + " has fewer than 3 coordinates");
      if (!parse_double(t, p[c])) fail(source, "cannot read '" + quoted(t) + "' as a number");
    }
    raw.vertices.push_back(p);
  }

  // Faces: a count, then that many indices (a colour may follow).
  TriangleBudget budget{source, options};
  for (long long f = 0; f < nf; ++f) {
    const std::string name = "face " + std::to_string(f);
    if (!lines.next(line)) fail(source, "the file ends before " + name + " is complete");
    Tokens tok(line);
    long long n = 0;
    tok.next(t);
    if (!parse_int(t, n)) fail(source, "cannot read '" + quoted(t) + "' as a number");
    if (n < 3) fail(source, name + " has " + std::to_string(n) + " vertices; a face needs at least 3");
    if (static_cast<unsigned long long>(n) > options.max_face_vertices)
      face_too_large(source, options, static_cast<std::size_t>(f), static_cast<unsigned long long>(n));
    budget.add(static_cast<std::size_t>(n));
    for (long long k = 0; k < n; ++k) {
      long long v = 0;
      if (!tok.next(t))
        fail(source, name + " lists " + std::to_string(k) + " of its " + std::to_string(n) + " vertex indices");
      if (!parse_int(t, v)) fail(source, "cannot read '" + quoted(t) + "' as a number");
      raw.face_indices.push_back(v);
    }
    raw.face_offsets.push_back(raw.face_indices.size());
  }
  return raw;
}

// ---------------------------------------------------------------------------
// PLY (ascii, binary_little_endian, binary_big_endian 1.0): the header's
// elements and properties; x, y, z of "vertex" and the "vertex_indices" (or
// "vertex_index") list of "face" are kept, everything else is skipped.
namespace {

enum class PlyType : unsigned char { none, i8, u8, i16, u16, i32, u32, f32, f64 };

PlyType ply_type(string_view name) {
  if (name == "char" || name == "int8") return PlyType::i8;
  if (name == "uchar" || name == "uint8") return PlyType::u8;
  if (name == "short" || name == "int16") return PlyType::i16;
  if (name == "ushort" || name == "uint16") return PlyType::u16;
  if (name == "int" || name == "int32") return PlyType::i32;
  if (name == "uint" || name == "uint32") return PlyType::u32;
  if (name == "float" || name == "float32") return PlyType::f32;
  if (name == "double" || name == "float64") return PlyType::f64;
  return PlyType::none;
}

std::size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::i8: case PlyType::u8: return 1;
    case PlyType::i16: case PlyType::u16: return 2;
    case PlyType::i32: case PlyType::u32: case PlyType::f32: return 4;
    case PlyType::f64: return 8;
    case PlyType::none: return 0;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::none;        // the value type (of a list: its items)
  PlyType count_type = PlyType::none;  // a list's count type; none for a scalar
};

struct PlyElement {
  std::string name;
  unsigned long long count = 0;
  std::vector<PlyProperty> properties;
};

// Reads the body's values one at a time, in the header's encoding.
class PlyBody {
 public:
  PlyBody(string_view body, int format) : body_(body), tokens_(body), format_(format) {}

  // One value; false at the end of the file (or `bad` holds a token that is not a number).
  bool value(PlyType t, double& v, std::string& bad) {
    if (format_ == 0) {
      string_view tok;
      if (!tokens_.next(tok)) return false;
      const bool integer = t != PlyType::f32 && t != PlyType::f64;
      long long i = 0;
      if (integer ? !parse_int(tok, i) : !parse_double(tok, v)) {
        bad = quoted(tok);
        return false;
      }
      if (integer) v = static_cast<double>(i);
      return true;
    }
    const std::size_t n = ply_size(t);
    if (body_.size() - pos_ < n) return false;
    unsigned char b[8];
    for (std::size_t k = 0; k < n; ++k)
      b[k] = static_cast<unsigned char>(body_[pos_ + (format_ == 1 ? k : n - 1 - k)]);
    pos_ += n;
    std::uint64_t u = 0;
    for (std::size_t k = n; k-- > 0;) u = u << 8 | b[k];
    switch (t) {
      case PlyType::i8: v = static_cast<std::int8_t>(u); break;
      case PlyType::u8: v = static_cast<std::uint8_t>(u); break;
      case PlyType::i16: v = static_cast<std::int16_t>(u); break;
      case PlyType::u16: v = static_cast<std::uint16_t>(u); break;
      case PlyType::i32: v = static_cast<std::int32_t>(u); break;
      case PlyType::u32: v = static_cast<std::uint32_t>(u); break;
      case PlyType::f32: {
        float f;
        const auto w = static_cast<std::uint32_t>(u);
        std::memcpy(&f, &w, 4);
        v = f;
        break;
      }
      case PlyType::f64: std::memcpy(&v, &u, 8); break;
      case PlyType::none: return false;
    }
    return true;
  }
  std::size_t remaining() const { return format_ == 0 ? body_.size() - tokens_.position() : body_.size() - pos_; }

 private:
  string_view body_;
  Tokens tokens_;
  int format_;  // 0 ascii, 1 little endian, 2 big endian
  std::size_t pos_ = 0;
};

}  // namespace

RawMesh read_ply(const std::string& bytes, const std::string& source, const LoadOptions& options) {
  // Header: "ply", "format ...", elements with their properties, "end_header".
  Lines lines(bytes);
  string_view line;
  if (!lines.raw(line) || trim(line) != "ply") fail(source, "is not a PLY file (its first line is not 'ply')");
  int format = -1;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (lines.raw(line)) {
    Tokens tok(trim(line));
    string_view key;
    if (!tok.next(key) || key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      ended = true;
      break;
    }
    string_view a, b, c, d;
    if (key == "format") {
      tok.next(a);
      if (a == "ascii") format = 0;
      else if (a == "binary_little_endian") format = 1;
      else if (a == "binary_big_endian") format = 2;
      else fail(source, "has an unknown PLY format '" + quoted(a) + "'");
    } else if (key == "element") {
      long long n = -1;
      if (!tok.next(a) || !tok.next(b) || !parse_int(b, n) || n < 0)
        fail(source, "has an unreadable PLY element line '" + quoted(trim(line)) + "'");
      elements.push_back({std::string(a), static_cast<unsigned long long>(n), {}});
    } else if (key == "property") {
      if (elements.empty()) fail(source, "has a PLY property before any element");
      PlyProperty p;
      tok.next(a);
      if (a == "list") {
        tok.next(b);
        tok.next(c);
        tok.next(d);
        p.count_type = ply_type(b);
        p.type = ply_type(c);
        p.name = std::string(d);
        if (p.count_type == PlyType::none || p.type == PlyType::none || p.count_type == PlyType::f32 ||
            p.count_type == PlyType::f64 || p.name.empty())
          fail(source, "has an unreadable PLY property line '" + quoted(trim(line)) + "'");
      } else {
        tok.next(b);
        p.type = ply_type(a);
        p.name = std::string(b);
        if (p.type == PlyType::none || p.name.empty())
          fail(source, "has an unreadable PLY property line '" + quoted(trim(line)) + "'");
      }
      elements.back().properties.push_back(p);
    } else {
      fail(source, "has an unknown PLY header line '" + quoted(trim(line)) + "'");
    }
  }
  if (!ended) fail(source, "the file ends inside its PLY header");
  if (format < 0) fail(source, "has no PLY format line");

  // Every count against its limit and against the bytes left, before reading.
  const string_view body = string_view(bytes).substr(lines.position());
  for (const PlyElement& e : elements) {
    if (e.name == "vertex" && e.count > options.max_vertices) too_many_vertices(source, options);
    if (e.name == "face" && e.count > options.max_triangles) too_many_triangles(source, options);
    std::size_t least = 0;  // bytes one item takes at least
    for (const PlyProperty& p : e.properties)
      least += format == 0 ? 2 : ply_size(p.count_type == PlyType::none ? p.type : p.count_type);
    if (e.count > 0 && least == 0) fail(source, "its PLY element '" + quoted(string_view(e.name)) + "' has no properties");
    if (e.count > 0 && e.count - 1 > body.size() / least)
      fail(source, "the header announces " + std::to_string(e.count) + " '" + quoted(string_view(e.name)) +
                       "' elements, but only " + std::to_string(body.size()) + " bytes follow it");
  }

  // Body.
  RawMesh raw;
  TriangleBudget budget{source, options};
  PlyBody in(body, format);
  std::string bad;
  std::size_t vertex_base = 0;
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int xyz[3] = {-1, -1, -1};
    int list = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const PlyProperty& p = e.properties[k];
      if (is_vertex && p.count_type == PlyType::none)
        for (int c = 0; c < 3; ++c)
          if (p.name == std::string(1, char('x' + c))) xyz[c] = static_cast<int>(k);
      if (is_face && p.count_type != PlyType::none && (p.name == "vertex_indices" || p.name == "vertex_index"))
        list = static_cast<int>(k);
    }
    if (is_vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0))
      fail(source, "its PLY vertex element has no x, y and z properties");
    if (is_face && list < 0) fail(source, "its PLY face element has no vertex_indices list");
    if (is_vertex) vertex_base = raw.vertices.size();
    (void)vertex_base;

    for (unsigned long long i = 0; i < e.count; ++i) {
      const std::string name = (is_vertex ? "vertex " : is_face ? "face " : e.name + " ") + std::to_string(i);
      auto truncated = [&]() {
        if (!bad.empty()) fail(source, "cannot read '" + bad + "' as a number");
        fail(source, "the file ends before " + name + " is complete");
      };
      Vec3 p = Vec3::Zero();
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& prop = e.properties[k];
        double v = 0;
        if (prop.count_type == PlyType::none) {
          if (!in.value(prop.type, v, bad)) truncated();
          for (int c = 0; c < 3; ++c)
            if (xyz[c] == static_cast<int>(k)) p[c] = v;
          continue;
        }
        // A list: its count first, checked before its items are read.
        double count = 0;
        if (!in.value(prop.count_type, count, bad)) truncated();
        if (count < 0) fail(source, name + " has a list of " + std::to_string(static_cast<long long>(count)) + " items");
        const auto n = static_cast<unsigned long long>(count);
        const bool indices = static_cast<int>(k) == list;
        if (indices && n < 3) fail(source, name + " has " + std::to_string(n) + " vertices; a face needs at least 3");
        if (indices && n > options.max_face_vertices) face_too_large(source, options, i, n);
        if (n > in.remaining()) truncated();
        if (indices) budget.add(static_cast<std::size_t>(n));
        for (unsigned long long j = 0; j < n; ++j) {
          if (!in.value(prop.type, v, bad)) truncated();
          if (!indices) continue;
          // A float list may hold any value: only whole numbers in int64 range are cast.
          if (!(v >= -9.2e18 && v <= 9.2e18 && v == std::floor(v))) {
            char buf[40];
            std::snprintf(buf, sizeof buf, "%g", v);
            fail(source, name + " has the vertex index " + buf + ", which is not a whole number");
          }
          raw.face_indices.push_back(static_cast<std::int64_t>(v));
        }
        if (indices) raw.face_offsets.push_back(raw.face_indices.size());
      }
      if (is_vertex) raw.vertices.push_back(p);
    }
  }
  return raw;
}

// ---------------------------------------------------------------------------
// Legacy VTK POLYDATA, ASCII or BINARY (big-endian): POINTS, and POLYGONS and
// TRIANGLE_STRIPS in either layout (VTK < 5.1: per cell a count and its ids;
// 5.1: OFFSETS and CONNECTIVITY); VERTICES and LINES are checked and dropped;
// METADATA is skipped; reading stops at the attribute data (POINT_DATA, ...),
// which a surface does not need.
namespace {

class LegacyVtk {
 public:
  LegacyVtk(const std::string& bytes, const std::string& source, const LoadOptions& options)
      : s_(bytes), lines_(s_), tokens_(s_), source_(source), options_(options) {}

  RawMesh read() {
    // Header: magic line, title line (may be empty), ASCII or BINARY, DATASET POLYDATA.
    string_view l;
    if (!lines_.raw(l) || trim(l).rfind("# vtk DataFile", 0) != 0)
      fail(source_, "is not a legacy VTK file (no '# vtk DataFile' header)");
    lines_.raw(l);
    if (!lines_.next(l)) fail(source_, "the file ends inside its header");
    const std::string mode = upper(l);
    if (mode != "ASCII" && mode != "BINARY") fail(source_, "has '" + quoted(l) + "' where ASCII or BINARY belongs");
    binary_ = mode == "BINARY";
    if (!lines_.next(l)) fail(source_, "the file ends inside its header");
    Tokens ds(l);
    string_view key, type;
    ds.next(key);
    ds.next(type);
    if (upper(key) != "DATASET") fail(source_, "has '" + quoted(l) + "' where DATASET POLYDATA belongs");
    if (upper(type) != "POLYDATA")
      fail(source_, "is a legacy VTK file but its dataset is " + quoted(type) + ", not POLYDATA");

    // Sections, in any order, up to the attribute data.
    std::vector<std::vector<std::int64_t>> strips;
    bool points = false;
    while (lines_.next(l)) {
      Tokens ss(l);
      string_view word_view;
      ss.next(word_view);
      const std::string word = upper(word_view);
      if (word == "POINTS") {
        if (points) fail(source_, "has two POINTS blocks");
        points = true;
        read_points(ss);
      } else if (word == "POLYGONS" || word == "TRIANGLE_STRIPS" || word == "VERTICES" || word == "LINES") {
        read_cells(word, ss, strips);
      } else if (word == "METADATA") {
        // Skipped up to the blank line that ends it.
        while (lines_.raw(l) && !trim(l).empty()) {
        }
      } else {
        break;  // POINT_DATA, CELL_DATA, FIELD, ...: not needed for a surface
      }
    }

    // Triangle strips after the polygons: triangle k of a strip is (k, k+1, k+2), every other one reversed.
    for (const auto& ids : strips) {
      if (ids.size() < 3) {
        raw_.add_face({});  // reported as a face with too few vertices
        continue;
      }
      for (std::size_t k = 0; k + 2 < ids.size(); ++k) {
        if (k % 2 == 0)
          raw_.add_face({ids[k], ids[k + 1], ids[k + 2]});
        else
          raw_.add_face({ids[k + 1], ids[k], ids[k + 2]});
      }
    }
    return std::move(raw_);
  }

 private:
  static std::size_t type_size(const std::string& t) {
    if (t == "UNSIGNED_CHAR" || t == "CHAR") return 1;
    if (t == "SHORT" || t == "UNSIGNED_SHORT") return 2;
    if (t == "INT" || t == "UNSIGNED_INT" || t == "FLOAT") return 4;
    if (t == "DOUBLE" || t == "LONG" || t == "UNSIGNED_LONG" || t == "VTKTYPEINT64" || t == "VTKTYPEUINT64" ||
        t == "VTKIDTYPE")
      return 8;
    return 0;
  }

  // Before a block of n values of `bytes_each` (binary) is read: the file must hold it.
  void need(unsigned long long n, std::size_t bytes_each, const std::string& block) {
    const std::size_t left = s_.size() - lines_.position();
    const std::size_t least = binary_ ? bytes_each : 2;  // ASCII: a digit and a separator, but the last
    if (n > 0 && n - 1 > left / least) fail(source_, "the file ends inside its " + block + " block");
  }

  // The next value of a block: ASCII token or big-endian binary of the type.
  double value(const std::string& type, bool integer, const std::string& block) {
    if (!binary_) {
      tokens_.seek(lines_.position());
      string_view t;
      if (!tokens_.next(t)) fail(source_, "the file ends inside its " + block + " block");
      lines_.seek(tokens_.position());
      double v = 0;
      long long i = 0;
      if (integer ? !parse_int(t, i) : !parse_double(t, v))
        fail(source_, "cannot read '" + quoted(t) + "' as a number in its " + block + " block");
      return integer ? static_cast<double>(i) : v;
    }
    const std::size_t n = type_size(type);
    if (s_.size() - lines_.position() < n) fail(source_, "the file ends inside its " + block + " block");
    std::uint64_t u = 0;
    for (std::size_t k = 0; k < n; ++k) u = u << 8 | static_cast<unsigned char>(s_[lines_.position() + k]);
    lines_.seek(lines_.position() + n);
    if (type == "FLOAT") {
      float f;
      const auto w = static_cast<std::uint32_t>(u);
      std::memcpy(&f, &w, 4);
      return f;
    }
    if (type == "DOUBLE") {
      double d;
      std::memcpy(&d, &u, 8);
      return d;
    }
    if (type == "CHAR") return static_cast<std::int8_t>(u);
    if (type == "SHORT") return static_cast<std::int16_t>(u);
    if (type == "INT") return static_cast<std::int32_t>(u);
    if (type == "LONG" || type == "VTKTYPEINT64" || type == "VTKIDTYPE") return static_cast<double>(static_cast<std::int64_t>(u));
    return static_cast<double>(u);
  }
  std::int64_t index(const std::string& type, const std::string& block) {
    const double v = value(type, true, block);
    return v >= -9.2e18 && v <= 9.2e18 ? static_cast<std::int64_t>(v) : -1;
  }

  // "POINTS n type", then 3n values.
  void read_points(Tokens& ss) {
    string_view a, b;
    long long n = -1;
    if (!ss.next(a) || !ss.next(b) || !parse_int(a, n) || n < 0) fail(source_, "has an unreadable POINTS line");
    if (static_cast<unsigned long long>(n) > options_.max_vertices)
      fail(source_, "has more than " + std::to_string(options_.max_vertices) + " vertices (LoadOptions::max_vertices)");
    const std::string type = upper(b);
    if (type_size(type) == 0) fail(source_, "has an unknown data type '" + quoted(b) + "' in its POINTS line");
    need(3 * static_cast<unsigned long long>(n), type_size(type), "POINTS");
    raw_.vertices.reserve(static_cast<std::size_t>(n));
    for (long long i = 0; i < n; ++i) {
      Vec3 p;
      for (int c = 0; c < 3; ++c) p[c] = value(type, false, "POINTS");
      raw_.vertices.push_back(p);
    }
  }

  // "WORD cells size": VTK < 5.1 per cell "n id1 .. idn" (size values in all);
  // 5.1 "OFFSETS type" (cells values) and "CONNECTIVITY type" (size values).
  void read_cells(const std::string& word, Tokens& ss, std::vector<std::vector<std::int64_t>>& strips) {
    string_view a, b;
    long long cells = -1, size = -1;
    if (!ss.next(a) || !ss.next(b) || !parse_int(a, cells) || !parse_int(b, size) || cells < 0 || size < 0)
      fail(source_, "has an unreadable " + word + " line");
    const bool polys = word == "POLYGONS", strip = word == "TRIANGLE_STRIPS", keep = polys || strip;
    if (keep && static_cast<unsigned long long>(cells) > options_.max_triangles)
      fail(source_, "has more than " + std::to_string(options_.max_triangles) + " triangles (LoadOptions::max_triangles)");
    const std::size_t first_face = raw_.face_count() + strips.size();

    // One cell's ids, checked and kept (polygons), kept for later (strips) or dropped.
    auto add_cell = [&](std::size_t cell, const std::vector<std::int64_t>& ids) {
      if (!keep) return;
      triangles_ += ids.size() >= 3 ? ids.size() - 2 : 1;
      if (triangles_ > options_.max_triangles)
        fail(source_, "has more than " + std::to_string(options_.max_triangles) + " triangles (LoadOptions::max_triangles)");
      (void)cell;
      if (polys) {
        raw_.face_indices.insert(raw_.face_indices.end(), ids.begin(), ids.end());
        raw_.face_offsets.push_back(raw_.face_indices.size());
      } else {
        strips.push_back(ids);
      }
    };
    auto too_large = [&](std::size_t cell, unsigned long long n) {
      if (keep && n > options_.max_face_vertices) face_too_large(source_, options_, first_face + cell, n);
    };

    const std::size_t mark = lines_.position();
    string_view next;
    Tokens nt("");
    string_view next_word;
    if (lines_.next(next) && (nt = Tokens(next), nt.next(next_word)) && upper(next_word) == "OFFSETS") {
      // VTK 5.1: cells offsets from 0 to size, then size ids.
      string_view t;
      nt.next(t);
      const std::string otype = upper(t);
      if (type_size(otype) == 0) fail(source_, "has an unknown data type '" + quoted(t) + "' in its " + word + " OFFSETS line");
      need(static_cast<unsigned long long>(cells), type_size(otype), word);
      std::vector<std::int64_t> offsets;
      offsets.reserve(static_cast<std::size_t>(cells));
      for (long long k = 0; k < cells; ++k) {
        const std::int64_t o = index(otype, word);
        const std::int64_t prev = offsets.empty() ? 0 : offsets.back();
        if ((k == 0 && o != 0) || o < prev || o > size)
          fail(source_, "its " + word + " offsets must rise from 0 to " + std::to_string(size) + ", but offset " +
                            std::to_string(k) + " is " + std::to_string(o));
        if (k > 0) too_large(static_cast<std::size_t>(k - 1), static_cast<unsigned long long>(o - prev));
        offsets.push_back(o);
      }
      if (cells > 0 && offsets.back() != size)
        fail(source_, "its " + word + " offsets end at " + std::to_string(offsets.back()) + ", not at its size " +
                          std::to_string(size));
      if (!lines_.next(next) || (nt = Tokens(next), !nt.next(next_word)) || upper(next_word) != "CONNECTIVITY")
        fail(source_, "the file ends inside its " + word + " block");
      nt.next(t);
      const std::string ctype = upper(t);
      if (type_size(ctype) == 0)
        fail(source_, "has an unknown data type '" + quoted(t) + "' in its " + word + " CONNECTIVITY line");
      need(static_cast<unsigned long long>(size), type_size(ctype), word);
      std::vector<std::int64_t> ids;
      for (long long k = 0; k + 1 < cells; ++k) {
        ids.clear();
        for (std::int64_t j = offsets[k]; j < offsets[k + 1]; ++j) ids.push_back(index(ctype, word));
        add_cell(static_cast<std::size_t>(k), ids);
      }
      return;
    }

    // VTK < 5.1: each cell's count, then its ids; all of them exactly fill `size`.
    lines_.seek(mark);
    need(static_cast<unsigned long long>(size), 4, word);
    long long left = size;
    std::vector<std::int64_t> ids;
    for (long long k = 0; k < cells; ++k) {
      if (left < 1) fail(source_, "its " + word + " block of " + std::to_string(size) + " values ends before cell " + std::to_string(k));
      const std::int64_t n = index("INT", word);
      --left;
      if (n < 0) fail(source_, "its " + word + " cell " + std::to_string(k) + " has " + std::to_string(n) + " vertices");
      too_large(static_cast<std::size_t>(k), static_cast<unsigned long long>(n));
      if (n > left)
        fail(source_, "its " + word + " cell " + std::to_string(k) + " has " + std::to_string(n) +
                          " vertices, but only " + std::to_string(left) + " values of its block of " +
                          std::to_string(size) + " are left");
      ids.clear();
      for (std::int64_t j = 0; j < n; ++j) ids.push_back(index("INT", word));
      left -= n;
      add_cell(static_cast<std::size_t>(k), ids);
    }
    if (left != 0)
      fail(source_, "its " + word + " block holds " + std::to_string(size - left) + " values for its " +
                        std::to_string(cells) + " cells, but its header says " + std::to_string(size));
  }

  const std::string& s_;
  Lines lines_;
  Tokens tokens_;
  const std::string& source_;
  const LoadOptions& options_;
  bool binary_ = false;
  std::size_t triangles_ = 0;
  RawMesh raw_;
};

}  // namespace

RawMesh read_legacy_vtk(const std::string& bytes, const std::string& source, const LoadOptions& options) {
  return LegacyVtk(bytes, source, options).read();
}

}  // namespace palpa::mesh::internal
