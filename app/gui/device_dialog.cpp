// The Add device dialog, built from the plugins' declared options.

#include "app/gui/device_dialog.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QSpinBox>
#include <QStackedWidget>
#include <QVBoxLayout>

#include <algorithm>
#include <climits>
#include <cmath>

namespace palpa::app {
namespace {

using devices::OptionDescription;

QString q(const std::string& s) { return QString::fromStdString(s); }

// "time_scale" -> "Time scale".
QString label_of(const OptionDescription& d) {
  QString s = q(d.name).replace('_', ' ');
  if (!s.isEmpty()) s[0] = s[0].toUpper();
  return d.required ? s + " *" : s;
}

QString number_text(double v) { return QString::number(v, 'g', 12); }

// Decimals that show `v` exactly (at most 8).
int decimals_for(double v) {
  for (int d = 0; d < 8; ++d) {
    const double scale = std::pow(10.0, d);
    if (std::abs(std::round(v * scale) / scale - v) <= 1e-12 * std::max(1.0, std::abs(v))) return d;
  }
  return 8;
}

bool parse_bool(const QString& v, bool& out) {
  if (v == "1" || v == "true" || v == "yes" || v == "on") return out = true, true;
  if (v == "0" || v == "false" || v == "no" || v == "off") return out = false, true;
  return false;
}

// The tooltip: the plugin's help, then the option as it is written, its
// range, unit and default.
QString tooltip_of(const OptionDescription& d) {
  QString tip = q(d.help);
  QStringList facts;
  facts << "Option " + q(d.name) + (d.required ? " (required)" : "");
  const QString unit = d.unit.empty() ? QString() : " " + q(d.unit);
  if (d.type == PALPA_OPTION_DOUBLE || d.type == PALPA_OPTION_INT)
    facts << QString("range %1 .. %2%3").arg(number_text(d.min), number_text(d.max), unit);
  if (d.type == PALPA_OPTION_CHOICE) {
    QStringList words;
    for (const auto& c : d.choices) words << q(c);
    facts << "one of " + words.join(", ");
  }
  if (!d.default_value.empty()) facts << "default " + q(d.default_value) + unit;
  return tip + "\n" + facts.join("; ");
}

}  // namespace

std::vector<DeviceDialog::Entry> DeviceDialog::discover(const devices::PluginLoader& loader) {
  std::vector<Entry> out;
  for (const std::string& name : loader.available()) {
    try {
      out.push_back({q(name), loader.load(name).options()});
    } catch (const devices::DeviceError&) {
      // gone or changed since it was listed
    }
  }
  return out;
}

DeviceDialog::DeviceDialog(QWidget* parent) : DeviceDialog(discover(devices::PluginLoader()), parent) {}

DeviceDialog::DeviceDialog(std::vector<Entry> plugins, QWidget* parent)
    : QDialog(parent), entries_(std::move(plugins)) {
  setWindowTitle("Add device probe");
  setObjectName("deviceDialog");
  auto* layout = new QVBoxLayout(this);
  auto* top = new QFormLayout;
  kind_ = new QComboBox;
  kind_->setObjectName("devicePlugin");
  kind_->setToolTip(
      "The device plugins this program can load (libpalpa_device_NAME.so in the plugin folders, "
      "plugins/README.md); the form below comes from the options the chosen plugin declares.");
  top->addRow("Device", kind_);
  layout->addLayout(top);
  pages_ = new QStackedWidget;
  fields_.resize(entries_.size());
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    kind_->addItem(entries_[i].name);
    pages_->addWidget(build_page(entries_[i], fields_[i]));
  }
  if (entries_.empty()) {
    auto* none = new QLabel("No device plugin can be loaded: see the plugin folders in plugins/README.md.");
    none->setWordWrap(true);
    pages_->addWidget(none);
  }
  layout->addWidget(pages_, 1);
  connect(kind_, qOverload<int>(&QComboBox::currentIndexChanged), this, [this](int i) {
    pages_->setCurrentIndex(std::max(i, 0));
    update_ok();
  });
  buttons_ = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel);
  buttons_->button(QDialogButtonBox::Ok)->setToolTip("Create the device with these options and add it as a probe");
  buttons_->button(QDialogButtonBox::Cancel)->setToolTip("Close without adding a device");
  connect(buttons_, &QDialogButtonBox::accepted, this, &QDialog::accept);
  connect(buttons_, &QDialogButtonBox::rejected, this, &QDialog::reject);
  layout->addWidget(buttons_);
  if (!select("scripted")) update_ok();
}

