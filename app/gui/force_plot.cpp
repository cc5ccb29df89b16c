// Force-versus-time plot drawn with QPainter. It asks for a repaint only when
// what it shows changed, so an idle window does not repaint it.

#include "app/gui/force_plot.h"

#include <QPainter>
#include <QPainterPath>

#include <algorithm>
#include <cmath>

namespace palpa::app {

ForcePlot::ForcePlot(QWidget* parent) : QWidget(parent) {
  setMinimumHeight(110);
  setObjectName("forcePlot");
  setToolTip(
      "Force on each probe over the last seconds, in the probe's colour (its glyph in the scene has the same); "
      "the dashed line is the force clamp (Material > max force).");
}

QColor ForcePlot::probe_colour(int id) {
  static const QColor colours[] = {QColor(240, 90, 70),  QColor(90, 170, 250), QColor(120, 220, 120),
                                   QColor(240, 200, 70), QColor(200, 120, 240), QColor(80, 220, 210),
                                   QColor(250, 150, 60), QColor(230, 110, 180)};
  constexpr int n = sizeof colours / sizeof colours[0];
  return colours[((id % n) + n) % n];
}

void ForcePlot::add_sample(int probe, double time, double force) {
  auto& s = series_[probe];
  s.push_back({time, force});
  latest_ = std::max(latest_, time);
  // Keep a little more than the window.
  while (!s.empty() && s.front().t < latest_ - 1.2 * window_) s.pop_front();
  update();
}

void ForcePlot::set_probe(int probe, const QString& label, const QColor& colour) {
  Legend& l = legend_[probe];
  if (l.label == label && l.colour == colour) return;
  l = {label, colour};
  update();
}

void ForcePlot::retain(const std::vector<int>& probes) {
  auto keep = [&](int id) { return std::find(probes.begin(), probes.end(), id) != probes.end(); };
  bool changed = false;
  for (auto it = series_.begin(); it != series_.end();)
    if (keep(it->first)) ++it;
    else it = series_.erase(it), changed = true;
  for (auto it = legend_.begin(); it != legend_.end();)
    if (keep(it->first)) ++it;
    else it = legend_.erase(it), changed = true;
  if (changed) update();
}

void ForcePlot::advance_to(double time) {
  if (time <= latest_) return;
  latest_ = time;
  // Only traces move with the time axis.
  bool visible = false;
  for (auto& [id, s] : series_) {
    while (!s.empty() && s.front().t < latest_ - 1.2 * window_) s.pop_front();
    visible = visible || !s.empty();
  }
  if (visible) update();
}

void ForcePlot::set_clamp(double newtons) {
  if (newtons == clamp_) return;
  clamp_ = newtons;
  update();
}

void ForcePlot::clear() {
  series_.clear();
  latest_ = 0;
  update();
}

std::size_t ForcePlot::sample_count(int probe) const {
  auto it = series_.find(probe);
  return it == series_.end() ? 0 : it->second.size();
}

std::vector<int> ForcePlot::probes() const {
  std::vector<int> out;
  for (const auto& [id, s] : series_) out.push_back(id);
  for (const auto& [id, l] : legend_)
    if (!series_.count(id)) out.push_back(id);
  std::sort(out.begin(), out.end());
  return out;
}

QColor ForcePlot::colour(int probe) const {
  auto it = legend_.find(probe);
  return it == legend_.end() ? probe_colour(probe) : it->second.colour;
}

QString ForcePlot::label(int probe) const {
  auto it = legend_.find(probe);
  return it == legend_.end() ? QString("Probe %1").arg(probe) : it->second.label;
}

// The largest force shown and the clamp, rounded up to 1, 2 or 5 x 10^k N.
double ForcePlot::scale() const {
  double fmax = std::max(0.5, clamp_);
  for (const auto& [id, s] : series_)
    for (const Sample& x : s)
      if (x.t >= latest_ - window_) fmax = std::max(fmax, x.f);
  const double mag = std::pow(10.0, std::floor(std::log10(fmax)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= fmax * (1 - 1e-12)) return m * mag;
  return fmax;
}

void ForcePlot::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.setRenderHint(QPainter::Antialiasing);
  p.fillRect(rect(), QColor(25, 27, 33));
  const QRectF area = QRectF(rect()).adjusted(40, 8, -8, -20);
  const double fmax = scale();
  auto y_of = [&](double f) { return area.bottom() - std::min(f / fmax, 1.0) * area.height(); };

  // Axes and labels.
  p.setPen(QColor(90, 95, 105));
  p.drawRect(area);
  p.setPen(QColor(170, 175, 185));
  p.drawText(QRectF(0, area.top() - 6, 36, 14), Qt::AlignRight, QString::number(fmax, 'g', 3) + " N");
  p.drawText(QRectF(0, area.bottom() - 8, 36, 14), Qt::AlignRight, "0");
  p.drawText(QRectF(area.left(), area.bottom() + 2, area.width(), 16), Qt::AlignCenter,
             QString("last %1 s").arg(window_));

  // The clamp: forces above it are cut to it.
  if (clamp_ > 0) {
    const double y = y_of(clamp_);
    p.setPen(QPen(QColor(230, 80, 80), 1.0, Qt::DashLine));
    p.drawLine(QPointF(area.left(), y), QPointF(area.right(), y));
    p.drawText(QRectF(area.left() + 4, y + 1, 120, 14), Qt::AlignLeft | Qt::AlignTop,
               QString("clamp %1 N").arg(QString::number(clamp_, 'g', 3)));
  }

  // One line per probe, in its colour.
  for (const auto& [id, s] : series_) {
    QPainterPath path;
    bool first = true;
    for (const Sample& x : s) {
      if (x.t < latest_ - window_) continue;
      const double px = area.left() + (x.t - (latest_ - window_)) / window_ * area.width();
      const double py = y_of(x.f);
      if (first)
        path.moveTo(px, py), first = false;
      else
        path.lineTo(px, py);
    }
    p.setPen(QPen(colour(id), 1.5));
    p.drawPath(path);
  }

  // Legend, top right: a swatch and the probe's name.
  const QFontMetrics fm = p.fontMetrics();
  double y = area.top() + 4;
  for (int id : probes()) {
    const QString text = label(id);
    const double w = fm.horizontalAdvance(text);
    const QRectF swatch(area.right() - w - 22, y + 3, 12, 3);
    p.fillRect(swatch, colour(id));
    p.setPen(QColor(210, 212, 218));
    p.drawText(QRectF(area.right() - w - 6, y, w + 2, fm.height()), Qt::AlignLeft, text);
    y += fm.height();
  }
}

}  // namespace palpa::app
