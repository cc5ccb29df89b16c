// Legacy VTK (.vtk, ASCII or big-endian BINARY POLYDATA) and XML PolyData
// (.vtp) through VTK 9.1's readers. The only file of the module that includes
// VTK headers.

#include "mesh/internal_io.h"

#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCellArrayIterator.h>
#include <vtkCommand.h>
#include <vtkExecutive.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include <cctype>
#include <fstream>
#include <sstream>
#include <string>

namespace palpa::mesh::internal {
namespace {

// Keeps the first message of a VTK event, without VTK's "ERROR: In file,
// line N\nClass (0x..): " prefix, on one line.
struct FirstMessage {
  std::string text;

  static void on_event(vtkObject*, unsigned long, void* client, void* call) {
    auto* self = static_cast<FirstMessage*>(client);
    if (call == nullptr || !self->text.empty()) return;
    std::string t = static_cast<const char*>(call);
    const auto tag = t.find("): ");
    if (tag != std::string::npos) t = t.substr(tag + 3);
    while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.pop_back();
    for (char& c : t)
      if (c == '\n') c = ' ';
    self->text = t;
  }
};

// Catches a reader's (and its executive's) error and warning events, so VTK
// does not print them; errors make the load fail, warnings are dropped (a file
// they concern fails our own checks afterwards).
class CatchVtkErrors {
 public:
  explicit CatchVtkErrors(vtkAlgorithm* reader) {
    on_error_->SetCallback(&FirstMessage::on_event);
    on_error_->SetClientData(&error_);
    on_warning_->SetCallback(&FirstMessage::on_event);
    on_warning_->SetClientData(&warning_);
    reader->AddObserver(vtkCommand::ErrorEvent, on_error_);
    reader->AddObserver(vtkCommand::WarningEvent, on_warning_);
    reader->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, on_error_);
  }
  const std::string& first() const { return error_.text; }

 private:
  FirstMessage error_, warning_;
  vtkNew<vtkCallbackCommand> on_error_, on_warning_;
};

// ---------------------------------------------------------------------------
// VTK 9.1's legacy reader crashes (segfault) when a cell block is shorter than
// its header says, so we first walk the file's sections far enough to know the
// point and cell blocks are complete. The walk stops, content, at anything it
// does not need to understand (attribute data, FIELD, METADATA); VTK reads those.
class LegacyWalker {
 public:
  explicit LegacyWalker(std::string bytes) : s_(std::move(bytes)) {}

  /// "" when the geometry blocks are complete, else what is wrong.
  std::string problem() {
    // Header: magic line, title line (may be empty), ASCII or BINARY, DATASET POLYDATA.
    std::string l;
    if (!raw_line(l) || l.rfind("# vtk DataFile", 0) != 0)
      return "is not a legacy VTK file (no '# vtk DataFile' header)";
    raw_line(l);
    if (!line(l)) return "the file ends inside its header";
    const std::string mode = upper(l);
    if (mode != "ASCII" && mode != "BINARY") return "has '" + l + "' where ASCII or BINARY belongs";
    binary_ = mode == "BINARY";
    if (!line(l)) return "the file ends inside its header";
    std::istringstream ds(l);
    std::string key, type;
    ds >> key >> type;
    if (upper(key) != "DATASET") return "has '" + l + "' where DATASET POLYDATA belongs";
    if (upper(type) != "POLYDATA") return "is a legacy VTK file but its dataset is " + type + ", not POLYDATA";

    // Sections.
    while (line(l)) {
      std::istringstream ss(l);
      std::string word;
      ss >> word;
      word = upper(word);
      if (word == "POINTS") {
        std::size_t n = 0;
        std::string t;
        if (!(ss >> n >> t) || !block(3 * n, t)) return "the file ends inside its POINTS block";
      } else if (word == "VERTICES" || word == "LINES" || word == "POLYGONS" || word == "TRIANGLE_STRIPS") {
        std::size_t a = 0, b = 0;
        if (!(ss >> a >> b)) return "has an unreadable " + word + " line";
        // VTK >= 9 writes OFFSETS and CONNECTIVITY blocks; older files one block of counts and ids.
        const std::size_t mark = pos_;
        std::string next;
        if (line(next) && upper(next.substr(0, 7)) == "OFFSETS") {
          std::string t = next.substr(7), c;
          if (!block(a, trim(t)) || !line(c) || upper(c.substr(0, 12)) != "CONNECTIVITY" ||
              !block(b, trim(c.substr(12))))
            return "the file ends inside its " + word + " block";
        } else {
          pos_ = mark;
          if (!block(b, "int")) return "the file ends inside its " + word + " block";
        }
      } else {
        return "";  // attribute data and the like: VTK's business
      }
    }
    return "";
  }

