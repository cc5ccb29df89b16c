#pragma once
// The workbench's number fields: a QDoubleSpinBox with its object name,
// range, step, decimals, unit suffix and tooltip, reporting a value only
// when editing ends (no keyboard tracking).

#include <QDoubleSpinBox>
#include <QString>

namespace palpa::app {

inline QDoubleSpinBox* make_spin_box(const char* name, double lo, double hi, double step, int decimals,
                                     const QString& suffix, const QString& tip) {
  auto* s = new QDoubleSpinBox;
  s->setObjectName(name);
  s->setRange(lo, hi);
  s->setSingleStep(step);
  s->setDecimals(decimals);
  s->setSuffix(suffix);
  s->setKeyboardTracking(false);
  s->setToolTip(tip);
  return s;
}

}  // namespace palpa::app
