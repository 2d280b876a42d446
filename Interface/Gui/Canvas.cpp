#include "Canvas.h"

#include <QApplication>
#include <QDragEnterEvent>
#include <QGraphicsSceneContextMenuEvent>
#include <QGraphicsSceneMouseEvent>
#include <QKeyEvent>
#include <QMenu>
#include <QMimeData>
#include <QPainter>
#include <QStyleOptionGraphicsItem>
#include <QUndoStack>
#include <QWheelEvent>

#include <algorithm>
#include <cmath>

#include "Commands.h"
#include "GuiStyle.h"

namespace tetflow::gui {

namespace {
constexpr qreal kPortPitch = 24;
constexpr qreal kPortFirst = 16;
constexpr qreal kTitleH = 22;

QString portTip(const PortSpec& spec, bool input) {
  QString types;
  for (PortType t : spec.accepts) types += (types.isEmpty() ? "" : " or ") + QString(portTypeName(t));
  QString tip = QString("%1 %2 (%3)").arg(input ? "input" : "output", qs(spec.name), types);
  if (!spec.description.empty()) tip += "\n" + qs(spec.description);
  if (spec.optional) tip += "\n(optional)";
  return tip;
}
} // namespace

// ---------------------------------------------------------------- PortItem
PortItem::PortItem(ModuleItem* module, bool isInput, int index, const PortSpec& spec)
    : QGraphicsItem(module), module_(module), input_(isInput), index_(index), type_(spec.type()) {
  baseTip_ = portTip(spec, isInput);
  setToolTip(baseTip_);
  setAcceptHoverEvents(true);
  setZValue(1);
}

QRectF PortItem::boundingRect() const { return QRectF(-9, -7, 18, 14); }

void PortItem::paint(QPainter* p, const QStyleOptionGraphicsItem*, QWidget*) {
  QColor c = portColor(type_);
  QRectF r(-7, -4, 14, 8);
  QPen pen(QColor(20, 20, 20), 1);
  if (highlight_ > 0) {
    r = QRectF(-9, -6, 18, 12);
    pen = QPen(Qt::white, 2);
  } else if (highlight_ < 0) {
    c.setAlpha(60);
    pen.setColor(QColor(20, 20, 20, 60));
  }
  p->setPen(pen);
  p->setBrush(c);
  p->drawRoundedRect(r, 2, 2);
}

QPointF PortItem::anchor() const { return scenePos() + QPointF(0, input_ ? -4 : 4); }

void PortItem::setHighlight(int h, const QString& reason) {
  highlight_ = h;
  refusal_ = reason;
  setToolTip(reason.isEmpty() ? baseTip_ : baseTip_ + "\n" + reason);
  update();
}

// ---------------------------------------------------------------- ModuleItem
ModuleItem::ModuleItem(const ModuleNode& node) : id_(node.id), info_(node.info) {
  setFlags(ItemIsMovable | ItemIsSelectable | ItemSendsGeometryChanges);
  setAcceptHoverEvents(true);
  QFont f = QApplication::font();
  f.setBold(true);
  const qreal titleW = QFontMetricsF(f).horizontalAdvance(qs(info_->name)) + 50;
  const size_t ports = std::max(info_->inputs.size(), info_->outputs.size());
  width_ = std::max<qreal>({160.0, titleW, kPortFirst * 2 + kPortPitch * qreal(ports)});
  for (size_t i = 0; i < info_->inputs.size(); ++i) {
    auto* p = new PortItem(this, true, int(i), info_->inputs[i]);
    p->setPos(kPortFirst + kPortPitch * qreal(i), 0);
    inputs_.push_back(p);
  }
  for (size_t i = 0; i < info_->outputs.size(); ++i) {
    auto* p = new PortItem(this, false, int(i), info_->outputs[i]);
    p->setPos(kPortFirst + kPortPitch * qreal(i), height_);
    outputs_.push_back(p);
  }
  baseTip_ = QString("%1 (%2)\n%3").arg(qs(id_), qs(info_->name), qs(info_->description));
  setToolTip(baseTip_);
  setPos(node.x, node.y);
}

QRectF ModuleItem::boundingRect() const { return QRectF(-3, -3, width_ + 6, height_ + 6); }

QString ModuleItem::statusText() const {
  QString t = moduleStatusName(status_);
  if (status_ == ModuleStatus::Running && live_) {
    // What the headless runner's live line says, less the id and name the box shows already.
    t += QString(" %1 s").arg(live_->seconds, 0, 'f', 1);
    if (!live_->stage.empty()) t += " · " + qs(liveStageText(*live_));
  } else if (status_ == ModuleStatus::Running) {
    t += QString(" %1 s").arg(clock_.isValid() ? clock_.elapsed() / 1000.0 : 0.0, 0, 'f', 1);
    if (!stage_.isEmpty()) t += QString(" · %1 %2%").arg(stage_).arg(int(std::round(progress_ * 100)));
  } else if (seconds_ >= 0 && (status_ == ModuleStatus::Done || status_ == ModuleStatus::Error ||
                               status_ == ModuleStatus::Cancelled)) {
    t += QString(" %1 s").arg(seconds_, 0, 'f', seconds_ < 10 ? 2 : 1);
  }
  if (!note_.isEmpty() && status_ == ModuleStatus::Done) t += " · " + note_;
  return t;
}

void ModuleItem::setNote(const QString& shortText, const QString& tip) {
  if (note_ == shortText && noteTip_ == tip) return;
  note_ = shortText;
  noteTip_ = tip;
  setToolTip(noteTip_.isEmpty() ? baseTip_ : baseTip_ + "\n" + noteTip_);
  update();
}

void ModuleItem::paint(QPainter* p, const QStyleOptionGraphicsItem*, QWidget*) {
  p->setRenderHint(QPainter::Antialiasing);
  const QColor sc = statusColor(status_);
  const QRectF box(0, 0, width_, height_);
  p->setPen(QPen(isSelected() ? QColor(255, 255, 255) : sc, isSelected() ? 3 : 2));
  p->setBrush(QColor(48, 50, 58));
  p->drawRoundedRect(box, 5, 5);
  // title band
  p->setPen(Qt::NoPen);
  p->setBrush(QColor(66, 70, 82));
  p->drawRect(QRectF(1.5, 6, width_ - 3, kTitleH - 6));
  QFont f = QApplication::font();
  f.setBold(true);
  p->setFont(f);
  p->setPen(Qt::white);
  p->drawText(QRectF(8, 6, width_ - 16, kTitleH - 4), Qt::AlignLeft | Qt::AlignVCenter, qs(info_->name));
  QFont small = QApplication::font();
  small.setPointSizeF(small.pointSizeF() * 0.85);
  p->setFont(small);
  p->setPen(QColor(190, 190, 200));
  p->drawText(QRectF(8, 6, width_ - 16, kTitleH - 4), Qt::AlignRight | Qt::AlignVCenter, qs(id_));
  // status line
  p->setPen(sc.lighter(130));
  // Elided to the box (the whole text is in the tooltip while it runs). A running box's colour
  // says "running", so its line leaves the word out and keeps the room for the stage.
  QString text = statusText();
  if (status_ == ModuleStatus::Running && text.startsWith("running ")) text = text.mid(8);
  const QString status = QFontMetricsF(small).elidedText(text, Qt::ElideRight, width_ - 16);
  p->drawText(QRectF(8, kTitleH + 2, width_ - 16, 16), Qt::AlignLeft | Qt::AlignVCenter, status);
  // progress bar
  const QRectF bar(8, height_ - 14, width_ - 16, 6);
  p->setPen(Qt::NoPen);
  p->setBrush(QColor(30, 30, 36));
  p->drawRect(bar);
  double f01 = status_ == ModuleStatus::Done ? 1.0 : std::clamp(progress_, 0.0, 1.0);
  if (status_ == ModuleStatus::Error || status_ == ModuleStatus::Skipped) f01 = 1.0;
  if (f01 > 0) {
    p->setBrush(sc);
    p->drawRect(QRectF(bar.x(), bar.y(), bar.width() * f01, bar.height()));
  }
}

void ModuleItem::setStatus(ModuleStatus s, double seconds) {
  if (s != ModuleStatus::Running && live_) {
    live_.reset();
    setToolTip(baseTip_);
  }
  if (s == ModuleStatus::Running || s == ModuleStatus::Waiting || s == ModuleStatus::Idle) setNote({});
  if (s == ModuleStatus::Running && status_ != ModuleStatus::Running) {
    clock_.start();
    progress_ = 0;
    stage_.clear();
    seconds_ = -1;
  } else if (s == ModuleStatus::Waiting || s == ModuleStatus::Idle) {
    progress_ = 0;
    stage_.clear();
    seconds_ = -1;
    clock_.invalidate();
  } else if (s != ModuleStatus::Running) {
    if (seconds >= 0) seconds_ = seconds;
    else if (clock_.isValid() && status_ == ModuleStatus::Running) seconds_ = clock_.elapsed() / 1000.0;
    if (s == ModuleStatus::Done) progress_ = 1.0;
  }
  status_ = s;
  update();
}

void ModuleItem::setProgress(const QString& stage, double fraction) {
  if (status_ != ModuleStatus::Running) return;
  stage_ = stage;
  progress_ = fraction;
  update();
}

void ModuleItem::tick(const std::optional<RunProgress::Entry>& live) {
  if (status_ != ModuleStatus::Running) return;
  if (live) {
    live_ = live;
    if (live_->fractionKnown) progress_ = live_->fraction;
    stage_ = qs(live_->stage);
    setToolTip(baseTip_ + "\n" + statusText());
  }
  update();
}

QVariant ModuleItem::itemChange(GraphicsItemChange change, const QVariant& value) {
  if (change == ItemPositionHasChanged)
    for (WireItem* w : wires_) w->updatePath();
  return QGraphicsObject::itemChange(change, value);
}

void ModuleItem::contextMenuEvent(QGraphicsSceneContextMenuEvent* e) {
  auto* sc = qobject_cast<NetworkScene*>(scene());
  if (!sc) return;
  if (!isSelected()) {
    sc->clearSelection();
    setSelected(true);
  }
  QMenu menu;
  QAction* exec = menu.addAction(QObject::tr("Execute this and downstream"));
  QAction* upTo = menu.addAction(QObject::tr("Execute up to here"));
  QAction* report = menu.addAction(QObject::tr("Show report"));
  QAction* log = menu.addAction(QObject::tr("Show log"));
  menu.addSeparator();
  QAction* del = menu.addAction(QObject::tr("Delete"));
  QAction* chosen = menu.exec(e->screenPos());
  const QString id = qs(id_);
  if (chosen == exec) emit sc->moduleContextAction(id, "execute");
  else if (chosen == upTo) emit sc->moduleContextAction(id, "upto");
  else if (chosen == report) emit sc->moduleContextAction(id, "report");
  else if (chosen == log) emit sc->moduleContextAction(id, "log");
  else if (chosen == del) sc->deleteSelection();
}

// ---------------------------------------------------------------- WireItem
WireItem::WireItem(std::string connectionId, PortItem* from, PortItem* to)
    : id_(std::move(connectionId)), from_(from), to_(to) {
  setFlags(ItemIsSelectable);
  setZValue(-1);
  from_->module()->addWire(this);
  to_->module()->addWire(this);
  setToolTip(QString("%1: %2 output %3 → %4 input %5 (%6)")
                 .arg(qs(id_), qs(from->module()->moduleId()))
                 .arg(from->index())
                 .arg(qs(to->module()->moduleId()))
                 .arg(to->index())
                 .arg(portTypeName(from->portType())));
  updatePath();
}

WireItem::~WireItem() { detach(); }

void WireItem::detach() {
  if (from_) from_->module()->removeWire(this);
  if (to_) to_->module()->removeWire(this);
  from_ = to_ = nullptr;
}

QPainterPath WireItem::curve(QPointF a, QPointF b) {
  const qreal d = std::max({30.0, std::abs(b.y() - a.y()) * 0.5, std::abs(b.x() - a.x()) * 0.25});
  QPainterPath path(a);
  path.cubicTo(a + QPointF(0, d), b - QPointF(0, d), b);
  return path;
}

void WireItem::updatePath() {
  if (from_ && to_) setPath(curve(from_->anchor(), to_->anchor()));
}

QPainterPath WireItem::shape() const {
  QPainterPathStroker s;
  s.setWidth(10);
  return s.createStroke(path());
}

void WireItem::paint(QPainter* p, const QStyleOptionGraphicsItem*, QWidget*) {
  p->setRenderHint(QPainter::Antialiasing);
  QColor c = from_ ? portColor(from_->portType()) : Qt::white;
  if (isSelected()) {
    p->setPen(QPen(Qt::white, 5));
    p->drawPath(path());
  }
  p->setPen(QPen(c, 2.5));
  p->setBrush(Qt::NoBrush);
  p->drawPath(path());
}

// ---------------------------------------------------------------- NetworkScene
NetworkScene::NetworkScene(QUndoStack* undo, QObject* parent) : QGraphicsScene(parent), undo_(undo) {
  setBackgroundBrush(QColor(36, 38, 44));
  setSceneRect(-2000, -2000, 6000, 6000);
  ticker_.setInterval(200);
  connect(&ticker_, &QTimer::timeout, this, [this] {
    bool any = false;
    for (auto& [id, m] : modules_)
      if (m->status() == ModuleStatus::Running) {
        m->tick(liveSource_ ? liveSource_(id) : std::nullopt);
        any = true;
      }
    if (!any) ticker_.stop();
  });
}

NetworkScene::~NetworkScene() {
  if (net_) net_->unsubscribe(token_);
  net_ = nullptr;
}

void NetworkScene::setNetwork(Network* net) {
  if (net_) net_->unsubscribe(token_);
  net_ = net;
  if (net_) token_ = net_->subscribe([this](const NetworkEvent& e) { onEvent(e); });
  rebuild();
}

void NetworkScene::rebuild() {
  clearSelection();
  for (auto& [id, w] : wires_) delete w;
  wires_.clear();
  for (auto& [id, m] : modules_) delete m;
  modules_.clear();
  if (!net_) return;
  for (const auto& m : net_->modules()) createModule(m.id);
  for (const auto& c : net_->connections()) createWire(c.id);
}

void NetworkScene::createModule(const std::string& id) {
  const ModuleNode* n = net_->module(id);
  if (!n || modules_.count(id)) return;
  auto* item = new ModuleItem(*n);
  addItem(item);
  modules_[id] = item;
}

void NetworkScene::createWire(const std::string& cid) {
  const Connection* c = net_->connection(cid);
  if (!c || wires_.count(cid)) return;
  ModuleItem* a = moduleItem(c->from);
  ModuleItem* b = moduleItem(c->to);
  if (!a || !b || !a->outputPort(c->fromPort) || !b->inputPort(c->toPort)) return;
  auto* w = new WireItem(cid, a->outputPort(c->fromPort), b->inputPort(c->toPort));
  addItem(w);
  wires_[cid] = w;
}

void NetworkScene::removeWireItem(const std::string& cid) {
  auto it = wires_.find(cid);
  if (it == wires_.end()) return;
  delete it->second;
  wires_.erase(it);
}

void NetworkScene::removeModuleItem(const std::string& id) {
  auto it = modules_.find(id);
  if (it == modules_.end()) return;
  // Wires were removed by the Disconnected events; drop any stragglers defensively.
  std::vector<std::string> stale;
  for (auto& [cid, w] : wires_)
    if (w->fromPort()->module() == it->second || w->toPort()->module() == it->second) stale.push_back(cid);
  for (const auto& cid : stale) removeWireItem(cid);
  if (dragFrom_ && dragFrom_->module() == it->second) clearHighlights();
  pressPositions_.erase(id);
  delete it->second;
  modules_.erase(it);
}

void NetworkScene::onEvent(const NetworkEvent& e) {
  switch (e.kind) {
    case NetworkEvent::Kind::ModuleAdded: createModule(e.id); break;
    case NetworkEvent::Kind::ModuleRemoved:
      removeModuleItem(e.id);
      emit moduleRemoved(qs(e.id));
      break;
    case NetworkEvent::Kind::Connected: createWire(e.id); break;
    case NetworkEvent::Kind::Disconnected: removeWireItem(e.id); break;
    case NetworkEvent::Kind::PositionChanged:
      if (ModuleItem* m = moduleItem(e.id)) {
        const ModuleNode* n = net_->module(e.id);
        if (n && m->pos() != QPointF(n->x, n->y)) {
          syncing_ = true;
          m->setPos(n->x, n->y);
          syncing_ = false;
        }
      }
      break;
    case NetworkEvent::Kind::ParameterChanged: emit parameterChanged(qs(e.id), qs(e.param)); break;
    case NetworkEvent::Kind::NoteChanged: break;
    case NetworkEvent::Kind::Cleared: rebuild(); break;
  }
  emit networkChanged();
}

ModuleItem* NetworkScene::moduleItem(const std::string& id) const {
  auto it = modules_.find(id);
  return it == modules_.end() ? nullptr : it->second;
}

WireItem* NetworkScene::wireItem(const std::string& cid) const {
  auto it = wires_.find(cid);
  return it == wires_.end() ? nullptr : it->second;
}

std::vector<std::string> NetworkScene::selectedModuleIds() const {
  std::vector<std::string> ids;
  if (!net_) return ids;
  for (const auto& m : net_->modules()) // model order
    if (ModuleItem* it = moduleItem(m.id); it && it->isSelected()) ids.push_back(m.id);
  return ids;
}

std::string NetworkScene::addModule(const std::string& name, QPointF pos) {
  auto* cmd = new AddModuleCommand(*net_, name, std::round(pos.x()), std::round(pos.y()));
  undo_->push(cmd); // redo() adds it
  return cmd->moduleId();
}

QString NetworkScene::tryConnect(const std::string& from, int fromPort, const std::string& to, int toPort) {
  const std::string why = net_->checkConnection(from, fromPort, to, toPort);
  if (!why.empty()) {
    emit message(tr("Connection refused: %1").arg(qs(why)));
    return qs(why);
  }
  undo_->push(new ConnectCommand(*net_, from, fromPort, to, toPort));
  return {};
}

void NetworkScene::deleteSelection() {
  if (!net_) return;
  const auto mods = selectedModuleIds();
  std::vector<std::string> wires;
  for (auto& [cid, w] : wires_) {
    if (!w->isSelected()) continue;
    const auto& a = w->fromPort()->module()->moduleId();
    const auto& b = w->toPort()->module()->moduleId();
    if (std::find(mods.begin(), mods.end(), a) == mods.end() &&
        std::find(mods.begin(), mods.end(), b) == mods.end())
      wires.push_back(cid);
  }
  if (mods.empty() && wires.empty()) return;
  undo_->beginMacro(tr("Delete"));
  for (const auto& cid : wires) undo_->push(new DisconnectCommand(*net_, cid));
  for (const auto& id : mods) undo_->push(new RemoveModuleCommand(*net_, id));
  undo_->endMacro();
}

void NetworkScene::setModuleStatus(const std::string& id, ModuleStatus s, double seconds) {
  if (ModuleItem* m = moduleItem(id)) {
    m->setStatus(s, seconds);
    if (s == ModuleStatus::Running && !ticker_.isActive()) ticker_.start();
  }
}

void NetworkScene::setModuleNote(const std::string& id, const QString& shortText, const QString& tip) {
  if (ModuleItem* m = moduleItem(id)) m->setNote(shortText, tip);
}

void NetworkScene::setModuleProgress(const std::string& id, const QString& stage, double fraction) {
  if (ModuleItem* m = moduleItem(id)) m->setProgress(stage, fraction);
}

void NetworkScene::resetStatuses() {
  for (auto& [id, m] : modules_) m->setStatus(ModuleStatus::Idle);
}

PortItem* NetworkScene::portAt(QPointF pos) const {
  for (QGraphicsItem* it : items(pos))
    if (it->type() == PortItem::Type) return static_cast<PortItem*>(it);
  return nullptr;
}

void NetworkScene::beginWireDrag(PortItem* port, QPointF pos) {
  dragFrom_ = port;
  dragWire_ = new QGraphicsPathItem;
  QPen pen(portColor(port->portType()), 2.5, Qt::DashLine);
  dragWire_->setPen(pen);
  dragWire_->setZValue(10);
  addItem(dragWire_);
  const std::string& self = port->module()->moduleId();
  for (auto& [id, m] : modules_) {
    const auto& candidates = port->isInput() ? m->outputPorts() : m->inputPorts();
    for (PortItem* other : candidates) {
      const std::string why =
          port->isInput() ? net_->checkConnection(id, other->index(), self, port->index())
                          : net_->checkConnection(self, port->index(), id, other->index());
      other->setHighlight(why.empty() ? 1 : -1, qs(why));
    }
    // Ports of the same direction can never take this wire.
    for (PortItem* same : port->isInput() ? m->inputPorts() : m->outputPorts())
      if (same != port) same->setHighlight(-1);
  }
  port->setHighlight(1);
  const QPointF a = port->anchor();
  dragWire_->setPath(port->isInput() ? WireItem::curve(pos, a) : WireItem::curve(a, pos));
}

void NetworkScene::clearHighlights() {
  for (auto& [id, m] : modules_) {
    for (PortItem* p : m->inputPorts()) p->setHighlight(0);
    for (PortItem* p : m->outputPorts()) p->setHighlight(0);
  }
  delete dragWire_;
  dragWire_ = nullptr;
  dragFrom_ = nullptr;
}

void NetworkScene::endWireDrag(QPointF pos) {
  PortItem* from = dragFrom_;
  PortItem* target = portAt(pos);
  const bool compatible = target && target->highlight() > 0 && target != from;
  const QString refusal = target ? target->refusal() : QString();
  clearHighlights();
  if (!target || target == from) return;
  if (target->isInput() == from->isInput()) {
    emit message(tr("Connection refused: connect an output port to an input port"));
    return;
  }
  PortItem* out = from->isInput() ? target : from;
  PortItem* in = from->isInput() ? from : target;
  if (!compatible && !refusal.isEmpty()) {
    emit message(tr("Connection refused: %1").arg(refusal));
    return;
  }
  tryConnect(out->module()->moduleId(), out->index(), in->module()->moduleId(), in->index());
}

void NetworkScene::mousePressEvent(QGraphicsSceneMouseEvent* e) {
  if (e->button() == Qt::LeftButton && net_) {
    if (PortItem* p = portAt(e->scenePos())) {
      beginWireDrag(p, e->scenePos());
      e->accept();
      return;
    }
  }
  QGraphicsScene::mousePressEvent(e);
  pressPositions_.clear();
  if (e->button() == Qt::LeftButton)
    for (auto& [id, m] : modules_)
      if (m->isSelected()) pressPositions_[id] = m->pos();
}

void NetworkScene::mouseMoveEvent(QGraphicsSceneMouseEvent* e) {
  if (dragWire_) {
    QPointF end = e->scenePos();
    if (PortItem* p = portAt(end); p && p->highlight() > 0 && p != dragFrom_) end = p->anchor();
    const QPointF a = dragFrom_->anchor();
    dragWire_->setPath(dragFrom_->isInput() ? WireItem::curve(end, a) : WireItem::curve(a, end));
    e->accept();
    return;
  }
  QGraphicsScene::mouseMoveEvent(e);
}

void NetworkScene::mouseReleaseEvent(QGraphicsSceneMouseEvent* e) {
  if (dragWire_) {
    endWireDrag(e->scenePos());
    e->accept();
    return;
  }
  QGraphicsScene::mouseReleaseEvent(e);
  std::vector<Move> moves;
  for (const auto& [id, before] : pressPositions_) {
    ModuleItem* m = moduleItem(id);
    const ModuleNode* n = net_ ? net_->module(id) : nullptr;
    if (!m || !n) continue;
    const QPointF now(std::round(m->pos().x()), std::round(m->pos().y()));
    if (now != QPointF(n->x, n->y)) moves.push_back({id, n->x, n->y, now.x(), now.y()});
  }
  pressPositions_.clear();
  if (!moves.empty()) undo_->push(new MoveModulesCommand(*net_, std::move(moves)));
}

void NetworkScene::keyPressEvent(QKeyEvent* e) {
  if ((e->key() == Qt::Key_Delete || e->key() == Qt::Key_Backspace) && !focusItem()) {
    deleteSelection();
    e->accept();
    return;
  }
  QGraphicsScene::keyPressEvent(e);
}

// ---------------------------------------------------------------- NetworkView
NetworkView::NetworkView(NetworkScene* scene, QWidget* parent) : QGraphicsView(scene, parent) {
  setRenderHint(QPainter::Antialiasing);
  setDragMode(QGraphicsView::RubberBandDrag);
  setTransformationAnchor(QGraphicsView::AnchorUnderMouse);
  setViewportUpdateMode(QGraphicsView::BoundingRectViewportUpdate);
  setAcceptDrops(true);
}

void NetworkView::zoomBy(double f) {
  const double s = transform().m11() * f;
  if (s < 0.1 || s > 4.0) return;
  scale(f, f);
}

void NetworkView::fitAll() {
  QRectF r = scene()->itemsBoundingRect();
  if (r.isEmpty()) {
    resetTransform();
    return;
  }
  r.adjust(-40, -40, 40, 40);
  fitInView(r, Qt::KeepAspectRatio);
  if (transform().m11() > 1.25) {
    resetTransform();
    scale(1.25, 1.25);
    centerOn(r.center());
  }
}

void NetworkView::wheelEvent(QWheelEvent* e) {
  zoomBy(std::pow(1.15, e->angleDelta().y() / 120.0));
  e->accept();
}

namespace {
bool hasLocalFile(const QMimeData* m) { return m->hasUrls() && !m->urls().isEmpty() && m->urls().first().isLocalFile(); }
} // namespace

void NetworkView::dragEnterEvent(QDragEnterEvent* e) {
  if (e->mimeData()->hasFormat(kModuleMime) || hasLocalFile(e->mimeData())) e->acceptProposedAction();
  else QGraphicsView::dragEnterEvent(e);
}

void NetworkView::dragMoveEvent(QDragMoveEvent* e) {
  if (e->mimeData()->hasFormat(kModuleMime) || hasLocalFile(e->mimeData())) e->acceptProposedAction();
  else QGraphicsView::dragMoveEvent(e);
}

void NetworkView::dropEvent(QDropEvent* e) {
  if (hasLocalFile(e->mimeData()) && !e->mimeData()->hasFormat(kModuleMime)) {
    e->acceptProposedAction();
    emit dropFile(e->mimeData()->urls().first().toLocalFile());
    return;
  }
  if (!e->mimeData()->hasFormat(kModuleMime)) return QGraphicsView::dropEvent(e);
  const QString name = QString::fromUtf8(e->mimeData()->data(kModuleMime));
  emit dropModule(name, mapToScene(e->position().toPoint()));
  e->acceptProposedAction();
}

} // namespace tetflow::gui
