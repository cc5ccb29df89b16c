// The assessment report in the workbench (assessment_dialog.h).

#include "app/gui/assessment_dialog.h"

#include <QBuffer>
#include <QByteArray>
#include <QDialogButtonBox>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QMessageBox>
#include <QPainter>
#include <QPushButton>
#include <QSaveFile>
#include <QUrl>
#include <QVBoxLayout>

#include <algorithm>

namespace palpa::app {

QVariant ReportView::loadResource(int type, const QUrl& name) {
  if (type == QTextDocument::ImageResource && name.scheme() == "data") {
    // data:image/png;base64,<bytes>
    const QString s = name.toString(QUrl::FullyEncoded);
    const int comma = s.indexOf(',');
    if (comma > 0 && s.left(comma).endsWith(";base64")) {
      QImage image;
      if (image.loadFromData(QByteArray::fromBase64(s.mid(comma + 1).toLatin1()))) return image;
    }
    return {};
  }
  return QTextBrowser::loadResource(type, name);
}

QImage force_plot_image(const std::vector<std::pair<double, double>>& curve, double force_limit, int width, int height) {
  QImage image(width, height, QImage::Format_RGB32);
  image.fill(Qt::white);
  QPainter p(&image);
  p.setRenderHint(QPainter::Antialiasing);
  const QRectF plot(50, 10, width - 60, height - 40);
  p.fillRect(plot, QColor(0xfa, 0xfa, 0xfa));
  p.setPen(QColor(0x99, 0x99, 0x99));
  p.drawRect(plot);
  if (curve.empty()) return image;
  // The same scales as the page's SVG: time to the last bucket, force to
  // 1.25 x the limit or 1.05 x the largest force.
  const double T = std::max(1e-9, curve.back().first);
  double F = force_limit * 1.25;
  for (const auto& [t, f] : curve) F = std::max(F, f * 1.05);
  if (F <= 0) F = 1;
  auto at = [&](double t, double f) {
    return QPointF(plot.left() + plot.width() * t / T, plot.bottom() - plot.height() * f / F);
  };
  if (force_limit > 0) {
    QPen dashed(QColor(0xcc, 0, 0));
    dashed.setDashPattern({6, 4});
    p.setPen(dashed);
    const double y = at(0, force_limit).y();
    p.drawLine(QPointF(plot.left(), y), QPointF(plot.right(), y));
    p.drawText(QPointF(plot.left() + 4, y - 4), QString("force limit %1 N").arg(force_limit, 0, 'g', 3));
  }
  QPolygonF line;
  for (const auto& [t, f] : curve) line << at(t, f);
  p.setPen(QPen(QColor(0, 0x33, 0x66), 1.2));
  p.drawPolyline(line);
  p.setPen(Qt::black);
  p.drawText(QPointF(plot.center().x() - 60, height - 8), QString("time (s), 0 to %1").arg(T, 0, 'g', 4));
  p.drawText(QPointF(4, plot.top() + 12), QString("%1 N").arg(F, 0, 'g', 3));
  return image;
}

QString report_for_view(const AssessedSession& a) {
  QString html = QString::fromStdString(a.html);
  // Qt's rich text sets an image after a paragraph inline with its last line.
  html.replace("</p>\n<img", "</p>\n<p><img");
  const int begin = html.indexOf("<svg");
  const int end = html.indexOf("</svg>", begin);
  if (begin >= 0 && end > begin) {
    QByteArray png;
    QBuffer buffer(&png);
    buffer.open(QIODevice::WriteOnly);
    force_plot_image(a.force_curve, a.force_limit, 860, 280).save(&buffer, "PNG");
    html.replace(begin, end + 6 - begin,
                 QString("<p><img alt=\"force plot\" src=\"data:image/png;base64,%1\"></p>").arg(QString::fromLatin1(png.toBase64())));
  }
  return html;
}

namespace {

bool write_whole(const QString& file, const std::string& bytes, QString* error) {
  QSaveFile out(file);  // a sibling, renamed over the file on commit
  if (!out.open(QIODevice::WriteOnly) ||
      out.write(bytes.data(), static_cast<qint64>(bytes.size())) != static_cast<qint64>(bytes.size()) || !out.commit()) {
    if (error) *error = QString("%1: cannot write (%2)").arg(file, out.errorString());
    return false;
  }
  return true;
}

}  // namespace

AssessmentDialog::AssessmentDialog(std::shared_ptr<const AssessedSession> assessment, const QString& session,
                                   QWidget* parent)
    : QDialog(parent), assessment_(std::move(assessment)), session_(session) {
  setObjectName("assessmentDialog");
  setWindowTitle(QString("Assessment: %1").arg(QFileInfo(session).fileName()));
  auto* layout = new QVBoxLayout(this);
  view_ = new ReportView;
  view_->setObjectName("assessmentView");
  view_->setOpenLinks(false);
  view_->setToolTip("The assessment of the session (definitions: docs/ASSESSMENT.md), as palpa-assess --html writes it");
  view_->setHtml(report_for_view(*assessment_));
  layout->addWidget(view_, 1);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Close);
  auto* html = buttons->addButton("Save report...", QDialogButtonBox::ActionRole);
  html->setObjectName("assessmentSaveHtml");
  html->setToolTip("Save this report as one self-contained HTML page (the same page as palpa-assess --html)");
  auto* json = buttons->addButton("Save numbers...", QDialogButtonBox::ActionRole);
  json->setObjectName("assessmentSaveJson");
  json->setToolTip("Save the report's numbers as JSON (the same file as palpa-assess --json)");
  connect(html, &QPushButton::clicked, this, [this] { save_with_dialog(true); });
  connect(json, &QPushButton::clicked, this, [this] { save_with_dialog(false); });
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  layout->addWidget(buttons);
  resize(960, 800);
}

bool AssessmentDialog::save_html(const QString& file, QString* error) const {
  return write_whole(file, assessment_->html, error);
}

bool AssessmentDialog::save_json(const QString& file, QString* error) const {
  return write_whole(file, assess::to_json(assessment_->report), error);
}

void AssessmentDialog::save_with_dialog(bool html) {
  const QFileInfo info(session_);
  const QString suggested = info.absolutePath() + "/" + info.completeBaseName() + (html ? ".html" : ".json");
  const QString file = QFileDialog::getSaveFileName(this, html ? "Save report" : "Save numbers", suggested,
                                                    html ? "HTML page (*.html)" : "JSON (*.json)");
  if (file.isEmpty()) return;
  QString error;
  if (!(html ? save_html(file, &error) : save_json(file, &error))) QMessageBox::warning(this, "Save", error);
}

}  // namespace palpa::app
