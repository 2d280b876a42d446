#include "ParameterPanel.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDir>
#include <QFileDialog>
#include <QFileInfo>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QScrollArea>
#include <QSignalBlocker>
#include <QSpinBox>
#include <QToolButton>
#include <QUndoStack>
#include <QVBoxLayout>

#include <climits>
#include <cmath>

#include "Commands.h"
#include "GuiStyle.h"

namespace tetflow::gui {

QString DoubleSpin::textFromValue(double v) const { return qs(formatDouble(v)); }

double DoubleSpin::valueFromText(const QString& text) const { return text.trimmed().toDouble(); }

QValidator::State DoubleSpin::validate(QString& text, int&) const {
  const QString t = text.trimmed();
  if (t.isEmpty() || t == "-" || t == "+" || t.endsWith('e') || t.endsWith('E') || t.endsWith('.'))
    return QValidator::Intermediate;
  bool ok = false;
  const double v = t.toDouble(&ok);
  if (!ok) return QValidator::Invalid;
  return (v >= minimum() && v <= maximum()) ? QValidator::Acceptable : QValidator::Intermediate;
}

ParameterPanel::ParameterPanel(QUndoStack* undo, QWidget* parent) : QWidget(parent), undo_(undo) {
  auto* lay = new QVBoxLayout(this);
  lay->setContentsMargins(4, 4, 4, 4);
  title_ = new QLabel(tr("No module selected"));
  QFont f = title_->font();
  f.setBold(true);
  title_->setFont(f);
  description_ = new QLabel;
  description_->setWordWrap(true);
  description_->setStyleSheet("color: palette(mid);");
  lay->addWidget(title_);
  lay->addWidget(description_);
  scroll_ = new QScrollArea;
  scroll_->setWidgetResizable(true);
  scroll_->setFrameShape(QFrame::NoFrame);
  lay->addWidget(scroll_, 1);
  newForm();
}

void ParameterPanel::newForm() {
  // Replace the whole form (deleteLater: an editor may be emitting the signal that got us here).
  if (QWidget* old = scroll_->takeWidget()) old->deleteLater();
  form_ = new QWidget;
  formLayout_ = new QFormLayout(form_);
  formLayout_->setFieldGrowthPolicy(QFormLayout::AllNonFixedFieldsGrow);
  scroll_->setWidget(form_);
}

void ParameterPanel::setNetwork(Network* net) {
  net_ = net;
  showModule("");
}

QWidget* ParameterPanel::editor(const std::string& param) const {
  auto it = editors_.find(param);
  return it == editors_.end() ? nullptr : it->second.widget;
}

void ParameterPanel::showModule(const std::string& id) {
  editors_.clear();
  newForm();
  id_.clear();
  const ModuleNode* node = net_ && !id.empty() ? net_->module(id) : nullptr;
  if (!node) {
    title_->setText(tr("No module selected"));
    description_->clear();
    return;
  }
  id_ = id;
  title_->setText(QString("%1  %2").arg(qs(node->info->name), qs(id)));
  // First sentence here, the whole description as tooltip.
  QString desc = qs(node->info->description);
  description_->setToolTip(desc);
  title_->setToolTip(desc);
  if (const int dot = desc.indexOf(". "); dot > 0) desc = desc.left(dot + 1);
  description_->setText(desc);
  if (node->info->params.empty()) formLayout_->addRow(new QLabel(tr("(no parameters)")));

  for (const ParamSpec& spec : node->info->params) {
    Editor ed;
    ed.spec = &spec;
    const std::string pname = spec.name;
    QWidget* field = nullptr;
    switch (spec.type) {
      case ParamType::Bool: {
        auto* cb = new QCheckBox;
        connect(cb, &QCheckBox::toggled, this, [this, pname](bool on) { applyValue(pname, ParamValue(on)); });
        ed.show = [cb](const ParamValue& v) {
          QSignalBlocker b(cb);
          cb->setChecked(std::get<bool>(v));
        };
        field = ed.widget = cb;
        break;
      }
      case ParamType::Int: {
        auto* sb = new QSpinBox;
        sb->setRange(spec.min ? int(std::max<double>(*spec.min, INT_MIN)) : INT_MIN,
                     spec.max ? int(std::min<double>(*spec.max, INT_MAX)) : INT_MAX);
        sb->setKeyboardTracking(false);
        connect(sb, &QSpinBox::valueChanged, this, [this, pname](int v) { applyValue(pname, ParamValue(int64_t(v))); });
        ed.show = [sb](const ParamValue& v) {
          QSignalBlocker b(sb);
          sb->setValue(int(std::get<int64_t>(v)));
        };
        field = ed.widget = sb;
        break;
      }
      case ParamType::Double: {
        auto* sb = new DoubleSpin;
        sb->setDecimals(15);
        const double lo = spec.min ? *spec.min : -1e15, hi = spec.max ? *spec.max : 1e15;
        sb->setRange(lo, hi);
        double step = 0.1;
        if (spec.min && spec.max) step = std::pow(10.0, std::floor(std::log10((hi - lo) / 20.0)));
        else if (const double* d = std::get_if<double>(&spec.defaultValue); d && *d != 0)
          step = std::pow(10.0, std::floor(std::log10(std::abs(*d))));
        sb->setSingleStep(step);
        sb->setKeyboardTracking(false);
        connect(sb, &QDoubleSpinBox::valueChanged, this, [this, pname](double v) { applyValue(pname, ParamValue(v)); });
        ed.show = [sb](const ParamValue& v) {
          QSignalBlocker b(sb);
          sb->setValue(std::get<double>(v));
        };
        field = ed.widget = sb;
        break;
      }
      case ParamType::Enum: {
        auto* combo = new QComboBox;
        for (const auto& c : spec.choices) combo->addItem(qs(c));
        connect(combo, &QComboBox::currentTextChanged, this,
                [this, pname](const QString& t) { applyValue(pname, ParamValue(ss(t))); });
        ed.show = [combo](const ParamValue& v) {
          QSignalBlocker b(combo);
          combo->setCurrentText(qs(std::get<std::string>(v)));
        };
        field = ed.widget = combo;
        break;
      }
      case ParamType::String:
      case ParamType::List: {
        auto* le = new QLineEdit;
        const ParamSpec* sp = &spec;
        connect(le, &QLineEdit::editingFinished, this, [this, pname, le] { applyText(pname, le->text()); });
        ed.show = [le, sp](const ParamValue& v) {
          QSignalBlocker b(le);
          le->setText(qs(formatParam(*sp, v)));
          le->setStyleSheet("");
        };
        ed.widget = le;
        field = le;
        if (spec.isInputPath || spec.isOutputPath) {
          auto* row = new QWidget;
          auto* h = new QHBoxLayout(row);
          h->setContentsMargins(0, 0, 0, 0);
          h->addWidget(le, 1);
          auto* pick = new QToolButton;
          pick->setText("…");
          pick->setToolTip(tr("Choose a file"));
          h->addWidget(pick);
          const bool list = spec.type == ParamType::List, output = spec.isOutputPath;
          connect(pick, &QToolButton::clicked, this, [this, pname, le, list, output] {
            const QString base = net_ && !net_->baseDir().empty() ? qs(net_->baseDir()) : QDir::currentPath();
            QStringList files;
            if (output) files << QFileDialog::getSaveFileName(this, tr("Output file"), base);
            else if (list) files = QFileDialog::getOpenFileNames(this, tr("Input files"), base);
            else files << QFileDialog::getOpenFileName(this, tr("Input file"), base);
            files.removeAll(QString());
            if (files.isEmpty()) return;
            QDir dir(base);
            for (QString& f : files) {
              const QString rel = dir.relativeFilePath(f);
              if (!rel.startsWith("../../..")) f = rel; // keep nets portable
            }
            le->setText(files.join("; "));
            applyText(pname, le->text());
          });
          field = row;
        }
        break;
      }
    }
    QString label = qs(spec.name);
    if (!spec.unit.empty()) label += QString(" [%1]").arg(qs(spec.unit));
    const QString tip = QString("%1\n%2").arg(qs(spec.description), qs(describeAllowed(spec)));
    ed.widget->setToolTip(tip);
    auto* lab = new QLabel(label);
    lab->setToolTip(tip);
    formLayout_->addRow(lab, field);
    ed.show(node->params.at(spec.name));
    editors_[spec.name] = ed;
  }
}

void ParameterPanel::markError(const std::string& param, const QString& error) {
  auto it = editors_.find(param);
  if (it == editors_.end()) return;
  it->second.widget->setStyleSheet(error.isEmpty() ? "" : "background: #7a2e2e;");
  if (!error.isEmpty())
    it->second.widget->setToolTip(error + "\n" + qs(describeAllowed(*it->second.spec)));
}

QString ParameterPanel::applyText(const std::string& param, const QString& text) {
  auto it = editors_.find(param);
  if (!net_ || it == editors_.end()) return tr("no such parameter");
  std::string err;
  auto v = parseParam(*it->second.spec, ss(text), err);
  if (!v) {
    const QString msg = QString("%1.%2: %3").arg(qs(id_), qs(param), qs(err));
    markError(param, msg);
    emit message(msg);
    return msg;
  }
  return applyValue(param, *v);
}

QString ParameterPanel::applyValue(const std::string& param, const ParamValue& value) {
  auto it = editors_.find(param);
  if (!net_ || it == editors_.end()) return tr("no such parameter");
  std::string err;
  if (!checkParam(*it->second.spec, value, err)) {
    const QString msg = QString("%1.%2: %3").arg(qs(id_), qs(param), qs(err));
    markError(param, msg);
    emit message(msg);
    return msg;
  }
  markError(param, {});
  const ModuleNode* node = net_->module(id_);
  if (!node) return tr("module is gone");
  if (node->params.at(param) == value) return {};
  undo_->push(new SetParameterCommand(*net_, id_, param, value));
  return {};
}

void ParameterPanel::onParameterChanged(const QString& id, const QString& param) {
  if (ss(id) != id_ || !net_) return;
  auto it = editors_.find(ss(param));
  const ModuleNode* node = net_->module(id_);
  if (it == editors_.end() || !node) return;
  it->second.show(node->params.at(ss(param)));
  markError(ss(param), {});
}

void ParameterPanel::onModuleRemoved(const QString& id) {
  if (ss(id) == id_) showModule("");
}

} // namespace tetflow::gui
