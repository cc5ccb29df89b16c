// The Help menu.

#include "app/gui/help.h"

#include "mesh/organ.h"

#include <QAction>
#include <QDialogButtonBox>
#include <QFile>
#include <QHeaderView>
#include <QMenu>
#include <QMenuBar>
#include <QMainWindow>
#include <QPushButton>
#include <QRegularExpression>
#include <QTableWidget>
#include <QTextBrowser>
#include <QVBoxLayout>
#include <QtGlobal>

#include <vtkVersion.h>

#include <cstdlib>
#include <map>
#include <set>

#ifndef PALPA_VERSION_TEXT
#define PALPA_VERSION_TEXT "unknown"
#endif
#ifndef PALPA_BUILD_TEXT
#define PALPA_BUILD_TEXT "unknown"
#endif

namespace palpa::app {
namespace {

QString plain(QString text) {
  text.remove(QRegularExpression("&(?!&)"));
  return text;
}

// The menu path of every action reachable from the menu bar.
void walk(const QMenu* menu, const QString& path, std::map<const QAction*, QString>& where) {
  for (QAction* a : menu->actions()) {
    if (a->menu()) walk(a->menu(), path + " > " + plain(a->menu()->title()), where);
    else if (!a->isSeparator() && !where.count(a)) where[a] = path;
  }
}

}  // namespace

QStringList shortcut_rows(const QWidget* window) {
  std::map<const QAction*, QString> where;
  if (const auto* mw = qobject_cast<const QMainWindow*>(window))
    for (QAction* top : mw->menuBar()->actions())
      if (top->menu()) walk(top->menu(), plain(top->menu()->title()), where);
  QStringList rows;
  std::set<const QAction*> seen;
  const auto add = [&](const QAction* a) {
    if (seen.count(a) || a->shortcut().isEmpty()) return;
    seen.insert(a);
    const auto it = where.find(a);
    const QString place = it != where.end() ? it->second : QString("Window");
    rows << QString("%1 > %2\t%3").arg(place, plain(a->text()), a->shortcut().toString(QKeySequence::NativeText));
  };
  for (const auto& [a, path] : where) add(a);
  for (const QAction* a : window->findChildren<QAction*>()) add(a);
  rows.sort(Qt::CaseInsensitive);
  return rows;
}

QDialog* make_shortcuts_dialog(QWidget* window) {
  auto* d = new QDialog(window);
  d->setObjectName("shortcutsDialog");
  d->setWindowTitle("Keyboard shortcuts");
  d->setAttribute(Qt::WA_DeleteOnClose);
  auto* layout = new QVBoxLayout(d);
  const QStringList rows = shortcut_rows(window);
  auto* table = new QTableWidget(rows.size(), 2);
  table->setObjectName("shortcutsTable");
  table->setHorizontalHeaderLabels({"Action", "Shortcut"});
  table->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table->verticalHeader()->hide();
  table->horizontalHeader()->setSectionResizeMode(0, QHeaderView::Stretch);
  table->setToolTip("Every action of the window that has a keyboard shortcut");
  for (int r = 0; r < rows.size(); ++r) {
    const QStringList parts = rows[r].split('\t');
    table->setItem(r, 0, new QTableWidgetItem(parts.value(0)));
    table->setItem(r, 1, new QTableWidgetItem(parts.value(1)));
  }
  layout->addWidget(table);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Close);
  buttons->button(QDialogButtonBox::Close)->setToolTip("Close this list");
  QObject::connect(buttons, &QDialogButtonBox::rejected, d, &QDialog::close);
  layout->addWidget(buttons);
  d->resize(560, 520);
  return d;
}

QString user_guide_path() {
  if (const char* dir = std::getenv("PALPA_DOCS_DIR"); dir && *dir) return QString(dir) + "/USER_GUIDE.md";
  return QString::fromStdString((mesh::data_dir().parent_path() / "docs" / "USER_GUIDE.md").string());
}

QDialog* make_user_guide_dialog(QWidget* parent, QString* error) {
  const QString path = user_guide_path();
  QFile file(path);
  if (!file.open(QIODevice::ReadOnly | QIODevice::Text)) {
    if (error) *error = QString("Could not open the user guide %1: %2").arg(path, file.errorString());
    return nullptr;
  }
  auto* d = new QDialog(parent);
  d->setObjectName("userGuideDialog");
  d->setWindowTitle("Palpa user guide");
  d->setAttribute(Qt::WA_DeleteOnClose);
  auto* layout = new QVBoxLayout(d);
  auto* text = new QTextBrowser;
  text->setObjectName("userGuideText");
  text->setToolTip(path);
  text->setMarkdown(QString::fromUtf8(file.readAll()));
  layout->addWidget(text);
  d->resize(760, 820);
  return d;
}

QString about_text() {
  return QString("<h3>Palpa %1</h3>"
                 "<p>A haptic palpation workbench: organs that deform under probes, scenarios with hidden "
                 "lesions, recorded and assessed sessions.</p>"
                 "<p>Build: %2<br>Qt %3 (run time %4), VTK %5</p>"
                 "<p><b>Libraries and their licences</b><ul>"
                 "<li>Qt 5 - LGPL v3</li>"
                 "<li>VTK - BSD 3-clause</li>"
                 "<li>Eigen - MPL 2.0</li>"
                 "<li>OpenMesh - BSD 3-clause</li>"
                 "<li>nanoflann - BSD 2-clause</li>"
                 "<li>nlohmann/json - MIT</li>"
                 "<li>SQLite - public domain</li>"
                 "<li>OpenSSL (libcrypto) - Apache 2.0</li>"
                 "<li>OpenCV - Apache 2.0 (palpa-replay's video)</li>"
                 "<li>GoogleTest - BSD 3-clause (tests only)</li>"
                 "</ul></p>")
      .arg(PALPA_VERSION_TEXT, PALPA_BUILD_TEXT, QT_VERSION_STR, qVersion(), vtkVersion::GetVTKVersion());
}

}  // namespace palpa::app
