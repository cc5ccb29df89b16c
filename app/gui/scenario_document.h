#pragma once
// The scenario an educator is authoring (docs/USER_GUIDE_AUTHORING.md): a
// scenario::Scenario, the file it is saved to, and the undo history of its
// edits. Every edit is a QUndoCommand holding the scenario before and after;
// the document checks an edit before taking it (the scenario written as the
// file's JSON and read back: every check the reader makes, with its JSON
// pointer in the message) and hands the checked scenario to its applier (the
// window: the running simulation). An edit that fails either step is
// refused: the error is returned and shown, and the document is unchanged.
//
// Values are kept as the file holds them (rounded to the file's 12
// significant digits by the check), so a saved document read back with
// scenario::load_scenario equals the document.

#include "scenario/scenario.h"

#include <QObject>
#include <QString>
#include <QUndoCommand>
#include <QUndoStack>

#include <filesystem>
#include <functional>
#include <optional>

namespace palpa::app {

class ScenarioDocument : public QObject {
  Q_OBJECT
 public:
  /// Runs a scenario in the simulation; throws (with a message for the
  /// user) when it cannot, leaving the simulation as it was.
  using Applier = std::function<void(const scenario::Scenario&)>;

  explicit ScenarioDocument(QObject* parent = nullptr);

  void set_applier(Applier applier) { applier_ = std::move(applier); }

  /// Whether a scenario is open (false on a bare organ).
  bool has_scenario() const { return scenario_.has_value(); }
  /// The scenario (has_scenario() must hold).
  const scenario::Scenario& scenario() const { return *scenario_; }
  /// Where it is saved (empty: never saved).
  std::filesystem::path file() const { return file_; }
  QUndoStack* undo_stack() { return &stack_; }
  /// Changes since the last save (or since it was opened or made).
  bool modified() const { return has_scenario() && !stack_.isClean(); }

  /// Takes a scenario that is already running (opened from a file, or none
  /// for a bare organ): the history is cleared and the document is clean.
  /// Does not apply it.
  void reset(std::optional<scenario::Scenario> s);
  /// Checks `s` (a new scenario, not saved yet), runs it through the
  /// applier and takes it (history cleared). Returns the error, empty on success.
  QString start_new(const scenario::Scenario& s);

  /// An edit of the scenario: `edit` changes a copy; the copy is checked,
  /// applied, and pushed as an undoable command named `text` (the Undo
  /// menu's "Undo <text>"). Returns the error (shown through error()), or
  /// an empty string; on error nothing changes. An edit that changes
  /// nothing pushes no command.
  QString edit(const QString& text, const std::function<void(scenario::Scenario&)>& edit);

  /// Saves to file() / to `path` (atomically, scenario::save_scenario);
  /// the document becomes clean and takes the file as read back. Returns
  /// the error (empty on success); on error the document stays modified.
  QString save();
  QString save_as(const std::filesystem::path& path);

  /// The scenario written as its file and read back: every check the
  /// reader makes, values rounded as the file holds them. Throws
  /// scenario::ScenarioError.
  static scenario::Scenario checked(const scenario::Scenario& s);

 signals:
  /// The scenario changed (an edit, undo, redo, reset or a new one).
  void changed();
  /// An edit, undo or redo could not be made (the text says why).
  void error(const QString& text);
  /// modified() changed.
  void modifiedChanged(bool modified);

 private:
  friend class ScenarioCommand;
  // Applies and takes `s` (used by commands' undo and redo).
  bool install(const scenario::Scenario& s);

  std::optional<scenario::Scenario> scenario_;
  std::filesystem::path file_;
  QUndoStack stack_;
  Applier applier_;
};

/// One edit: the scenario before and after.
class ScenarioCommand : public QUndoCommand {
 public:
  ScenarioCommand(ScenarioDocument* doc, const QString& text, scenario::Scenario before, scenario::Scenario after);
  void undo() override;
  void redo() override;

 private:
  ScenarioDocument* doc_;
  scenario::Scenario before_, after_;
  bool first_ = true;  // the first redo: already applied by ScenarioDocument::edit
};

}  // namespace palpa::app