QWidget* DeviceDialog::build_page(const Entry& entry, std::vector<Field>& fields) {
  auto* page = new QWidget;
  page->setObjectName("devicePage_" + entry.name);
  auto* form = new QFormLayout(page);
  if (entry.options.empty()) form->addRow(new QLabel("This device takes no options."));
  fields.resize(entry.options.size());
  for (std::size_t i = 0; i < entry.options.size(); ++i) {
    QWidget* row = build_field(entry.name, entry.options[i], fields[i]);
    auto* label = new QLabel(label_of(entry.options[i]));
    label->setToolTip(fields[i].widget->toolTip());
    form->addRow(label, row);
  }
  return page;
}

// One editor per declared option; the row widget returned (a file's row
// holds its Browse button too).
QWidget* DeviceDialog::build_field(const QString& plugin, const OptionDescription& d, Field& field) {
  field.desc = d;
  const QString tip = tooltip_of(d);
  const QString def = q(d.default_value);
  QWidget* row = nullptr;
  switch (d.type) {
    case PALPA_OPTION_DOUBLE: {
      auto* box = new QDoubleSpinBox;
      const double value = def.isEmpty() ? d.min : def.toDouble();
      box->setDecimals(std::clamp(std::max({2, decimals_for(d.min), decimals_for(value)}), 0, 8));
      box->setRange(d.min, d.max);
      const double mag = std::abs(value) > 0 ? std::abs(value) : std::max(std::abs(d.max), 1e-9);
      box->setSingleStep(std::max(std::pow(10.0, std::floor(std::log10(mag))) / 10, std::pow(10.0, -box->decimals())));
      box->setValue(value);
      if (!d.unit.empty()) box->setSuffix(" " + q(d.unit));
      row = field.widget = box;
      break;
    }
    case PALPA_OPTION_INT: {
      auto* box = new QSpinBox;
      box->setRange(static_cast<int>(std::max(d.min, double(INT_MIN))), static_cast<int>(std::min(d.max, double(INT_MAX))));
      box->setValue(def.toInt());
      if (!d.unit.empty()) box->setSuffix(" " + q(d.unit));
      row = field.widget = box;
      break;
    }
    case PALPA_OPTION_BOOL: {
      auto* box = new QCheckBox;
      bool on = false;
      parse_bool(def, on);
      box->setChecked(on);
      row = field.widget = box;
      break;
    }
    case PALPA_OPTION_CHOICE: {
      auto* box = new QComboBox;
      for (const auto& c : d.choices) box->addItem(q(c));
      box->setCurrentText(def);
      row = field.widget = box;
      break;
    }
    case PALPA_OPTION_FILE: {
      row = new QWidget;
      auto* h = new QHBoxLayout(row);
      h->setContentsMargins(0, 0, 0, 0);
      auto* edit = new QLineEdit(def);
      edit->setPlaceholderText(d.required ? "required: choose a file" : "optional");
      auto* browse = new QPushButton("Browse...");
      browse->setObjectName("browse_" + plugin + "_" + q(d.name));
      browse->setToolTip("Choose the file for " + q(d.name));
      h->addWidget(edit, 1);
      h->addWidget(browse);
      const QString title = label_of(d);
      connect(browse, &QPushButton::clicked, this, [this, edit, title] {
        const QString path = QFileDialog::getOpenFileName(this, title, edit->text());
        if (!path.isEmpty()) edit->setText(path);
      });
      if (d.required) connect(edit, &QLineEdit::textChanged, this, &DeviceDialog::update_ok);
      field.widget = edit;
      break;
    }
    default: {  // PALPA_OPTION_STRING and anything newer: free text
      auto* edit = new QLineEdit(def);
      if (d.required) connect(edit, &QLineEdit::textChanged, this, &DeviceDialog::update_ok);
      row = field.widget = edit;
      break;
    }
  }
  field.widget->setObjectName("option_" + plugin + "_" + q(d.name));
  field.widget->setToolTip(tip);
  if (row != field.widget) row->setToolTip(tip);
  return row;
}

