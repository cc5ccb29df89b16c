#pragma once
// Exam mode's widgets (docs/USER_GUIDE.md, "Exam"): the pressure gauge (the
// selected probe's normal force against the task's force limit, in bands),
// the countdown, the trainee's marks with Delete, Mark and Finish, and the
// result against the truth after Finish; and the dialog that asks a mark's
// size and consistency. The panel holds the exam's state; MainWindow decides
// what the view shows and records the marks.

#include "app/gui/exam.h"

#include <QDialog>
#include <QWidget>

#include <vector>

class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QListWidget;
class QPushButton;

namespace palpa::app {

/// A bar: the force (N, shown) against the limit in four bands.
class PressureGauge : public QWidget {
  Q_OBJECT
 public:
  enum class Band { Light, Medium, Deep, Over };
  explicit PressureGauge(QWidget* parent = nullptr);
  /// The task's force limit, N (> 0).
  void set_limit(double newtons);
  /// The selected probe's normal force, N.
  void set_force(double newtons);
  double force() const { return force_; }
  double limit() const { return limit_; }
  Band band() const { return band_for(force_, limit_); }
  /// Light below 30 % of the limit, medium below 70 %, deep up to the limit, over above it.
  static Band band_for(double force, double limit);
  static QString band_name(Band b);
  QSize sizeHint() const override;

 protected:
  void paintEvent(QPaintEvent* event) override;

 private:
  double force_ = 0, limit_ = 8.0;
};

/// Asks a mark's size (mm) and consistency, as the task's report fields ask.
/// Non-modal: MainWindow shows it and adds the mark when it is accepted.
class MarkDialog : public QDialog {
  Q_OBJECT
 public:
  MarkDialog(bool ask_size, bool ask_consistency, QWidget* parent = nullptr);
  double diameter() const;      ///< m (0 when not asked)
  QString consistency() const;  ///< "soft", "firm", "hard" (empty when not asked)
  QDoubleSpinBox* size_box() const { return size_; }
  QComboBox* consistency_box() const { return consistency_; }

 private:
  QDoubleSpinBox* size_ = nullptr;
  QComboBox* consistency_ = nullptr;
};

class ExamPanel : public QWidget {
  Q_OBJECT
 public:
  explicit ExamPanel(QWidget* parent = nullptr);

  /// A new exam: the countdown from `time_limit` (s, 0: none), the gauge's
  /// limit (N), no marks.
  void start(double time_limit, double force_limit);
  /// Exam time passes (s): the countdown runs; at zero finish_requested().
  /// No effect when no exam runs or it is finished.
  void elapse(double seconds);
  bool running() const { return running_; }
  bool finished() const { return finished_; }
  /// s left (the time limit when there is none... see has_time_limit()).
  double time_left() const { return time_left_; }
  bool has_time_limit() const { return time_limit_ > 0; }
  double elapsed() const { return elapsed_; }
  /// Ends the exam without a result (leaving exam mode).
  void stop();

  void add_mark(const ExamMark& mark);
  void remove_mark(int index);
  const std::vector<ExamMark>& marks() const { return marks_; }
  /// The marks against the truth (Finish); the exam is finished.
  void show_result(const ExamResult& result, const std::vector<tissue::Lesion>& lesions, double tolerance);
  const ExamResult& result() const { return result_; }
  QString result_text() const;
  QString countdown_text() const;

  PressureGauge* gauge() const { return gauge_; }

 signals:
  void mark_requested();
  void finish_requested();
  /// `mark` is the one deleted (it was at `index` in the list).
  void mark_removed(int index, const ExamMark& mark);

 private:
  void refresh_marks();
  void refresh_countdown();

  PressureGauge* gauge_ = nullptr;
  QLabel* countdown_ = nullptr;
  QListWidget* list_ = nullptr;
  QPushButton* mark_ = nullptr;
  QPushButton* delete_ = nullptr;
  QPushButton* finish_ = nullptr;
  QLabel* result_label_ = nullptr;
  std::vector<ExamMark> marks_;
  ExamResult result_;
  double time_limit_ = 0, time_left_ = 0, elapsed_ = 0;
  bool running_ = false, finished_ = false;
};

}  // namespace palpa::app
