// Marks against the truth.

#include "app/gui/exam.h"

#include "assess/assess.h"

#include <algorithm>
#include <cmath>

namespace palpa::app {

double lesion_diameter(const tissue::Lesion& l) {
  return 2 * std::cbrt(l.semi_axes.x() * l.semi_axes.y() * l.semi_axes.z());
}

ExamResult score_exam(const std::vector<ExamMark>& marks, const std::vector<tissue::Lesion>& lesions,
                      double tolerance, const mesh::SurfaceMesh* organ) {
  ExamResult r;
  r.marks.resize(marks.size());
  r.lesion_mark.assign(lesions.size(), -1);
  struct Pair {
    double d;
    std::size_t mark, lesion;
  };
  std::vector<Pair> pairs;
  std::vector<Vec3> above;
  for (const auto& l : lesions) above.push_back(organ ? assess::surface_point_above(*organ, l) : l.centre);
  for (std::size_t i = 0; i < marks.size(); ++i)
    for (std::size_t k = 0; k < lesions.size(); ++k) {
      const double d = assess::mark_distance(marks[i].point, lesions[k], above[k]);
      if (d <= tolerance) pairs.push_back({d, i, k});
    }
  std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.d < b.d; });
  for (const Pair& p : pairs) {
    if (r.marks[p.mark].lesion >= 0 || r.lesion_mark[p.lesion] >= 0) continue;
    ExamMarkResult& m = r.marks[p.mark];
    m.lesion = static_cast<int>(p.lesion);
    m.distance = p.d;
    m.size_error = marks[p.mark].diameter > 0 ? marks[p.mark].diameter - lesion_diameter(lesions[p.lesion]) : 0.0;
    r.lesion_mark[p.lesion] = static_cast<int>(p.mark);
  }
  for (const ExamMarkResult& m : r.marks) (m.lesion >= 0 ? r.found : r.false_positives) += 1;
  r.missed = static_cast<int>(std::count(r.lesion_mark.begin(), r.lesion_mark.end(), -1));
  return r;
}

}  // namespace palpa::app
