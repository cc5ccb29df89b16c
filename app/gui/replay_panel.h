#pragma once
// The workbench's replay timeline: play, pause, speed (0.25x .. 4x) and a
// slider over the session's duration that seeks (SessionPlayer restores the
// nearest state at or before the target and re-simulates forward). The
// window draws the player's surface and probes whenever moved() fires.

#include "app/gui/session_player.h"

#include <QElapsedTimer>
#include <QTimer>
#include <QWidget>

#include <memory>
#include <vector>

class QComboBox;
class QLabel;
class QPushButton;
class QSlider;

namespace palpa::app {

class ReplayPanel : public QWidget {
  Q_OBJECT
 public:
  explicit ReplayPanel(QWidget* parent = nullptr);
  ~ReplayPanel() override;

  /// Takes a player (paused at its first tick) and shows its timeline.
  void open(std::unique_ptr<SessionPlayer> player);
  /// Drops the player (paused).
  void close();
  SessionPlayer* player() const { return player_.get(); }

  void play();
  void pause();
  bool playing() const { return timer_.isActive(); }
  /// Playback speed, times real time (one of speeds(); others snap to the nearest).
  void set_speed(double speed);
  double speed() const;
  static const std::vector<double>& speeds();
  /// Shows the tick at `seconds` from the session's start (clamped). False
  /// (and failed() emitted) when the file cannot be replayed there.
  bool seek(double seconds);

 signals:
  /// The player shows another tick.
  void moved();
  /// "Back to live" was pressed.
  void leave_requested();
  /// Replaying failed (a damaged part of the file): the message names the file.
  void failed(const QString& message);

 private:
  void step();
  void sync_controls();

  std::unique_ptr<SessionPlayer> player_;
  QLabel* file_label_ = nullptr;
  QPushButton* play_button_ = nullptr;
  QComboBox* speed_box_ = nullptr;
  QSlider* slider_ = nullptr;
  QLabel* time_label_ = nullptr;
  QPushButton* leave_button_ = nullptr;
  QTimer timer_;
  QElapsedTimer wall_;
  double last_wall_ = 0;  // s, wall time of the previous playback step
};

}  // namespace palpa::app
