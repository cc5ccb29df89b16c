// File > Prepare organ... (prep_action.h): the question, the worker thread,
// the progress dialog fed from prep's progress callback (queued to the GUI
// thread), cancellation, and handing the prepared organ to the window.

#include "app/gui/prep_action.h"

#include "app/gui/main_window.h"
#include "tissue/tissue.h"

#include <QAction>
#include <QButtonGroup>
#include <QCheckBox>
#include <QDialog>
#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QEventLoop>
#include <QFileInfo>
#include <QFormLayout>
#include <QLabel>
#include <QMetaObject>
#include <QProgressDialog>
#include <QPushButton>
#include <QRadioButton>
#include <QStatusBar>
#include <QVBoxLayout>

#include <algorithm>
#include <atomic>
#include <exception>

namespace palpa::app {

// One preparation: what the worker reads and writes. The GUI thread reads
// the outcome only after the worker posted on_done (and is joined).
struct PrepAction::Job {
  std::atomic<bool> cancel{false};
  scenario::OrganRef ref;   // with prep set
  std::string file;         // names the organ's scenario (or the organ) in messages
  bool scenario = false;    // a scenario was running when it started
  // Outcome.
  mesh::Organ organ;
  scenario::PrepSummary summary;
  bool ok = false, was_cancelled = false;
  std::string error;
};

namespace {

// The reader's message for a bad parameter, in the dialog's words.
QString spec_message(const scenario::PrepSpec& spec) {
  const std::string e = scenario::prep_spec_error(spec);
  if (e.empty()) return {};
  if (e.rfind("edge_mm:", 0) == 0)
    return QString("the edge length must be from %1 to %2 mm, got %3 mm")
        .arg(scenario::kMinPrepEdge * 1e3)
        .arg(scenario::kMaxPrepEdge * 1e3)
        .arg(spec.edge * 1e3);
  if (e.rfind("probe_radius_mm:", 0) == 0)
    return QString("the probe radius must be more than 0 and at most %1 mm, got %2 mm")
        .arg(scenario::kMaxPrepProbeRadius * 1e3)
        .arg(spec.probe_radius * 1e3);
  return QString::fromStdString(e);
}

bool same_organ(const scenario::OrganRef& a, const scenario::OrganRef& b) {
  return a.path == b.path && a.resolved == b.resolved && a.unit == b.unit;
}

}  // namespace

PrepAction::PrepAction(MainWindow* window) : QObject(window), window_(window) {
  action_ = new QAction("&Prepare organ...", this);
  action_->setObjectName("prepareOrgan");
  action_->setToolTip("Repair and remesh the organ (closed, outward, even vertex spacing for the probe) on a "
                      "background thread; a scenario records the parameters when saved");
  connect(action_, &QAction::triggered, this, [this] { ask(); });
}

PrepAction::~PrepAction() {
  if (job_) job_->cancel = true;
  if (worker_.joinable()) worker_.join();
}

void PrepAction::ask() {
  if (running()) {
    if (dialog_) dialog_->raise();
    return;
  }
  const scenario::OrganRef ref = window_->organ_ref();
  scenario::PrepSpec last = ref.prep.value_or(scenario::PrepSpec{});
  double tip = tissue::kDefaultTipRadius, smallest = 0;
  if (const scenario::Resolved* sc = window_->workbench().scenario()) {
    tip = sc->scenario.probe.tip_radius;
    smallest = scenario::smallest_lesion_radius(sc->scenario);
  }

  QDialog dialog(window_);
  dialog.setWindowTitle("Prepare organ");
  auto* layout = new QVBoxLayout(&dialog);
  auto* intro = new QLabel("Repair the organ and remesh it evenly. The simulation keeps running on the current "
                           "organ until the prepared one is ready.");
  intro->setWordWrap(true);
  layout->addWidget(intro);
  auto* form = new QFormLayout;
  auto* by_edge = new QRadioButton("Edge length");
  by_edge->setObjectName("prepByEdge");
  by_edge->setToolTip("Remesh to this target edge length");
  auto* edge = new QDoubleSpinBox;
  edge->setObjectName("prepEdge");
  edge->setToolTip("Target edge length of the prepared surface, mm (0.1 to 100)");
  edge->setRange(scenario::kMinPrepEdge * 1e3, scenario::kMaxPrepEdge * 1e3);
  edge->setDecimals(2);
  edge->setSuffix(" mm");
  edge->setValue(last.edge > 0 ? last.edge * 1e3 : 2.0);
  auto* by_probe = new QRadioButton("From the probe radius");
  by_probe->setObjectName("prepByProbe");
  by_probe->setToolTip("Choose the edge from the probe: a quarter of its radius, at most 1/40 of the organ's size");
  auto* probe = new QDoubleSpinBox;
  probe->setObjectName("prepProbeRadius");
  probe->setToolTip("Radius of the probe tip the mesh is prepared for, mm");
  probe->setRange(0.1, scenario::kMaxPrepProbeRadius * 1e3);
  probe->setDecimals(2);
  probe->setSuffix(" mm");
  probe->setValue((last.probe_radius > 0 ? last.probe_radius : tip) * 1e3);
  auto* lesion = new QDoubleSpinBox;
  lesion->setObjectName("prepLesionRadius");
  lesion->setToolTip("The smallest lesion the mesh must resolve, mm: the edge is at most half of it (0: none; "
                     "filled from the scenario's smallest lesion)");
  lesion->setRange(0, scenario::kMaxPrepProbeRadius * 1e3);
  lesion->setDecimals(2);
  lesion->setSuffix(" mm");
  lesion->setSpecialValueText("none");
  lesion->setValue((last.lesion_radius > 0 ? last.lesion_radius : smallest) * 1e3);
  auto* group = new QButtonGroup(&dialog);
  group->addButton(by_edge);
  group->addButton(by_probe);
  (last.edge > 0 || last.probe_radius == 0 ? by_edge : by_probe)->setChecked(true);
  auto* fit = new QCheckBox("Shorten the edge where the shape needs it (slower)");
  fit->setObjectName("prepFit");
  fit->setToolTip("Up to 3 rounds that shorten the edge while the Hausdorff distance or the volume change misses "
                  "its target");
  fit->setChecked(last.fit_rounds > 0);
  form->addRow(by_edge, edge);
  form->addRow(by_probe, probe);
  form->addRow("Smallest lesion radius", lesion);
  lesion->setEnabled(by_probe->isChecked());
  connect(by_probe, &QRadioButton::toggled, lesion, &QWidget::setEnabled);
  layout->addLayout(form);
  layout->addWidget(fit);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel);
  buttons->button(QDialogButtonBox::Ok)->setText("Prepare");
  buttons->button(QDialogButtonBox::Ok)->setToolTip("Start preparing the organ in the background");
  buttons->button(QDialogButtonBox::Cancel)->setToolTip("Close without preparing");
  layout->addWidget(buttons);
  connect(buttons, &QDialogButtonBox::accepted, &dialog, &QDialog::accept);
  connect(buttons, &QDialogButtonBox::rejected, &dialog, &QDialog::reject);
  if (dialog.exec() != QDialog::Accepted) return;

