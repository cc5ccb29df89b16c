// The session browser (session_browser.h).

#include "app/gui/session_browser.h"

#include "app/gui/assessment_dialog.h"
#include "record/session_file.h"

#include <QDateTime>
#include <QDir>
#include <QFileDialog>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QPushButton>
#include <QTableWidget>
#include <QVBoxLayout>

#include <exception>

namespace palpa::app {
namespace {

enum Column { kFile = 0, kTrainee, kScenario, kDate, kDuration, kScore, kStatus, kColumns };

struct Cancelled {};  // thrown from the replay's callback when the browser goes

}  // namespace

SessionBrowser::SessionBrowser(QWidget* parent) : QWidget(parent) {
  auto* outer = new QVBoxLayout(this);
  auto* row = new QHBoxLayout;
  folder_label_ = new QLabel;
  folder_label_->setObjectName("sessionFolder");
  folder_label_->setWordWrap(true);
  folder_label_->setToolTip("The folder listed");
  row->addWidget(folder_label_, 1);
  auto* pick = new QPushButton("Folder...");
  pick->setObjectName("sessionFolderPick");
  pick->setToolTip("List the sessions of another folder");
  connect(pick, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, "Sessions folder", folder_);
    if (dir.isEmpty()) return;
    set_folder(dir);
    emit folder_changed(folder_);
  });
  row->addWidget(pick);
  auto* again = new QPushButton("Refresh");
  again->setObjectName("sessionRefresh");
  again->setToolTip("Read the folder again (new sessions, changed files)");
  connect(again, &QPushButton::clicked, this, &SessionBrowser::refresh);
  row->addWidget(again);
  auto* open = new QPushButton("Replay");
  open->setObjectName("sessionOpen");
  open->setToolTip("Replay the selected session in the window (or double-click it)");
  connect(open, &QPushButton::clicked, this, [this] {
    const int r = table_->currentRow();
    if (r >= 0 && r < count() && entries_[static_cast<std::size_t>(r)].error.isEmpty())
      emit open_requested(entries_[static_cast<std::size_t>(r)].path);
  });
  row->addWidget(open);
  assessment_button_ = new QPushButton("Assessment");
  assessment_button_->setObjectName("sessionAssessment");
  assessment_button_->setToolTip(
      "Show the selected session's assessment report: coverage map, force plot, numbers and lesions "
      "(sessions with a scenario, once scored)");
  connect(assessment_button_, &QPushButton::clicked, this, [this] { show_assessment(table_->currentRow()); });
  row->addWidget(assessment_button_);
  outer->addLayout(row);

  table_ = new QTableWidget(0, kColumns);
  table_->setObjectName("sessionTable");
  table_->setHorizontalHeaderLabels({"File", "Trainee", "Scenario", "Date (UTC)", "Duration", "Score", "Status"});
  table_->horizontalHeaderItem(kDuration)->setToolTip("Recorded ticks over the tick rate, s");
  table_->horizontalHeaderItem(kScore)->setToolTip(
      "The assessment's score, 0..100% (docs/ASSESSMENT.md), for sessions with a scenario; computed in the "
      "background (a replay of the session when it stores no results); Assessment shows the whole report");
  table_->horizontalHeaderItem(kStatus)->setToolTip("recording, finished or interrupted; or why the file does not open");
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_->setSelectionMode(QAbstractItemView::SingleSelection);
  table_->verticalHeader()->hide();
  table_->horizontalHeader()->setStretchLastSection(true);
  table_->setToolTip("Session files of the folder; double-click one to replay it");
  connect(table_, &QTableWidget::cellDoubleClicked, this, [this](int r, int) {
    if (r >= 0 && r < count() && entries_[static_cast<std::size_t>(r)].error.isEmpty())
      emit open_requested(entries_[static_cast<std::size_t>(r)].path);
  });
  connect(table_, &QTableWidget::currentCellChanged, this, [this] { update_buttons(); });
  outer->addWidget(table_, 1);
  update_buttons();

  worker_ = std::thread([this] { worker_main(); });
}

