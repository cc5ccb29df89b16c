// The workbench window under a real X server (Xvfb, started for each test by
// xvfb_run.sh): it opens on the default organ and draws it, a mouse
// press-and-drag on the organ makes a contact with a force through the
// real-time haptic loop, a scripted device probe drives a contact, bad files
// and bad devices show an error and keep the scene, the kPa material panel
// reaches the loop as the Hertz material, scenarios open (menu, drop, recent)
// with their task and title, a bad one keeps the scene, hidden lesions are
// never drawn, a breathing organ is drawn where it is, and the rest of the
// window's promises. The loop runs on its own threads: the tests wait for
// conditions with a timeout and never assert wall-time figures.

#include "app/gui/force_plot.h"
#include "app/gui/main_window.h"
#include "haptics/safety.h"
#include "common/test_support.h"
#include "gui_wait.h"
#include "mesh/generate.h"
#include "mesh/io.h"
#include "mesh/organ.h"
#include "render/surface_view.h"
#include "scenario/scenario.h"
#include "tissue/tissue.h"

#include <vtkActor.h>
#include <vtkProperty.h>
#include <vtkMatrix4x4.h>

#include <QAction>
#include <QApplication>
#include <QComboBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QFileInfo>
#include <QGroupBox>
#include <QPushButton>
#include <QDropEvent>
#include <QLabel>
#include <QMimeData>
#include <QMouseEvent>
#include <QSettings>
#include <QTest>
#include <QUrl>
#include <QVTKOpenGLNativeWidget.h>

#include <QListWidget>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <optional>

#include <unistd.h>

namespace palpa::app {
namespace {

// Skips (saying why) when the test binary runs without an X display.
class MainWindowTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!qApp)
      GTEST_SKIP() << "no X display: these tests run under tests/app/xvfb_run.sh, which ctest uses for them";
  }

  // A shown window that has drawn a few frames. Tall enough that the Task
  // dock of a scenario does not make it grow (the camera is framed on the
  // viewport of the moment: a later growth would change the picture).
  std::unique_ptr<MainWindow> open_window() {
    auto w = std::make_unique<MainWindow>();
    w->resize(1100, 820);
    w->show();
    EXPECT_TRUE(QTest::qWaitForWindowExposed(w.get()));
    QTest::qWait(200);
    return w;
  }

  // A viewport position (logical pixels) on the organ, near the centre.
  static std::optional<QPoint> point_on_organ(MainWindow& w) {
    auto* vp = w.viewport();
    const double dpr = vp->devicePixelRatioF();
    for (int r = 0; r < 200; r += 10)
      for (int dx : {0, r, -r})
        for (int dy : {0, r, -r}) {
          const QPoint p(vp->width() / 2 + dx, vp->height() / 2 + dy);
          if (w.surface_view()->pick(w.renderer(), (p.x() + 0.5) * dpr, (vp->height() - p.y() - 0.5) * dpr))
            return p;
        }
    return std::nullopt;
  }

  // Lets the event loop run until `done` holds or `timeout_ms` passes.
  static bool wait_until(const std::function<bool()>& done, int timeout_ms = 20000) {
    return gui_test::wait_until(done, timeout_ms);
  }

  static void drag(QWidget* vp, QPoint from, QPoint to, int steps) {
    for (int i = 1; i <= steps; ++i) {
      const QPoint p = from + (to - from) * i / steps;
      QMouseEvent move(QEvent::MouseMove, p, vp->mapToGlobal(p), Qt::NoButton, Qt::LeftButton, Qt::NoModifier);
      QApplication::sendEvent(vp, &move);
      QTest::qWait(20);
    }
  }
};

TEST_F(MainWindowTest, OpensOnTheDefaultOrganAndDrawsIt) {
  auto w = open_window();
  const mesh::Organ expected = mesh::load_default_organ();
  ASSERT_TRUE(w->workbench().has_organ());
  EXPECT_EQ(w->workbench().organ().mesh->vertex_count(), expected.mesh->vertex_count());
  EXPECT_TRUE(w->facts_text().contains(QString::number(expected.mesh->vertex_count()) + " vertices"))
      << w->facts_text().toStdString();
  EXPECT_TRUE(w->facts_text().contains("closed")) << w->facts_text().toStdString();
  EXPECT_TRUE(w->error_text().isEmpty()) << w->error_text().toStdString();
  // The organ is drawn: the pixel under a point on it is not the background.
  const auto p = point_on_organ(*w);
  ASSERT_TRUE(p.has_value());
  const QImage img = w->viewport()->grabFramebuffer();
  const QImage corner = img.copy(0, 0, 4, 4);
  const double dpr = w->viewport()->devicePixelRatioF();
  const QColor organ = img.pixelColor(static_cast<int>(p->x() * dpr), static_cast<int>(p->y() * dpr));
  const QColor background = corner.pixelColor(1, 1);
  EXPECT_GT(std::abs(organ.red() - background.red()) + std::abs(organ.green() - background.green()), 60);
  // Frames and haptic ticks run (their rates are measured, not asserted:
  // tests never assert wall time). The haptic rate is the loop's own. An
  // idle window draws nothing, so its frame rate may fall to 0 once the
  // first second is over: frames are asked for (advance() draws, as a
  // changing scene does) until the rate of a second holds some.
  ASSERT_NE(w->workbench().loop(), nullptr);
  EXPECT_TRUE(w->workbench().loop()->running());
  EXPECT_TRUE(wait_until([&] {
    w->advance();
    return w->frame_rate() > 0 && w->haptic_rate() > 0;
  }));
  EXPECT_TRUE(wait_until([&] { return w->findChild<QLabel*>("hapticRateReadout")->text() != "0 Hz"; }));
}

