#pragma once
// The network canvas: a QGraphicsScene that *observes* a tetflow::Network (Network::subscribe)
// and edits it only through undoable commands on the network API.
//
//   ModuleItem  box with title, input ports on the top edge, outputs on the bottom edge
//               (SCIRun's top-to-bottom flow), status colour, progress bar, elapsed time and,
//               while it runs, its current stage with the stage's percent and time left.
//   PortItem    coloured by port type; tooltip "name (Type)"; highlighted while a wire is
//               dragged when Network::checkConnection allows the wire, dimmed when it refuses.
//   WireItem    cubic Bézier from an output to an input, coloured by the output's type.
//   NetworkView zoom (wheel), fit, rubber-band selection, drop target for the palette.
#include <QElapsedTimer>
#include <QGraphicsObject>
#include <QGraphicsPathItem>
#include <QGraphicsScene>
#include <QGraphicsView>
#include <QPointer>
#include <QTimer>

#include <functional>
#include <map>
#include <optional>
#include <string>

#include "Dataflow/Executor.h"
#include "Dataflow/Network.h"
#include "Dataflow/RunProgress.h"

class QUndoStack;

namespace tetflow::gui {

class ModuleItem;
class WireItem;

class PortItem : public QGraphicsItem {
public:
  enum { Type = UserType + 2 };
  PortItem(ModuleItem* module, bool isInput, int index, const PortSpec& spec);
  int type() const override { return Type; }
  QRectF boundingRect() const override;
  void paint(QPainter* p, const QStyleOptionGraphicsItem*, QWidget*) override;

  ModuleItem* module() const { return module_; }
  bool isInput() const { return input_; }
  int index() const { return index_; }
  PortType portType() const { return type_; }
  // Point where wires attach, in scene coordinates.
  QPointF anchor() const;
  // Wire-drag feedback: 0 none, 1 compatible (highlighted), -1 refused (dimmed).
  void setHighlight(int h, const QString& reason = {});
  int highlight() const { return highlight_; }
  QString refusal() const { return refusal_; }

private:
  ModuleItem* module_;
  bool input_;
  int index_;
  PortType type_;
  int highlight_ = 0;
  QString refusal_;
  QString baseTip_;
};

class ModuleItem : public QGraphicsObject {
  Q_OBJECT
public:
  enum { Type = UserType + 1 };
  ModuleItem(const ModuleNode& node);
  int type() const override { return Type; }
  QRectF boundingRect() const override;
  void paint(QPainter* p, const QStyleOptionGraphicsItem*, QWidget*) override;

  const std::string& moduleId() const { return id_; }
  const ModuleInfo& info() const { return *info_; }
  PortItem* inputPort(int i) const { return i >= 0 && i < int(inputs_.size()) ? inputs_[i] : nullptr; }
  PortItem* outputPort(int i) const { return i >= 0 && i < int(outputs_.size()) ? outputs_[i] : nullptr; }
  const std::vector<PortItem*>& inputPorts() const { return inputs_; }
  const std::vector<PortItem*>& outputPorts() const { return outputs_; }

  void setStatus(ModuleStatus s, double seconds = -1);
  ModuleStatus status() const { return status_; }
  void setProgress(const QString& stage, double fraction);
  double progress() const { return progress_; }
  // Called by the scene's timer while running: refreshes the elapsed time, and the stage with
  // its elapsed time and estimate when the run tells them (live).
  void tick(const std::optional<RunProgress::Entry>& live = std::nullopt);
  QString statusText() const;
  // A short figure from the last run shown after the status ("~1.33 M tets": a background's
  // predicted mesh size), with a longer tooltip line; empty clears it.
  void setNote(const QString& shortText, const QString& tip = {});
  const QString& note() const { return note_; }

