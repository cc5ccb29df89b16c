// Exam mode's widgets.

#include "app/gui/exam_panel.h"

#include <QComboBox>
#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QListWidget>
#include <QPainter>
#include <QPushButton>
#include <QVBoxLayout>

#include <algorithm>
#include <cmath>

namespace palpa::app {
namespace {

constexpr double kLightFraction = 0.3, kMediumFraction = 0.7;

QString mm(double m, int decimals = 1) { return QString::number(m * 1e3, 'f', decimals); }

}  // namespace

// ---------------------------------------------------------------------------
PressureGauge::PressureGauge(QWidget* parent) : QWidget(parent) {
  setObjectName("pressureGauge");
  setMinimumHeight(34);
  setToolTip("Pressure gauge: the selected probe's force along the surface normal, N, against the task's force "
             "limit (light, medium, deep, over the limit)");
}

void PressureGauge::set_limit(double newtons) {
  limit_ = newtons > 0 ? newtons : 8.0;
  update();
}

void PressureGauge::set_force(double newtons) {
  if (newtons == force_) return;
  force_ = newtons;
  update();
}

PressureGauge::Band PressureGauge::band_for(double force, double limit) {
  if (force > limit) return Band::Over;
  if (force >= kMediumFraction * limit) return Band::Deep;
  if (force >= kLightFraction * limit) return Band::Medium;
  return Band::Light;
}

QString PressureGauge::band_name(Band b) {
  switch (b) {
    case Band::Light: return "light";
    case Band::Medium: return "medium";
    case Band::Deep: return "deep";
    case Band::Over: return "over the limit";
  }
  return {};
}

QSize PressureGauge::sizeHint() const { return {240, 40}; }

void PressureGauge::paintEvent(QPaintEvent*) {
  QPainter p(this);
  const QRectF bar(1, 1, width() - 2, height() - 18);
  // The bands over 0 .. 1.25 x the limit.
  const double full = 1.25 * limit_;
  const auto x_of = [&](double f) { return bar.left() + bar.width() * std::clamp(f / full, 0.0, 1.0); };
  const struct {
    double from, to;
    QColor colour;
  } bands[] = {{0, kLightFraction, QColor(200, 230, 200)},
               {kLightFraction, kMediumFraction, QColor(240, 230, 170)},
               {kMediumFraction, 1.0, QColor(245, 200, 150)},
               {1.0, 1.25, QColor(235, 150, 150)}};
  for (const auto& b : bands)
    p.fillRect(QRectF(QPointF(x_of(b.from * limit_), bar.top()), QPointF(x_of(b.to * limit_), bar.bottom())),
               b.colour);
  p.fillRect(QRectF(QPointF(bar.left(), bar.top() + bar.height() * 0.3), QPointF(x_of(force_), bar.bottom() - bar.height() * 0.3)),
             QColor(40, 40, 40));
  p.setPen(Qt::black);
  p.drawRect(bar);
  p.drawText(QRectF(0, bar.bottom() + 1, width(), 16), Qt::AlignLeft | Qt::AlignVCenter,
             QString("%1 N - %2").arg(force_, 0, 'f', 1).arg(band_name(band())));
  p.drawText(QRectF(0, bar.bottom() + 1, width(), 16), Qt::AlignRight | Qt::AlignVCenter,
             QString("limit %1 N").arg(limit_, 0, 'f', 1));
}

// ---------------------------------------------------------------------------
MarkDialog::MarkDialog(bool ask_size, bool ask_consistency, QWidget* parent) : QDialog(parent) {
  setObjectName("markDialog");
  setWindowTitle("Mark a finding");
  auto* form = new QFormLayout(this);
  form->addRow(new QLabel("A finding at the probe's contact point (or tip)."));
  if (ask_size) {
    size_ = new QDoubleSpinBox;
    size_->setObjectName("markSize");
    size_->setRange(0, 200);
    size_->setDecimals(1);
    size_->setSingleStep(1);
    size_->setSuffix(" mm");
    size_->setValue(10);
    size_->setToolTip("The finding's diameter as you feel it, mm");
    form->addRow("Size", size_);
  }
  if (ask_consistency) {
    consistency_ = new QComboBox;
    consistency_->setObjectName("markConsistency");
    consistency_->addItems({"soft", "firm", "hard"});
    consistency_->setCurrentIndex(1);
    consistency_->setToolTip("The finding's consistency as you feel it");
    form->addRow("Consistency", consistency_);
  }
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel);
  buttons->button(QDialogButtonBox::Ok)->setToolTip("Add the mark");
  buttons->button(QDialogButtonBox::Cancel)->setToolTip("No mark");
  connect(buttons, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  form->addRow(buttons);
}

double MarkDialog::diameter() const { return size_ ? size_->value() * 1e-3 : 0.0; }
QString MarkDialog::consistency() const { return consistency_ ? consistency_->currentText() : QString(); }

// ---------------------------------------------------------------------------
ExamPanel::ExamPanel(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  countdown_ = new QLabel;
  countdown_->setObjectName("examCountdown");
  countdown_->setStyleSheet("QLabel { font-size: 16pt; font-weight: bold; }");
  countdown_->setToolTip("Time left for the exam (the task's time limit); at zero the exam finishes");
  layout->addWidget(countdown_);
  gauge_ = new PressureGauge;
  layout->addWidget(gauge_);
  layout->addWidget(new QLabel("Marks (findings):"));
  list_ = new QListWidget;
  list_->setObjectName("examMarks");
  list_->setToolTip("Your findings: position, size and consistency");
  layout->addWidget(list_, 1);
  auto* row = new QHBoxLayout;
  mark_ = new QPushButton("Mark (M)");
  mark_->setObjectName("examMark");
  mark_->setToolTip("Mark a finding at the selected probe's contact point (key M)");
  delete_ = new QPushButton("Delete");
  delete_->setObjectName("examDeleteMark");
  delete_->setToolTip("Delete the selected mark");
  finish_ = new QPushButton("Finish");
  finish_->setObjectName("examFinish");
  finish_->setToolTip("End the exam: your marks against the truth, and the lesions revealed");
  row->addWidget(mark_);
  row->addWidget(delete_);
  row->addWidget(finish_);
  layout->addLayout(row);
  result_label_ = new QLabel;
  result_label_->setObjectName("examResult");
  result_label_->setWordWrap(true);
  result_label_->setTextFormat(Qt::RichText);
  result_label_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(result_label_);
  connect(mark_, &QPushButton::clicked, this, &ExamPanel::mark_requested);
  connect(finish_, &QPushButton::clicked, this, &ExamPanel::finish_requested);
  connect(delete_, &QPushButton::clicked, this, [this] {
    const int row = list_->currentRow();
    if (row >= 0) remove_mark(row);
  });
  refresh_countdown();
  refresh_marks();
}

void ExamPanel::start(double time_limit, double force_limit) {
  time_limit_ = std::max(0.0, time_limit);
  time_left_ = time_limit_;
  elapsed_ = 0;
  running_ = true;
  finished_ = false;
  marks_.clear();
  result_ = {};
  result_label_->clear();
  gauge_->set_limit(force_limit);
  gauge_->set_force(0);
  refresh_marks();
  refresh_countdown();
}

void ExamPanel::stop() {
  running_ = false;
  refresh_marks();
}

void ExamPanel::elapse(double seconds) {
  if (!running_ || finished_ || !(seconds > 0)) return;
  elapsed_ += seconds;
  if (time_limit_ > 0) {
    const int shown = static_cast<int>(std::ceil(time_left_));
    time_left_ = std::max(0.0, time_limit_ - elapsed_);
    if (static_cast<int>(std::ceil(time_left_)) != shown) refresh_countdown();
    if (time_left_ <= 0) emit finish_requested();
  }
}

QString ExamPanel::countdown_text() const { return countdown_->text(); }

void ExamPanel::refresh_countdown() {
  if (finished_) {
    countdown_->setText("Finished");
    return;
  }
  if (time_limit_ <= 0) {
    countdown_->setText("No time limit");
    return;
  }
  const int s = static_cast<int>(std::ceil(time_left_));
  countdown_->setText(QString("%1:%2 left").arg(s / 60).arg(s % 60, 2, 10, QChar('0')));
}

void ExamPanel::add_mark(const ExamMark& mark) {
  marks_.push_back(mark);
  refresh_marks();
  list_->setCurrentRow(static_cast<int>(marks_.size()) - 1);
}

void ExamPanel::remove_mark(int index) {
  if (index < 0 || index >= static_cast<int>(marks_.size()) || finished_) return;
  const ExamMark removed = marks_[static_cast<std::size_t>(index)];
  marks_.erase(marks_.begin() + index);
  refresh_marks();
  emit mark_removed(index, removed);
}

void ExamPanel::refresh_marks() {
  list_->clear();
  for (std::size_t i = 0; i < marks_.size(); ++i) {
    const ExamMark& m = marks_[i];
    QString text = QString("%1. at (%2, %3, %4) mm").arg(i + 1).arg(mm(m.point.x()), mm(m.point.y()), mm(m.point.z()));
    if (m.diameter > 0) text += QString(", %1 mm").arg(mm(m.diameter));
    if (!m.consistency.empty()) text += ", " + QString::fromStdString(m.consistency);
    if (finished_ && i < result_.marks.size())
      text += result_.marks[i].lesion >= 0 ? "  - found" : "  - false positive";
    list_->addItem(text);
  }
  const bool open = running_ && !finished_;
  mark_->setEnabled(open);
  delete_->setEnabled(open && !marks_.empty());
  finish_->setEnabled(open);
}

void ExamPanel::show_result(const ExamResult& result, const std::vector<tissue::Lesion>& lesions, double tolerance) {
  result_ = result;
  finished_ = true;
  QString html = QString("<b>Result:</b> %1 found, %2 false positive(s), %3 missed (within %4 mm of a lesion's "
                         "centre counts)<ul>")
                     .arg(result.found)
                     .arg(result.false_positives)
                     .arg(result.missed)
                     .arg(mm(tolerance));
  for (std::size_t i = 0; i < marks_.size() && i < result.marks.size(); ++i) {
    const ExamMarkResult& r = result.marks[i];
    if (r.lesion < 0) {
      html += QString("<li>Mark %1: false positive</li>").arg(i + 1);
      continue;
    }
    const tissue::Lesion& l = lesions[static_cast<std::size_t>(r.lesion)];
    html += QString("<li>Mark %1: found %2, %3 mm from its centre")
                .arg(i + 1)
                .arg(QString::fromStdString(l.name.empty() ? "lesion " + std::to_string(r.lesion + 1) : l.name).toHtmlEscaped())
                .arg(mm(r.distance));
    if (marks_[i].diameter > 0)
      html += QString(", size %1 mm against %2 mm (error %3 mm)")
                  .arg(mm(marks_[i].diameter), mm(lesion_diameter(l)), mm(r.size_error));
    html += "</li>";
  }
  for (std::size_t k = 0; k < lesions.size() && k < result.lesion_mark.size(); ++k)
    if (result.lesion_mark[k] < 0)
      html += QString("<li>Missed: %1 (%2 mm)</li>")
                  .arg(QString::fromStdString(lesions[k].name.empty() ? "lesion " + std::to_string(k + 1) : lesions[k].name)
                           .toHtmlEscaped())
                  .arg(mm(lesion_diameter(lesions[k])));
  html += "</ul>";
  result_label_->setText(html);
  refresh_marks();
  refresh_countdown();
}

QString ExamPanel::result_text() const { return result_label_->text(); }

}  // namespace palpa::app
