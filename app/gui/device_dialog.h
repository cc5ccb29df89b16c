#pragma once
// The Add device dialog: lists the device plugins this program can load
// (PluginLoader::available()) and builds a form for each from the options
// the plugin declares (palpa_device_options, plugins/README.md): a spin box
// with the unit as suffix and the declared range for numbers, a check box
// for booleans, a combo box for choices, a line edit for text and a line
// edit with a Browse button for files; the declared help is each field's
// tooltip. Nothing about a plugin is written here: a new plugin gets its
// form by declaring its options.

#include "devices/loader.h"

#include <QDialog>
#include <QString>
#include <QStringList>

#include <vector>

class QComboBox;
class QDialogButtonBox;
class QStackedWidget;

namespace palpa::app {

class DeviceDialog : public QDialog {
  Q_OBJECT
 public:
  /// A plugin and the options it declares.
  struct Entry {
    QString name;
    std::vector<devices::OptionDescription> options;
  };

  /// The plugins `loader` can load, each with its declarations (a plugin
  /// that fails to load between listing and reading is left out).
  static std::vector<Entry> discover(const devices::PluginLoader& loader);

  /// Offers discover(PluginLoader()); `scripted` is selected when present.
  explicit DeviceDialog(QWidget* parent = nullptr);
  explicit DeviceDialog(std::vector<Entry> plugins, QWidget* parent = nullptr);

  /// The plugins offered, in order.
  QStringList plugins() const;
  /// The selected plugin ("" when none can be loaded).
  QString plugin() const;
  /// Selects a plugin; false when it is not offered.
  bool select(const QString& plugin);
  /// The field of `option` on `plugin`'s form (QDoubleSpinBox, QSpinBox,
  /// QCheckBox, QComboBox or QLineEdit; a file's QLineEdit), null when none.
  QWidget* field(const QString& plugin, const QString& option) const;
  /// Sets a field of the selected plugin from text written as the option
  /// would be given ("0.5", "true", "server", a path); false when the option
  /// is not declared or the text does not fit the field.
  bool set_value(const QString& option, const QString& value);
  /// The selected plugin's options as create() takes them: key=value for
  /// every field that differs from its declared default (files and text
  /// when filled in), joined by ';'.
  QString options() const;

 private:
  struct Field {
    devices::OptionDescription desc;
    QWidget* widget = nullptr;  // the editor (a file's line edit)
  };
  QWidget* build_page(const Entry& entry, std::vector<Field>& fields);
  QWidget* build_field(const QString& plugin, const devices::OptionDescription& d, Field& field);
  const std::vector<Field>* selected_fields() const;
  void update_ok();

  std::vector<Entry> entries_;
  std::vector<std::vector<Field>> fields_;  // per entry
  QComboBox* kind_ = nullptr;
  QStackedWidget* pages_ = nullptr;
  QDialogButtonBox* buttons_ = nullptr;
};

}  // namespace palpa::app
