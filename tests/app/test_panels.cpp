// The window's parts on their own, without a MainWindow: the material panel
// shows MaterialSettings and gives them back in SI, an edit says so with the
// new value, a preset fills in its tissue, its settings keys are those the
// window always used; the probe panel lists probes and says what the user
// asked for; the readouts show the selected probe; the probe tool presses,
// drags and wheels a mouse probe as the window did, through an injected pick.
// (main() is test_main_window.cpp's: a QApplication under Xvfb.)

#include "app/gui/material_panel.h"
#include "app/gui/probe_panel.h"
#include "app/gui/probe_tool.h"
#include "app/gui/readouts_panel.h"
#include "common/test_support.h"
#include "mesh/generate.h"

#include <QComboBox>
#include <QDoubleSpinBox>
#include <QGroupBox>
#include <QLabel>
#include <QListWidget>
#include <QMouseEvent>
#include <QPushButton>
#include <QSettings>
#include <QWheelEvent>

#include <optional>
#include <vector>

namespace palpa::app {
namespace {

// Values the panel's spin boxes show exactly (their decimals).
MaterialSettings edited_settings() {
  MaterialSettings m;
  m.law = MaterialLaw::Linear;
  m.tissue.name = "custom";
  m.tissue.youngs_modulus = 12.5e3;
  m.tissue.poisson = 0.45;
  m.tissue.damping_ratio = 0.8;
  m.tissue.relaxation_time = 1.5;
  m.tissue.relaxation_fraction = 0.25;
  m.tissue.stiffening = 20.0;  // 1/m: 0.020 /mm
  m.tip_radius = 0.005;
  m.model = deform::LocalModelKind::Exponential;
  m.shape = deform::ShapeKind::Gaussian;
  m.stiffness = 350;
  m.damping = 3.5;
  m.mass = 0.002;
  m.radius = 0.03;
  m.friction = 0.3;
  m.max_force = 6.5;
  return m;
}

void expect_same(const MaterialSettings& a, const MaterialSettings& b) {
  EXPECT_EQ(a.law, b.law);
  EXPECT_EQ(a.tissue.name, b.tissue.name);
  EXPECT_NEAR(a.tissue.youngs_modulus, b.tissue.youngs_modulus, 1e-6);
  EXPECT_NEAR(a.tissue.poisson, b.tissue.poisson, 1e-9);
  EXPECT_NEAR(a.tissue.damping_ratio, b.tissue.damping_ratio, 1e-9);
  EXPECT_NEAR(a.tissue.relaxation_time, b.tissue.relaxation_time, 1e-9);
  EXPECT_NEAR(a.tissue.relaxation_fraction, b.tissue.relaxation_fraction, 1e-9);
  EXPECT_NEAR(a.tissue.stiffening, b.tissue.stiffening, 1e-9);
  EXPECT_NEAR(a.tip_radius, b.tip_radius, 1e-12);
  EXPECT_EQ(a.model, b.model);
  EXPECT_EQ(a.shape, b.shape);
  EXPECT_NEAR(a.stiffness, b.stiffness, 1e-9);
  EXPECT_NEAR(a.damping, b.damping, 1e-9);
  EXPECT_NEAR(a.mass, b.mass, 1e-12);
  EXPECT_NEAR(a.radius, b.radius, 1e-12);
  EXPECT_NEAR(a.friction, b.friction, 1e-9);
  EXPECT_NEAR(a.max_force, b.max_force, 1e-9);
}

TEST(MaterialPanelTest, ShowsSettingsAndGivesThemBackWithoutAnEdit) {
  MaterialPanel panel;
  int edits = 0;
  QObject::connect(&panel, &MaterialPanel::edited, [&](const MaterialSettings&) { ++edits; });
  expect_same(panel.settings(), [] {
    MaterialSettings d;
    d.tissue.name = "custom";  // no preset shown
    return d;
  }());
  const MaterialSettings m = edited_settings();
  panel.set_settings(m);
  expect_same(panel.settings(), m);
  EXPECT_EQ(edits, 0);
  // The linear law: the tissue's controls are off.
  EXPECT_FALSE(panel.findChild<QDoubleSpinBox*>("youngsModulus")->isEnabled());
  EXPECT_TRUE(panel.findChild<QGroupBox*>("linearModel")->isChecked());
}

TEST(MaterialPanelTest, AnEditSaysSoWithTheNewValueInSI) {
  MaterialPanel panel;
  std::vector<MaterialSettings> edits;
  QObject::connect(&panel, &MaterialPanel::edited, [&](const MaterialSettings& m) { edits.push_back(m); });
  panel.findChild<QDoubleSpinBox*>("youngsModulus")->setValue(20.0);  // kPa
  ASSERT_EQ(edits.size(), 1u);
  EXPECT_NEAR(edits[0].tissue.youngs_modulus, 20e3, 1e-6);
  EXPECT_EQ(edits[0].law, MaterialLaw::Hertz);
  panel.findChild<QDoubleSpinBox*>("tipRadius")->setValue(4.0);  // mm
  ASSERT_EQ(edits.size(), 2u);
  EXPECT_NEAR(edits[1].tip_radius, 0.004, 1e-12);
  panel.findChild<QDoubleSpinBox*>("maxForce")->setValue(3.0);  // N
  ASSERT_EQ(edits.size(), 3u);
  EXPECT_NEAR(edits[2].max_force, 3.0, 1e-12);
  panel.findChild<QGroupBox*>("linearModel")->setChecked(true);
  ASSERT_EQ(edits.size(), 4u);
  EXPECT_EQ(edits[3].law, MaterialLaw::Linear);
  EXPECT_FALSE(panel.findChild<QDoubleSpinBox*>("youngsModulus")->isEnabled());
}

TEST(MaterialPanelTest, APresetFillsInItsTissueAndAnEditMakesItCustom) {
  if (tissue::presets().empty()) GTEST_SKIP() << "no presets";
  const tissue::Preset& p = tissue::presets().front();
  MaterialPanel panel;
  std::vector<MaterialSettings> edits;
  QObject::connect(&panel, &MaterialPanel::edited, [&](const MaterialSettings& m) { edits.push_back(m); });
  auto* box = panel.findChild<QComboBox*>("presetBox");
  box->setCurrentIndex(box->findData(QString::fromStdString(p.key)));
  ASSERT_EQ(edits.size(), 1u);
  EXPECT_EQ(edits[0].tissue.source, p.tissue.source);
  EXPECT_NEAR(edits[0].tissue.youngs_modulus, p.tissue.youngs_modulus, 1e-6 * p.tissue.youngs_modulus);
  EXPECT_EQ(panel.preset_key(), p.key);
  auto* e = panel.findChild<QDoubleSpinBox*>("youngsModulus");
  e->setValue(e->value() + 1.0);
  ASSERT_EQ(edits.size(), 2u);
  EXPECT_EQ(edits[1].tissue.name, "custom");
  EXPECT_TRUE(edits[1].tissue.source.empty());
  EXPECT_EQ(box->currentIndex(), 0);
  EXPECT_EQ(panel.preset_key(), "");
}

TEST(MaterialPanelTest, KeepsItsKeysInTheSettings) {
  const auto dir = test::temp_dir("material_panel_settings");
  const QString file = QString::fromStdString((dir / "palpa.ini").string());
  const MaterialSettings m = edited_settings();
  {
    MaterialPanel panel;
    panel.set_settings(m);
    QSettings s(file, QSettings::IniFormat);
    panel.save(s);
  }
  QSettings s(file, QSettings::IniFormat);
  // The keys the window has always written (users' settings carry over).
  EXPECT_DOUBLE_EQ(s.value("tissue/youngs_modulus_kpa").toDouble(), 12.5);
  EXPECT_DOUBLE_EQ(s.value("tissue/tip_radius_mm").toDouble(), 5.0);
  EXPECT_TRUE(s.value("tissue/advanced_linear").toBool());
  EXPECT_DOUBLE_EQ(s.value("material/mass_g").toDouble(), 2.0);
  EXPECT_DOUBLE_EQ(s.value("material/radius_mm").toDouble(), 30.0);
  EXPECT_EQ(s.value("material/shape").toInt(), 0);
  MaterialPanel other;
  int edits = 0;
  QObject::connect(&other, &MaterialPanel::edited, [&](const MaterialSettings&) { ++edits; });
  other.load(s);
  expect_same(other.settings(), m);
  EXPECT_EQ(edits, 0);
}

TEST(MaterialPanelTest, TheScenarioNoteAndRestoreButtonShowWhenAsked) {
  MaterialPanel panel;
  panel.show();
  auto* note = panel.findChild<QLabel*>("scenarioMaterialNote");
  auto* restore = panel.findChild<QPushButton*>("restoreTissueMap");
  EXPECT_FALSE(note->isVisible());
  EXPECT_FALSE(restore->isVisible());
  panel.set_scenario_note("a note");
  panel.set_restore_visible(true);
  EXPECT_TRUE(note->isVisible());
  EXPECT_EQ(note->text(), "a note");
  EXPECT_TRUE(restore->isVisible());
  int restores = 0;
  QObject::connect(&panel, &MaterialPanel::restore_requested, [&] { ++restores; });
  restore->click();
  EXPECT_EQ(restores, 1);
  panel.set_scenario_note(QString());
  EXPECT_FALSE(note->isVisible());
}

std::vector<Probe> two_probes() {
  std::vector<Probe> probes(2);
  probes[0].id = 1;
  probes[1].id = 3;
  probes[1].device = "scripted";
  probes[1].host_fed = false;
  return probes;
}

TEST(ProbePanelTest, ListsTheProbesAndSaysWhatTheUserAskedFor) {
  ProbePanel panel;
  std::vector<int> selected, removed;
  int adds = 0;
  QObject::connect(&panel, &ProbePanel::selected, [&](int id) { selected.push_back(id); });
  QObject::connect(&panel, &ProbePanel::remove_requested, [&](int id) { removed.push_back(id); });
  QObject::connect(&panel, &ProbePanel::add_requested, [&] { ++adds; });
  panel.refresh(two_probes(), 3);
  auto* list = panel.findChild<QListWidget*>("probeList");
  ASSERT_EQ(list->count(), 2);
  EXPECT_EQ(list->item(0)->text(), "Probe 1");
  EXPECT_EQ(list->item(1)->text(), "Probe 3 (scripted)");
  EXPECT_EQ(list->currentRow(), 1);
  EXPECT_EQ(panel.current_id(), 3);
  EXPECT_TRUE(selected.empty());  // a refresh is not the user's choice
  list->setCurrentRow(0);
  EXPECT_EQ(selected, std::vector<int>{1});
  panel.findChild<QPushButton*>("removeProbe")->click();
  EXPECT_EQ(removed, std::vector<int>{1});
  panel.findChild<QPushButton*>("addProbe")->click();
  EXPECT_EQ(adds, 1);
}

TEST(ReadoutsPanelTest, ShowsTheSelectedProbe) {
  ReadoutsPanel panel;
  std::vector<Probe> probes = two_probes();
  probes[0].placed = true;
  probes[0].output.force = Vec3(3, 4, 0);
  probes[0].output.in_contact = true;
  probes[0].output.depth = 0.0042;
  panel.update(probes, 1, 1.0, 8.0);
  EXPECT_EQ(panel.findChild<QLabel*>("forceReadout")->text(), "5.00 N");
  EXPECT_EQ(panel.findChild<QLabel*>("depthReadout")->text(), "4.2 mm");
  EXPECT_FALSE(panel.findChild<QPushButton*>("reenableDevice")->isEnabled());
  panel.update(probes, 0, 1.1, 8.0);
  EXPECT_EQ(panel.findChild<QLabel*>("forceReadout")->text(), "-");
  panel.set_warnings("late ticks", "notice");
  EXPECT_EQ(panel.warnings_text(), "late ticks");
}

mesh::Organ sphere_organ() {
  mesh::Organ o;
  o.name = "sphere";
  auto m = std::make_shared<mesh::SurfaceMesh>(mesh::make_sphere(2000, 0.05));
  o.mesh = m;
  o.facts = mesh::analyse(*m);
  return o;
}

TEST(ProbeToolTest, APressAndDragDownPressesTheMouseProbeIn) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  // The pick: the top of the sphere wherever the press is, nothing left of x = 10.
  ProbeTool tool(
      wb,
      [](const QPoint& pos, Vec3& rest, Vec3& normal, Vec3& drawn) {
        if (pos.x() < 10) return false;
        rest = drawn = Vec3(0, 0, 0.05);
        normal = Vec3::UnitZ();
        return true;
      },
      [] { return false; });
  std::vector<int> selected, added;
  QObject::connect(&tool, &ProbeTool::probeSelected, [&](int id) { selected.push_back(id); });
  QObject::connect(&tool, &ProbeTool::probeAdded, [&](int id) { added.push_back(id); });

