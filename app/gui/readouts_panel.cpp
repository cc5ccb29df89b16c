// The Readouts dock's panel (moved out of main_window.cpp).

#include "app/gui/readouts_panel.h"

#include "app/gui/force_plot.h"

#include <QFormLayout>
#include <QLabel>
#include <QPushButton>
#include <QStringList>

namespace palpa::app {
namespace {

QString mm(double metres, int decimals = 1) { return QString::number(metres * 1e3, 'f', decimals); }

}  // namespace

// Readouts dock: numbers and the force plot.
ReadoutsPanel::ReadoutsPanel(QWidget* parent) : QWidget(parent) {
  auto* readouts_layout = new QFormLayout(this);
  force_label_ = new QLabel("0.00 N");
  depth_label_ = new QLabel("0.0 mm");
  force_label_->setObjectName("forceReadout");
  depth_label_->setObjectName("depthReadout");
  readouts_layout->addRow("Force", force_label_);
  readouts_layout->addRow("Indentation", depth_label_);
  device_label_ = new QLabel;
  warnings_label_ = new QLabel;
  device_label_->setObjectName("deviceStatus");
  warnings_label_->setObjectName("loopWarnings");
  device_label_->setWordWrap(true);
  warnings_label_->setWordWrap(true);
  warnings_label_->setStyleSheet("QLabel { color: #a05a00; }");
  reenable_button_ = new QPushButton("Re-enable device");
  reenable_button_->setObjectName("reenableDevice");
  reenable_button_->setToolTip("Re-enable force output of the selected probe's device (clears a latched fault)");
  connect(reenable_button_, &QPushButton::clicked, this, &ReadoutsPanel::reenable_requested);
  readouts_layout->addRow("Device", device_label_);
  readouts_layout->addRow(reenable_button_);
  readouts_layout->addRow(warnings_label_);
  plot_ = new ForcePlot;
  readouts_layout->addRow(plot_);
}

void ReadoutsPanel::update(const std::vector<Probe>& probes, int selected_id, double time, double max_force) {
  const double t = time;
  // The plot: probes that are gone lose their trace; the clamp as a line.
  std::vector<int> ids;
  const Probe* selected = nullptr;
  for (const Probe& p : probes) {
    ids.push_back(p.id);
    if (p.placed) plot_->add_sample(p.id, t, p.output.force.norm());
    if (p.id == selected_id) selected = &p;
  }
  plot_->retain(ids);
  plot_->advance_to(t);
  plot_->set_clamp(max_force);
  QString status;
  if (const Probe* p = selected) {
    force_label_->setText(QString::number(p->output.force.norm(), 'f', 2) + " N");
    depth_label_->setText(mm(p->output.in_contact ? p->output.depth : 0.0) + " mm");
    // Device state: the plugin's message, a latched fault, the safety flags.
    QStringList lines;
    if (p->dev) lines << QString::fromStdString(p->dev->message());
    if (!p->fault_text.empty())
      lines << QString("<b>Fault latched: %1</b> - press Re-enable").arg(QString::fromStdString(p->fault_text));
    if (p->force_output) {
      for (const auto& f : haptics::describe_safety_flags(p->output.flags))
        lines << QString::fromStdString(f);
    }
    status = lines.join("<br>");
    reenable_button_->setEnabled(p->force_output);
  } else {
    // No probe selected (the last one removed): nothing to read out.
    force_label_->setText("-");
    depth_label_->setText("-");
    reenable_button_->setEnabled(false);
  }
  if (device_label_->text() != status) device_label_->setText(status);
}

void ReadoutsPanel::set_warnings(const QString& text, const QString& tip) {
  if (warnings_label_->text() != text) {
    warnings_label_->setText(text);
    warnings_label_->setToolTip(tip);
  }
}

QString ReadoutsPanel::warnings_text() const { return warnings_label_->text(); }
QString ReadoutsPanel::device_status_text() const { return device_label_->text(); }

}  // namespace palpa::app
