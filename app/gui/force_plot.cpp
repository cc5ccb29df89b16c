// Force-versus-time plot drawn with QPainter.

#include "app/gui/force_plot.h"

#include <QPainter>
#include <QPainterPath>

#include <algorithm>
#include <cmath>

namespace palpa::app {

ForcePlot::ForcePlot(QWidget* parent) : QWidget(parent) {
  setMinimumHeight(100);
  setObjectName("forcePlot");
}

void ForcePlot::add_sample(int probe, double time, double force) {
  auto& s = series_[probe];
  s.push_back({time, force});
  latest_ = std::max(latest_, time);
  // Keep a little more than the window.
  while (!s.empty() && s.front().t < latest_ - 1.2 * window_) s.pop_front();
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

void ForcePlot::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.setRenderHint(QPainter::Antialiasing);
  p.fillRect(rect(), QColor(25, 27, 33));
  const QRectF area = QRectF(rect()).adjusted(40, 8, -8, -20);

  // Vertical scale: the largest force shown, rounded up to 1, 2 or 5 x 10^k N.
  double fmax = 0.5;
  for (const auto& [id, s] : series_)
    for (const Sample& x : s)
      if (x.t >= latest_ - window_) fmax = std::max(fmax, x.f);
  const double mag = std::pow(10.0, std::floor(std::log10(fmax)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= fmax) {
      fmax = m * mag;
      break;
    }

  // Axes and labels.
  p.setPen(QColor(90, 95, 105));
  p.drawRect(area);
  p.setPen(QColor(170, 175, 185));
  p.drawText(QRectF(0, area.top() - 6, 36, 14), Qt::AlignRight, QString::number(fmax, 'g', 3) + " N");
  p.drawText(QRectF(0, area.bottom() - 8, 36, 14), Qt::AlignRight, "0");
  p.drawText(QRectF(area.left(), area.bottom() + 2, area.width(), 16), Qt::AlignCenter,
             QString("last %1 s").arg(window_));

  // One line per probe.
  static const QColor colors[] = {QColor(240, 90, 70), QColor(90, 170, 250), QColor(120, 220, 120),
                                  QColor(240, 200, 70), QColor(200, 120, 240)};
  int k = 0;
  for (const auto& [id, s] : series_) {
    QPainterPath path;
    bool first = true;
    for (const Sample& x : s) {
      if (x.t < latest_ - window_) continue;
      const double px = area.left() + (x.t - (latest_ - window_)) / window_ * area.width();
      const double py = area.bottom() - std::min(x.f / fmax, 1.0) * area.height();
      if (first)
        path.moveTo(px, py), first = false;
      else
        path.lineTo(px, py);
    }
    p.setPen(QPen(colors[k++ % 5], 1.5));
    p.drawPath(path);
  }
}

}  // namespace palpa::app
