// The workbench window under a real X server (Xvfb, started for each test by
// xvfb_run.sh): it opens on the default organ and draws it, a mouse
// press-and-drag on the organ makes a contact with a force through the
// real-time haptic loop, a scripted device probe drives a contact, bad files
// and bad devices show an error and keep the scene, and the rest of the
// window's promises. The loop runs on its own threads: the tests wait for
// conditions with a timeout and never assert wall-time figures.

#include "app/gui/force_plot.h"
#include "app/gui/main_window.h"
#include "common/test_support.h"
#include "mesh/generate.h"
#include "mesh/io.h"
#include "mesh/organ.h"
#include "render/surface_view.h"

#include <QApplication>
#include <QDoubleSpinBox>
#include <QDropEvent>
#include <QElapsedTimer>
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

  // A shown window that has drawn a few frames.
  std::unique_ptr<MainWindow> open_window() {
    auto w = std::make_unique<MainWindow>();
    w->resize(1100, 760);
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
    QElapsedTimer t;
    t.start();
    while (!done()) {
      if (t.elapsed() > timeout_ms) return false;
      QTest::qWait(20);
    }
    return true;
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
  // tests never assert wall time). The haptic rate is the loop's own.
  ASSERT_NE(w->workbench().loop(), nullptr);
  EXPECT_TRUE(w->workbench().loop()->running());
  EXPECT_TRUE(wait_until([&] { return w->frame_rate() > 0 && w->haptic_rate() > 0; }));
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
  EXPECT_TRUE(wait_until([&] {
    probe = w->workbench().probe(id);
    return probe->output.in_contact && probe->output.force.dot(n0) > 0.05 &&
           w->surface_view()->max_displacement() > 1e-4;
  })) << "force " << probe->output.force.transpose();
  EXPECT_NE(w->findChild<QLabel*>("forceReadout")->text(), "0.00 N");
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

TEST_F(MainWindowTest, MaterialPanelAppliesAtOnceAndIsRememberedNextTime) {
  {
    auto w = open_window();
    auto* stiffness = w->findChild<QDoubleSpinBox*>("stiffness");
    ASSERT_NE(stiffness, nullptr);
    stiffness->setValue(777);
    // The running loop takes the new material as an edit at its next step.
    ASSERT_NE(w->workbench().loop(), nullptr);
    ASSERT_TRUE(wait_until([&] { return w->workbench().settled(); }));
    EXPECT_EQ(w->workbench().loop()->surface().materials().stiffness.front(), 777);
    EXPECT_EQ(w->workbench().material().stiffness, 777);
    w->findChild<QDoubleSpinBox*>("radius")->setValue(31);
    EXPECT_NEAR(w->workbench().material().radius, 0.031, 1e-12);
    w->close();
  }
  auto again = open_window();
  EXPECT_EQ(again->workbench().material().stiffness, 777);
  EXPECT_EQ(again->workbench().materials().stiffness.front(), 777);
  EXPECT_NEAR(again->workbench().material().radius, 0.031, 1e-12);
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