  scenario::PrepSpec spec = last;
  spec.edge = by_edge->isChecked() ? edge->value() * 1e-3 : 0.0;
  spec.probe_radius = by_edge->isChecked() ? 0.0 : probe->value() * 1e-3;
  spec.lesion_radius = by_edge->isChecked() ? 0.0 : lesion->value() * 1e-3;
  spec.fit_rounds = fit->isChecked() ? std::max(last.fit_rounds, scenario::PrepSpec{}.fit_rounds) : 0;
  start(spec);
}

void PrepAction::fail(const QString& message) {
  last_message_ = message;
  window_->show_error(message);
  emit failed(message);
}

QString PrepAction::start(const scenario::PrepSpec& spec) {
  QString why;
  if (running()) why = "a preparation is already running";
  else if (window_->in_replay()) why = "leave the replay first (Session > Back to live)";
  else if (window_->mode() == WorkbenchMode::Exam) why = "it would change the organ during an exam";
  else if (!window_->workbench().has_organ()) why = "no organ is open";
  else why = spec_message(spec);
  if (!why.isEmpty()) {
    const QString message = "Could not prepare the organ: " + why;
    fail(message);
    return message;
  }

  auto job = std::make_shared<Job>();
  job->ref = window_->organ_ref();
  job->ref.prep = scenario::as_written(spec);  // what the saved scenario will hold: the same cache entry
  job->scenario = window_->workbench().has_scenario();
  const scenario::Resolved* sc = window_->workbench().scenario();
  job->file = sc && !sc->scenario.file.empty() ? sc->scenario.file.string() : job->ref.path;
  job_ = job;
  last_fraction_ = 0;
  if (worker_.joinable()) worker_.join();  // a finished one

  const QString name = QString::fromStdString(window_->workbench().organ().name);
  dialog_ = new QProgressDialog(QString("Preparing %1...").arg(name), "Cancel", 0, 1000, window_);
  dialog_->setObjectName("prepProgress");
  dialog_->setWindowTitle("Prepare organ");
  dialog_->setToolTip("The organ's preparation; the simulation runs on the current organ meanwhile");
  auto* cancel_button = new QPushButton("Cancel");
  cancel_button->setObjectName("prepCancel");
  cancel_button->setToolTip("Stop the preparation at its next step; the organ stays as it is");
  dialog_->setCancelButton(cancel_button);
  dialog_->setWindowModality(Qt::NonModal);
  dialog_->setAutoClose(false);
  dialog_->setAutoReset(false);
  dialog_->setMinimumDuration(0);
  dialog_->setValue(0);
  connect(dialog_, &QProgressDialog::canceled, this, &PrepAction::cancel);
  dialog_->show();
  window_->statusBar()->showMessage(QString("Preparing %1 in the background...").arg(name));

  worker_ = std::thread([this, job] {
    scenario::PrepHooks hooks;
    hooks.cancel = &job->cancel;
    hooks.progress = [this, job](std::string_view step, int index, int count, double fraction) {
      const double done = count > 0 ? (index + std::clamp(fraction, 0.0, 1.0)) / count : 0.0;
      const QString s = QString::fromUtf8(step.data(), static_cast<int>(step.size()));
      QMetaObject::invokeMethod(this, [this, job, s, done] { on_progress(job, s, done); }, Qt::QueuedConnection);
    };
    try {
      job->organ = scenario::load_scenario_organ(job->ref, job->file, hooks, &job->summary);
      job->ok = true;
    } catch (const scenario::PrepCancelled&) {
      job->was_cancelled = true;
    } catch (const std::exception& e) {
      job->error = e.what();
    }
    QMetaObject::invokeMethod(this, [this, job] { on_done(job); }, Qt::QueuedConnection);
  });
  return {};
}