SessionBrowser::~SessionBrowser() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_.store(true);
    queue_.clear();
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void SessionBrowser::set_folder(const QString& folder) {
  folder_ = QDir(folder).absolutePath();
  folder_label_->setText(folder_);
  refresh_when_shown();
}

void SessionBrowser::refresh_when_shown() {
  stale_ = true;
  if (isVisible()) refresh();
}

void SessionBrowser::showEvent(QShowEvent* event) {
  QWidget::showEvent(event);
  if (stale_) refresh();
}

// The cache key: the file, its size and its modification time (a file
// still being recorded changes both).
QString SessionBrowser::cache_key(const QString& path) {
  const QFileInfo info(path);
  return QString("%1|%2|%3").arg(info.absoluteFilePath()).arg(info.size()).arg(info.lastModified().toMSecsSinceEpoch());
}

void SessionBrowser::refresh() {
  stale_ = false;
  entries_.clear();
  const QDir dir(folder_);
  // Newest first; hidden files (a recorder's ".NAME.creating-PID") are not sessions yet.
  const QFileInfoList files = dir.entryInfoList({"*.palpa"}, QDir::Files, QDir::Time);
  std::vector<std::pair<QString, QString>> jobs;
  for (const QFileInfo& f : files) {
    SessionEntry e;
    e.path = f.absoluteFilePath();
    try {
      // mark = false: opening never writes "interrupted" into anyone's file.
      const record::SessionFile file = record::SessionFile::open(e.path.toStdString(), false);
      const record::SessionHeader& h = file.header();
      e.trainee = QString::fromStdString(h.info.trainee);
      e.organ = QString::fromStdString(h.info.organ);
      e.scenario = h.info.scenario_file.empty()
                       ? QString()
                       : QFileInfo(QString::fromStdString(h.info.scenario_file)).fileName();
      e.date = QString::fromStdString(h.created_utc);
      e.duration = h.config.rate_hz > 0 ? static_cast<double>(h.ticks) / h.config.rate_hz : 0.0;
      e.status = QString::fromStdString(std::string(record::status_name(h.status)));
      if (h.dropped > 0) e.status += QString(", %1 records dropped").arg(h.dropped);
      const bool scorable = !h.info.scenario_json.empty() && h.status != record::SessionStatus::Recording && h.ticks > 0;
      if (scorable) {
        const QString key = cache_key(e.path);
        if (const auto it = scores_.find(key); it != scores_.end()) {
          e.score_state = it->second.ok ? SessionEntry::Score::Done : SessionEntry::Score::Failed;
          e.score = it->second.score;
          e.passed = it->second.passed;
          e.score_error = it->second.error;
          e.assessment = it->second.assessment;
        } else {
          e.score_state = SessionEntry::Score::Pending;
          jobs.emplace_back(key, e.path);
        }
      }
    } catch (const std::exception& ex) {
      e.error = QString::fromStdString(ex.what());
    }
    entries_.push_back(std::move(e));
  }
  table_->setRowCount(count());
  for (int r = 0; r < count(); ++r) fill_row(r);
  table_->resizeColumnsToContents();
  update_buttons();
  if (!jobs.empty()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (auto& j : jobs) {
        bool queued = false;
        for (const auto& q : queue_) queued = queued || q.first == j.first;
        if (queued) continue;
        queue_.push_back(j);
        ++busy_;
      }
    }
    wake_.notify_one();
  }
}