  void addWire(WireItem* w) { wires_.push_back(w); }
  void removeWire(WireItem* w) { std::erase(wires_, w); }

protected:
  QVariant itemChange(GraphicsItemChange change, const QVariant& value) override;
  void contextMenuEvent(QGraphicsSceneContextMenuEvent* e) override;

private:
  std::string id_;
  const ModuleInfo* info_;
  qreal width_ = 160, height_ = 58;
  std::vector<PortItem*> inputs_, outputs_;
  std::vector<WireItem*> wires_;
  ModuleStatus status_ = ModuleStatus::Idle;
  double progress_ = 0;
  QString stage_;
  std::optional<RunProgress::Entry> live_; // while running, from the run's progress board
  QString baseTip_;
  double seconds_ = -1;
  QElapsedTimer clock_;
  QString note_, noteTip_;
};

class WireItem : public QGraphicsPathItem {
public:
  enum { Type = UserType + 3 };
  WireItem(std::string connectionId, PortItem* from, PortItem* to);
  ~WireItem() override;
  int type() const override { return Type; }
  const std::string& connectionId() const { return id_; }
  PortItem* fromPort() const { return from_; }
  PortItem* toPort() const { return to_; }
  void updatePath();
  void detach(); // forget the ports (their modules are being deleted)
  static QPainterPath curve(QPointF from, QPointF to);

protected:
  void paint(QPainter* p, const QStyleOptionGraphicsItem* o, QWidget* w) override;
  QPainterPath shape() const override;

private:
  std::string id_;
  PortItem* from_;
  PortItem* to_;
};

class NetworkScene : public QGraphicsScene {
  Q_OBJECT
public:
  NetworkScene(QUndoStack* undo, QObject* parent = nullptr);
  ~NetworkScene() override;
  // Observe `net` (nullptr detaches). Rebuilds every item from the model.
  void setNetwork(Network* net);
  Network* network() const { return net_; }
  QUndoStack* undoStack() const { return undo_; }

  ModuleItem* moduleItem(const std::string& id) const;
  WireItem* wireItem(const std::string& connectionId) const;
  const std::map<std::string, ModuleItem*>& moduleItems() const { return modules_; }
  std::vector<std::string> selectedModuleIds() const;

  // Undoable edits (all go through the network API via QUndoStack).
  std::string addModule(const std::string& name, QPointF pos);
  // Connects if Network::checkConnection allows it; otherwise returns the reason (and logs it).
  QString tryConnect(const std::string& from, int fromPort, const std::string& to, int toPort);
  void deleteSelection();

  // Execution feedback (GUI thread).
  void setModuleStatus(const std::string& id, ModuleStatus s, double seconds = -1);
  void setModuleNote(const std::string& id, const QString& shortText, const QString& tip = {});
  void setModuleProgress(const std::string& id, const QString& stage, double fraction);
  // Where the ticker reads a running module's live progress (ExecutionController::liveProgress).
  void setLiveProgressSource(std::function<std::optional<RunProgress::Entry>(const std::string&)> f) {
    liveSource_ = std::move(f);
  }
  void resetStatuses();

  bool isDraggingWire() const { return dragWire_ != nullptr; }

signals:
  void message(const QString& text);           // refusals and other notes for the log
  void moduleContextAction(const QString& id, const QString& action); // "execute", "report", "log"
  void networkChanged();                        // any model event
  void moduleRemoved(const QString& id);
  void parameterChanged(const QString& id, const QString& param);

protected:
  void mousePressEvent(QGraphicsSceneMouseEvent* e) override;
  void mouseMoveEvent(QGraphicsSceneMouseEvent* e) override;
  void mouseReleaseEvent(QGraphicsSceneMouseEvent* e) override;
  void keyPressEvent(QKeyEvent* e) override;

private:
  friend class ModuleItem;
  void onEvent(const NetworkEvent& e);
  void rebuild();
  void createModule(const std::string& id);
  void createWire(const std::string& connectionId);
  void removeModuleItem(const std::string& id);
  void removeWireItem(const std::string& connectionId);
  PortItem* portAt(QPointF scenePos) const;
  void beginWireDrag(PortItem* port, QPointF pos);
  void endWireDrag(QPointF pos);
  void clearHighlights();

  QUndoStack* undo_;
  Network* net_ = nullptr;
  int token_ = 0;
  std::map<std::string, ModuleItem*> modules_;
  std::map<std::string, WireItem*> wires_;
  // wire drag
  PortItem* dragFrom_ = nullptr;
  QGraphicsPathItem* dragWire_ = nullptr;
  // module move: positions at mouse press
  std::map<std::string, QPointF> pressPositions_;
  bool syncing_ = false; // applying a model position to an item
  QTimer ticker_;
  std::function<std::optional<RunProgress::Entry>(const std::string&)> liveSource_;
};

class NetworkView : public QGraphicsView {
  Q_OBJECT
public:
  explicit NetworkView(NetworkScene* scene, QWidget* parent = nullptr);
  void zoomBy(double factor);
  void fitAll();

signals:
  void dropModule(const QString& name, QPointF scenePos);
  void dropFile(const QString& path); // a local file dropped on the canvas (a .srn, a volume)

protected:
  void wheelEvent(QWheelEvent* e) override;
  void dragEnterEvent(QDragEnterEvent* e) override;
  void dragMoveEvent(QDragMoveEvent* e) override;
  void dropEvent(QDropEvent* e) override;
};

inline constexpr const char* kModuleMime = "application/x-tetflow-module";

} // namespace tetflow::gui