void PrepAction::cancel() {
  if (!job_) return;
  job_->cancel = true;
  if (dialog_) dialog_->setLabelText("Cancelling at the end of the current step...");
}

void PrepAction::on_progress(const std::shared_ptr<Job>& job, const QString& step, double fraction) {
  if (job != job_) return;  // a late report of an earlier preparation
  fraction = std::max(fraction, last_fraction_);
  last_fraction_ = fraction;
  if (dialog_ && !job->cancel) {
    dialog_->setLabelText(QString("Preparing %1: %2").arg(QString::fromStdString(window_->workbench().organ().name), step));
    dialog_->setValue(static_cast<int>(fraction * 1000));
  }
  emit progress(step, fraction);
}

void PrepAction::close_dialog() {
  if (!dialog_) return;
  dialog_->disconnect(this);
  dialog_->close();
  dialog_->deleteLater();
  dialog_ = nullptr;
}

void PrepAction::on_done(const std::shared_ptr<Job>& job) {
  if (job != job_) return;
  if (worker_.joinable()) worker_.join();
  job_.reset();
  close_dialog();

  if (job->was_cancelled || (job->cancel && job->ok)) {  // a cache hit can finish before the cancel is seen
    last_message_ = "Preparation cancelled: the organ is unchanged";
    window_->statusBar()->showMessage(last_message_, 8000);
    emit cancelled();
    return;
  }
  if (!job->ok) {
    fail("Could not prepare the organ: " + QString::fromStdString(job->error));
    return;
  }
  // The window must still show the organ this was made from.
  const scenario::OrganRef now = window_->organ_ref();
  if (!same_organ(now, job->ref) || window_->workbench().has_scenario() != job->scenario) {
    fail("The prepared organ was not used: another organ or scenario was opened while it was being prepared");
    return;
  }
  if (window_->in_replay() || window_->mode() == WorkbenchMode::Exam) {
    fail("The prepared organ was not used: a replay or an exam started while it was being prepared");
    return;
  }
  Result r{job->organ, job->ref, job->summary};
  const QString error = window_->install_prepared_organ(r.organ, r.ref);
  if (!error.isEmpty()) {
    fail("Could not use the prepared organ: " + error);
    return;
  }
  result_ = std::move(r);
  last_message_ = QString::fromStdString(result_.summary.text());
  for (const std::string& w : result_.summary.warnings) last_message_ += "; " + QString::fromStdString(w);
  window_->statusBar()->showMessage(last_message_);
  emit finished(last_message_);
}