TEST_F(MainWindowTest, PressAndDragOnTheOrganMakesAContactWithForce) {
  auto w = open_window();
  auto* vp = w->viewport();
  const auto p = point_on_organ(*w);
  ASSERT_TRUE(p.has_value());
  const QImage before = vp->grabFramebuffer();
  QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, *p);
  drag(vp, *p, *p + QPoint(0, 80), 8);  // 80 px down = 4 mm
  const Probe* probe = w->workbench().selected_probe();
  ASSERT_NE(probe, nullptr);
  EXPECT_TRUE(probe->placed);
  EXPECT_TRUE(probe->host_fed) << "the mouse probe is a `mouse` device the window feeds";
  EXPECT_NEAR(probe->depth, 0.004, 1e-9);
  // The loop computes the contact and its force.
  EXPECT_TRUE(wait_until([&] {
    probe = w->workbench().selected_probe();
    return probe->output.in_contact && probe->output.force.norm() > 0.05 &&
           w->force_plot()->sample_count(probe->id) > 5 && w->surface_view()->max_displacement() > 1e-4;
  }));
  EXPECT_TRUE(probe->output.in_contact);
  EXPECT_GT(probe->output.force.norm(), 0.05);
  EXPECT_GT(probe->output.force.dot(probe->normal), 0.0) << "the organ pushes the probe out";
  EXPECT_NE(w->findChild<QLabel*>("forceReadout")->text(), "0.00 N");
  EXPECT_EQ(w->findChild<QLabel*>("depthReadout")->text(), "4.0 mm");
  EXPECT_GT(w->force_plot()->sample_count(probe->id), 5u);
  // The dent is drawn.
  const QImage after = vp->grabFramebuffer();
  EXPECT_NE(before, after);
  // PALPA_TEST_SCREENSHOTS=DIR keeps a picture of the whole window for people.
  if (const char* dir = std::getenv("PALPA_TEST_SCREENSHOTS"); dir && *dir)
    w->grab().save(QString(dir) + "/workbench_pressing.png");
  // Released with "hold" on: the indentation stays.
  QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, *p + QPoint(0, 80));
  QTest::qWait(200);
  QTest::qWait(200);
  EXPECT_TRUE(w->workbench().selected_probe()->output.in_contact);
}

TEST_F(MainWindowTest, AScriptedDeviceProbeDrivesAContact) {
  auto w = open_window();
  const auto& mesh = *w->workbench().organ().mesh;
  const Vec3 p0 = mesh.positions[0];
  const Vec3 n0 = mesh.normals[0].normalized();
  const Vec3 above = p0 + 0.01 * n0, inside = p0 - 0.004 * n0;
  // A small trajectory: from 1 cm outside vertex 0 to 4 mm inside, then held.
  const auto file = palpa::test::temp_dir("gui_scripted") / "press.csv";
  {
    std::ofstream f(file);
    f.precision(17);
    f << "# press vertex 0 of the default organ\nt,x,y,z,buttons\n";
    f << "0," << above.x() << "," << above.y() << "," << above.z() << ",0\n";
    f << "0.2," << inside.x() << "," << inside.y() << "," << inside.z() << ",0\n";
    f << "1000," << inside.x() << "," << inside.y() << "," << inside.z() << ",0\n";
  }
  const std::size_t before = w->workbench().probes().size();
  ASSERT_TRUE(w->add_device_probe("scripted", QString::fromStdString("file=" + file.string())))
      << w->error_text().toStdString();
  EXPECT_TRUE(w->error_text().isEmpty());
  ASSERT_EQ(w->workbench().probes().size(), before + 1);
  EXPECT_EQ(w->findChild<QListWidget*>("probeList")->count(), static_cast<int>(before + 1));
  const int id = w->workbench().selected_id();
  const Probe* probe = w->workbench().probe(id);
  ASSERT_NE(probe, nullptr);
  EXPECT_EQ(probe->device, "scripted");
  // The device drives the probe into the organ: contact, force along the normal, a dent drawn.
  // Under the sanitizers (TSan; ASan under load) the loop runs several times slower than its
  // deadlines, and the safety chain rightly holds the force at zero while the
  // loop or the model is late: there the test accepts a held force only when
  // the flags say the watchdog held it.
  using gui_test::kSlowBuild;
  const std::uint32_t late = haptics::kSafetyLoopLate | haptics::kSafetyModelLate;
  bool held_late = false;
  EXPECT_TRUE(wait_until([&] {
    probe = w->workbench().probe(id);
    const bool pressed = probe->output.in_contact && probe->output.depth > 0.003 &&
                         w->surface_view()->max_displacement() > 1e-4;
    held_late = kSlowBuild && (probe->output.flags & late) != 0 && probe->output.force.isZero();
    return pressed && (probe->output.force.dot(n0) > 0.05 || held_late);
  })) << "force " << probe->output.force.transpose() << ", depth " << probe->output.depth << " m, in contact "
      << probe->output.in_contact << ", safety flags 0x" << std::hex << probe->output.flags;
  if (!held_late) {
    EXPECT_NE(w->findChild<QLabel*>("forceReadout")->text(), "0.00 N");
  }
  EXPECT_TRUE(w->device_status_text().startsWith("scripted")) << w->device_status_text().toStdString();
  // Removing it releases the contact.
  w->remove_selected_probe();
  EXPECT_EQ(w->workbench().probes().size(), before);
  EXPECT_EQ(w->workbench().probe(id), nullptr);
}

