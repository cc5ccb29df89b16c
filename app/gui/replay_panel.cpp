// The replay timeline (replay_panel.h).

#include "app/gui/replay_panel.h"

#include <QComboBox>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QLabel>
#include <QPushButton>
#include <QSlider>
#include <QVBoxLayout>

#include <algorithm>
#include <cmath>

namespace palpa::app {
namespace {

constexpr int kStepMs = 16;             // playback step, ms of wall time (about the frame rate)
constexpr double kMaxStepS = 0.1;       // s of wall time one step covers at most (a stalled frame does not jump)
constexpr int kSliderStepsPerS = 1000;  // slider resolution: one step per ms of session time

QString clock_text(double s) {
  const int minutes = static_cast<int>(s / 60);
  return QString("%1:%2").arg(minutes).arg(s - 60 * minutes, 6, 'f', 3, QChar('0'));
}

}  // namespace

const std::vector<double>& ReplayPanel::speeds() {
  static const std::vector<double> v{0.25, 0.5, 1.0, 2.0, 4.0};
  return v;
}

ReplayPanel::ReplayPanel(QWidget* parent) : QWidget(parent) {
  auto* outer = new QVBoxLayout(this);
  file_label_ = new QLabel;
  file_label_->setObjectName("replayFile");
  file_label_->setToolTip("The session file being replayed");
  file_label_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  outer->addWidget(file_label_);
  auto* row = new QHBoxLayout;
  play_button_ = new QPushButton("Play");
  play_button_->setObjectName("replayPlay");
  play_button_->setCheckable(true);
  play_button_->setToolTip("Play or pause the replay (the recorded ticks re-simulated at the chosen speed)");
  connect(play_button_, &QPushButton::toggled, this, [this](bool on) { on ? play() : pause(); });
  row->addWidget(play_button_);
  speed_box_ = new QComboBox;
  speed_box_->setObjectName("replaySpeed");
  for (double s : speeds()) speed_box_->addItem(QString("%1x").arg(s), s);
  speed_box_->setCurrentIndex(2);
  speed_box_->setToolTip("Playback speed, times real time (0.25x .. 4x)");
  row->addWidget(speed_box_);
  slider_ = new QSlider(Qt::Horizontal);
  slider_->setObjectName("replaySlider");
  slider_->setToolTip("The session's timeline: drag to seek (the nearest snapshot at or before, then re-simulated "
                      "to the tick)");
  connect(slider_, &QSlider::valueChanged, this,
          [this](int v) { seek(static_cast<double>(v) / kSliderStepsPerS); });
  row->addWidget(slider_, 1);
  time_label_ = new QLabel("0:00.000 / 0:00.000");
  time_label_->setObjectName("replayTime");
  time_label_->setToolTip("Time of the tick shown / the session's duration (min:s), and the tick");
  row->addWidget(time_label_);
  leave_button_ = new QPushButton("Back to live");
  leave_button_->setObjectName("replayLeave");
  leave_button_->setToolTip("Leave the replay: the live organ and probes again, the haptic loop running");
  connect(leave_button_, &QPushButton::clicked, this, [this] {
    pause();
    emit leave_requested();
  });
  row->addWidget(leave_button_);
  outer->addLayout(row);
  timer_.setInterval(kStepMs);
  connect(&timer_, &QTimer::timeout, this, &ReplayPanel::step);
  wall_.start();
  sync_controls();
}

ReplayPanel::~ReplayPanel() = default;

void ReplayPanel::open(std::unique_ptr<SessionPlayer> player) {
  pause();
  player_ = std::move(player);
  if (player_) {
    file_label_->setText(QFileInfo(QString::fromStdString(player_->file())).fileName());
    file_label_->setToolTip(QString::fromStdString(player_->file()));
  }
  sync_controls();
  emit moved();
}

void ReplayPanel::close() {
  pause();
  player_.reset();
  file_label_->clear();
  sync_controls();
}

void ReplayPanel::play() {
  if (!player_) return;
  if (player_->at_end()) seek(0);  // play again from the start
  last_wall_ = wall_.nsecsElapsed() * 1e-9;
  timer_.start();
  const QSignalBlocker block(play_button_);
  play_button_->setChecked(true);
  play_button_->setText("Pause");
}

void ReplayPanel::pause() {
  timer_.stop();
  const QSignalBlocker block(play_button_);
  play_button_->setChecked(false);
  play_button_->setText("Play");
}

void ReplayPanel::set_speed(double speed) {
  int best = 0;
  for (int i = 0; i < static_cast<int>(speeds().size()); ++i)
    if (std::abs(speeds()[i] - speed) < std::abs(speeds()[best] - speed)) best = i;
  speed_box_->setCurrentIndex(best);
}

double ReplayPanel::speed() const { return speed_box_->currentData().toDouble(); }

bool ReplayPanel::seek(double seconds) {
  if (!player_) return false;
  try {
    player_->seek(seconds);
  } catch (const std::exception& e) {
    pause();
    emit failed(QString::fromStdString(e.what()));
    return false;
  }
  sync_controls();
  emit moved();
  return true;
}

// One playback step: the wall time since the last one, times the speed.
void ReplayPanel::step() {
  if (!player_) return pause();
  const double now = wall_.nsecsElapsed() * 1e-9;
  const double dt = std::clamp(now - last_wall_, 0.0, kMaxStepS);
  last_wall_ = now;
  try {
    player_->advance(dt * speed());
  } catch (const std::exception& e) {
    pause();
    emit failed(QString::fromStdString(e.what()));
    return;
  }
  if (player_->at_end()) pause();
  sync_controls();
  emit moved();
}

void ReplayPanel::sync_controls() {
  const bool on = player_ != nullptr;
  for (QWidget* w : std::initializer_list<QWidget*>{play_button_, speed_box_, slider_}) w->setEnabled(on);
  const QSignalBlocker block(slider_);
  if (!on) {
    slider_->setRange(0, 0);
    time_label_->setText("0:00.000 / 0:00.000");
    return;
  }
  slider_->setRange(0, static_cast<int>(std::lround(player_->duration() * kSliderStepsPerS)));
  slider_->setValue(static_cast<int>(std::lround(player_->time() * kSliderStepsPerS)));
  time_label_->setText(QString("%1 / %2 (tick %3)")
                           .arg(clock_text(player_->time()), clock_text(player_->duration()))
                           .arg(player_->tick()));
}

}  // namespace palpa::app
