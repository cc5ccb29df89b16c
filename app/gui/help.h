#pragma once
// The Help menu's dialogs: keyboard shortcuts (generated from the window's
// actions, so the list is never out of date), the user guide
// (docs/USER_GUIDE.md shown in a window) and About (version, build, the
// libraries Palpa uses and their licences).

#include <QDialog>
#include <QString>
#include <QStringList>

class QWidget;

namespace palpa::app {

/// "Menu > Action<TAB>Shortcut" for every action of `window` (menus,
/// toolbars, docks) with a shortcut, sorted by menu; ampersands removed.
QStringList shortcut_rows(const QWidget* window);

/// A dialog listing shortcut_rows() in a table (objectName "shortcutsDialog").
QDialog* make_shortcuts_dialog(QWidget* window);

/// Where the user guide is: $PALPA_DOCS_DIR/USER_GUIDE.md if set, else the
/// source tree's docs/USER_GUIDE.md (next to the bundled data).
QString user_guide_path();
/// A window showing the guide (objectName "userGuideDialog"); null with
/// `error` set when the file cannot be read.
QDialog* make_user_guide_dialog(QWidget* parent, QString* error);

/// Version, build and the libraries' licences, as rich text.
QString about_text();

}  // namespace palpa::app