TEST_F(MainWindowTest, ABadDeviceShowsAnErrorAndKeepsTheScene) {
  auto w = open_window();
  const auto mesh_before = w->workbench().organ().mesh;
  const auto* loop_before = w->workbench().loop();
  const std::size_t probes_before = w->workbench().probes().size();
  // A Falcon that is not there (no such USB device in the test machine).
  EXPECT_FALSE(w->add_device_probe("falcon", ""));
  EXPECT_TRUE(w->error_text().startsWith("Could not add a falcon device: falcon: ")) << w->error_text().toStdString();
  EXPECT_TRUE(w->findChild<QLabel*>("errorBanner")->isVisible());
  // A scripted device with a missing file: the plugin's exact message.
  const auto missing = palpa::test::temp_dir("gui_bad_device") / "missing.csv";
  EXPECT_FALSE(w->add_device_probe("scripted", QString::fromStdString("file=" + missing.string())));
  EXPECT_EQ(w->error_text().toStdString(),
            "Could not add a scripted device: scripted: cannot open trajectory file '" + missing.string() + "'");
  // Nothing else changed, and the loop keeps running.
  EXPECT_EQ(w->workbench().organ().mesh, mesh_before);
  EXPECT_EQ(w->workbench().probes().size(), probes_before);
  EXPECT_EQ(w->workbench().loop(), loop_before);
  const auto ticks = w->workbench().statistics().ticks;
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > ticks; }));
}