QStringList DeviceDialog::plugins() const {
  QStringList out;
  for (const auto& e : entries_) out << e.name;
  return out;
}

QString DeviceDialog::plugin() const { return entries_.empty() ? QString() : kind_->currentText(); }

bool DeviceDialog::select(const QString& plugin) {
  const int i = kind_->findText(plugin);
  if (i < 0) return false;
  kind_->setCurrentIndex(i);
  pages_->setCurrentIndex(i);
  update_ok();
  return true;
}

QWidget* DeviceDialog::field(const QString& plugin, const QString& option) const {
  for (std::size_t i = 0; i < entries_.size(); ++i)
    if (entries_[i].name == plugin)
      for (const Field& f : fields_[i])
        if (q(f.desc.name) == option) return f.widget;
  return nullptr;
}

const std::vector<DeviceDialog::Field>* DeviceDialog::selected_fields() const {
  const int i = kind_->currentIndex();
  return i < 0 || i >= static_cast<int>(fields_.size()) ? nullptr : &fields_[i];
}

bool DeviceDialog::set_value(const QString& option, const QString& value) {
  QWidget* w = field(plugin(), option);
  if (w == nullptr) return false;
  bool ok = true;
  if (auto* box = qobject_cast<QDoubleSpinBox*>(w)) {
    const double v = value.toDouble(&ok);
    if (!ok || v < box->minimum() || v > box->maximum()) return false;
    box->setValue(v);
  } else if (auto* box = qobject_cast<QSpinBox*>(w)) {
    const int v = value.toInt(&ok);
    if (!ok || v < box->minimum() || v > box->maximum()) return false;
    box->setValue(v);
  } else if (auto* box = qobject_cast<QCheckBox*>(w)) {
    bool on = false;
    if (!parse_bool(value, on)) return false;
    box->setChecked(on);
  } else if (auto* box = qobject_cast<QComboBox*>(w)) {
    const int i = box->findText(value);
    if (i < 0) return false;
    box->setCurrentIndex(i);
  } else if (auto* edit = qobject_cast<QLineEdit*>(w)) {
    edit->setText(value);
  }
  return true;
}

QString DeviceDialog::options() const {
  const auto* fields = selected_fields();
  if (fields == nullptr) return {};
  QStringList out;
  for (const Field& f : *fields) {
    const QString key = q(f.desc.name), def = q(f.desc.default_value);
    QString value;
    bool is_default = false;
    if (auto* box = qobject_cast<QDoubleSpinBox*>(f.widget)) {
      value = number_text(box->value());
      is_default = !def.isEmpty() && std::abs(box->value() - def.toDouble()) <= 0.5 * std::pow(10.0, -box->decimals());
    } else if (auto* box = qobject_cast<QSpinBox*>(f.widget)) {
      value = QString::number(box->value());
      is_default = !def.isEmpty() && box->value() == def.toInt();
    } else if (auto* box = qobject_cast<QCheckBox*>(f.widget)) {
      bool on = false;
      value = box->isChecked() ? "true" : "false";
      is_default = parse_bool(def, on) && on == box->isChecked();
    } else if (auto* box = qobject_cast<QComboBox*>(f.widget)) {
      value = box->currentText();
      is_default = value == def;
    } else if (auto* edit = qobject_cast<QLineEdit*>(f.widget)) {
      value = edit->text().trimmed();
      is_default = value == def || (value.isEmpty() && !f.desc.required);
    }
    if (!is_default) out << key + "=" + value;
  }
  return out.join(';');
}

// OK only with every required field filled in.
void DeviceDialog::update_ok() {
  QString missing;
  if (const auto* fields = selected_fields())
    for (const Field& f : *fields)
      if (auto* edit = qobject_cast<QLineEdit*>(f.widget); edit && f.desc.required && edit->text().trimmed().isEmpty())
        missing = q(f.desc.name);
  QPushButton* ok = buttons_->button(QDialogButtonBox::Ok);
  ok->setEnabled(!entries_.empty() && missing.isEmpty());
  ok->setToolTip(missing.isEmpty() ? "Create the device with these options and add it as a probe"
                                   : "Fill in " + missing + " first");
}

}  // namespace palpa::app