// ---------------------------------------------------------------------------
// Opening a scenario whose organ is prepared: the first time, preparation
// takes seconds to minutes; the window stays live and the user may cancel.
std::optional<scenario::Resolved> resolve_scenario_with_progress(QWidget* parent, const QString& path) {
  const std::filesystem::path file = path.toStdString();
  scenario::Scenario sc = scenario::load_scenario(file);  // throws ScenarioError naming the file
  if (!sc.organ.prep) return Workbench::resolve_scenario(file);

  QProgressDialog dialog(QString("Opening %1: loading and preparing its organ...").arg(QFileInfo(path).fileName()),
                         "Cancel", 0, 1000, parent);
  dialog.setObjectName("openPrepProgress");
  dialog.setWindowTitle("Open scenario");
  dialog.setToolTip("The scenario's organ is prepared as its organ.prep says (from prep's cache after the first time)");
  dialog.setWindowModality(Qt::WindowModal);
  dialog.setAutoClose(false);
  dialog.setAutoReset(false);
  dialog.setMinimumDuration(500);
  dialog.setValue(0);
  std::atomic<bool> cancel{false};
  QObject::connect(&dialog, &QProgressDialog::canceled, &dialog, [&] {
    cancel = true;
    dialog.setLabelText("Cancelling at the end of the current step...");
  });

  QEventLoop loop;
  mesh::Organ organ;
  std::exception_ptr error;
  bool cancelled = false;
  std::thread worker([&] {
    scenario::PrepHooks hooks;
    hooks.cancel = &cancel;
    QProgressDialog* d = &dialog;
    hooks.progress = [d](std::string_view step, int index, int count, double fraction) {
      const int value = count > 0 ? static_cast<int>(1000 * (index + std::clamp(fraction, 0.0, 1.0)) / count) : 0;
      const QString s = QString::fromUtf8(step.data(), static_cast<int>(step.size()));
      // Queued to the dialog: dropped if it is gone.
      QMetaObject::invokeMethod(
          d,
          [d, s, value] {
            if (d->wasCanceled()) return;
            d->setLabelText("Preparing the scenario's organ: " + s);
            d->setValue(std::max(d->value(), value));
          },
          Qt::QueuedConnection);
    };
    try {
      organ = scenario::load_scenario_organ(sc.organ, sc.file.empty() ? file.string() : sc.file.string(), hooks);
    } catch (const scenario::PrepCancelled&) {
      cancelled = true;
    } catch (...) {
      error = std::current_exception();
    }
    QMetaObject::invokeMethod(&loop, [&loop] { loop.quit(); }, Qt::QueuedConnection);
  });
  loop.exec();
  worker.join();
  if (cancelled || cancel) return std::nullopt;
  try {
    if (error) std::rethrow_exception(error);
    return scenario::resolve_on(sc, std::move(organ));
  } catch (const scenario::ScenarioError&) {
    throw;
  } catch (const std::exception& e) {
    throw std::runtime_error(file.string() + ": " + e.what());  // as Workbench::resolve_scenario names it
  }
}

}  // namespace palpa::app