TEST_F(MainWindowTest, ABadFileShowsAnErrorAndKeepsTheScene) {
  auto w = open_window();
  const auto mesh_before = w->workbench().organ().mesh;
  const QString facts_before = w->facts_text();
  const auto dir = palpa::test::temp_dir("gui_bad_file");
  const auto bad = dir / "broken.obj";
  { std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nf 1 2 7\n"; }
  EXPECT_FALSE(w->open_mesh(QString::fromStdString(bad.string())));
  EXPECT_TRUE(w->error_text().startsWith("Could not open broken.obj: ")) << w->error_text().toStdString();
  EXPECT_TRUE(w->findChild<QLabel*>("errorBanner")->isVisible());
  EXPECT_EQ(w->workbench().organ().mesh, mesh_before);
  EXPECT_EQ(w->facts_text(), facts_before);
  QTest::qWait(100);  // and it keeps running
  EXPECT_EQ(w->workbench().organ().mesh, mesh_before);
}

TEST_F(MainWindowTest, AVanishedRecentFileIsReportedAndForgotten) {
  auto w = open_window();
  const auto dir = palpa::test::temp_dir("gui_recent");
  const auto path = dir / "ball.ply";
  mesh::save_mesh(mesh::make_sphere(600, 0.04), path);
  ASSERT_TRUE(w->open_mesh(QString::fromStdString(path.string())));
  EXPECT_EQ(w->recent_files().value(0), QString::fromStdString(path.string()));
  const auto mesh_before = w->workbench().organ().mesh;
  std::filesystem::remove(path);
  EXPECT_FALSE(w->open_mesh(QString::fromStdString(path.string())));
  EXPECT_TRUE(w->error_text().contains("does not exist")) << w->error_text().toStdString();
  EXPECT_FALSE(w->recent_files().contains(QString::fromStdString(path.string())));
  EXPECT_EQ(w->workbench().organ().mesh, mesh_before);
}

TEST_F(MainWindowTest, TheOrgansBackFacesAreSkippedOnlyWhereTheyCannotShow) {
  // A closed, outward organ drawn opaque: back faces skipped (about half the
  // software renderer's geometry work), and the picture is the one with them
  // (a live window: 1 of 356 640 pixels differed, at the silhouette).
  auto w = open_window();
  ASSERT_TRUE(w->workbench().organ().facts.closed_outward());
  vtkProperty* prop = w->surface_view()->actor()->GetProperty();
  EXPECT_TRUE(prop->GetBackfaceCulling());
  w->advance();
  const QImage culled = w->viewport()->grabFramebuffer();
  prop->BackfaceCullingOff();
  w->advance();
  const QImage drawn = w->viewport()->grabFramebuffer();
  prop->BackfaceCullingOn();
  ASSERT_EQ(culled.size(), drawn.size());
  // Only where a back face ties a front face in depth at the silhouette
  // (the depth test passes equal depths) may a pixel differ: a handful, not
  // the thousands of a wrong choice of faces.
  int differ = 0;
  for (int y = 0; y < culled.height(); ++y)
    for (int x = 0; x < culled.width(); ++x) differ += culled.pixel(x, y) != drawn.pixel(x, y);
  EXPECT_LE(differ, culled.width() * culled.height() / 2000) << "skipping the back faces changed the picture";
  const auto dir = palpa::test::temp_dir("gui_cull");
  // An open organ (a sphere with a cap cut off) shows its inside through the
  // hole: every face is drawn.
  mesh::SurfaceMesh open = mesh::make_sphere(700, 0.05);
  std::erase_if(open.triangles, [&](const auto& t) { return open.positions[t[0]].z() > 0.04; });
  mesh::save_mesh(open, dir / "open.ply");
  ASSERT_TRUE(w->open_mesh(QString::fromStdString((dir / "open.ply").string())));
  EXPECT_FALSE(w->workbench().organ().facts.closed());
  EXPECT_FALSE(w->surface_view()->actor()->GetProperty()->GetBackfaceCulling());
  // A closed one again: skipped again.
  mesh::save_mesh(mesh::make_sphere(700, 0.05), dir / "closed.ply");
  ASSERT_TRUE(w->open_mesh(QString::fromStdString((dir / "closed.ply").string())));
  EXPECT_TRUE(w->surface_view()->actor()->GetProperty()->GetBackfaceCulling());
}

TEST_F(MainWindowTest, ADroppedFileOpens) {
  auto w = open_window();
  const auto path = palpa::test::temp_dir("gui_drop") / "drop.ply";
  const auto sphere = mesh::make_sphere(700, 0.05);
  mesh::save_mesh(sphere, path);
  QMimeData data;
  data.setUrls({QUrl::fromLocalFile(QString::fromStdString(path.string()))});
  QDragEnterEvent enter(QPoint(50, 50), Qt::CopyAction, &data, Qt::LeftButton, Qt::NoModifier);
  QApplication::sendEvent(w.get(), &enter);
  EXPECT_TRUE(enter.isAccepted());
  QDropEvent drop(QPointF(50, 50), Qt::CopyAction, &data, Qt::LeftButton, Qt::NoModifier);
  QApplication::sendEvent(w.get(), &drop);
  EXPECT_EQ(w->workbench().organ().mesh->vertex_count(), sphere.vertex_count());
  EXPECT_EQ(w->workbench().organ().name, "drop.ply");
}

TEST_F(MainWindowTest, TheKpaPanelReachesTheLoopAsTheHertzMaterialAndIsRememberedNextTime) {
  tissue::Tissue t;
  double tip = 0;
  {
    auto w = open_window();
    auto spin = [&](const char* name) {
      auto* s = w->findChild<QDoubleSpinBox*>(name);
      EXPECT_NE(s, nullptr) << name;
      return s;
    };
    // Every field with its unit, and a tooltip saying so.
    EXPECT_EQ(spin("youngsModulus")->suffix(), " kPa");
    EXPECT_EQ(spin("stiffening")->suffix(), " /mm");
    EXPECT_EQ(spin("tipRadius")->suffix(), " mm");
    EXPECT_EQ(spin("relaxationTime")->suffix(), " s");
    for (const char* name : {"youngsModulus", "poisson", "dampingRatio", "relaxationTime", "relaxationFraction",
                             "stiffening", "tipRadius"})
      EXPECT_FALSE(spin(name)->toolTip().isEmpty()) << name;
    spin("youngsModulus")->setValue(12.5);
    spin("poisson")->setValue(0.45);
    spin("dampingRatio")->setValue(0.8);
    spin("relaxationTime")->setValue(0.5);
    spin("relaxationFraction")->setValue(0.25);
    spin("stiffening")->setValue(0.02);
    spin("tipRadius")->setValue(6);
    // The running loop takes the Hertz material of these values as an edit.
    t.youngs_modulus = spin("youngsModulus")->value() * 1e3;
    t.poisson = spin("poisson")->value();
    t.damping_ratio = spin("dampingRatio")->value();
    t.relaxation_time = spin("relaxationTime")->value();
    t.relaxation_fraction = spin("relaxationFraction")->value();
    t.stiffening = spin("stiffening")->value() * 1e3;
    tip = spin("tipRadius")->value() * 1e-3;
    const deform::Material expected = tissue::hertz_material(t, tip, w->workbench().material().mass);
    ASSERT_NE(w->workbench().loop(), nullptr);
    ASSERT_TRUE(wait_until([&] { return w->workbench().settled(); }));
    const deform::Material got = w->workbench().loop()->surface().material(0);
    EXPECT_EQ(got.model, deform::LocalModelKind::Hertz);
    EXPECT_EQ(got.hertz, expected.hertz);
    EXPECT_EQ(got.damping, expected.damping);
    EXPECT_EQ(got.mass, expected.mass);
    EXPECT_EQ(got.tau, expected.tau);
    EXPECT_EQ(got.relaxation, expected.relaxation);
    EXPECT_EQ(got.alpha, expected.alpha);
    EXPECT_EQ(got.stiffness, expected.stiffness);
    EXPECT_EQ(got, expected);
    EXPECT_EQ(w->workbench().material().tissue.youngs_modulus, 12.5e3);
    w->findChild<QDoubleSpinBox*>("radius")->setValue(31);
    EXPECT_NEAR(w->workbench().material().radius, 0.031, 1e-12);
    w->close();
  }
  auto again = open_window();
  EXPECT_EQ(again->workbench().material().law, MaterialLaw::Hertz);
  EXPECT_EQ(again->workbench().material().tissue.youngs_modulus, t.youngs_modulus);
  EXPECT_EQ(again->workbench().material().tissue.stiffening, t.stiffening);
  EXPECT_EQ(again->workbench().material().tip_radius, tip);
  EXPECT_EQ(again->workbench().materials().at(0), tissue::hertz_material(t, tip, again->workbench().material().mass));
  EXPECT_NEAR(again->workbench().material().radius, 0.031, 1e-12);
}

TEST_F(MainWindowTest, APresetFillsTheTissueWithItsSourceAsTooltip) {
  auto w = open_window();
  auto* box = w->findChild<QComboBox*>("presetBox");
  ASSERT_NE(box, nullptr);
  const auto& presets = tissue::presets();
  ASSERT_FALSE(presets.empty());
  ASSERT_EQ(box->count(), static_cast<int>(presets.size()) + 1) << "Custom and every preset";
  for (std::size_t k = 0; k < presets.size(); ++k)
    EXPECT_EQ(box->itemData(static_cast<int>(k) + 1, Qt::ToolTipRole).toString().toStdString(),
              presets[k].tissue.source)
        << presets[k].key;
  const tissue::Preset& last = presets.back();
  box->setCurrentIndex(box->count() - 1);
  EXPECT_NEAR(w->findChild<QDoubleSpinBox*>("youngsModulus")->value(), last.tissue.youngs_modulus * 1e-3, 0.005);
  EXPECT_EQ(w->workbench().material().tissue.youngs_modulus,
            w->findChild<QDoubleSpinBox*>("youngsModulus")->value() * 1e3);
  // Editing a value makes the tissue a custom one.
  w->findChild<QDoubleSpinBox*>("poisson")->setValue(0.3);
  EXPECT_EQ(box->currentIndex(), 0);
  EXPECT_EQ(w->workbench().material().tissue.poisson, 0.3);
  // The advanced linear model in N/m is still there, off by default.
  auto* linear = w->findChild<QGroupBox*>("linearModel");
  ASSERT_NE(linear, nullptr);
  linear->setChecked(true);
  w->findChild<QDoubleSpinBox*>("stiffness")->setValue(777);
  EXPECT_EQ(w->workbench().material().law, MaterialLaw::Linear);
  ASSERT_TRUE(wait_until([&] { return w->workbench().settled(); }));
  EXPECT_EQ(w->workbench().loop()->surface().material(0).stiffness, 777);
  EXPECT_EQ(w->workbench().loop()->surface().material(0).model, deform::LocalModelKind::Linear);
  linear->setChecked(false);
  EXPECT_EQ(w->workbench().material().law, MaterialLaw::Hertz);
}

// ---------------------------------------------------------------------------
// Scenarios.

std::filesystem::path shipped(const std::string& name) { return palpa::test::project_data_dir() / "scenarios" / name; }

// A copy of a shipped scenario, changed by `edit`, in `dir` (the organ by its absolute path).
std::filesystem::path scenario_copy(const std::string& name, const std::filesystem::path& dir,
                                    const std::function<void(scenario::Scenario&)>& edit) {
  scenario::Scenario s = scenario::load_scenario(shipped(name));
  s.organ.path = s.organ.resolved.string();
  edit(s);
  const auto file = dir / name;
  scenario::save_scenario(s, file);
  return file;
}

TEST_F(MainWindowTest, OpensAScenarioWithItsTaskTitleAndTissue) {
  auto w = open_window();
  const auto file = shipped("liver_tumour.json");
  const QString path = QString::fromStdString(file.string());
  ASSERT_TRUE(w->open_file(path)) << w->error_text().toStdString();
  EXPECT_TRUE(w->error_text().isEmpty());
  ASSERT_TRUE(w->workbench().has_scenario());
  const scenario::Scenario& s = w->workbench().scenario()->scenario;
  EXPECT_EQ(w->windowTitle(), QString("Palpa - %1 (liver_tumour.json)").arg(QString::fromStdString(s.title)));
  // The task is shown.
  EXPECT_TRUE(w->findChild<QDockWidget*>("taskDock")->isVisible());
  EXPECT_TRUE(w->task_text().contains(QString::fromStdString(s.task.instructions).toHtmlEscaped()))
      << w->task_text().toStdString();
  // The panel shows the base tissue in kPa and says what an edit would do.
  EXPECT_NEAR(w->findChild<QDoubleSpinBox*>("youngsModulus")->value(),
              s.tissues[w->workbench().scenario()->base].youngs_modulus * 1e-3, 0.005);
  auto* note = w->findChild<QLabel*>("scenarioMaterialNote");
  EXPECT_TRUE(note->isVisible());
  EXPECT_TRUE(note->text().contains("replaces the map with one tissue for the whole organ")) << note->text().toStdString();
  // It runs: the loop on the scenario's model, frames drawn.
  ASSERT_NE(w->workbench().loop(), nullptr);
  EXPECT_EQ(w->workbench().loop()->model()->tissue_map, w->workbench().scenario()->materials);
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > 10 && w->frame_rate() > 0; }));
  // Recent files hold scenarios too.
  EXPECT_EQ(w->recent_files().value(0), QFileInfo(path).absoluteFilePath());
  // A plain organ again: no task, the title names the organ.
  w->open_default_organ();
  EXPECT_FALSE(w->workbench().has_scenario());
  EXPECT_FALSE(w->findChild<QDockWidget*>("taskDock")->isVisible());
  EXPECT_FALSE(note->isVisible());
  EXPECT_EQ(w->windowTitle(), "Palpa - " + QString::fromStdString(w->workbench().organ().name));
}

