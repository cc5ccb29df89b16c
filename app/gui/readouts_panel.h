#pragma once
// The Readouts dock's panel: the selected probe's force and indentation,
// its device's state (the plugin's message, a latched fault, the safety
// flags) with Re-enable, the loop's warnings, and the force plot of every
// probe. The window feeds it the workbench's probes each frame (update) and
// the loop's warnings twice a second (set_warnings).

#include "app/gui/workbench.h"

#include <QString>
#include <QWidget>

#include <vector>

class QLabel;
class QPushButton;

namespace palpa::app {

class ForcePlot;

class ReadoutsPanel : public QWidget {
  Q_OBJECT
 public:
  explicit ReadoutsPanel(QWidget* parent = nullptr);

  /// The probes at loop time `time` (s): their forces into the plot (with
  /// the clamp `max_force`, N), probe `selected_id`'s numbers and device
  /// state ("-" when no probe is selected).
  void update(const std::vector<Probe>& probes, int selected_id, double time, double max_force);
  /// The loop's warnings (one a line) and the real-time notice as their tooltip.
  void set_warnings(const QString& text, const QString& tip);

  QString warnings_text() const;
  QString device_status_text() const;
  ForcePlot* plot() const { return plot_; }

 signals:
  /// Re-enable device was pressed.
  void reenable_requested();

 private:
  QLabel* force_label_ = nullptr;
  QLabel* depth_label_ = nullptr;
  QLabel* device_label_ = nullptr;
  QLabel* warnings_label_ = nullptr;
  QPushButton* reenable_button_ = nullptr;
  ForcePlot* plot_ = nullptr;
};

}  // namespace palpa::app
