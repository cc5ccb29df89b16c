#pragma once
// File > Prepare organ... (issue 10, docs/PREP.md "In the workbench"): the
// organ shown is prepared (closed, manifold, outward, evenly remeshed to a
// target edge) on a worker thread while the haptic loop keeps running on the
// old organ; a progress dialog follows prep's steps and its Cancel stops the
// preparation at the next step (nothing changes). On success the window
// takes the prepared organ: a bare organ is installed as a new organ; a
// running scenario gets organ.prep set through its authoring document (an
// undoable edit; saving the scenario records the parameters, and opening it
// again rebuilds the same mesh from prep's cache). The report's summary
// (counts before and after, edge CV, Hausdorff distance, volume change)
// goes to the status bar.
//
// The preparation itself runs in scenario::load_scenario_organ (modules/prep
// behind it); no CGAL header reaches the GUI.

#include "mesh/organ.h"
#include "scenario/resolve.h"
#include "scenario/scenario.h"

#include <QObject>
#include <QString>

#include <memory>
#include <optional>
#include <thread>

class QAction;
class QProgressDialog;
class QWidget;

namespace palpa::app {

/// Reads and resolves the scenario file `path` like
/// Workbench::resolve_scenario, but loads (and, with organ.prep not yet in
/// prep's cache, prepares) its organ on a worker thread under a window-modal
/// progress dialog (objectName "openPrepProgress", shown after 0.5 s) with a
/// Cancel button, while the window's event loop, and so its haptic loop and
/// frames, keep running. nullopt when cancelled; throws what
/// Workbench::resolve_scenario throws (messages naming the file).
std::optional<scenario::Resolved> resolve_scenario_with_progress(QWidget* parent, const QString& path);

class MainWindow;

class PrepAction : public QObject {
  Q_OBJECT
 public:
  /// What a finished preparation made.
  struct Result {
    mesh::Organ organ;              ///< the prepared organ, m
    scenario::OrganRef ref;         ///< the organ reference it was made from, with prep set
    scenario::PrepSummary summary;  ///< the report's numbers
  };

  /// The action (objectName "prepareOrgan") is made here; the window puts it in its File menu.
  explicit PrepAction(MainWindow* window);
  /// Cancels a running preparation and waits for its thread.
  ~PrepAction() override;

  QAction* action() const { return action_; }

  /// Asks the target edge length (mm), or the probe radius it is chosen
  /// from, and whether to fit the edge to the shape; then start().
  void ask();
  /// Starts preparing the window's organ (the running scenario's organ file
  /// in its unit, or the bare organ's file) with `spec`. Returns the error,
  /// also shown in the window and sent as failed() (empty: started): bad
  /// parameters ("Could not prepare the organ: the edge length must be from
  /// 0.1 to 100 mm, got -1 mm"), a preparation already running, a replay or
  /// an exam in progress.
  QString start(const scenario::PrepSpec& spec);
  /// Asks the running preparation to stop (at its next step); cancelled()
  /// follows and nothing changes.
  void cancel();
  bool running() const { return job_ != nullptr; }
  /// The last finished preparation (valid after finished()).
  const Result& result() const { return result_; }
  /// The last outcome in words, as the status bar showed it.
  QString last_message() const { return last_message_; }
  /// The progress dialog of the running preparation (null when none).
  QProgressDialog* progress_dialog() const { return dialog_; }

 signals:
  /// A step of the preparation began or ended: its name and the fraction of
  /// the whole preparation done (0..1, never falling).
  void progress(const QString& step, double fraction);
  /// The prepared organ runs; the text is PrepSummary::text().
  void finished(const QString& summary);
  /// The organ could not be prepared or installed; nothing changed.
  void failed(const QString& message);
  /// Cancelled; nothing changed.
  void cancelled();

 private:
  struct Job;
  void on_progress(const std::shared_ptr<Job>& job, const QString& step, double fraction);
  void on_done(const std::shared_ptr<Job>& job);
  void fail(const QString& message);
  void close_dialog();

  MainWindow* window_;
  QAction* action_ = nullptr;
  QProgressDialog* dialog_ = nullptr;
  std::shared_ptr<Job> job_;
  std::thread worker_;
  Result result_;
  QString last_message_;
  double last_fraction_ = 0;
};

}  // namespace palpa::app