 private:
  static std::string upper(std::string t) {
    for (char& c : t) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return t;
  }
  static std::string trim(std::string t) {
    while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.pop_back();
    std::size_t i = 0;
    while (i < t.size() && std::isspace(static_cast<unsigned char>(t[i]))) ++i;
    return t.substr(i);
  }
  // The next line as it is (without its newline); false at the end.
  bool raw_line(std::string& out) {
    if (pos_ >= s_.size()) return false;
    std::size_t end = s_.find('\n', pos_);
    if (end == std::string::npos) end = s_.size();
    out = trim(s_.substr(pos_, end - pos_));
    pos_ = std::min(end + 1, s_.size());
    return true;
  }
  // The next non-blank line, trimmed.
  bool line(std::string& out) {
    while (raw_line(out))
      if (!out.empty()) return true;
    return false;
  }
  // Skips n values of a VTK data type: whitespace-separated tokens in ASCII,
  // raw bytes in BINARY. Unknown types are taken as complete.
  bool block(std::size_t n, const std::string& type) {
    if (!binary_) {
      for (std::size_t k = 0; k < n; ++k) {
        while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
        if (pos_ >= s_.size()) return false;
        while (pos_ < s_.size() && !std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
      }
      return true;
    }
    const std::string t = upper(type);
    std::size_t bytes = 0;
    if (t == "UNSIGNED_CHAR" || t == "CHAR") bytes = 1;
    else if (t == "SHORT" || t == "UNSIGNED_SHORT") bytes = 2;
    else if (t == "INT" || t == "UNSIGNED_INT" || t == "FLOAT") bytes = 4;
    else if (t == "DOUBLE" || t == "VTKTYPEINT64" || t == "VTKTYPEUINT64" || t == "VTKIDTYPE") bytes = 8;
    else return true;
    if (n > (s_.size() - pos_) / bytes) return false;
    pos_ += n * bytes;
    return true;
  }

  std::string s_;
  std::size_t pos_ = 0;
  bool binary_ = false;
};

}  // namespace

// ---------------------------------------------------------------------------
// Reads one .vtk / .vtp file into a raw soup: points, polygons and triangle
// strips (lines and vertices are ignored).
RawMesh read_vtk(const std::filesystem::path& path, const std::string& ext, const LoadOptions& options) {
  const std::string source = path.string();
  vtkSmartPointer<vtkPolyData> data;

  if (ext == "vtk") {
    // Legacy format: refuse datasets other than POLYDATA with a clear word.
    // Legacy format: check the structure ourselves first (see LegacyWalker).
    {
      std::ifstream in(path, std::ios::binary);
      if (!in) fail(source, "cannot be opened for reading");
      std::ostringstream bytes;
      bytes << in.rdbuf();
      const std::string problem = LegacyWalker(bytes.str()).problem();
      if (!problem.empty()) fail(source, problem);
    }
    vtkNew<vtkPolyDataReader> reader;
    CatchVtkErrors errors(reader);
    reader->SetFileName(source.c_str());
    reader->Update();
    if (!errors.first().empty()) fail(source, "VTK cannot read it: " + errors.first());
    data = reader->GetOutput();
  } else {
    vtkNew<vtkXMLPolyDataReader> reader;
    CatchVtkErrors errors(reader);
    if (!reader->CanReadFile(source.c_str())) fail(source, "is not a VTK XML PolyData file");
    reader->SetFileName(source.c_str());
    reader->Update();
    if (!errors.first().empty()) fail(source, "VTK cannot read it: " + errors.first());
    data = reader->GetOutput();
  }
  if (data == nullptr) fail(source, "VTK read no data from it");

  // Limits before copying anything.
  const vtkIdType n_points = data->GetNumberOfPoints();
  if (static_cast<std::size_t>(n_points) > options.max_vertices)
    fail(source, "has more than " + std::to_string(options.max_vertices) + " vertices (LoadOptions::max_vertices)");
  const vtkIdType n_cells = data->GetNumberOfPolys() + data->GetNumberOfStrips();
  if (static_cast<std::size_t>(n_cells) > options.max_triangles)
    fail(source, "has more than " + std::to_string(options.max_triangles) +
                     " triangles (LoadOptions::max_triangles)");

  // Points, in file units.
  RawMesh raw;
  raw.vertices.resize(static_cast<std::size_t>(n_points));
  for (vtkIdType i = 0; i < n_points; ++i) {
    double p[3];
    data->GetPoint(i, p);
    raw.vertices[static_cast<std::size_t>(i)] = Vec3(p[0], p[1], p[2]);
  }

  // Polygons as they are.
  if (vtkCellArray* polys = data->GetPolys()) {
    auto it = vtkSmartPointer<vtkCellArrayIterator>::Take(polys->NewIterator());
    for (it->GoToFirstCell(); !it->IsDoneWithTraversal(); it->GoToNextCell()) {
      vtkIdType n = 0;
      const vtkIdType* ids = nullptr;
      it->GetCurrentCell(n, ids);
      for (vtkIdType k = 0; k < n; ++k) raw.face_indices.push_back(ids[k]);
      raw.face_offsets.push_back(raw.face_indices.size());
    }
  }

  // Triangle strips: triangle k of a strip is (k, k+1, k+2), every other one reversed.
  if (vtkCellArray* strips = data->GetStrips()) {
    auto it = vtkSmartPointer<vtkCellArrayIterator>::Take(strips->NewIterator());
    for (it->GoToFirstCell(); !it->IsDoneWithTraversal(); it->GoToNextCell()) {
      vtkIdType n = 0;
      const vtkIdType* ids = nullptr;
      it->GetCurrentCell(n, ids);
      if (n < 3) {
        raw.add_face({});  // reported as a face with too few vertices
        continue;
      }
      for (vtkIdType k = 0; k + 2 < n; ++k) {
        if (k % 2 == 0)
          raw.add_face({ids[k], ids[k + 1], ids[k + 2]});
        else
          raw.add_face({ids[k + 1], ids[k], ids[k + 2]});
      }
    }
  }
  return raw;
}

}  // namespace palpa::mesh::internal
