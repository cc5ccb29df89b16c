// Parts of the workbench window under Xvfb (part of test_app_gui, whose
// main() is in test_main_window.cpp): the Add device dialog built from what
// each plugin declares, and a scripted device added through it; the force
// plot's legend, probe colours, clamp, and its clearing when the last probe
// goes.

#include "app/gui/device_dialog.h"
#include "app/gui/force_plot.h"
#include "app/gui/main_window.h"
#include "common/test_support.h"
#include "gui_wait.h"
#include "render/probe_view.h"

#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCommand.h>
#include <vtkNew.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>

#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QPushButton>
#include <QSpinBox>
#include <QTest>
#include <QTimer>
#include <QVTKOpenGLNativeWidget.h>

#include <cmath>
#include <fstream>
#include <functional>

namespace palpa::app {
namespace {

QString q(const std::string& s) { return QString::fromStdString(s); }

class WindowParts : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!qApp) GTEST_SKIP() << "no X display: these tests run under tests/app/xvfb_run.sh";
  }
  std::unique_ptr<MainWindow> open_window() {
    auto w = std::make_unique<MainWindow>();
    w->resize(1100, 760);
    w->show();
    EXPECT_TRUE(QTest::qWaitForWindowExposed(w.get()));
    QTest::qWait(200);
    return w;
  }
  static bool wait_until(const std::function<bool()>& done, int timeout_ms = 20000) {
    return gui_test::wait_until(done, timeout_ms);
  }
  // A trajectory that presses vertex 0 of the organ 4 mm deep and holds.
  static std::filesystem::path press_file(MainWindow& w, const std::string& name) {
    const auto& mesh = *w.workbench().organ().mesh;
    const Vec3 p0 = mesh.positions[0];
    const Vec3 n0 = mesh.normals[0].normalized();
    const Vec3 above = p0 + 0.01 * n0, inside = p0 - 0.004 * n0;
    const auto file = palpa::test::temp_dir(name) / "press.csv";
    std::ofstream f(file);
    f.precision(17);
    f << "t,x,y,z,buttons\n";
    f << "0," << above.x() << "," << above.y() << "," << above.z() << ",0\n";
    f << "0.2," << inside.x() << "," << inside.y() << "," << inside.z() << ",0\n";
    f << "1000," << inside.x() << "," << inside.y() << "," << inside.z() << ",0\n";
    return file;
  }
};

// Every plugin the loader can load has a page, and every option it declares
// a field of its type with its range, unit, default and help: checked
// against the plugin's own table (Plugin::options()), not the dialog's.
TEST_F(WindowParts, TheDeviceDialogBuildsEachPluginsFormFromItsDeclarations) {
  const devices::PluginLoader loader;
  const auto names = loader.available();
  DeviceDialog dialog;
  QStringList expected;
  for (const auto& n : names) expected << q(n);
  ASSERT_EQ(dialog.plugins(), expected);
  for (const char* name : {"mouse", "scripted", "spacemouse", "falcon", "igtl"})
    EXPECT_TRUE(dialog.plugins().contains(name)) << name;
  EXPECT_EQ(dialog.plugin(), "scripted");  // the one that needs no hardware
  EXPECT_FALSE(dialog.findChild<QComboBox*>("devicePlugin")->toolTip().isEmpty());

  int fields = 0;
  for (const auto& name : names) {
    for (const devices::OptionDescription& d : loader.load(name).options()) {
      SCOPED_TRACE(name + "." + d.name);
      QWidget* w = dialog.field(q(name), q(d.name));
      ASSERT_NE(w, nullptr);
      ++fields;
      EXPECT_TRUE(w->toolTip().startsWith(q(d.help))) << w->toolTip().toStdString();
      const QString suffix = d.unit.empty() ? QString() : " " + q(d.unit);
      switch (d.type) {
        case PALPA_OPTION_DOUBLE: {
          auto* box = qobject_cast<QDoubleSpinBox*>(w);
          ASSERT_NE(box, nullptr);
          EXPECT_DOUBLE_EQ(box->minimum(), d.min);
          EXPECT_DOUBLE_EQ(box->maximum(), d.max);
          EXPECT_DOUBLE_EQ(box->value(), std::stod(d.default_value));
          EXPECT_EQ(box->suffix(), suffix);
          break;
        }
        case PALPA_OPTION_INT: {
          auto* box = qobject_cast<QSpinBox*>(w);
          ASSERT_NE(box, nullptr);
          EXPECT_EQ(box->minimum(), static_cast<int>(d.min));
          EXPECT_EQ(box->maximum(), static_cast<int>(d.max));
          EXPECT_EQ(box->value(), std::stoi(d.default_value));
          EXPECT_EQ(box->suffix(), suffix);
          break;
        }
        case PALPA_OPTION_BOOL: {
          auto* box = qobject_cast<QCheckBox*>(w);
          ASSERT_NE(box, nullptr);
          EXPECT_EQ(box->isChecked(), d.default_value == "true");
          break;
        }
        case PALPA_OPTION_CHOICE: {
          auto* box = qobject_cast<QComboBox*>(w);
          ASSERT_NE(box, nullptr);
          ASSERT_EQ(box->count(), static_cast<int>(d.choices.size()));
          for (std::size_t i = 0; i < d.choices.size(); ++i) EXPECT_EQ(box->itemText(i), q(d.choices[i]));
          EXPECT_EQ(box->currentText(), q(d.default_value));
          break;
        }
        case PALPA_OPTION_FILE: {
          auto* edit = qobject_cast<QLineEdit*>(w);
          ASSERT_NE(edit, nullptr);
          EXPECT_EQ(edit->text(), q(d.default_value));
          auto* browse = dialog.findChild<QPushButton*>(q("browse_" + name + "_" + d.name));
          ASSERT_NE(browse, nullptr) << "a file option has a Browse button";
          EXPECT_FALSE(browse->toolTip().isEmpty());
          break;
        }
        default: {
          auto* edit = qobject_cast<QLineEdit*>(w);
          ASSERT_NE(edit, nullptr);
          EXPECT_EQ(edit->text(), q(d.default_value));
        }
      }
    }
  }
  EXPECT_GT(fields, 25);

  // Untouched fields give no options (the plugin's defaults apply); changed
  // ones are written as create() takes them.
  ASSERT_TRUE(dialog.select("igtl"));
  EXPECT_EQ(dialog.options(), "");
  EXPECT_TRUE(dialog.set_value("mode", "server"));
  EXPECT_TRUE(dialog.set_value("port", "0"));
  EXPECT_TRUE(dialog.set_value("stale_after", "0.25"));
  EXPECT_FALSE(dialog.set_value("stale_after", "1000"));  // outside the declared range
  EXPECT_FALSE(dialog.set_value("mode", "peer"));
  EXPECT_EQ(dialog.options(), "mode=server;port=0;stale_after=0.25");
  // OK waits for the required trajectory file.
  ASSERT_TRUE(dialog.select("scripted"));
  auto* ok = dialog.findChild<QDialogButtonBox*>()->button(QDialogButtonBox::Ok);
  EXPECT_FALSE(ok->isEnabled());
  EXPECT_TRUE(dialog.set_value("file", "/tmp/x.csv"));
  EXPECT_TRUE(ok->isEnabled());
}