  QMouseEvent off(QEvent::MouseButtonPress, QPointF(5, 100), Qt::LeftButton, Qt::LeftButton, Qt::NoModifier);
  EXPECT_FALSE(tool.handle(&off));  // off the organ: VTK rotates
  EXPECT_TRUE(wb.probes().empty());

  QMouseEvent press(QEvent::MouseButtonPress, QPointF(100, 100), Qt::LeftButton, Qt::LeftButton, Qt::NoModifier);
  EXPECT_TRUE(tool.handle(&press));
  ASSERT_EQ(added.size(), 1u);  // no mouse probe yet: a new one
  EXPECT_EQ(selected, added);
  ASSERT_TRUE(wb.selected_probe());
  EXPECT_EQ(wb.selected_id(), added[0]);
  EXPECT_TRUE(wb.selected_probe()->placed);
  EXPECT_EQ(wb.selected_probe()->depth, 0.0);
  EXPECT_TRUE(tool.pressing());

  QMouseEvent drag(QEvent::MouseMove, QPointF(100, 140), Qt::NoButton, Qt::LeftButton, Qt::NoModifier);
  EXPECT_TRUE(tool.handle(&drag));
  EXPECT_NEAR(wb.selected_probe()->depth, 40 * ProbeTool::kDepthPerPixel, 1e-12);