TEST_F(MainWindowTest, ABadScenarioShowsAnErrorNamingTheFileAndKeepsTheScene) {
  auto w = open_window();
  ASSERT_TRUE(w->open_file(QString::fromStdString(shipped("breast_two_nodules.json").string())));
  const auto* loop_before = w->workbench().loop();
  const auto mesh_before = w->workbench().organ().mesh;
  const QString title_before = w->windowTitle();
  const QString task_before = w->task_text();
  const auto dir = palpa::test::temp_dir("gui_bad_scenario");
  const auto bad = dir / "typo.json";
  {
    std::string text = scenario::to_json_text(scenario::load_scenario(shipped("liver_tumour.json")));
    text.replace(text.find("\"title\""), 7, "\"titel\"");
    std::ofstream(bad) << text;
  }
  EXPECT_FALSE(w->open_file(QString::fromStdString(bad.string())));
  EXPECT_TRUE(w->error_text().startsWith("Could not open typo.json: " + QString::fromStdString(bad.string())))
      << w->error_text().toStdString();
  EXPECT_TRUE(w->error_text().contains("/titel")) << w->error_text().toStdString();
  EXPECT_TRUE(w->findChild<QLabel*>("errorBanner")->isVisible());
  EXPECT_EQ(w->workbench().loop(), loop_before);
  EXPECT_EQ(w->workbench().organ().mesh, mesh_before);
  EXPECT_EQ(w->windowTitle(), title_before);
  EXPECT_EQ(w->task_text(), task_before);
  EXPECT_FALSE(w->recent_files().contains(QString::fromStdString(bad.string())));
  const auto ticks = w->workbench().statistics().ticks;
  EXPECT_TRUE(wait_until([&] { return w->workbench().statistics().ticks > ticks; }));
}