// Devices > Add device probe: the dialog (modal) takes a trajectory file and
// the scripted device it adds drives a contact.
TEST_F(WindowParts, AddingAScriptedDeviceThroughTheDialogWorks) {
  auto w = open_window();
  const auto file = press_file(*w, "gui_dialog_scripted");
  const std::size_t before = w->workbench().probes().size();
  bool filled = false;
  QTimer::singleShot(300, [&] {
    auto* d = qobject_cast<DeviceDialog*>(QApplication::activeModalWidget());
    if (d == nullptr) return;
    filled = d->select("scripted") && d->set_value("file", q(file.string())) && d->set_value("loop", "true");
    d->findChild<QDialogButtonBox*>()->button(QDialogButtonBox::Ok)->click();
  });
  w->add_device_dialog();
  ASSERT_TRUE(filled) << "the dialog did not open";
  EXPECT_TRUE(w->error_text().isEmpty()) << w->error_text().toStdString();
  ASSERT_EQ(w->workbench().probes().size(), before + 1);
  const int id = w->workbench().selected_id();
  EXPECT_EQ(w->workbench().probe(id)->device, "scripted");
  EXPECT_TRUE(wait_until([&] { return w->workbench().probe(id)->output.in_contact; }));
}

// The plot names each probe in the legend, in the colour of its glyph, marks
// the clamp; removing the last probe clears its trace and the readouts.
TEST_F(WindowParts, RemovingTheLastProbeClearsThePlotAndReadouts) {
  auto w = open_window();
  ASSERT_TRUE(w->add_device_probe("scripted", q("file=" + press_file(*w, "gui_plot_clear").string())));
  const int id = w->workbench().selected_id();
  ForcePlot* plot = w->force_plot();
  // Under the sanitizers the loop runs late and the watchdog holds the force at zero (as it must).
  using gui_test::kSlowBuild;
  const std::uint32_t late = haptics::kSafetyLoopLate | haptics::kSafetyModelLate;
  ASSERT_TRUE(wait_until([&] {
    const ProbeReadout& out = w->workbench().probe(id)->output;
    const bool pushed = out.force.norm() > 0.05 || (kSlowBuild && out.in_contact && (out.flags & late) != 0);
    return pushed && plot->sample_count(id) > 0;
  }));
  EXPECT_EQ(plot->label(id), QString("Probe %1 (scripted)").arg(id));
  EXPECT_EQ(plot->colour(id), ForcePlot::probe_colour(id));
  ASSERT_NE(w->probe_view(id), nullptr);
  const Vec3 glyph = w->probe_view(id)->colour();
  const QColor c = plot->colour(id);
  EXPECT_NEAR(glyph.x(), c.redF(), 1e-6);
  EXPECT_NEAR(glyph.y(), c.greenF(), 1e-6);
  EXPECT_NEAR(glyph.z(), c.blueF(), 1e-6);
  EXPECT_DOUBLE_EQ(plot->clamp(), w->workbench().material().max_force);
  EXPECT_GE(plot->scale(), plot->clamp());  // the clamp line is inside the plot
  auto* force = w->findChild<QLabel*>("forceReadout");
  // The readout shows the pushing force (under ThreadSanitizer, a number: the held zero).
  EXPECT_TRUE(wait_until([&] { return force->text() != "0.00 N" || (kSlowBuild && force->text() != "-"); }));

  // Remove every probe: no traces, no legend, no numbers left.
  while (!w->workbench().probes().empty()) w->remove_selected_probe();
  QTest::qWait(200);
  EXPECT_EQ(plot->sample_count(id), 0u);
  EXPECT_TRUE(plot->probes().empty());
  EXPECT_EQ(force->text(), "-");
  EXPECT_EQ(w->findChild<QLabel*>("depthReadout")->text(), "-");
}


}  // namespace
}  // namespace palpa::app
