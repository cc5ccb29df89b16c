#pragma once
// The Probes dock's panel: the probes (each in its trace's and glyph's
// colour), Add and Remove, and how the mouse drives a probe. The panel shows
// the workbench's probes (refresh) and says what the user asked for; the
// window adds, removes and selects them on the Workbench.

#include "app/gui/workbench.h"

#include <QString>
#include <QWidget>

#include <vector>

class QListWidget;

namespace palpa::app {

class ProbePanel : public QWidget {
  Q_OBJECT
 public:
  explicit ProbePanel(QWidget* parent = nullptr);

  /// Lists `probes` ("Probe 2", "Probe 3 (scripted)") with probe
  /// `selected_id` current, without emitting selected.
  void refresh(const std::vector<Probe>& probes, int selected_id);
  /// A probe's name in the list (and the force plot's legend).
  static QString label(const Probe& p);
  /// The id of the probe current in the list (0: none).
  int current_id() const;
  QListWidget* list() const { return list_; }

 signals:
  /// Add was pressed.
  void add_requested();
  /// Remove was pressed, with the probe current in the list (0: none).
  void remove_requested(int id);
  /// The user made probe `id` current.
  void selected(int id);

 private:
  QListWidget* list_ = nullptr;
  std::vector<int> ids_;  // the listed probes, by row
};

}  // namespace palpa::app
