// The authoring panel (authoring_panel.h).

#include "app/gui/authoring_panel.h"
#include "app/gui/spin_box.h"

#include <QAbstractButton>
#include <QCheckBox>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QEvent>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QSignalBlocker>
#include <QTableWidget>
#include <QToolButton>
#include <QVBoxLayout>

#include <cmath>

namespace palpa::app {

namespace {

constexpr double kMm = 1e-3;

const char* const kVisibilityText[] = {"hidden", "shown", "after exam"};

QDoubleSpinBox* spin(const char* name, double lo, double hi, double step, int decimals, const QString& suffix,
                     const QString& tip) {
  return make_spin_box(name, lo, hi, step, decimals, suffix, tip);
}

QComboBox* visibility_box(const char* name, const QString& tip) {
  auto* b = new QComboBox;
  b->setObjectName(name);
  for (const char* t : kVisibilityText) b->addItem(t);
  b->setItemData(0, "Felt, never drawn: the trainee finds it by feel", Qt::ToolTipRole);
  b->setItemData(1, "Drawn as an inclusion during the exam", Qt::ToolTipRole);
  b->setItemData(2, "Hidden during the exam, drawn in the debriefing", Qt::ToolTipRole);
  b->setToolTip(tip);
  return b;
}

QToolButton* tool_button(const char* name, const QString& text, const QString& tip) {
  auto* b = new QToolButton;
  b->setObjectName(name);
  b->setText(text);
  b->setCheckable(true);
  b->setToolTip(tip);
  b->setToolButtonStyle(Qt::ToolButtonTextOnly);
  return b;
}

void fill_presets(QComboBox* box) {
  try {
    for (const tissue::Preset& p : tissue::presets()) {
      const QString name = QString::fromStdString(p.tissue.name.empty() ? p.key : p.tissue.name);
      box->addItem(QString("%1 (%2 kPa)").arg(name).arg(p.tissue.youngs_modulus * 1e-3, 0, 'g', 3),
                   QString::fromStdString(p.key));
      box->setItemData(box->count() - 1, QString::fromStdString(p.tissue.source), Qt::ToolTipRole);
    }
  } catch (const std::exception& e) {
    box->setToolTip(QString("No presets: %1").arg(e.what()));
  }
}

}  // namespace

AuthoringPanel::AuthoringPanel(ScenarioDocument* doc, AuthoringTools* tools, QWidget* parent)
    : QWidget(parent), doc_(doc), tools_(tools) {
  auto* outer = new QVBoxLayout(this);
  hint_ = new QLabel("No scenario: File > New scenario makes one around the organ shown "
                     "(or open a scenario file).");
  hint_->setObjectName("authorHint");
  hint_->setWordWrap(true);
  outer->addWidget(hint_);
  body_ = new QWidget;
  auto* body = new QVBoxLayout(body_);
  body->setContentsMargins(0, 0, 0, 0);
  outer->addWidget(body_);

  auto* scenario = new QGroupBox("Scenario");
  auto* form = new QFormLayout(scenario);
  title_ = new QLineEdit;
  title_->setObjectName("authorTitle");
  title_->setToolTip("The scenario's title (the window and the Task dock show it)");
  connect(title_, &QLineEdit::editingFinished, this, [this] {
    if (syncing_) return;
    const std::string t = title_->text().toStdString();
    if (doc_->edit("Edit title", [&](scenario::Scenario& s) { s.title = t; }).size()) sync();
  });
  form->addRow("Title", title_);
  base_tissue_ = new QComboBox;
  base_tissue_->setObjectName("authorBaseTissue");
  base_tissue_->setToolTip("The base tissue of the whole organ (a published preset, Young's modulus in kPa); "
                           "painted regions and lesions are relative to it");
  fill_presets(base_tissue_);
  connect(base_tissue_, qOverload<int>(&QComboBox::activated), this, [this](int index) {
    if (syncing_ || index < 0) return;
    const std::string key = base_tissue_->itemData(index).toString().toStdString();
    if (doc_->edit("Set base tissue", [&](scenario::Scenario& s) { s.base_tissue = ensure_preset_tissue(s, key); }).size())
      sync();
  });
  form->addRow("Base tissue", base_tissue_);
  body->addWidget(scenario);
  body->addWidget(build_lesions());
  body->addWidget(build_task());
  body->addWidget(build_motion());
  body->addWidget(build_paint());
  body->addStretch(1);

  connect(doc_, &ScenarioDocument::changed, this, &AuthoringPanel::sync);
  connect(tools_, &AuthoringTools::toolChanged, this, &AuthoringPanel::sync_tools);
  connect(tools_, &AuthoringTools::selectionChanged, this, [this](int lesion) {
    const QSignalBlocker block(lesions_);
    if (lesion < 0) lesions_->clearSelection();
    else lesions_->selectRow(lesion);
    delete_lesion_->setEnabled(lesion >= 0);
  });
  connect(tools_, &AuthoringTools::pulsePointsChanged, this, [this](int n) {
    pulse_points_->setText(QString("%1 point(s) drawn").arg(n));
    finish_pulse_->setEnabled(n >= 2);
  });
  read_defaults();
  sync();
}

// ---------------------------------------------------------------------------
QWidget* AuthoringPanel::build_lesions() {
  auto* box = new QGroupBox("Lesions");
  auto* layout = new QVBoxLayout(box);
  place_tool_ = tool_button("placeLesionTool", "Place lesion",
                            "Click on the organ to place a lesion below that point (depth, radius, ratio and "
                            "visibility below); drag a lesion's handle to move it");
  connect(place_tool_, &QToolButton::toggled, this, [this](bool on) {
    if (!syncing_) tools_->set_tool(on ? AuthoringTool::PlaceLesion : AuthoringTool::None);
  });
  layout->addWidget(place_tool_);
  auto* defaults = new QFormLayout;
  new_depth_ = spin("lesionDepth", 0.5, 200, 1, 1, " mm",
                    "Depth of a new lesion's centre below the clicked surface point, along the inward normal, mm");
  new_radius_ = spin("lesionRadius", 0.5, 100, 0.5, 1, " mm", "Radius of a new lesion, mm");
  new_ratio_ = spin("lesionRatio", 0.05, 100, 0.5, 2, "",
                    "Modulus ratio of a new lesion: its Young's modulus over the surrounding tissue's (> 1: stiffer)");
  new_visibility_ = visibility_box("lesionVisibility", "Whether a new lesion is drawn for the trainee");
  const AuthoringDefaults d;
  new_depth_->setValue(d.lesion_depth / kMm);
  new_radius_->setValue(d.lesion_radius / kMm);
  new_ratio_->setValue(d.lesion_ratio);
  defaults->addRow("New lesion depth", new_depth_);
  defaults->addRow("New lesion radius", new_radius_);
  defaults->addRow("New lesion ratio", new_ratio_);
  defaults->addRow("New lesion visibility", new_visibility_);
  layout->addLayout(defaults);
  for (QDoubleSpinBox* s : {new_depth_, new_radius_, new_ratio_})
    connect(s, qOverload<double>(&QDoubleSpinBox::valueChanged), this, &AuthoringPanel::read_defaults);
  connect(new_visibility_, qOverload<int>(&QComboBox::currentIndexChanged), this, &AuthoringPanel::read_defaults);

  lesions_ = new QTableWidget(0, 5);
  lesions_->setObjectName("lesionTable");
  // The table's corner button selects every row: say so like every control.
  for (QAbstractButton* corner : lesions_->findChildren<QAbstractButton*>()) corner->setToolTip("Select every lesion");
  lesions_->setHorizontalHeaderLabels({"Name", "Depth (mm)", "Radius (mm)", "Ratio", "Visibility"});
  lesions_->setToolTip("The scenario's lesions: double-click a cell to edit it (each edit can be undone)");
  lesions_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  lesions_->setSelectionBehavior(QAbstractItemView::SelectRows);
  lesions_->setSelectionMode(QAbstractItemView::SingleSelection);
  lesions_->setMinimumHeight(120);
  connect(lesions_, &QTableWidget::cellChanged, this, &AuthoringPanel::edit_lesion_cell);
  connect(lesions_, &QTableWidget::itemSelectionChanged, this, [this] {
    if (syncing_) return;
    const auto rows = lesions_->selectionModel()->selectedRows();
    tools_->select(rows.isEmpty() ? -1 : rows.first().row());
  });
  layout->addWidget(lesions_);
  delete_lesion_ = new QPushButton("Delete lesion");
  delete_lesion_->setObjectName("deleteLesion");
  delete_lesion_->setToolTip("Delete the selected lesion (Edit > Undo brings it back)");
  connect(delete_lesion_, &QPushButton::clicked, this, [this] {
    const int k = tools_->selected();
    if (k < 0 || !doc_->has_scenario() || k >= static_cast<int>(doc_->scenario().lesions.size())) return;
    const QString name = QString::fromStdString(doc_->scenario().lesions[static_cast<std::size_t>(k)].lesion.name);
    tools_->select(-1);
    doc_->edit(QString("Delete lesion '%1'").arg(name),
               [&](scenario::Scenario& s) { s.lesions.erase(s.lesions.begin() + k); });
  });
  layout->addWidget(delete_lesion_);
  return box;
}

QWidget* AuthoringPanel::build_task() {
  auto* box = new QGroupBox("Task and scoring");
  auto* form = new QFormLayout(box);
  instructions_ = new QPlainTextEdit;
  instructions_->setObjectName("taskInstructions");
  instructions_->setToolTip("What the trainee is asked to do (shown in the Task dock); taken when the field "
                            "loses the focus");
  instructions_->setMaximumHeight(80);
  instructions_->installEventFilter(this);
  form->addRow("Instructions", instructions_);
  time_limit_ = spin("timeLimit", 0, 36000, 10, 0, " s", "Time limit of the exam, s (0: none)");
  form->addRow("Time limit", time_limit_);
  auto* report = new QHBoxLayout;
  report_position_ = new QCheckBox("position");
  report_size_ = new QCheckBox("size");
  report_consistency_ = new QCheckBox("consistency");
  report_position_->setObjectName("reportPosition");
  report_size_->setObjectName("reportSize");
  report_consistency_->setObjectName("reportConsistency");
  report_position_->setToolTip("The trainee reports where each lesion found is");
  report_size_->setToolTip("The trainee reports each lesion's size");
  report_consistency_->setToolTip("The trainee reports each lesion's consistency (soft, firm, hard)");
  report->addWidget(report_position_);
  report->addWidget(report_size_);
  report->addWidget(report_consistency_);
  form->addRow("Trainee reports", report);
  force_limit_ = spin("forceLimit", 0.1, 100, 0.5, 1, " N",
                      "Force limit, N: pressing harder counts against the trainee (and is the force clamp)");
  pass_score_ = spin("passScore", 0, 100, 5, 0, " %", "Score needed to pass, % of the full score");
  position_tolerance_ = spin("positionTolerance", 0.5, 200, 1, 1, " mm",
                             "A reported lesion within this distance of a true one counts as found, mm");
  form->addRow("Force limit", force_limit_);
  form->addRow("Pass score", pass_score_);
  form->addRow("Position tolerance", position_tolerance_);
  for (QDoubleSpinBox* s : {time_limit_, force_limit_, pass_score_, position_tolerance_})
    connect(s, qOverload<double>(&QDoubleSpinBox::valueChanged), this, &AuthoringPanel::edit_task);
  for (QCheckBox* c : {report_position_, report_size_, report_consistency_})
    connect(c, &QCheckBox::toggled, this, &AuthoringPanel::edit_task);
  return box;
}

QWidget* AuthoringPanel::build_motion() {
  auto* box = new QGroupBox("Breathing and pulse");
  auto* form = new QFormLayout(box);
  breathing_on_ = new QCheckBox("Breathing");
  breathing_on_->setObjectName("breathingOn");
  breathing_on_->setToolTip("The whole organ moves with breathing");
  breathing_rate_ = spin("breathingRate", 1, 60, 1, 0, " bpm", "Breathing rate, breaths per minute");
  breathing_amplitude_ = spin("breathingAmplitude", 0, 100, 1, 1, " mm",
                              "How far the organ moves at end inspiration, mm (along the scenario's breathing "
                              "direction, up by default)");
  form->addRow(breathing_on_);
  form->addRow("Breathing rate", breathing_rate_);
  form->addRow("Breathing amplitude", breathing_amplitude_);
  connect(breathing_on_, &QCheckBox::toggled, this, &AuthoringPanel::edit_breathing);
  for (QDoubleSpinBox* s : {breathing_rate_, breathing_amplitude_})
    connect(s, qOverload<double>(&QDoubleSpinBox::valueChanged), this, &AuthoringPanel::edit_breathing);

  auto* tools = new QHBoxLayout;
  pulse_tool_ = tool_button("drawPulsePath", "Draw pulse path",
                            "Click on the organ to add points of a pulsing vessel's path; Enter or Finish adds "
                            "the pulse, Escape drops the points");
  finish_pulse_ = new QPushButton("Finish");
  finish_pulse_->setObjectName("finishPulsePath");
  finish_pulse_->setToolTip("Add the pulse path drawn (at least 2 points)");
  finish_pulse_->setEnabled(false);
  tools->addWidget(pulse_tool_);
  tools->addWidget(finish_pulse_);
  form->addRow(tools);
  pulse_points_ = new QLabel("0 point(s) drawn");
  pulse_points_->setObjectName("pulsePointCount");
  pulse_points_->setToolTip("Points of the pulse path being drawn");
  form->addRow(pulse_points_);
  connect(pulse_tool_, &QToolButton::toggled, this, [this](bool on) {
    if (!syncing_) tools_->set_tool(on ? AuthoringTool::DrawPulse : AuthoringTool::None);
  });
  connect(finish_pulse_, &QPushButton::clicked, this, [this] { tools_->finish_pulse(); });
  const AuthoringDefaults d;
  pulse_rate_ = spin("pulseRate", 10, 250, 1, 0, " bpm", "Pulse rate, beats per minute (new pulses, or the one selected)");
  pulse_amplitude_ = spin("pulseAmplitude", 0.05, 20, 0.1, 2, " mm",
                          "How far the surface over the vessel moves out at the systolic peak, mm");
  pulse_radius_ = spin("pulseRadius", 1, 100, 1, 1, " mm", "The surface within this distance of the path moves, mm");
  pulse_rate_->setValue(d.pulse_rate_bpm);
  pulse_amplitude_->setValue(d.pulse_amplitude / kMm);
  pulse_radius_->setValue(d.pulse_radius / kMm);
  form->addRow("Pulse rate", pulse_rate_);
  form->addRow("Pulse amplitude", pulse_amplitude_);
  form->addRow("Pulse radius", pulse_radius_);
  for (QDoubleSpinBox* s : {pulse_rate_, pulse_amplitude_, pulse_radius_})
    connect(s, qOverload<double>(&QDoubleSpinBox::valueChanged), this, &AuthoringPanel::edit_pulse);
  pulses_ = new QListWidget;
  pulses_->setObjectName("pulseList");
  pulses_->setToolTip("The scenario's pulses; select one to edit its rate, amplitude and radius above");
  pulses_->setMaximumHeight(70);
  connect(pulses_, &QListWidget::currentRowChanged, this, [this](int row) {
    delete_pulse_->setEnabled(row >= 0);
    if (syncing_ || row < 0 || !doc_->has_scenario()) return;
    const tissue::Pulse& p = doc_->scenario().pulses.at(static_cast<std::size_t>(row));
    syncing_ = true;
    pulse_rate_->setValue(p.rate_bpm);
    pulse_amplitude_->setValue(p.amplitude / kMm);
    pulse_radius_->setValue(p.radius / kMm);
    syncing_ = false;
  });
  form->addRow(pulses_);
  delete_pulse_ = new QPushButton("Delete pulse");
  delete_pulse_->setObjectName("deletePulse");
  delete_pulse_->setToolTip("Delete the selected pulse");
  delete_pulse_->setEnabled(false);
  connect(delete_pulse_, &QPushButton::clicked, this, [this] {
    const int row = pulses_->currentRow();
    if (row < 0) return;
    doc_->edit("Delete pulse", [&](scenario::Scenario& s) { s.pulses.erase(s.pulses.begin() + row); });
  });
  form->addRow(delete_pulse_);
  return box;
}

QWidget* AuthoringPanel::build_paint() {
  auto* box = new QGroupBox("Paint tissue");
  auto* form = new QFormLayout(box);
  paint_tool_ = tool_button("paintTool", "Paint",
                            "Press and drag on the organ to paint a tissue or a stiffness scale with the brush "
                            "(or to erase painted strokes)");
  connect(paint_tool_, &QToolButton::toggled, this, [this](bool on) {
    if (!syncing_) tools_->set_tool(on ? AuthoringTool::Paint : AuthoringTool::None);
  });
  form->addRow(paint_tool_);
  const AuthoringDefaults d;
  brush_radius_ = spin("brushRadius", 1, 100, 1, 1, " mm", "Brush radius, mm");
  brush_feather_ = spin("brushFeather", 0, 50, 1, 1, " mm", "Width of the brush's soft edge, mm (0: hard edge)");
  brush_tissue_ = new QComboBox;
  brush_tissue_->setObjectName("brushTissue");
  brush_tissue_->setToolTip("What the brush paints: a tissue preset (kPa), or a scale of the modulus below");
  brush_tissue_->addItem("Modulus scale", QString());
  fill_presets(brush_tissue_);
  brush_scale_ = spin("brushScale", 0.05, 100, 0.5, 2, " x",
                      "Modulus scale the brush paints (2: twice as stiff as the tissue below)");
  brush_erase_ = new QCheckBox("Erase");
  brush_erase_->setObjectName("brushErase");
  brush_erase_->setToolTip("The brush removes painted strokes it touches");
  brush_radius_->setValue(d.brush_radius / kMm);
  brush_feather_->setValue(d.brush_feather / kMm);
  brush_scale_->setValue(d.brush_scale);
  form->addRow("Brush radius", brush_radius_);
  form->addRow("Feather", brush_feather_);
  form->addRow("Paints", brush_tissue_);
  form->addRow("Modulus scale", brush_scale_);
  form->addRow(brush_erase_);
  for (QDoubleSpinBox* s : {brush_radius_, brush_feather_, brush_scale_})
    connect(s, qOverload<double>(&QDoubleSpinBox::valueChanged), this, &AuthoringPanel::read_defaults);
  connect(brush_tissue_, qOverload<int>(&QComboBox::currentIndexChanged), this, &AuthoringPanel::read_defaults);
  connect(brush_erase_, &QCheckBox::toggled, this, &AuthoringPanel::read_defaults);
  return box;
}

// ---------------------------------------------------------------------------
void AuthoringPanel::read_defaults() {
  AuthoringDefaults& d = tools_->defaults();
  d.lesion_depth = new_depth_->value() * kMm;
  d.lesion_radius = new_radius_->value() * kMm;
  d.lesion_ratio = new_ratio_->value();
  d.lesion_visibility = static_cast<tissue::Visibility>(std::max(0, new_visibility_->currentIndex()));
  if (pulse_rate_) {
    d.pulse_rate_bpm = pulse_rate_->value();
    d.pulse_amplitude = pulse_amplitude_->value() * kMm;
    d.pulse_radius = pulse_radius_->value() * kMm;
  }
  if (brush_radius_) {
    d.brush_radius = brush_radius_->value() * kMm;
    d.brush_feather = brush_feather_->value() * kMm;
    d.brush_tissue = brush_tissue_->currentData().toString().toStdString();
    d.brush_scale = brush_scale_->value();
    d.brush_erase = brush_erase_->isChecked();
    brush_scale_->setEnabled(d.brush_tissue.empty());
  }
}

void AuthoringPanel::sync_tools() {
  const bool was = syncing_;
  syncing_ = true;
  place_tool_->setChecked(tools_->tool() == AuthoringTool::PlaceLesion);
  pulse_tool_->setChecked(tools_->tool() == AuthoringTool::DrawPulse);
  paint_tool_->setChecked(tools_->tool() == AuthoringTool::Paint);
  syncing_ = was;
}

void AuthoringPanel::sync() {
  syncing_ = true;
  const bool has = doc_->has_scenario();
  hint_->setVisible(!has);
  body_->setEnabled(has);
  if (has) {
    const scenario::Scenario& s = doc_->scenario();
    title_->setText(QString::fromStdString(s.title));
    // The base tissue's preset (none: the first entry is shown, unselected).
    int base = -1;
    for (std::size_t k = 0; k < s.tissues.size(); ++k)
      if (s.tissues[k].name == s.base_tissue && k < s.tissue_presets.size())
        base = base_tissue_->findData(QString::fromStdString(s.tissue_presets[k]));
    base_tissue_->setCurrentIndex(base);
    base_tissue_->setToolTip(QString("The base tissue '%1' (%2 kPa); pick a preset to change it")
                                 .arg(QString::fromStdString(s.base_tissue))
                                 .arg([&] {
                                   for (const auto& t : s.tissues)
                                     if (t.name == s.base_tissue) return t.youngs_modulus * 1e-3;
                                   return 0.0;
                                 }()));

    lesions_->setRowCount(static_cast<int>(s.lesions.size()));
    for (int row = 0; row < static_cast<int>(s.lesions.size()); ++row) {
      const scenario::LesionSpec& l = s.lesions[static_cast<std::size_t>(row)];
      auto set = [&](int col, const QString& text, bool editable, const QString& tip) {
        auto* item = new QTableWidgetItem(text);
        if (!editable) item->setFlags(item->flags() & ~Qt::ItemIsEditable);
        item->setToolTip(tip);
        lesions_->setItem(row, col, item);
      };
      const bool sphere = l.lesion.semi_axes.minCoeff() == l.lesion.semi_axes.maxCoeff();
      set(Name, QString::fromStdString(l.lesion.name), true, "The lesion's name");
      set(Depth, l.from_surface ? QString::number(l.depth / kMm, 'g', 6) : QString("(centre)"), l.from_surface,
          l.from_surface ? "Depth of the centre below its surface point, mm"
                         : "Given by its centre: no surface point and depth");
      set(Radius, QString::number(l.lesion.semi_axes.maxCoeff() / kMm, 'g', 6), true,
          sphere ? "Radius, mm" : "Largest semi-axis, mm (an edit makes it a sphere of this radius)");
      set(Ratio, QString::number(l.lesion.modulus_ratio, 'g', 6), true,
          "Modulus ratio: the lesion's Young's modulus over the surrounding tissue's");
      auto* vis = visibility_box("", "Whether the lesion is drawn: hidden (felt only), shown, or after the exam");
      vis->setObjectName(QString("lesionVisibility%1").arg(row));
      vis->setCurrentIndex(static_cast<int>(l.lesion.visibility));
      connect(vis, qOverload<int>(&QComboBox::activated), this, [this, row](int index) {
        doc_->edit("Edit lesion", [&](scenario::Scenario& sc) {
          sc.lesions.at(static_cast<std::size_t>(row)).lesion.visibility = static_cast<tissue::Visibility>(index);
        });
      });
      lesions_->setCellWidget(row, Shown, vis);
    }
    if (tools_->selected() >= 0 && tools_->selected() < lesions_->rowCount()) lesions_->selectRow(tools_->selected());
    delete_lesion_->setEnabled(tools_->selected() >= 0);

    const scenario::Task& t = s.task;
    if (!instructions_->hasFocus()) instructions_->setPlainText(QString::fromStdString(t.instructions));
    time_limit_->setValue(t.time_limit);
    report_position_->setChecked(t.report.position);
    report_size_->setChecked(t.report.size);
    report_consistency_->setChecked(t.report.consistency);
    force_limit_->setValue(t.force_limit);
    pass_score_->setValue(t.scoring.pass_score * 100);
    position_tolerance_->setValue(t.scoring.position_tolerance / kMm);

    breathing_on_->setChecked(s.breathing.enabled);
    breathing_rate_->setValue(s.breathing.rate_bpm);
    breathing_amplitude_->setValue(s.breathing.translation.norm() / kMm);
    breathing_rate_->setEnabled(s.breathing.enabled);
    breathing_amplitude_->setEnabled(s.breathing.enabled);

    const int row = pulses_->currentRow();
    pulses_->clear();
    for (const tissue::Pulse& p : s.pulses)
      pulses_->addItem(QString("%1: %2 points, %3 bpm, %4 mm")
                           .arg(QString::fromStdString(p.name))
                           .arg(p.path.size())
                           .arg(p.rate_bpm)
                           .arg(p.amplitude / kMm));
    if (row >= 0 && row < pulses_->count()) pulses_->setCurrentRow(row);
    delete_pulse_->setEnabled(pulses_->currentRow() >= 0);
  } else {
    lesions_->setRowCount(0);
    pulses_->clear();
  }
  syncing_ = false;
  sync_tools();
}

// ---------------------------------------------------------------------------
// Edits.
void AuthoringPanel::edit_lesion_cell(int row, int column) {
  if (syncing_ || !doc_->has_scenario()) return;
  const QTableWidgetItem* item = lesions_->item(row, column);
  if (!item) return;
  const QString text = item->text().trimmed();
  bool ok = true;
  const double value = column == Name ? 0.0 : text.toDouble(&ok);
  QString error;
  if (!ok) {
    error = QString("Edit lesion refused: '%1' is not a number").arg(text);
    emit doc_->error(error);
  } else {
    error = doc_->edit("Edit lesion", [&](scenario::Scenario& s) {
      scenario::LesionSpec& l = s.lesions.at(static_cast<std::size_t>(row));
      switch (column) {
        case Name: l.lesion.name = text.toStdString(); break;
        case Depth: l.depth = value * kMm; break;
        case Radius: l.lesion.semi_axes = Vec3::Constant(value * kMm); break;
        case Ratio: l.lesion.modulus_ratio = value; break;
        default: break;
      }
    });
  }
  if (!error.isEmpty()) sync();  // the document as it is
}

void AuthoringPanel::edit_task() {
  if (syncing_) return;
  const double time_limit = time_limit_->value(), force_limit = force_limit_->value();
  const double pass = pass_score_->value() / 100, tolerance = position_tolerance_->value() * kMm;
  const scenario::ReportFields report{report_position_->isChecked(), report_size_->isChecked(),
                                      report_consistency_->isChecked()};
  if (doc_->edit("Edit task", [&](scenario::Scenario& s) {
        s.task.time_limit = time_limit;
        s.task.force_limit = force_limit;
        s.task.report = report;
        s.task.scoring.pass_score = pass;
        s.task.scoring.position_tolerance = tolerance;
      }).size())
    sync();
}

void AuthoringPanel::commit_instructions() {
  if (syncing_ || !doc_->has_scenario()) return;
  const std::string text = instructions_->toPlainText().toStdString();
  if (text == doc_->scenario().task.instructions) return;
  if (doc_->edit("Edit task", [&](scenario::Scenario& s) { s.task.instructions = text; }).size()) sync();
}

bool AuthoringPanel::eventFilter(QObject* watched, QEvent* event) {
  if (watched == instructions_ && event->type() == QEvent::FocusOut) commit_instructions();
  return QWidget::eventFilter(watched, event);
}

void AuthoringPanel::edit_breathing() {
  if (syncing_) return;
  const bool on = breathing_on_->isChecked();
  const double rate = breathing_rate_->value(), amplitude = breathing_amplitude_->value() * kMm;
  if (doc_->edit("Set breathing", [&](scenario::Scenario& s) {
        tissue::Breathing& b = s.breathing;
        b.enabled = on;
        b.rate_bpm = rate;
        const Vec3 dir = b.translation.norm() > 0 ? Vec3(b.translation.normalized()) : Vec3::UnitZ();
        b.translation = amplitude * dir;
      }).size())
    sync();
  breathing_rate_->setEnabled(breathing_on_->isChecked());
  breathing_amplitude_->setEnabled(breathing_on_->isChecked());
}

void AuthoringPanel::edit_pulse() {
  if (syncing_) return;
  read_defaults();
  const int row = pulses_->currentRow();
  if (row < 0 || !doc_->has_scenario()) return;  // the values are for the next pulse drawn
  const AuthoringDefaults d = tools_->defaults();
  if (doc_->edit("Edit pulse", [&](scenario::Scenario& s) {
        tissue::Pulse& p = s.pulses.at(static_cast<std::size_t>(row));
        p.rate_bpm = d.pulse_rate_bpm;
        p.amplitude = d.pulse_amplitude;
        p.radius = d.pulse_radius;
      }).size())
    sync();
}

}  // namespace palpa::app
