// The authored scenario and its undo history (scenario_document.h).

#include "app/gui/scenario_document.h"

namespace palpa::app {

namespace fs = std::filesystem;

ScenarioDocument::ScenarioDocument(QObject* parent) : QObject(parent) {
  connect(&stack_, &QUndoStack::cleanChanged, this, [this](bool clean) { emit modifiedChanged(has_scenario() && !clean); });
}

scenario::Scenario ScenarioDocument::checked(const scenario::Scenario& s) {
  // Relative paths are written against the scenario's own folder and read
  // back against it (absolute ones as they are for a scenario not saved yet).
  // (A scenario not saved yet is named "new scenario" in messages.)
  const std::string text = scenario::to_json_text(s);
  scenario::Scenario c = scenario::parse_scenario(text, s.file.empty() ? fs::path("new scenario") : s.file);
  c.file = s.file;
  return c;
}

void ScenarioDocument::reset(std::optional<scenario::Scenario> s) {
  const bool was_modified = modified();
  stack_.clear();
  scenario_ = std::move(s);
  file_ = scenario_ ? scenario_->file : fs::path();
  stack_.setClean();
  if (was_modified) emit modifiedChanged(false);
  emit changed();
}

QString ScenarioDocument::start_new(const scenario::Scenario& s) {
  scenario::Scenario c;
  try {
    c = checked(s);
    if (applier_) applier_(c);
  } catch (const std::exception& e) {
    const QString text = QString("Could not make the scenario: %1").arg(QString::fromStdString(e.what()));
    emit error(text);
    return text;
  }
  reset(std::move(c));
  return {};
}

QString ScenarioDocument::edit(const QString& text, const std::function<void(scenario::Scenario&)>& edit) {
  if (!scenario_) {
    const QString e = QString("Could not %1: no scenario is open (File > New scenario makes one)").arg(text.toLower());
    emit error(e);
    return e;
  }
  scenario::Scenario after = *scenario_;
  scenario::Scenario c;
  try {
    edit(after);
    c = checked(after);
    c.file = scenario_->file;
    if (c == *scenario_) return {};  // nothing changed: no command
    if (applier_) applier_(c);
  } catch (const std::exception& e) {
    const QString msg = QString("%1 refused: %2").arg(text, QString::fromStdString(e.what()));
    emit error(msg);
    return msg;
  }
  scenario::Scenario before = *scenario_;
  scenario_ = c;
  // The push calls redo(), which skips its first time (applied above).
  stack_.push(new ScenarioCommand(this, text, std::move(before), std::move(c)));
  emit changed();
  return {};
}

bool ScenarioDocument::install(const scenario::Scenario& s) {
  try {
    if (applier_) applier_(s);
  } catch (const std::exception& e) {
    emit error(QString("Could not apply the scenario: %1").arg(QString::fromStdString(e.what())));
    return false;
  }
  scenario_ = s;
  scenario_->file = file_;
  emit changed();
  return true;
}

QString ScenarioDocument::save() {
  if (file_.empty()) return "The scenario has no file yet: use Save As";
  return save_as(file_);
}

QString ScenarioDocument::save_as(const fs::path& path) {
  if (!scenario_) return "No scenario to save";
  try {
    const fs::path target = fs::absolute(path).lexically_normal();
    scenario::save_scenario(*scenario_, target);
    // The document as the file now holds it (relative paths as written there).
    scenario::Scenario saved = scenario::load_scenario(target);
    scenario_ = std::move(saved);
    file_ = target;
  } catch (const std::exception& e) {
    const QString msg = QString("Could not save the scenario: %1").arg(QString::fromStdString(e.what()));
    emit error(msg);
    return msg;
  }
  stack_.setClean();
  emit changed();
  return {};
}

ScenarioCommand::ScenarioCommand(ScenarioDocument* doc, const QString& text, scenario::Scenario before,
                                 scenario::Scenario after)
    : QUndoCommand(text), doc_(doc), before_(std::move(before)), after_(std::move(after)) {}

void ScenarioCommand::undo() { doc_->install(before_); }

void ScenarioCommand::redo() {
  if (first_) {
    first_ = false;
    return;
  }
  doc_->install(after_);
}

}  // namespace palpa::app