TEST_F(MainWindowTest, EditingAScenarioTissueReplacesItsMapAndUndoRestoresIt) {
  auto w = open_window();
  ASSERT_TRUE(w->open_file(QString::fromStdString(shipped("breast_two_nodules.json").string())));
  auto* undo = w->findChild<QAction*>("undoMaterialEdit");
  ASSERT_NE(undo, nullptr);
  EXPECT_FALSE(undo->isEnabled());
  w->findChild<QDoubleSpinBox*>("youngsModulus")->setValue(20);
  EXPECT_FALSE(w->workbench().tissue_map_in_force());
  EXPECT_TRUE(undo->isEnabled());
  EXPECT_TRUE(w->findChild<QPushButton*>("restoreTissueMap")->isVisible());
  EXPECT_TRUE(w->findChild<QLabel*>("scenarioMaterialNote")->text().contains("replaced"));
  undo->trigger();
  EXPECT_TRUE(w->workbench().tissue_map_in_force());
  EXPECT_FALSE(undo->isEnabled());
  const auto& sc = *w->workbench().scenario();
  EXPECT_NEAR(w->findChild<QDoubleSpinBox*>("youngsModulus")->value(), sc.scenario.tissues[sc.base].youngs_modulus * 1e-3,
              0.005);
  ASSERT_TRUE(wait_until([&] { return w->workbench().settled(); }));
  const deform::MaterialMap& map = *sc.materials;
  for (Index i = 0; i < map.tissue_of.size(); i += 101) {
    const deform::Material& m = map.tissues[map.tissue_of[i]];
    ASSERT_EQ(w->workbench().loop()->surface().vertex_material(i), map.scale.empty() ? m : deform::scaled(m, map.scale[i]));
  }
}

TEST_F(MainWindowTest, TheDropHandlerTakesScenariosAndMeshes) {
  auto w = open_window();
  auto mime = [](const std::filesystem::path& p) {
    auto data = std::make_unique<QMimeData>();
    data->setUrls({QUrl::fromLocalFile(QString::fromStdString(p.string()))});
    return data;
  };
  const auto dir = palpa::test::temp_dir("gui_drop_kinds");
  const auto ply = dir / "ball.ply";
  mesh::save_mesh(mesh::make_sphere(600, 0.04), ply);
  const auto json = shipped("liver_tumour.json");
  EXPECT_EQ(MainWindow::droppable_file(mime(json).get()).toStdString(), json.string());
  EXPECT_EQ(MainWindow::droppable_file(mime(ply).get()).toStdString(), ply.string());
  EXPECT_TRUE(MainWindow::droppable_file(mime(dir / "notes.txt").get()).isEmpty());
  EXPECT_TRUE(MainWindow::droppable_file(nullptr).isEmpty());
  EXPECT_TRUE(w->drop_file(mime(json).get())) << w->error_text().toStdString();
  EXPECT_TRUE(w->workbench().has_scenario());
  EXPECT_TRUE(w->drop_file(mime(ply).get())) << w->error_text().toStdString();
  EXPECT_FALSE(w->workbench().has_scenario());
  EXPECT_EQ(w->workbench().organ().name, "ball.ply");
  // A drag of a scenario is accepted by the window.
  auto data = mime(json);
  QDragEnterEvent enter(QPoint(50, 50), Qt::CopyAction, data.get(), Qt::LeftButton, Qt::NoModifier);
  QApplication::sendEvent(w.get(), &enter);
  EXPECT_TRUE(enter.isAccepted());
}

