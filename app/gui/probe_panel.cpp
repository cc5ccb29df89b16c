// The Probes dock's panel (moved out of main_window.cpp).

#include "app/gui/probe_panel.h"

#include "app/gui/force_plot.h"

#include <QHBoxLayout>
#include <QLabel>
#include <QListWidget>
#include <QPushButton>
#include <QSignalBlocker>
#include <QVBoxLayout>

namespace palpa::app {

// Probes dock: list, add, remove.
ProbePanel::ProbePanel(QWidget* parent) : QWidget(parent) {
  auto* probes_layout = new QVBoxLayout(this);
  list_ = new QListWidget;
  list_->setObjectName("probeList");
  probes_layout->addWidget(list_);
  auto* buttons = new QHBoxLayout;
  auto* add = new QPushButton("Add");
  auto* remove = new QPushButton("Remove");
  add->setObjectName("addProbe");
  remove->setObjectName("removeProbe");
  buttons->addWidget(add);
  buttons->addWidget(remove);
  probes_layout->addLayout(buttons);
  probes_layout->addWidget(new QLabel("Left-drag on the organ: press (drag down = deeper,\n"
                                      "wheel while pressing = depth, Shift = slide).\n"
                                      "Left-drag elsewhere: rotate. Wheel: zoom."));
  connect(add, &QPushButton::clicked, this, &ProbePanel::add_requested);
  connect(remove, &QPushButton::clicked, this, [this] { emit remove_requested(current_id()); });
  connect(list_, &QListWidget::currentRowChanged, this, [this](int row) {
    if (row >= 0 && row < static_cast<int>(ids_.size())) emit selected(ids_[static_cast<std::size_t>(row)]);
  });
}

QString ProbePanel::label(const Probe& p) {
  return p.host_fed && p.device == "mouse" ? QString("Probe %1").arg(p.id)
                                           : QString("Probe %1 (%2)").arg(p.id).arg(QString::fromStdString(p.device));
}

void ProbePanel::refresh(const std::vector<Probe>& probes, int selected_id) {
  const QSignalBlocker block(list_);
  list_->clear();
  ids_.clear();
  int row = 0;
  for (const Probe& p : probes) {
    list_->addItem(label(p));
    list_->item(row)->setData(Qt::DecorationRole, ForcePlot::probe_colour(p.id));  // its trace's and glyph's colour
    ids_.push_back(p.id);
    if (p.id == selected_id) list_->setCurrentRow(row);
    ++row;
  }
}

int ProbePanel::current_id() const {
  const int row = list_->currentRow();
  return row >= 0 && row < static_cast<int>(ids_.size()) ? ids_[static_cast<std::size_t>(row)] : 0;
}

}  // namespace palpa::app
