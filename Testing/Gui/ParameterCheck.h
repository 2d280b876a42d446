#pragma once
// What the parameter panel shows (issue 27, item 4), for the GUI tests: the selected module's
// every parameter has its name (with its unit) and its whole value in view, without scrolling,
// and the value shown is the one the module runs with.
#include <QAbstractSpinBox>
#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QLabel>
#include <QLineEdit>
#include <QScrollArea>
#include <QScrollBar>
#include <QStyle>
#include <QStyleOptionComboBox>
#include <QStyleOptionFrame>
#include <QTextEdit>

#include <algorithm>
#include <climits>

#include "Interface/Gui/MainWindow.h"
#include "Interface/Gui/ParameterPanel.h"

namespace tetflow::gui {

// Width a QLineEdit has for its text: the style's contents rectangle less the text margins and
// the 2 px QLineEdit keeps on each side.
inline int lineEditRoom(const QLineEdit* le) {
  QStyleOptionFrame opt;
  opt.initFrom(le);
  opt.rect = le->rect();
  opt.lineWidth = le->hasFrame() ? le->style()->pixelMetric(QStyle::PM_DefaultFrameWidth, &opt, le) : 0;
  const QRect r = le->style()->subElementRect(QStyle::SE_LineEditContents, &opt, le).marginsRemoved(le->textMargins());
  return r.width() - 4;
}

// What an editor displays and whether all of it is shown; "" when it is, else why not.
inline QString cutOff(QWidget* w, QString& shown) {
  if (auto* te = qobject_cast<QTextEdit*>(w)) {
    shown = te->toPlainText();
    if (te->verticalScrollBar()->maximum() > 0 || te->horizontalScrollBar()->maximum() > 0 ||
        te->document()->size().height() > te->viewport()->height() + 0.5 ||
        te->document()->idealWidth() > te->viewport()->width() + 0.5)
      return QString("text of %1 x %2 px in a %3 x %4 px box")
          .arg(te->document()->idealWidth()).arg(te->document()->size().height())
          .arg(te->viewport()->width()).arg(te->viewport()->height());
    return {};
  }
  if (auto* sb = qobject_cast<QAbstractSpinBox*>(w)) {
    shown = sb->text();
    const QLineEdit* le = sb->findChild<QLineEdit*>();
    const int need = le->fontMetrics().horizontalAdvance(shown), room = lineEditRoom(le);
    return need <= room ? QString() : QString("%1 px of text in %2 px").arg(need).arg(room);
  }
  if (auto* le = qobject_cast<QLineEdit*>(w)) {
    shown = le->text();
    const int need = le->fontMetrics().horizontalAdvance(shown), room = lineEditRoom(le);
    return need <= room ? QString() : QString("%1 px of text in %2 px").arg(need).arg(room);
  }
  if (auto* cb = qobject_cast<QComboBox*>(w)) {
    shown = cb->currentText();
    QStyleOptionComboBox opt;
    opt.initFrom(cb);
    opt.editable = cb->isEditable();
    opt.currentText = shown;
    const QRect r = cb->style()->subControlRect(QStyle::CC_ComboBox, &opt, QStyle::SC_ComboBoxEditField, cb);
    const int need = cb->fontMetrics().horizontalAdvance(shown);
    return need <= r.width() ? QString() : QString("%1 px of text in %2 px").arg(need).arg(r.width());
  }
  if (auto* ch = qobject_cast<QCheckBox*>(w)) {
    shown = ch->isChecked() ? "true" : "false";
    return {};
  }
  shown.clear();
  return QString("unexpected editor %1").arg(w->metaObject()->className());
}

struct ShownParameters {
  int checked = 0;      // parameters checked so far
  size_t longest = 0;   // the most parameters of a module checked
  int tightest = INT_MAX; // the least height left under a form
  QString tightestAt;

  // Selects module m in `win` and checks what its panel shows; "" or the first problem.
  QString check(MainWindow& win, const ModuleNode& m, const QString& net) {
    win.selectModule(QString::fromStdString(m.id));
    ParameterPanel* p = win.parameters();
    if (p->moduleId() != m.id) return "module " + QString::fromStdString(m.id) + " not selected";
    for (int i = 0; i < 5; ++i) QApplication::processEvents(); // layout settles (heights for widths)
    QScrollArea* scroll = p->scrollArea();
    QWidget* vp = scroll->viewport();
    const QString where = QString("%1 %2 (%3)").arg(net, QString::fromStdString(m.id), QString::fromStdString(m.info->name));
    if (win.size() != QSize(1280, 800))
      return QString("%1: the window is %2 x %3, not the default 1280 x 800").arg(where).arg(win.width()).arg(win.height());
    // The panel lies inside the window, and nothing in it needs scrolling.
    const QRect vpInWindow(vp->mapTo(&win, QPoint(0, 0)), vp->size());
    if (!win.rect().contains(vpInWindow)) return where + ": the panel is not inside the window";
    if (const int over = scroll->horizontalScrollBar()->maximum(); over > 0)
      return QString("%1: the form is %2 px wider than the panel").arg(where).arg(over);
    if (const int over = scroll->verticalScrollBar()->maximum(); over > 0)
      return QString("%1: %2 parameters; the form is %3 px taller than the panel").arg(where).arg(m.info->params.size()).arg(over);
    longest = std::max(longest, m.info->params.size());
    if (const int room = vp->height() - scroll->widget()->sizeHint().height(); room < tightest) {
      tightest = room;
      tightestAt = where;
    }
    for (const ParamSpec& spec : m.info->params) {
      const QString at = where + "." + QString::fromStdString(spec.name);
      QWidget* ed = p->editor(spec.name);
      if (!ed || !ed->isVisible()) return at + ": no visible editor";
      const QRect r(ed->mapTo(vp, QPoint(0, 0)), ed->size());
      if (!vp->rect().contains(r))
        return QString("%1: editor at (%2, %3) %4 x %5 outside the %6 x %7 panel")
            .arg(at).arg(r.x()).arg(r.y()).arg(r.width()).arg(r.height()).arg(vp->width()).arg(vp->height());
      QString shown;
      if (const QString why = cutOff(ed, shown); !why.isEmpty()) return at + ": value '" + shown + "' cut off: " + why;
      // It shows the value the module runs with.
      const QString value = QString::fromStdString(formatParam(spec, m.params.at(spec.name)));
      if (shown != value) return at + ": shows '" + shown + "', runs with '" + value + "'";
      // The name, with its unit, is whole and in view too.
      QLabel* lab = p->label(spec.name);
      if (!lab || !lab->isVisible()) return at + ": no visible name";
      if (!lab->text().startsWith(QString::fromStdString(spec.name))) return at + ": labelled " + lab->text();
      if (!spec.unit.empty() && !lab->text().contains("[" + QString::fromStdString(spec.unit) + "]"))
        return at + ": no unit in " + lab->text();
      if (!vp->rect().contains(QRect(lab->mapTo(vp, QPoint(0, 0)), lab->size()))) return at + ": name outside the panel";
      if (lab->fontMetrics().horizontalAdvance(lab->text()) > lab->contentsRect().width()) return at + ": name cut off";
      ++checked;
    }
    return {};
  }
};

} // namespace tetflow::gui
