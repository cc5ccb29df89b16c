#pragma once
// The authoring panel (a dock in authoring mode): the scenario's base
// tissue, its lesions (name, depth, radius, modulus ratio, visibility), the
// task and its scoring, breathing, pulses, and the tools of the 3D view
// (place lesion, draw pulse path, paint) with what they make. Units are
// the file's (mm, kPa, N, s, bpm); every edit is an undoable command of the
// ScenarioDocument, refused with its error when the scenario would not be
// valid (the panel then shows the document as it is).

#include "app/gui/authoring_tools.h"

#include <QWidget>

class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QLineEdit;
class QListWidget;
class QPlainTextEdit;
class QPushButton;
class QTableWidget;
class QToolButton;

namespace palpa::app {

class AuthoringPanel : public QWidget {
  Q_OBJECT
 public:
  AuthoringPanel(ScenarioDocument* doc, AuthoringTools* tools, QWidget* parent = nullptr);

  /// Shows the document (called on every change; signals blocked).
  void sync();
  /// Commits the task instructions being typed (also done when the field loses focus).
  void commit_instructions();

  /// Table columns.
  enum Column { Name = 0, Depth = 1, Radius = 2, Ratio = 3, Shown = 4 };

 protected:
  bool eventFilter(QObject* watched, QEvent* event) override;

 private:
  QWidget* build_lesions();
  QWidget* build_task();
  QWidget* build_motion();
  QWidget* build_paint();
  void edit_lesion_cell(int row, int column);
  void edit_task();
  void edit_breathing();
  void edit_pulse();
  void read_defaults();
  void sync_tools();

  ScenarioDocument* doc_;
  AuthoringTools* tools_;
  bool syncing_ = false;

  QLabel* hint_ = nullptr;
  QWidget* body_ = nullptr;
  QLineEdit* title_ = nullptr;
  QComboBox* base_tissue_ = nullptr;
  QToolButton* place_tool_ = nullptr;
  QDoubleSpinBox* new_depth_ = nullptr;
  QDoubleSpinBox* new_radius_ = nullptr;
  QDoubleSpinBox* new_ratio_ = nullptr;
  QComboBox* new_visibility_ = nullptr;
  QTableWidget* lesions_ = nullptr;
  QPushButton* delete_lesion_ = nullptr;

  QPlainTextEdit* instructions_ = nullptr;
  QDoubleSpinBox* time_limit_ = nullptr;
  QCheckBox* report_position_ = nullptr;
  QCheckBox* report_size_ = nullptr;
  QCheckBox* report_consistency_ = nullptr;
  QDoubleSpinBox* force_limit_ = nullptr;
  QDoubleSpinBox* pass_score_ = nullptr;
  QDoubleSpinBox* position_tolerance_ = nullptr;

  QCheckBox* breathing_on_ = nullptr;
  QDoubleSpinBox* breathing_rate_ = nullptr;
  QDoubleSpinBox* breathing_amplitude_ = nullptr;
  QToolButton* pulse_tool_ = nullptr;
  QPushButton* finish_pulse_ = nullptr;
  QLabel* pulse_points_ = nullptr;
  QDoubleSpinBox* pulse_rate_ = nullptr;
  QDoubleSpinBox* pulse_amplitude_ = nullptr;
  QDoubleSpinBox* pulse_radius_ = nullptr;
  QListWidget* pulses_ = nullptr;
  QPushButton* delete_pulse_ = nullptr;

  QToolButton* paint_tool_ = nullptr;
  QDoubleSpinBox* brush_radius_ = nullptr;
  QDoubleSpinBox* brush_feather_ = nullptr;
  QComboBox* brush_tissue_ = nullptr;
  QDoubleSpinBox* brush_scale_ = nullptr;
  QCheckBox* brush_erase_ = nullptr;
};

}  // namespace palpa::app
