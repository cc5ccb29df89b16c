// XML PolyData (.vtp) through VTK 9.1's reader. The only file of the module
// that includes VTK headers. (Legacy .vtk has our own reader, io_text.cpp:
// VTK's crashed on cells whose counts disagree with the data.)

#include "mesh/internal_io.h"

#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCellArrayIterator.h>
#include <vtkCommand.h>
#include <vtkExecutive.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
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

}  // namespace

// ---------------------------------------------------------------------------
// Reads one .vtp file into a raw soup: points, polygons and triangle strips
// (lines and vertices are ignored).
RawMesh read_vtp(const std::filesystem::path& path, const LoadOptions& options) {
  const std::string source = path.string();
  vtkSmartPointer<vtkPolyData> data;
  {
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
