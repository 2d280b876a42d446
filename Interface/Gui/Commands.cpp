#include "Commands.h"

#include "GuiStyle.h"

namespace tetflow::gui {

AddModuleCommand::AddModuleCommand(Network& net, std::string name, double x, double y, std::string id)
    : net_(net), name_(std::move(name)), id_(std::move(id)), x_(x), y_(y) {
  setText(QObject::tr("Add %1").arg(qs(name_)));
}

void AddModuleCommand::redo() { id_ = net_.addModule(name_, id_, x_, y_); }

void AddModuleCommand::undo() {
  if (net_.module(id_)) net_.removeModule(id_);
}

RemoveModuleCommand::RemoveModuleCommand(Network& net, const std::string& id) : net_(net) {
  node_ = net.requireModule(id);
  name_ = node_.info->name;
  for (const auto& c : net.connections())
    if (c.from == id || c.to == id) connections_.push_back(c);
  setText(QObject::tr("Delete %1 (%2)").arg(qs(id), qs(name_)));
}

void RemoveModuleCommand::redo() { net_.removeModule(node_.id); }

void RemoveModuleCommand::undo() {
  net_.addModule(name_, node_.id, node_.x, node_.y);
  for (const auto& [k, v] : node_.params) net_.setParameter(node_.id, k, v);
  if (!node_.note.empty()) net_.setNote(node_.id, node_.note);
  for (const auto& c : connections_) net_.connect(c.from, c.fromPort, c.to, c.toPort, c.id);
}

ConnectCommand::ConnectCommand(Network& net, std::string from, int fromPort, std::string to, int toPort)
    : net_(net) {
  c_.from = std::move(from);
  c_.fromPort = fromPort;
  c_.to = std::move(to);
  c_.toPort = toPort;
  setText(QObject::tr("Connect %1:%2 to %3:%4").arg(qs(c_.from)).arg(fromPort).arg(qs(c_.to)).arg(toPort));
}

void ConnectCommand::redo() { c_.id = net_.connect(c_.from, c_.fromPort, c_.to, c_.toPort, c_.id); }

void ConnectCommand::undo() {
  if (net_.connection(c_.id)) net_.disconnect(c_.id);
}

DisconnectCommand::DisconnectCommand(Network& net, const std::string& connectionId) : net_(net) {
  const Connection* c = net.connection(connectionId);
  if (c) c_ = *c;
  c_.id = connectionId;
  setText(QObject::tr("Disconnect %1").arg(qs(connectionId)));
}

void DisconnectCommand::redo() {
  if (net_.connection(c_.id)) net_.disconnect(c_.id);
}

void DisconnectCommand::undo() { net_.connect(c_.from, c_.fromPort, c_.to, c_.toPort, c_.id); }

MoveModulesCommand::MoveModulesCommand(Network& net, std::vector<Move> moves)
    : net_(net), moves_(std::move(moves)) {
  setText(moves_.size() == 1 ? QObject::tr("Move %1").arg(qs(moves_[0].id))
                             : QObject::tr("Move %1 modules").arg(moves_.size()));
}

void MoveModulesCommand::redo() {
  for (const auto& m : moves_)
    if (net_.module(m.id)) net_.setPosition(m.id, m.toX, m.toY);
}

void MoveModulesCommand::undo() {
  for (const auto& m : moves_)
    if (net_.module(m.id)) net_.setPosition(m.id, m.fromX, m.fromY);
}

SetParameterCommand::SetParameterCommand(Network& net, std::string id, std::string param, ParamValue value)
    : net_(net), module_(std::move(id)), param_(std::move(param)), new_(std::move(value)) {
  old_ = net.requireModule(module_).params.at(param_);
  setText(QObject::tr("Set %1.%2").arg(qs(module_), qs(param_)));
}

void SetParameterCommand::redo() { net_.setParameter(module_, param_, new_); }
void SetParameterCommand::undo() { net_.setParameter(module_, param_, old_); }

bool SetParameterCommand::mergeWith(const QUndoCommand* other) {
  auto* o = dynamic_cast<const SetParameterCommand*>(other);
  if (!o || o->module_ != module_ || o->param_ != param_) return false;
  new_ = o->new_;
  return true;
}

} // namespace tetflow::gui
