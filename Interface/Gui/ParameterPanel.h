#pragma once
// Parameter panel generated from a module's parameter schema (ParamSpec): spin boxes with the
// declared ranges (unit in the label), combo boxes for enums, check boxes for booleans, line
// edits with a file picker for paths. Every edit is validated (checkParam / parseParam) and goes
// through the network model as an undoable SetParameterCommand; invalid input is refused and
// shown (red field + message), the model stays unchanged.
#include <QDoubleSpinBox>
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

// Shows doubles in their shortest round-trip form (what .srn files hold), not "0.357000".
class DoubleSpin : public QDoubleSpinBox {
  Q_OBJECT
public:
  using QDoubleSpinBox::QDoubleSpinBox;
  QString textFromValue(double v) const override;
  double valueFromText(const QString& text) const override;
  QValidator::State validate(QString& text, int& pos) const override;
};

class ParameterPanel : public QWidget {
  Q_OBJECT
public:
  ParameterPanel(QUndoStack* undo, QWidget* parent = nullptr);
  void setNetwork(Network* net);
  void showModule(const std::string& id); // "" shows nothing
  const std::string& moduleId() const { return id_; }
  QWidget* editor(const std::string& param) const;
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
    std::function<void(const ParamValue&)> show; // model -> widget (signals blocked)
  };
  void newForm();
  void markError(const std::string& param, const QString& error);

  QUndoStack* undo_;
  Network* net_ = nullptr;
  std::string id_;
  QLabel* title_;
  QLabel* description_;
  QScrollArea* scroll_ = nullptr;
  QWidget* form_ = nullptr;
  QFormLayout* formLayout_ = nullptr;
  std::map<std::string, Editor> editors_;
};

} // namespace tetflow::gui
