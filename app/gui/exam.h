#pragma once
// An exam's marks compared with the truth (no Qt): each mark matched one to
// one with the nearest unmatched lesion centre within the task's position
// tolerance, closest pairs first, as palpa-assess does (docs/ASSESSMENT.md):
// a matched mark found its lesion, an unmatched mark is a false positive, an
// unmatched lesion is missed. SI units.

#include "core/types.h"
#include "mesh/surface_mesh.h"
#include "tissue/lesion.h"

#include <string>
#include <vector>

namespace palpa::app {

/// A finding the trainee marked.
struct ExamMark {
  Vec3 point = Vec3::Zero();  ///< organ frame, m
  double diameter = 0;        ///< m as reported (0: not reported)
  std::string consistency;    ///< "soft", "firm", "hard" or empty
  double time = 0;            ///< s of exam time when marked
};

struct ExamMarkResult {
  int lesion = -1;            ///< matched lesion (-1: false positive)
  double distance = 0;        ///< m, mark to the lesion's centre (when matched)
  double size_error = 0;      ///< m, reported minus true diameter (when matched and a size was reported)
};

struct ExamResult {
  std::vector<ExamMarkResult> marks;  ///< one per mark, in order
  std::vector<int> lesion_mark;       ///< per lesion: the mark that found it (-1: missed)
  int found = 0, false_positives = 0, missed = 0;
};

/// A lesion's diameter as palpa-assess reports it: 2 (a b c)^(1/3), m.
double lesion_diameter(const tissue::Lesion& l);

/// Matches `marks` to `lesions` within `tolerance` (m), one to one, the
/// closest pairs first, by assess::mark_distance: a mark counts from the
/// lesion's centre or from the surface point above it on `organ` (a mark is
/// made on the surface; null organ: from the centre only), as palpa-assess
/// scores the session.
ExamResult score_exam(const std::vector<ExamMark>& marks, const std::vector<tissue::Lesion>& lesions,
                      double tolerance, const mesh::SurfaceMesh* organ = nullptr);

}  // namespace palpa::app
