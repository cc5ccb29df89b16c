// The Material dock's panel (moved out of main_window.cpp).

#include "app/gui/material_panel.h"
#include "app/gui/spin_box.h"

#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGroupBox>
#include <QLabel>
#include <QPushButton>
#include <QSettings>
#include <QSignalBlocker>
#include <QVBoxLayout>

#include <algorithm>

namespace palpa::app {
namespace {

// Same numbers (the name and source aside).
bool same_values(const tissue::Tissue& a, const tissue::Tissue& b) {
  return a.youngs_modulus == b.youngs_modulus && a.poisson == b.poisson && a.damping_ratio == b.damping_ratio &&
         a.relaxation_time == b.relaxation_time && a.relaxation_fraction == b.relaxation_fraction &&
         a.stiffening == b.stiffening;
}

const tissue::Preset* preset_at(const QComboBox* box) {
  const std::string key = box->currentData().toString().toStdString();
  try {
    return key.empty() ? nullptr : tissue::find_preset(key);
  } catch (const std::exception&) {
    return nullptr;
  }
}

}  // namespace

// The material panel: a tissue in kPa (Hertz contact at the probe tip), the
// probe, and the advanced linear local model in N/m; applied to the whole
// organ at once.
MaterialPanel::MaterialPanel(QWidget* parent) : QWidget(parent) {
  auto* w = this;
  auto* outer = new QVBoxLayout(w);
  auto* form = new QFormLayout;
  outer->addLayout(form);
  auto spin = [&](const char* name, double lo, double hi, double step, int decimals, const char* suffix,
                  const QString& tip) {
    QDoubleSpinBox* s = make_spin_box(name, lo, hi, step, decimals, suffix, tip);
    connect(s, qOverload<double>(&QDoubleSpinBox::valueChanged), this, &MaterialPanel::apply_material);
    return s;
  };

  // With a scenario: what editing here does to its tissue map, and the undo.
  scenario_note_ = new QLabel;
  scenario_note_->setObjectName("scenarioMaterialNote");
  scenario_note_->setWordWrap(true);
  scenario_note_->setStyleSheet("QLabel { color: #a05a00; }");
  scenario_note_->hide();
  outer->insertWidget(0, scenario_note_);
  restore_map_ = new QPushButton("Restore the scenario's tissues");
  restore_map_->setObjectName("restoreTissueMap");
  restore_map_->setToolTip("Undo the material edit: the scenario's tissue map (its tissues and regions) again");
  restore_map_->hide();
  connect(restore_map_, &QPushButton::clicked, this, &MaterialPanel::restore_requested);
  form->addRow(restore_map_);

  // The tissue: a preset or values of its own.
  preset_box_ = new QComboBox;
  preset_box_->setObjectName("presetBox");
  preset_box_->setToolTip("Published tissue values (data/tissues.json); hover an entry for its source");
  preset_box_->addItem("Custom", QString());
  try {
    for (const tissue::Preset& p : tissue::presets()) {
      preset_box_->addItem(QString::fromStdString(p.tissue.name.empty() ? p.key : p.tissue.name),
                           QString::fromStdString(p.key));
      preset_box_->setItemData(preset_box_->count() - 1, QString::fromStdString(p.tissue.source), Qt::ToolTipRole);
    }
  } catch (const std::exception& e) {
    preset_box_->setToolTip(QString("No presets: %1").arg(e.what()));
  }
  connect(preset_box_, qOverload<int>(&QComboBox::currentIndexChanged), this, &MaterialPanel::apply_preset);
  const MaterialSettings d;
  youngs_kpa_ = spin("youngsModulus", 0.01, 10000, 0.5, 2, " kPa",
                     "Young's modulus E of the tissue, kPa (Hertz contact: F = 4/3 E/(1-nu^2) sqrt(R) d^1.5)");
  poisson_ = spin("poisson", 0, 0.499, 0.01, 3, "", "Poisson ratio nu, dimensionless, 0 .. 0.499 (soft tissue ~0.49)");
  damping_ratio_ = spin("dampingRatio", 0, 10, 0.1, 2, "",
                        "Damping ratio zeta of the local model at 5 mm indentation, dimensionless (1: critically damped)");
  relaxation_s_ = spin("relaxationTime", 0, 100, 0.1, 2, " s",
                       "Viscoelastic relaxation time tau, s (0: elastic): a held press relaxes with this time constant");
  relaxation_fraction_ = spin("relaxationFraction", 0, 10, 0.05, 2, "",
                              "Extra force of a quick press, fraction of the relaxed force (used when tau > 0)");
  stiffening_mm_ = spin("stiffening", 0, 10, 0.01, 3, " /mm",
                        "Stiffening, 1/mm: the force is multiplied by (1 + stiffening * depth); 0: pure Hertz");
  tip_radius_mm_ = spin("tipRadius", 0.5, 50, 0.5, 1, " mm", "Radius R of the probe tip, mm (8 mm: a fingertip)");
  youngs_kpa_->setValue(d.tissue.youngs_modulus * 1e-3);
  poisson_->setValue(d.tissue.poisson);
  damping_ratio_->setValue(d.tissue.damping_ratio);
  relaxation_s_->setValue(d.tissue.relaxation_time);
  relaxation_fraction_->setValue(d.tissue.relaxation_fraction);
  stiffening_mm_->setValue(d.tissue.stiffening * 1e-3);
  tip_radius_mm_->setValue(d.tip_radius * 1e3);
  form->addRow("Preset", preset_box_);
  form->addRow("Young's modulus", youngs_kpa_);
  form->addRow("Poisson ratio", poisson_);
  form->addRow("Damping ratio", damping_ratio_);
  form->addRow("Relaxation time", relaxation_s_);
  form->addRow("Relaxation fraction", relaxation_fraction_);
  form->addRow("Stiffening", stiffening_mm_);
  form->addRow("Tip radius", tip_radius_mm_);

  // The contact's spread and eq. (4).
  shape_box_ = new QComboBox;
  shape_box_->setObjectName("shapeBox");
  shape_box_->addItems({"Gaussian", "Wendland C2", "Volume conserving"});
  shape_box_->setCurrentIndex(1);
  shape_box_->setToolTip("Shape function: how the dent spreads around the contact");
  connect(shape_box_, qOverload<int>(&QComboBox::currentIndexChanged), this, &MaterialPanel::apply_material);
  radius_mm_ = spin("radius", 1, 200, 1, 1, " mm", "Support radius of the shape function, mm (also the deepest press)");
  friction_ = spin("friction", 0, 2, 0.05, 2, "", "Friction coefficient K of eq. (4), dimensionless");
  max_force_ = spin("maxForce", 0.1, 100, 0.5, 1, " N", "Largest force the model asks for, N");
  radius_mm_->setValue(d.radius * 1e3);
  friction_->setValue(d.friction);
  max_force_->setValue(d.max_force);
  form->addRow("Shape function", shape_box_);
  form->addRow("Radius", radius_mm_);
  form->addRow("Friction K", friction_);
  form->addRow("Max force", max_force_);

  // Advanced: the local model's own parameters instead of a tissue.
  linear_group_ = new QGroupBox("Advanced: local model in N/m instead of the tissue");
  linear_group_->setObjectName("linearModel");
  linear_group_->setCheckable(true);
  linear_group_->setChecked(false);
  linear_group_->setToolTip("Set the per-vertex local model directly (stiffness N/m, damping N s/m, mass g) "
                            "instead of a tissue in kPa");
  connect(linear_group_, &QGroupBox::toggled, this, &MaterialPanel::apply_material);
  auto* linear = new QFormLayout(linear_group_);
  model_box_ = new QComboBox;
  model_box_->setObjectName("modelBox");
  model_box_->addItems({"Linear (eq. 1)", "Exponential (stiffening)", "Viscoelastic (relaxing)"});
  model_box_->setToolTip("Local model kind of every vertex");
  connect(model_box_, qOverload<int>(&QComboBox::currentIndexChanged), this, &MaterialPanel::apply_material);
  stiffness_ = spin("stiffness", 1, 1e5, 10, 1, " N/m", "Stiffness k of every vertex's local model, N/m");
  damping_ = spin("damping", 0.01, 1e3, 0.5, 2, " N·s/m", "Damping b of every vertex's local model, N s/m");
  mass_g_ = spin("mass", 0.01, 1e3, 0.1, 2, " g", "Mass m of every vertex's local model, g");
  stiffness_->setValue(d.stiffness);
  damping_->setValue(d.damping);
  mass_g_->setValue(d.mass * 1e3);
  linear->addRow("Local model", model_box_);
  linear->addRow("Stiffness", stiffness_);
  linear->addRow("Damping", damping_);
  linear->addRow("Mass per vertex", mass_g_);
  outer->addWidget(linear_group_);
  outer->addStretch(1);
  quiet_ = false;
}

// ---------------------------------------------------------------------------
// Settings kept between runs (QSettings): the tissue (kPa, mm as shown), the
// law and the preset named, the local model, the shape function, the clamp.
void MaterialPanel::load(QSettings& s) {
  const bool was_quiet = quiet_;
  quiet_ = true;
  const MaterialSettings d;
  linear_group_->setChecked(s.value("tissue/advanced_linear", false).toBool());
  youngs_kpa_->setValue(s.value("tissue/youngs_modulus_kpa", d.tissue.youngs_modulus * 1e-3).toDouble());
  poisson_->setValue(s.value("tissue/poisson", d.tissue.poisson).toDouble());
  damping_ratio_->setValue(s.value("tissue/damping_ratio", d.tissue.damping_ratio).toDouble());
  relaxation_s_->setValue(s.value("tissue/relaxation_time_s", d.tissue.relaxation_time).toDouble());
  relaxation_fraction_->setValue(s.value("tissue/relaxation_fraction", d.tissue.relaxation_fraction).toDouble());
  stiffening_mm_->setValue(s.value("tissue/stiffening_per_mm", d.tissue.stiffening * 1e-3).toDouble());
  tip_radius_mm_->setValue(s.value("tissue/tip_radius_mm", d.tip_radius * 1e3).toDouble());
  preset_box_->setCurrentIndex(std::max(0, preset_box_->findData(s.value("tissue/preset", QString()).toString())));
  model_box_->setCurrentIndex(std::clamp(s.value("material/model", 0).toInt(), 0, 2));
  shape_box_->setCurrentIndex(std::clamp(s.value("material/shape", 1).toInt(), 0, 2));
  stiffness_->setValue(s.value("material/stiffness", d.stiffness).toDouble());
  damping_->setValue(s.value("material/damping", d.damping).toDouble());
  mass_g_->setValue(s.value("material/mass_g", d.mass * 1e3).toDouble());
  radius_mm_->setValue(s.value("material/radius_mm", d.radius * 1e3).toDouble());
  friction_->setValue(s.value("material/friction", d.friction).toDouble());
  max_force_->setValue(s.value("material/max_force", d.max_force).toDouble());
  quiet_ = was_quiet;
  // As an edit would show them: values away from the preset are a custom
  // tissue; the tissue's controls only for the Hertz law.
  if (const tissue::Preset* p = preset_at(preset_box_); p && !same_values(p->tissue, panel_tissue())) {
    const QSignalBlocker block(preset_box_);
    preset_box_->setCurrentIndex(0);
    preset_box_->setToolTip("A tissue of its own (no preset)");
  }
  for (QWidget* t : tissue_widgets()) t->setEnabled(!linear_group_->isChecked());
}

void MaterialPanel::save(QSettings& s) const {
  s.setValue("tissue/advanced_linear", linear_group_->isChecked());
  s.setValue("tissue/youngs_modulus_kpa", youngs_kpa_->value());
  s.setValue("tissue/poisson", poisson_->value());
  s.setValue("tissue/damping_ratio", damping_ratio_->value());
  s.setValue("tissue/relaxation_time_s", relaxation_s_->value());
  s.setValue("tissue/relaxation_fraction", relaxation_fraction_->value());
  s.setValue("tissue/stiffening_per_mm", stiffening_mm_->value());
  s.setValue("tissue/tip_radius_mm", tip_radius_mm_->value());
  s.setValue("tissue/preset", preset_box_->currentData().toString());
  s.setValue("material/model", model_box_->currentIndex());
  s.setValue("material/shape", shape_box_->currentIndex());
  s.setValue("material/stiffness", stiffness_->value());
  s.setValue("material/damping", damping_->value());
  s.setValue("material/mass_g", mass_g_->value());
  s.setValue("material/radius_mm", radius_mm_->value());
  s.setValue("material/friction", friction_->value());
  s.setValue("material/max_force", max_force_->value());
}

// ---------------------------------------------------------------------------
// The panel's values in SI.

// The tissue as the panel shows it (kPa and mm to SI).
tissue::Tissue MaterialPanel::panel_tissue() const {
  tissue::Tissue t;
  if (const tissue::Preset* p = preset_at(preset_box_)) t = p->tissue;
  else t.name = "custom";
  t.youngs_modulus = youngs_kpa_->value() * 1e3;
  t.poisson = poisson_->value();
  t.damping_ratio = damping_ratio_->value();
  t.relaxation_time = relaxation_s_->value();
  t.relaxation_fraction = relaxation_fraction_->value();
  t.stiffening = stiffening_mm_->value() * 1e3;
  return t;
}

MaterialSettings MaterialPanel::settings() const {
  MaterialSettings m;
  m.law = linear_group_->isChecked() ? MaterialLaw::Linear : MaterialLaw::Hertz;
  m.tissue = panel_tissue();
  // Values edited away from the preset: a custom tissue.
  if (const tissue::Preset* p = preset_at(preset_box_); p && !same_values(p->tissue, m.tissue)) {
    m.tissue.name = "custom";
    m.tissue.source.clear();
  }
  m.tip_radius = tip_radius_mm_->value() * 1e-3;
  m.model = static_cast<deform::LocalModelKind>(model_box_->currentIndex());
  m.shape = static_cast<deform::ShapeKind>(shape_box_->currentIndex());
  m.stiffness = stiffness_->value();
  m.damping = damping_->value();
  m.mass = mass_g_->value() * 1e-3;
  m.radius = radius_mm_->value() * 1e-3;
  m.friction = friction_->value();
  m.max_force = max_force_->value();
  return m;
}

std::string MaterialPanel::preset_key() const { return preset_box_->currentData().toString().toStdString(); }

// An edit: values away from the preset make the box say Custom; the
// tissue's controls only for the Hertz law; then edited.
void MaterialPanel::apply_material() {
  if (quiet_) return;
  const MaterialSettings m = settings();
  if (const tissue::Preset* p = preset_at(preset_box_); p && !same_values(p->tissue, m.tissue)) {
    const QSignalBlocker block(preset_box_);
    preset_box_->setCurrentIndex(0);
    preset_box_->setToolTip("A tissue of its own (no preset)");
  }
  for (QWidget* t : tissue_widgets()) t->setEnabled(m.law == MaterialLaw::Hertz);
  emit edited(m);
}

// A preset fills in the tissue's values, then applies them.
void MaterialPanel::apply_preset() {
  if (quiet_) return;
  if (const tissue::Preset* p = preset_at(preset_box_)) {
    const tissue::Tissue& t = p->tissue;
    for (QDoubleSpinBox* b : {youngs_kpa_, poisson_, damping_ratio_, relaxation_s_, relaxation_fraction_,
                              stiffening_mm_})
      b->blockSignals(true);
    youngs_kpa_->setValue(t.youngs_modulus * 1e-3);
    poisson_->setValue(t.poisson);
    damping_ratio_->setValue(t.damping_ratio);
    relaxation_s_->setValue(t.relaxation_time);
    relaxation_fraction_->setValue(t.relaxation_fraction);
    stiffening_mm_->setValue(t.stiffening * 1e-3);
    for (QDoubleSpinBox* b : {youngs_kpa_, poisson_, damping_ratio_, relaxation_s_, relaxation_fraction_,
                              stiffening_mm_})
      b->blockSignals(false);
    preset_box_->setToolTip(QString::fromStdString(t.source));
  }
  apply_material();
}

std::vector<QWidget*> MaterialPanel::tissue_widgets() const {
  return {preset_box_, youngs_kpa_, poisson_, damping_ratio_, relaxation_s_, relaxation_fraction_, stiffening_mm_,
          tip_radius_mm_};
}

// The panel shows the workbench's settings (after a scenario set them),
// without applying anything.
void MaterialPanel::set_settings(const MaterialSettings& m) {
  const bool was_quiet = quiet_;
  quiet_ = true;
  linear_group_->setChecked(m.law == MaterialLaw::Linear);
  youngs_kpa_->setValue(m.tissue.youngs_modulus * 1e-3);
  poisson_->setValue(m.tissue.poisson);
  damping_ratio_->setValue(m.tissue.damping_ratio);
  relaxation_s_->setValue(m.tissue.relaxation_time);
  relaxation_fraction_->setValue(m.tissue.relaxation_fraction);
  stiffening_mm_->setValue(m.tissue.stiffening * 1e-3);
  tip_radius_mm_->setValue(m.tip_radius * 1e3);
  // The preset with these values (and this source, when several have them).
  int by_values = 0, by_source = 0;
  try {
    const auto& presets = tissue::presets();
    for (std::size_t k = 0; k < presets.size(); ++k) {
      if (!same_values(presets[k].tissue, m.tissue)) continue;
      if (by_values == 0) by_values = static_cast<int>(k) + 1;
      if (by_source == 0 && presets[k].tissue.source == m.tissue.source) by_source = static_cast<int>(k) + 1;
    }
  } catch (const std::exception&) {
  }
  const int preset = by_source != 0 ? by_source : by_values;
  preset_box_->setCurrentIndex(preset);
  shape_box_->setCurrentIndex(static_cast<int>(m.shape));
  radius_mm_->setValue(m.radius * 1e3);
  friction_->setValue(m.friction);
  max_force_->setValue(m.max_force);
  model_box_->setCurrentIndex(static_cast<int>(m.model));
  stiffness_->setValue(m.stiffness);
  damping_->setValue(m.damping);
  mass_g_->setValue(m.mass * 1e3);
  for (QWidget* t : tissue_widgets()) t->setEnabled(m.law == MaterialLaw::Hertz);
  quiet_ = was_quiet;
}

void MaterialPanel::set_scenario_note(const QString& text) {
  if (text.isEmpty()) {
    scenario_note_->hide();
    return;
  }
  scenario_note_->setText(text);
  scenario_note_->show();
}

void MaterialPanel::set_restore_visible(bool visible) { restore_map_->setVisible(visible); }

}  // namespace palpa::app
