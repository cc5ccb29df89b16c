// Exports (export.h).

#include "app/replay/export.h"

#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLPolyDataWriter.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace palpa::app {

void write_ticks_csv(const LoadedSession& s, const std::string& file) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(file + ": cannot write");
  out.precision(17);
  out << "tick,time_s,probe,position_x_m,position_y_m,position_z_m,force_device_x_n,force_device_y_n,force_device_z_n,"
         "flags,world_x_m,world_y_m,world_z_m,force_x_n,force_y_n,force_z_n,contact_x_m,contact_y_m,contact_z_m,"
         "depth_m,in_contact\n";
  const std::uint64_t end = s.first_tick + s.file.header().ticks;
  for (std::uint64_t w = s.first_tick; w < end; w += 20000) {
    const auto span = s.file.ticks(w, w + 20000);
    for (std::size_t k = 0; k < span.ticks.size(); ++k) {
      const auto& t = span.ticks[k];
      for (std::size_t j = 0; j < t.probe_count; ++j) {
        const auto& p = t.inputs[j].sample.position;
        const auto& f = t.force_device[j];
        out << t.tick << ',' << t.time << ',' << j << ',' << p[0] << ',' << p[1] << ',' << p[2] << ',' << f[0] << ','
            << f[1] << ',' << f[2] << ',' << t.flags[j];
        if (!span.results.empty()) {
          const auto& r = span.results[k][j];
          out << ',' << r.world[0] << ',' << r.world[1] << ',' << r.world[2] << ',' << r.force_world[0] << ','
              << r.force_world[1] << ',' << r.force_world[2] << ',' << r.contact_point[0] << ',' << r.contact_point[1]
              << ',' << r.contact_point[2] << ',' << r.depth << ',' << int(r.in_contact) << '\n';
        } else {
          out << ",,,,,,,,,,,\n";
        }
      }
    }
    if (span.ticks.empty()) break;
  }
  out.close();
  if (!out) throw std::runtime_error(file + ": cannot write");
}

void write_coverage_vtp(const assess::Coverage& c, const std::string& file) {
  const mesh::SurfaceMesh& m = c.mesh();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  for (const Vec3& p : m.positions) points->InsertNextPoint(p.x(), p.y(), p.z());
  vtkNew<vtkCellArray> cells;
  for (const auto& t : m.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    cells->InsertNextCell(3, ids);
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetPolys(cells);
  vtkNew<vtkUnsignedCharArray> level;
  level->SetName("coverage_level");
  vtkNew<vtkDoubleArray> peak, thick;
  peak->SetName("peak_force_n");
  thick->SetName("thickness_m");
  vtkNew<vtkUnsignedCharArray> episodes;
  episodes->SetName("episodes");
  for (Index i = 0; i < m.vertex_count(); ++i) {
    level->InsertNextValue(static_cast<unsigned char>(c.highest()[i]));
    peak->InsertNextValue(c.peak_force()[i]);
    thick->InsertNextValue(std::isfinite(c.thickness()[i]) ? c.thickness()[i] : -1.0);
    episodes->InsertNextValue(c.episodes()[i]);
  }
  poly->GetPointData()->AddArray(level);
  poly->GetPointData()->AddArray(peak);
  poly->GetPointData()->AddArray(thick);
  poly->GetPointData()->AddArray(episodes);
  vtkNew<vtkXMLPolyDataWriter> writer;
  writer->SetFileName(file.c_str());
  writer->SetInputData(poly);
  writer->SetDataModeToBinary();
  if (writer->Write() != 1) throw std::runtime_error(file + ": cannot write");
}

namespace {

std::string point_json(int id, const std::string& label, const Vec3& p, const std::string& description) {
  char b[512];
  std::snprintf(b, sizeof b,
                "{\"id\": \"%d\", \"label\": \"%s\", \"description\": \"%s\", \"position\": [%.6f, %.6f, %.6f], "
                "\"selected\": true, \"locked\": true, \"visibility\": true, \"positionStatus\": \"defined\"}",
                id, label.c_str(), description.c_str(), 1e3 * p.x(), 1e3 * p.y(), 1e3 * p.z());
  return b;
}

std::string clean(std::string s) {
  for (char& c : s)
    if (c == '"' || c == '\\' || static_cast<unsigned char>(c) < 0x20) c = ' ';
  return s;
}

}  // namespace

std::string markups_json(const assess::Report& r) {
  std::ostringstream j;
  j << "{\n  \"@schema\": \"https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/Resources/"
       "Schema/markups-schema-v1.0.3.json#\",\n  \"markups\": [\n";
  j << "    {\"type\": \"Fiducial\", \"name\": \"lesions\", \"coordinateSystem\": \"RAS\", \"coordinateUnits\": \"mm\", "
       "\"controlPoints\": [";
  for (std::size_t k = 0; k < r.lesions.size(); ++k) {
    const auto& l = r.lesions[k];
    char d[128];
    std::snprintf(d, sizeof d, "diameter %.1f mm, %s", 1e3 * l.diameter, l.found ? "found" : l.missed.c_str());
    j << (k ? ", " : "") << "\n      " << point_json(static_cast<int>(k + 1), clean(l.name), l.centre, d);
  }
  j << "]},\n    {\"type\": \"Fiducial\", \"name\": \"marks\", \"coordinateSystem\": \"RAS\", \"coordinateUnits\": \"mm\", "
       "\"controlPoints\": [";
  for (std::size_t k = 0; k < r.marks.size(); ++k) {
    const auto& m = r.marks[k];
    char d[160];
    std::snprintf(d, sizeof d, "at %.1f s, diameter %.1f mm, %s%s", m.time, 1e3 * m.diameter, clean(m.consistency).c_str(),
                  m.lesion < 0 ? ", false positive" : "");
    j << (k ? ", " : "") << "\n      " << point_json(static_cast<int>(k + 1), "mark " + std::to_string(k + 1), m.point, d);
  }
  j << "]}\n  ]\n}\n";
  return j.str();
}

}  // namespace palpa::app
