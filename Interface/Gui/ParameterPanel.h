#pragma once
// Parameter panel generated from a module's parameter schema (ParamSpec): spin boxes with the
// declared ranges (unit in the label), combo boxes for enums, check boxes for booleans, wrapping
// text fields (a file picker beside paths) for strings and lists. Every edit is validated
// (checkParam / parseParam) and goes through the network model as an undoable
// SetParameterCommand; invalid input is refused and shown (red field + message), the model stays
// unchanged.
//
// What a module runs with is shown whole: names (with units) in one column, values in the other,
// rows packed tightly; text values wrap onto more lines instead of scrolling sideways, and when
// the panel is made narrower than a name and its value, the value moves under its name.
#include <QDoubleSpinBox>
#include <QSpinBox>
#include <QTextEdit>
#include <QWidget>

#include <functional>
#include <map>
#include <string>

#include "Dataflow/Network.h"

class QUndoStack;
class QFormLayout;
class QLabel;
class QScrollArea;

namespace tetflow::gui {

class ShortText;

// Shows doubles in their shortest round-trip form (what .srn files hold), not "0.357000".
class DoubleSpin : public QDoubleSpinBox {
  Q_OBJECT
public:
  using QDoubleSpinBox::QDoubleSpinBox;
  QString textFromValue(double v) const override;
  double valueFromText(const QString& text) const override;
  QValidator::State validate(QString& text, int& pos) const override;
};

// Integers: sized for the value shown, not for the range's ends (INT_MIN is 11 characters).
class IntSpin : public QSpinBox {
  Q_OBJECT
public:
  using QSpinBox::QSpinBox;
  QSize sizeHint() const override;
  QSize minimumSizeHint() const override;
};

// A one-paragraph text value that wraps instead of scrolling: as tall as its text needs at the
// width it is given (height for width), so a long list or file name is shown whole. Enter and
// leaving the field commit (editingFinished); line breaks typed or pasted become spaces.
class TextValueEdit : public QTextEdit {
  Q_OBJECT
public:
  explicit TextValueEdit(QWidget* parent = nullptr);
  QString text() const { return toPlainText(); }
  void setText(const QString& text);
  bool hasHeightForWidth() const override { return true; }
  int heightForWidth(int width) const override;
  QSize sizeHint() const override;
  QSize minimumSizeHint() const override;

signals:
  void editingFinished();

protected:
  void keyPressEvent(QKeyEvent* e) override;
  void focusOutEvent(QFocusEvent* e) override;
  void resizeEvent(QResizeEvent* e) override;
  void insertFromMimeData(const QMimeData* source) override;
};

class ParameterPanel : public QWidget {
  Q_OBJECT
public:
  ParameterPanel(QUndoStack* undo, QWidget* parent = nullptr);
  void setNetwork(Network* net);
  void showModule(const std::string& id); // "" shows nothing
  const std::string& moduleId() const { return id_; }
  QWidget* editor(const std::string& param) const;
  QLabel* label(const std::string& param) const; // the parameter's name (and unit) in the form
  QScrollArea* scrollArea() const { return scroll_; }
  // Width that shows the names and values of every module in `registry` side by side (the
  // widest name, unit included, beside the widest choice box), in this panel's font.
  int preferredWidth(const ModuleRegistry& registry) const;
  // Validate and apply a value given as text (what typing into the editor does). Returns the
  // error message, or empty when applied (or unchanged).
  QString applyText(const std::string& param, const QString& text);
  QString applyValue(const std::string& param, const ParamValue& value);

public slots:
  void onParameterChanged(const QString& id, const QString& param);
  void onModuleRemoved(const QString& id);

signals:
  void message(const QString& text);

private:
  struct Editor {
    const ParamSpec* spec = nullptr;
    QWidget* widget = nullptr;
    QLabel* label = nullptr;
    std::function<void(const ParamValue&)> show; // model -> widget (signals blocked)
  };
  void newForm();
  void markError(const std::string& param, const QString& error);

  QUndoStack* undo_;
  Network* net_ = nullptr;
  std::string id_;
  QLabel* title_;
  ShortText* description_;
  QScrollArea* scroll_ = nullptr;
  QWidget* form_ = nullptr;
  QFormLayout* formLayout_ = nullptr;
  std::map<std::string, Editor> editors_;
};

} // namespace tetflow::gui