  QWheelEvent wheel(QPointF(100, 140), QPointF(100, 140), QPoint(), QPoint(0, 120), Qt::LeftButton, Qt::NoModifier,
                    Qt::NoScrollPhase, false);
  EXPECT_TRUE(tool.handle(&wheel));
  EXPECT_NEAR(wb.selected_probe()->depth, 40 * ProbeTool::kDepthPerPixel + ProbeTool::kDepthPerWheelStep, 1e-12);

  // Held by default; without hold the release lifts the probe.
  tool.set_hold(false);
  QMouseEvent release(QEvent::MouseButtonRelease, QPointF(100, 140), Qt::LeftButton, Qt::NoButton, Qt::NoModifier);
  EXPECT_TRUE(tool.handle(&release));
  EXPECT_FALSE(tool.pressing());
  EXPECT_EQ(wb.selected_probe()->depth, 0.0);

  // A second press takes the same mouse probe.
  EXPECT_TRUE(tool.handle(&press));
  EXPECT_EQ(added.size(), 1u);
  EXPECT_EQ(wb.probes().size(), 1u);
}

TEST(ProbeToolTest, HoverSaysWhereAPressWouldTouch) {
  Workbench wb;
  wb.set_organ(sphere_organ());
  bool suspended = false;
  ProbeTool tool(
      wb,
      [](const QPoint& pos, Vec3& rest, Vec3& normal, Vec3& drawn) {
        if (pos.x() < 10) return false;
        rest = drawn = Vec3(0, 0, 0.05);
        normal = Vec3::UnitZ();
        return true;
      },
      [&] { return suspended; });
  std::optional<bool> shown;
  Vec3 where = Vec3::Zero();
  QObject::connect(&tool, &ProbeTool::hover, [&](bool s, const Vec3& p, const Vec3&) {
    shown = s;
    where = p;
  });
  QMouseEvent over(QEvent::MouseMove, QPointF(100, 100), Qt::NoButton, Qt::NoButton, Qt::NoModifier);
  EXPECT_FALSE(tool.handle(&over));  // VTK sees moves too
  ASSERT_TRUE(shown);
  EXPECT_TRUE(*shown);
  EXPECT_NEAR(where.z(), 0.05, 1e-12);
  QMouseEvent away(QEvent::MouseMove, QPointF(5, 100), Qt::NoButton, Qt::NoButton, Qt::NoModifier);
  tool.handle(&away);
  EXPECT_FALSE(*shown);
  // During a replay a press goes on to VTK.
  suspended = true;
  QMouseEvent press(QEvent::MouseButtonPress, QPointF(100, 100), Qt::LeftButton, Qt::LeftButton, Qt::NoModifier);
  EXPECT_FALSE(tool.handle(&press));
  EXPECT_TRUE(wb.probes().empty());
}

}  // namespace
}  // namespace palpa::app