// Frames until the drawn surface stops changing (every vertex bit for bit
// the same two frames in a row, at rest or held under a press) and the
// picture with it.
QImage settled_frame(MainWindow& w) {
  std::vector<Vec3> last_drawn;
  QImage last;
  for (int k = 0; k < 200; ++k) {
    QTest::qWait(50);
    w.advance();
    std::vector<Vec3> drawn;
    for (Index i = 0; i < w.surface_view()->mesh().vertex_count(); ++i) drawn.push_back(w.surface_view()->drawn_position(i));
    const QImage now = w.viewport()->grabFramebuffer();
    if (drawn == last_drawn && now == last) return now;
    last_drawn = std::move(drawn);
    last = now;
  }
  ADD_FAILURE() << "the surface did not come to rest";
  return last;
}

TEST_F(MainWindowTest, HiddenLesionsAreNeverDrawnAndShownOnesAre) {
  auto w = open_window();
  const auto dir = palpa::test::temp_dir("gui_lesions");
  const auto none_dir = dir / "none", shown_dir = dir / "shown";
  std::filesystem::create_directories(none_dir);
  std::filesystem::create_directories(shown_dir);
  const auto with_hidden = scenario_copy("breast_two_nodules.json", dir, [](scenario::Scenario&) {});
  const auto without = scenario_copy("breast_two_nodules.json", none_dir, [](scenario::Scenario& s) { s.lesions.clear(); });
  const auto shown = scenario_copy("breast_two_nodules.json", shown_dir, [](scenario::Scenario& s) {
    for (auto& l : s.lesions) l.lesion.visibility = tissue::Visibility::Shown;
  });
  // At rest, and under the same press over nodule A (the force differs,
  // that is how the lesion is felt, so a scenario's picture shows no force
  // arrow unless revealed).
  const auto press = [&] {
    const auto& mesh = *w->workbench().organ().mesh;
    const Vec3 centre = w->workbench().scenario()->scenario.lesions.empty()
                            ? Vec3(0.025, 0.020, 0.053)
                            : w->workbench().scenario()->scenario.lesions[0].surface_point;
    Index v = 0;
    for (Index i = 0; i < mesh.vertex_count(); ++i)
      if ((mesh.positions[i] - centre).norm() < (mesh.positions[v] - centre).norm()) v = i;
    w->workbench().place(w->workbench().selected_id(), mesh.positions[v], mesh.normals[v], 0.005);
    EXPECT_TRUE(wait_until([&] { return w->surface_view()->max_displacement() > 1e-3; }));
  };
  ASSERT_TRUE(w->open_file(QString::fromStdString(with_hidden.string()))) << w->error_text().toStdString();
  ASSERT_EQ(w->workbench().field()->lesion_count, 2u);
  EXPECT_EQ(w->lesions_drawn(), 0u);
  const QImage hidden_rest = settled_frame(*w);
  press();
  const QImage hidden_pressed = settled_frame(*w);
  ASSERT_TRUE(w->open_file(QString::fromStdString(without.string()))) << w->error_text().toStdString();
  ASSERT_EQ(w->workbench().field()->lesion_count, 0u);
  const QImage bare_rest = settled_frame(*w);
  press();
  const QImage bare_pressed = settled_frame(*w);
  EXPECT_TRUE(hidden_rest == bare_rest) << "a hidden lesion changed the picture at rest";
  EXPECT_TRUE(hidden_pressed == bare_pressed) << "a hidden lesion changed the picture under a press";
  EXPECT_FALSE(hidden_pressed == hidden_rest) << "the press is not drawn";
  // Shown lesions are drawn (translucent, over the organ).
  ASSERT_TRUE(w->open_file(QString::fromStdString(shown.string()))) << w->error_text().toStdString();
  EXPECT_EQ(w->lesions_drawn(), 2u);
  const QImage shown_rest = settled_frame(*w);
  EXPECT_FALSE(shown_rest == bare_rest) << "a shown lesion is not drawn";
  // The debriefing reveals hidden ones.
  ASSERT_TRUE(w->open_file(QString::fromStdString(with_hidden.string())));
  EXPECT_EQ(w->lesions_drawn(), 0u);
  w->findChild<QAction*>("revealLesions")->setChecked(true);
  EXPECT_EQ(w->lesions_drawn(), 2u);
  press();
  const QImage revealed_pressed = settled_frame(*w);
  EXPECT_FALSE(revealed_pressed == hidden_pressed) << "revealed: the lesions and the force arrow are drawn";
  w->findChild<QAction*>("revealLesions")->setChecked(false);
  EXPECT_EQ(w->lesions_drawn(), 0u);
  EXPECT_TRUE(settled_frame(*w) == hidden_pressed) << "hidden again: the same picture as before";
  w->findChild<QAction*>("showForceArrows")->setChecked(true);
  if (const char* dir = std::getenv("PALPA_TEST_SCREENSHOTS"); dir && *dir)
    w->grab().save(QString(dir) + "/workbench_shown_lesions.png");
}