void SessionBrowser::fill_row(int r) {
  const SessionEntry& e = entries_[static_cast<std::size_t>(r)];
  auto put = [&](int c, const QString& text, const QString& tip = QString()) {
    auto* item = new QTableWidgetItem(text);
    item->setToolTip(tip.isEmpty() ? text : tip);
    if (!e.error.isEmpty()) item->setForeground(QColor(0xb0, 0x20, 0x20));
    table_->setItem(r, c, item);
  };
  put(kFile, QFileInfo(e.path).fileName(), e.path);
  if (!e.error.isEmpty()) {
    for (int c = kTrainee; c < kStatus; ++c) put(c, QString());
    put(kStatus, e.error);
    return;
  }
  put(kTrainee, e.trainee);
  put(kScenario, e.scenario.isEmpty() ? QString("(%1)").arg(e.organ) : e.scenario,
      e.scenario.isEmpty() ? QString("No scenario: the organ %1").arg(e.organ) : e.scenario);
  put(kDate, e.date);
  put(kDuration, QString("%1 s").arg(e.duration, 0, 'f', 1));
  switch (e.score_state) {
    case SessionEntry::Score::None: put(kScore, "-", "No scenario to score against (or still recording)"); break;
    case SessionEntry::Score::Pending: put(kScore, "...", "Being computed"); break;
    case SessionEntry::Score::Done:
      put(kScore, QString("%1% %2").arg(100 * e.score, 0, 'f', 0).arg(e.passed ? "pass" : "fail"));
      break;
    case SessionEntry::Score::Failed: put(kScore, "error", e.score_error); break;
  }
  put(kStatus, e.status);
}

int SessionBrowser::row_of(const QString& path) const {
  const QString abs = QFileInfo(path).absoluteFilePath();
  for (int r = 0; r < count(); ++r)
    if (entries_[static_cast<std::size_t>(r)].path == abs) return r;
  return -1;
}

bool SessionBrowser::scores_idle() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.empty() && busy_ == 0;
}

void SessionBrowser::score_done(const QString& key, const QString& path, const ScoreResult& result) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    --busy_;
  }
  scores_[key] = result;
  const int r = row_of(path);
  if (r < 0) return;
  SessionEntry& e = entries_[static_cast<std::size_t>(r)];
  e.score_state = result.ok ? SessionEntry::Score::Done : SessionEntry::Score::Failed;
  e.score = result.score;
  e.passed = result.passed;
  e.score_error = result.error;
  e.assessment = result.assessment;
  fill_row(r);
  update_buttons();
}

void SessionBrowser::update_buttons() {
  const int r = table_->currentRow();
  assessment_button_->setEnabled(r >= 0 && r < count() && entries_[static_cast<std::size_t>(r)].assessment != nullptr);
}

AssessmentDialog* SessionBrowser::show_assessment(int row) {
  if (row < 0 || row >= count()) return nullptr;
  const SessionEntry& e = entries_[static_cast<std::size_t>(row)];
  if (!e.assessment) return nullptr;
  QPointer<AssessmentDialog>& d = dialogs_[e.path];
  if (d && &d->assessment() != e.assessment.get()) {  // the file changed since: a new report
    d->close();
    d = nullptr;
  }
  if (!d) {
    d = new AssessmentDialog(e.assessment, e.path, this);
    d->setAttribute(Qt::WA_DeleteOnClose);
  }
  d->show();
  d->raise();
  d->activateWindow();
  return d;
}

// One file at a time: open, rebuild the model, assess (replaying when the
// file stores no results). Any error is that file's row's; nothing else.
void SessionBrowser::worker_main() {
  for (;;) {
    std::pair<QString, QString> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return quit_.load() || !queue_.empty(); });
      if (quit_.load()) return;
      job = queue_.front();
      queue_.pop_front();
    }
    ScoreResult r;
    try {
      const LoadedSession s = load_session(job.second.toStdString());
      AssessedSession a = assess_session_report(s, job.second.toStdString(), [this](const auto&, auto) {
        if (quit_.load(std::memory_order_relaxed)) throw Cancelled{};
      });
      a.coverage.reset();  // the page holds its picture; the per-vertex arrays are not kept
      r.ok = true;
      r.score = a.report.score;
      r.passed = a.report.passed;
      r.assessment = std::make_shared<const AssessedSession>(std::move(a));
    } catch (const Cancelled&) {
      return;
    } catch (const std::exception& e) {
      r.error = QString::fromStdString(e.what());
    }
    if (quit_.load()) return;
    QMetaObject::invokeMethod(
        this, [this, job, r] { score_done(job.first, job.second, r); }, Qt::QueuedConnection);
  }
}

}  // namespace palpa::app
