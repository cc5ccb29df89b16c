#pragma once
// The session browser: the session files (*.palpa) of a folder, one row each
// with the trainee, the scenario, the date, the duration and the score. A
// file that does not open is listed with its error (record::SessionFile
// names the file and the fault) and never opened for writing: the browser
// opens every file read-only in effect (no "interrupted" mark), so the
// user's sessions are never touched. Scores (modules/assess, for sessions
// with a scenario) are computed one file at a time on a worker thread, a
// replay each when the file stores no results, and cached by file, size and
// modification time. Double-click (or open_requested) opens one for replay;
// Assessment shows a scored session's report (AssessmentDialog).

#include "app/replay/session_job.h"

#include <QPointer>
#include <QString>
#include <QWidget>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

class QLabel;
class QPushButton;
class QTableWidget;

namespace palpa::app {

/// One row of the browser.
struct SessionEntry {
  QString path;        ///< absolute
  QString trainee;
  QString scenario;    ///< the scenario file's name (empty: a bare organ)
  QString organ;
  QString date;        ///< created, UTC (ISO 8601)
  double duration = 0; ///< s (ticks over the tick rate)
  QString status;      ///< recording, finished, interrupted
  QString error;       ///< why the file does not open (empty: it opens)
  enum class Score { None, Pending, Done, Failed };
  Score score_state = Score::None;  ///< None: no scenario (nothing to score against), or a recording
  double score = 0;    ///< 0..1 (Done)
  bool passed = false;
  QString score_error; ///< Failed: why
  /// Done: the whole assessment (its report page, the numbers).
  std::shared_ptr<const AssessedSession> assessment;
};

class AssessmentDialog;

class SessionBrowser : public QWidget {
  Q_OBJECT
 public:
  explicit SessionBrowser(QWidget* parent = nullptr);
  /// Stops the scoring worker (a replay in progress is abandoned).
  ~SessionBrowser() override;

  /// Lists `folder` (now when shown, else when next shown: nothing is read
  /// or scored while the browser is hidden).
  void set_folder(const QString& folder);
  QString folder() const { return folder_; }
  /// Reads the folder again (now, shown or not).
  void refresh();
  /// Reads the folder again now when shown, else when next shown.
  void refresh_when_shown();

  int count() const { return static_cast<int>(entries_.size()); }
  const SessionEntry& entry(int row) const { return entries_.at(static_cast<std::size_t>(row)); }
  /// The row of `path` (absolute or as listed), -1 when not listed.
  int row_of(const QString& path) const;
  /// True when no score is being computed or waits.
  bool scores_idle() const;
  QTableWidget* table() const { return table_; }
  /// Shows the assessment report of `row` (a scored session) in a window of
  /// its own and returns it (one window per session: shown again when
  /// asked again); null when the row has no score yet (or none to have).
  AssessmentDialog* show_assessment(int row);

 signals:
  /// A session was double-clicked (or Open pressed): replay it.
  void open_requested(const QString& path);
  /// The folder changed (the user picked one).
  void folder_changed(const QString& folder);

 private:
  struct ScoreResult {
    bool ok = false;
    double score = 0;
    bool passed = false;
    QString error;
    std::shared_ptr<const AssessedSession> assessment;
  };
  void showEvent(QShowEvent* event) override;
  void fill_row(int row);
  void update_buttons();
  void score_done(const QString& key, const QString& path, const ScoreResult& r);
  void worker_main();
  static QString cache_key(const QString& path);

  QString folder_;
  bool stale_ = true;  // the folder changed since it was last read
  QLabel* folder_label_ = nullptr;
  QTableWidget* table_ = nullptr;
  QPushButton* assessment_button_ = nullptr;
  std::map<QString, QPointer<AssessmentDialog>> dialogs_;  // by file
  std::vector<SessionEntry> entries_;
  std::map<QString, ScoreResult> scores_;  // by cache_key (GUI thread)

  // The scoring worker: a queue of (key, path).
  std::thread worker_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::pair<QString, QString>> queue_;
  int busy_ = 0;  // jobs taken but not answered (GUI thread sets it back)
  std::atomic<bool> quit_{false};
};

}  // namespace palpa::app
