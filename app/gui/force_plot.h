#pragma once
// Force magnitude against time for each probe over the last seconds.

#include <QColor>
#include <QWidget>

#include <deque>
#include <map>

namespace palpa::app {

class ForcePlot : public QWidget {
  Q_OBJECT
 public:
  explicit ForcePlot(QWidget* parent = nullptr);

  /// Adds a sample: probe id, time (s), force magnitude (N).
  void add_sample(int probe, double time, double force);
  /// Forgets every sample (new organ, reset).
  void clear();
  /// Seconds shown (default 10).
  void set_window(double seconds) { window_ = seconds; }
  /// Samples held for a probe (for tests).
  std::size_t sample_count(int probe) const;

  QSize sizeHint() const override { return {320, 140}; }

 protected:
  void paintEvent(QPaintEvent*) override;

 private:
  struct Sample {
    double t, f;
  };
  std::map<int, std::deque<Sample>> series_;
  double window_ = 10.0;
  double latest_ = 0;
};

}  // namespace palpa::app
