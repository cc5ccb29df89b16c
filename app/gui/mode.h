#pragma once
// The workbench's modes (the Mode menu and the toolbar's mode box):
// Explore, the free workbench; Author, editing a scenario (its tools come
// with the authoring work; until then it behaves as Explore); Exam, a
// trainee examining a scenario: nothing on screen gives a lesion away, a
// countdown runs, findings are marked and compared with the truth at Finish.

#include <QString>

namespace palpa::app {

enum class WorkbenchMode { Explore, Author, Exam };

/// "Explore", "Author", "Exam".
inline QString mode_name(WorkbenchMode m) {
  switch (m) {
    case WorkbenchMode::Explore: return QStringLiteral("Explore");
    case WorkbenchMode::Author: return QStringLiteral("Author");
    case WorkbenchMode::Exam: return QStringLiteral("Exam");
  }
  return {};
}

}  // namespace palpa::app