TEST_F(MainWindowTest, ABreathingOrganIsDrawnWhereItIsAndPicksStayOnIt) {
  auto w = open_window();
  ASSERT_TRUE(w->open_file(QString::fromStdString(shipped("abdomen_aorta.json").string())));
  const auto field = w->workbench().field();
  ASSERT_TRUE(field && field->breathing.enabled);
  // The organ actor carries the breathing transform of the frame's time.
  double lo = 1e9, hi = -1e9;
  for (int k = 0; k < 40; ++k) {
    QTest::qWait(40);
    w->advance();
    vtkMatrix4x4* m = w->surface_view()->actor()->GetUserMatrix();
    ASSERT_NE(m, nullptr);
    const Eigen::Matrix4d expected = field->organ_to_world(w->workbench().loop_time());
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) ASSERT_NEAR(m->GetElement(r, c), expected(r, c), 1e-12);
    lo = std::min(lo, m->GetElement(2, 3));
    hi = std::max(hi, m->GetElement(2, 3));
  }
  EXPECT_GT(hi - lo, 1e-4) << "the organ did not move with the breathing";
  // A press on the drawn organ anchors the probe on the organ (organ frame).
  const auto p = point_on_organ(*w);
  ASSERT_TRUE(p.has_value());
  auto* vp = w->viewport();
  QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, *p);
  drag(vp, *p, *p + QPoint(0, 60), 4);
  const Probe* probe = w->workbench().selected_probe();
  ASSERT_TRUE(probe && probe->placed);
  const auto& mesh = *w->workbench().organ().mesh;
  double nearest = 1e9;
  for (const Vec3& x : mesh.positions) nearest = std::min(nearest, (x - probe->anchor).norm());
  EXPECT_LT(nearest, 0.01) << "the anchor is not on the organ";
  EXPECT_TRUE(wait_until([&] { return w->workbench().selected_probe()->output.in_contact; }));
  QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, *p + QPoint(0, 60));
}

TEST_F(MainWindowTest, SeveralProbesPressAtOnce) {
  auto w = open_window();
  auto* vp = w->viewport();
  const auto p = point_on_organ(*w);
  ASSERT_TRUE(p.has_value());
  // First probe.
  QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, *p);
  drag(vp, *p, *p + QPoint(0, 60), 4);
  QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, *p + QPoint(0, 60));
  // A second one, 60 px to the side.
  w->add_probe();
  std::optional<QPoint> q;
  for (int dx : {60, -60, 90, -90}) {
    const QPoint c = *p + QPoint(dx, 0);
    const double dpr = vp->devicePixelRatioF();
    if (w->surface_view()->pick(w->renderer(), (c.x() + 0.5) * dpr, (vp->height() - c.y() - 0.5) * dpr)) {
      q = c;
      break;
    }
  }
  ASSERT_TRUE(q.has_value());
  QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, *q);
  drag(vp, *q, *q + QPoint(0, 60), 4);
  QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, *q + QPoint(0, 60));
  ASSERT_EQ(w->workbench().probes().size(), 2u);
  EXPECT_TRUE(wait_until([&] { return w->workbench().contact_count() == 2; }));
  for (const Probe& pr : w->workbench().probes()) {
    EXPECT_TRUE(pr.output.in_contact) << "probe " << pr.id;
    EXPECT_GT(pr.output.force.norm(), 0.0) << "probe " << pr.id;
  }
  // Remove the selected one: one contact left.
  w->remove_selected_probe();
  EXPECT_EQ(w->workbench().probes().size(), 1u);
  EXPECT_TRUE(wait_until([&] { return w->workbench().contact_count() == 1; }));
}

TEST_F(MainWindowTest, ScreenshotAndResetWork) {
  auto w = open_window();
  const auto path = palpa::test::temp_dir("gui_shot") / "shot.png";
  ASSERT_TRUE(w->save_screenshot(QString::fromStdString(path.string())));
  const QImage shot(QString::fromStdString(path.string()));
  EXPECT_EQ(shot.width(), static_cast<int>(w->viewport()->width() * w->viewport()->devicePixelRatioF()));
  EXPECT_FALSE(w->save_screenshot("/nonexistent-folder/x.png"));
  EXPECT_EQ(w->error_text(), "Could not save the screenshot to /nonexistent-folder/x.png");

  const int id = w->workbench().selected_id();
  w->workbench().place(id, w->workbench().organ().mesh->positions[0], w->workbench().organ().mesh->normals[0],
                       0.004);
  ASSERT_TRUE(wait_until([&] { return w->surface_view()->max_displacement() > 1e-4; }));
  w->reset();
  EXPECT_EQ(w->workbench().selected_probe()->depth, 0.0);
  // The reset reaches the running loop at its next deformation step.
  EXPECT_TRUE(wait_until([&] { return w->surface_view()->max_displacement() == 0.0; }));
}

}  // namespace
}  // namespace palpa::app

// QApplication must exist before any widget, with VTK's surface format set
// first; none is made when listing tests or when there is no display.
int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  const char* display = std::getenv("DISPLAY");
  if (::testing::GTEST_FLAG(list_tests) || !display || !*display) return RUN_ALL_TESTS();
  // Settings of this run go to a fresh folder.
  const auto settings = palpa::test::temp_dir("gui_settings_" + std::to_string(::getpid()));
  QSettings::setDefaultFormat(QSettings::IniFormat);
  QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, QString::fromStdString(settings.string()));
  palpa::app::configure_application_defaults();
  QApplication app(argc, argv);
  return RUN_ALL_TESTS();
}
