#include "ParameterPanel.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDir>
#include <QFileDialog>
#include <QFileInfo>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QKeyEvent>
#include <QLabel>
#include <QLineEdit>
#include <QMimeData>
#include <QPainter>
#include <QRegularExpression>
#include <QScrollArea>
#include <QSignalBlocker>
#include <QStyle>
#include <QStyleOptionSpinBox>
#include <QTextLayout>
#include <QToolButton>
#include <QUndoStack>
#include <QVBoxLayout>

#include <climits>
#include <cmath>
#include <memory>

#include "Commands.h"
#include "GuiStyle.h"

namespace tetflow::gui {

namespace {
// A parameter's name in the form: "name [unit]".
QString labelText(const ParamSpec& spec) {
  QString label = qs(spec.name);
  if (!spec.unit.empty()) label += QString(" [%1]").arg(qs(spec.unit));
  return label;
}
} // namespace

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

QSize IntSpin::sizeHint() const {
  // QAbstractSpinBox's hint without the range: the shown text plus room for three more digits.
  ensurePolished();
  const QFontMetrics fm(font());
  const int textWidth = fm.horizontalAdvance(text() + "000") + 2 * 2; // QLineEdit's margins
  QStyleOptionSpinBox opt;
  initStyleOption(&opt);
  const QSize contents(textWidth, QSpinBox::sizeHint().height());
  return style()->sizeFromContents(QStyle::CT_SpinBox, &opt, contents + QSize(2 * fm.height(), 0), this);
}

QSize IntSpin::minimumSizeHint() const { return sizeHint(); }

TextValueEdit::TextValueEdit(QWidget* parent) : QTextEdit(parent) {
  setAcceptRichText(false);
  setLineWrapMode(QTextEdit::WidgetWidth);
  setWordWrapMode(QTextOption::WrapAtWordBoundaryOrAnywhere);
  setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  setVerticalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  setTabChangesFocus(true);
  document()->setDocumentMargin(2);
  QSizePolicy sp(QSizePolicy::Expanding, QSizePolicy::Fixed);
  sp.setHeightForWidth(true);
  setSizePolicy(sp);
  connect(this, &QTextEdit::textChanged, this, [this] { updateGeometry(); });
}

void TextValueEdit::setText(const QString& text) {
  setPlainText(text);
  updateGeometry();
}

int TextValueEdit::heightForWidth(int width) const {
  std::unique_ptr<QTextDocument> doc(document()->clone());
  doc->setDefaultFont(font());
  doc->setTextWidth(std::max(1, width - 2 * frameWidth()));
  return int(std::ceil(doc->size().height())) + 2 * frameWidth();
}

QSize TextValueEdit::sizeHint() const {
  const int w = fontMetrics().averageCharWidth() * 16 + 2 * frameWidth();
  return {w, heightForWidth(width() > 1 ? width() : w)};
}

QSize TextValueEdit::minimumSizeHint() const {
  const int w = fontMetrics().averageCharWidth() * 8 + 2 * frameWidth();
  return {w, heightForWidth(width() > 1 ? width() : w)};
}

void TextValueEdit::keyPressEvent(QKeyEvent* e) {
  if (e->key() == Qt::Key_Return || e->key() == Qt::Key_Enter) {
    emit editingFinished(); // one paragraph: Enter commits, as in a line edit
    return;
  }
  QTextEdit::keyPressEvent(e);
}

void TextValueEdit::focusOutEvent(QFocusEvent* e) {
  QTextEdit::focusOutEvent(e);
  emit editingFinished();
}

void TextValueEdit::resizeEvent(QResizeEvent* e) {
  QTextEdit::resizeEvent(e);
  if (height() != heightForWidth(width())) updateGeometry(); // the text wraps differently now
}

void TextValueEdit::insertFromMimeData(const QMimeData* source) {
  if (!source->hasText()) return;
  QString t = source->text();
  t.replace(QRegularExpression("[\\r\\n]+"), " ");
  insertPlainText(t);
}

// At most `maxLines` lines of wrapped text, the last one elided; the whole text is the tooltip.
class ShortText : public QWidget {
public:
  explicit ShortText(int maxLines) : maxLines_(maxLines) {
    QSizePolicy sp(QSizePolicy::Ignored, QSizePolicy::Fixed);
    sp.setHeightForWidth(true);
    setSizePolicy(sp);
  }
  void setText(const QString& text) {
    text_ = text;
    setToolTip(text);
    updateGeometry();
    update();
  }
  bool hasHeightForWidth() const override { return true; }
  int heightForWidth(int w) const override { return int(lines(w).size()) * fontMetrics().lineSpacing(); }
  QSize sizeHint() const override { return {fontMetrics().averageCharWidth() * 30, heightForWidth(width())}; }
  QSize minimumSizeHint() const override { return {0, heightForWidth(width())}; }

protected:
  void paintEvent(QPaintEvent*) override {
    QPainter p(this);
    p.setPen(palette().color(QPalette::Mid));
    const QFontMetrics fm = fontMetrics();
    int y = fm.ascent();
    for (const QString& line : lines(width())) {
      p.drawText(0, y, line);
      y += fm.lineSpacing();
    }
  }
  void resizeEvent(QResizeEvent*) override { updateGeometry(); }

private:
  QStringList lines(int width) const {
    QStringList out;
    if (text_.isEmpty() || width <= 0) return out;
    QTextLayout layout(text_, font());
    layout.beginLayout();
    for (QTextLine line = layout.createLine(); line.isValid(); line = layout.createLine()) {
      line.setLineWidth(width);
      if (int(out.size()) == maxLines_ - 1) {
        out << fontMetrics().elidedText(text_.mid(line.textStart()).simplified(), Qt::ElideRight, width);
        break;
      }
      out << text_.mid(line.textStart(), line.textLength()).trimmed();
    }
    layout.endLayout();
    return out;
  }
  QString text_;
  int maxLines_;
};

ParameterPanel::ParameterPanel(QUndoStack* undo, QWidget* parent) : QWidget(parent), undo_(undo) {
  auto* lay = new QVBoxLayout(this);
  lay->setContentsMargins(4, 2, 4, 2);
  lay->setSpacing(2);
  title_ = new QLabel(tr("No module selected"));
  QFont f = title_->font();
  f.setBold(true);
  title_->setFont(f);
  description_ = new ShortText(2);
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
  // A name and its value side by side while they fit; in a narrower panel the value goes under
  // its name rather than out of view.
  formLayout_->setRowWrapPolicy(QFormLayout::WrapLongRows);
  formLayout_->setLabelAlignment(Qt::AlignLeft | Qt::AlignVCenter);
  formLayout_->setContentsMargins(2, 2, 2, 2);
  formLayout_->setHorizontalSpacing(6);
  formLayout_->setVerticalSpacing(2);
  scroll_->setWidget(form_);
}

int ParameterPanel::preferredWidth(const ModuleRegistry& registry) const {
  ensurePolished();
  const QFontMetrics fm(font());
  int label = 0, field = 0;
  for (const ModuleInfo* info : registry.all())
    for (const ParamSpec& spec : info->params) {
      label = std::max(label, fm.horizontalAdvance(labelText(spec)));
      if (spec.type == ParamType::Enum) {
        QComboBox probe;
        probe.setFont(font());
        for (const auto& c : spec.choices) probe.addItem(qs(c));
        field = std::max(field, probe.minimumSizeHint().width());
      }
    }
  // Margins: the panel's and the form's (2 x (4 + 2)), the column gap (6) and a few pixels for
  // the label's own margins.
  return label + 6 + field + 2 * (4 + 2) + 4;
}

void ParameterPanel::setNetwork(Network* net) {
  net_ = net;
  showModule("");
}

QWidget* ParameterPanel::editor(const std::string& param) const {
  auto it = editors_.find(param);
  return it == editors_.end() ? nullptr : it->second.widget;
}

QLabel* ParameterPanel::label(const std::string& param) const {
  auto it = editors_.find(param);
  return it == editors_.end() ? nullptr : it->second.label;
}

void ParameterPanel::showModule(const std::string& id) {
  editors_.clear();
  newForm();
  id_.clear();
  const ModuleNode* node = net_ && !id.empty() ? net_->module(id) : nullptr;
  if (!node) {
    title_->setText(tr("No module selected"));
    description_->setText({});
    return;
  }
  id_ = id;
  title_->setText(QString("%1  %2").arg(qs(node->info->name), qs(id)));
  // First sentence here, the whole description as tooltip.
  QString desc = qs(node->info->description);
  title_->setToolTip(desc);
  // The first sentence, in at most two lines; the whole description as tooltip.
  if (const int dot = desc.indexOf(". "); dot > 0) desc = desc.left(dot + 1);
  description_->setText(desc);
  description_->setToolTip(qs(node->info->description));
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
        auto* sb = new IntSpin;
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
        auto* le = new TextValueEdit;
        const ParamSpec* sp = &spec;
        connect(le, &TextValueEdit::editingFinished, this, [this, pname, le] { applyText(pname, le->text()); });
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
    const QString label = labelText(spec);
    const QString tip = QString("%1\n%2").arg(qs(spec.description), qs(describeAllowed(spec)));
    ed.widget->setToolTip(tip);
    auto* lab = new QLabel(label);
    lab->setToolTip(tip);
    ed.label = lab;
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
