#pragma once
// The assessment report of one recorded session in the workbench: the page
// palpa-assess --html writes (verdict, coverage map on the organ, force plot,
// the numbers and the lesions; docs/ASSESSMENT.md), shown in a window, with
// Save buttons for that page and for the JSON. Qt's rich text has no SVG, so
// the page's force plot is shown as an image drawn from the same curve; the
// page saved is palpa-assess's, byte for byte.

#include "app/replay/session_job.h"

#include <QDialog>
#include <QImage>
#include <QString>
#include <QTextBrowser>

#include <memory>

class QPushButton;

namespace palpa::app {

/// A text browser that also shows `data:` URLs (the report's embedded images).
class ReportView : public QTextBrowser {
  Q_OBJECT
 public:
  using QTextBrowser::QTextBrowser;
  QVariant loadResource(int type, const QUrl& name) override;
};

/// The force plot of a report as an image: the largest |F| (N) against time
/// (s), the force limit (N, 0: none) dashed, `width` x `height` pixels.
QImage force_plot_image(const std::vector<std::pair<double, double>>& curve, double force_limit, int width, int height);

/// The report page as shown in the window: its html with the SVG force plot
/// replaced by force_plot_image as a PNG data URL.
QString report_for_view(const AssessedSession& a);

class AssessmentDialog : public QDialog {
  Q_OBJECT
 public:
  /// `session` is the file assessed (its name heads the window and names
  /// the files offered by Save).
  AssessmentDialog(std::shared_ptr<const AssessedSession> assessment, const QString& session,
                   QWidget* parent = nullptr);

  ReportView* view() const { return view_; }
  const AssessedSession& assessment() const { return *assessment_; }
  /// Write the page (palpa-assess --html's bytes) or the JSON (--json's) to
  /// `file`, through a sibling and a rename so an existing file is replaced
  /// whole or not at all. False with `error` naming the file on failure.
  bool save_html(const QString& file, QString* error = nullptr) const;
  bool save_json(const QString& file, QString* error = nullptr) const;

 private:
  void save_with_dialog(bool html);

  std::shared_ptr<const AssessedSession> assessment_;
  QString session_;
  ReportView* view_ = nullptr;
};

}  // namespace palpa::app
