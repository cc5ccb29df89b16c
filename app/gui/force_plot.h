#pragma once
// Force magnitude against time for each probe over the last seconds, each
// probe in its own colour (the colour of its glyph in the scene) and named
// in a legend, with the force clamp drawn as a dashed line. Probes that are
// gone lose their trace and legend entry.

#include <QColor>
#include <QString>
#include <QWidget>

#include <deque>
#include <map>
#include <vector>

namespace palpa::app {

class ForcePlot : public QWidget {
  Q_OBJECT
 public:
  explicit ForcePlot(QWidget* parent = nullptr);

  /// The colour of probe `id`: a fixed palette by id, so a probe keeps its
  /// colour. The window gives each probe's glyph the same colour.
  static QColor probe_colour(int id);

  /// Adds a sample: probe id, time (s), force magnitude (N).
  void add_sample(int probe, double time, double force);
  /// Names a probe in the legend (e.g. "Probe 2 (scripted)") with its colour.
  void set_probe(int probe, const QString& label, const QColor& colour);
  /// Keeps only these probes: the others lose their trace and legend entry.
  void retain(const std::vector<int>& probes);
  /// Moves the time axis on to `time` (s) without a sample.
  void advance_to(double time);
  /// The force clamp (N) drawn as a dashed line (0: none).
  void set_clamp(double newtons);
  double clamp() const { return clamp_; }
  /// Forgets every sample (new organ, reset); the legend stays (retain()
  /// drops the probes that are gone).
  void clear();
  /// Seconds shown (default 10).
  void set_window(double seconds) { window_ = seconds; }

  /// For tests and the window: samples held for a probe, the probes with a
  /// trace or a legend entry, and a probe's colour and legend text.
  std::size_t sample_count(int probe) const;
  std::vector<int> probes() const;
  QColor colour(int probe) const;
  QString label(int probe) const;
  /// The vertical scale (N at the top) the next paint uses.
  double scale() const;

  QSize sizeHint() const override { return {320, 160}; }

 protected:
  void paintEvent(QPaintEvent*) override;

 private:
  struct Sample {
    double t, f;
  };
  struct Legend {
    QString label;
    QColor colour;
  };
  std::map<int, std::deque<Sample>> series_;
  std::map<int, Legend> legend_;
  double window_ = 10.0;
  double latest_ = 0;
  double clamp_ = 0;
};

}  // namespace palpa::app
