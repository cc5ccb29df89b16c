#pragma once
// The Material dock's panel: a tissue in kPa (Hertz contact at the probe
// tip) or a preset, the probe's tip radius, the shape function and the
// force clamp, and the advanced linear local model in N/m. The panel owns
// its widgets and their state; it shows MaterialSettings in SI units and
// says when the user edited them (edited). With a scenario, the window
// shows a note on what an edit does to its tissue map, and the button that
// restores the map (restore_requested). What MainWindow does with an edit:
// Workbench::set_material on the whole organ.

#include "app/gui/workbench.h"

#include <QWidget>

#include <string>
#include <vector>

class QComboBox;
class QDoubleSpinBox;
class QGroupBox;
class QLabel;
class QPushButton;
class QSettings;

namespace palpa::app {

class MaterialPanel : public QWidget {
  Q_OBJECT
 public:
  explicit MaterialPanel(QWidget* parent = nullptr);

  /// What the panel shows, in SI units. A tissue whose values differ from
  /// the preset named is a custom one (named "custom", no source).
  MaterialSettings settings() const;
  /// Shows `m` (and the preset with its values, when there is one) without
  /// emitting edited.
  void set_settings(const MaterialSettings& m);

  /// Reads the panel's keys (tissue/..., material/...; kPa and mm as
  /// shown) without emitting edited; save() writes them.
  void load(QSettings& s);
  void save(QSettings& s) const;

  /// The key of the preset shown (empty: a custom tissue).
  std::string preset_key() const;

  /// The scenario note over the panel (empty: hidden) and whether the
  /// "Restore the scenario's tissues" button shows.
  void set_scenario_note(const QString& text);
  void set_restore_visible(bool visible);

 signals:
  /// The user changed a value (or picked a preset): the panel's settings().
  void edited(const palpa::app::MaterialSettings& settings);
  /// "Restore the scenario's tissues" was pressed.
  void restore_requested();

 private:
  void apply_material();
  void apply_preset();
  std::vector<QWidget*> tissue_widgets() const;
  tissue::Tissue panel_tissue() const;

  bool quiet_ = true;  // no edited while the panel is built, loaded or set
  QLabel* scenario_note_ = nullptr;
  QPushButton* restore_map_ = nullptr;
  QComboBox* preset_box_ = nullptr;
  QDoubleSpinBox* youngs_kpa_ = nullptr;
  QDoubleSpinBox* poisson_ = nullptr;
  QDoubleSpinBox* damping_ratio_ = nullptr;
  QDoubleSpinBox* relaxation_s_ = nullptr;
  QDoubleSpinBox* relaxation_fraction_ = nullptr;
  QDoubleSpinBox* stiffening_mm_ = nullptr;
  QDoubleSpinBox* tip_radius_mm_ = nullptr;
  QGroupBox* linear_group_ = nullptr;
  QComboBox* model_box_ = nullptr;
  QComboBox* shape_box_ = nullptr;
  QDoubleSpinBox* stiffness_ = nullptr;
  QDoubleSpinBox* damping_ = nullptr;
  QDoubleSpinBox* mass_g_ = nullptr;
  QDoubleSpinBox* radius_mm_ = nullptr;
  QDoubleSpinBox* friction_ = nullptr;
  QDoubleSpinBox* max_force_ = nullptr;
};

}  // namespace palpa::app
