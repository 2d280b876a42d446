#pragma once
// Undoable edits of a tetflow::Network (QUndoStack). Every command edits the network only through
// its public API (the same one the .srn loader and the headless runner use); the canvas follows
// through the network's change notifications, never by touching its items directly.
//
// Commands are pushed only after the edit was checked (Network::checkConnection, checkParam), so
// the first redo() does not throw; ids of added modules / connections are kept so undo -> redo
// recreates the same ids (and therefore the same saved bytes).
#include <QUndoCommand>

#include <string>
#include <vector>

#include "Dataflow/Network.h"

namespace tetflow::gui {

class AddModuleCommand : public QUndoCommand {
public:
  AddModuleCommand(Network& net, std::string name, double x, double y, std::string id = "");
  void redo() override;
  void undo() override;
  const std::string& moduleId() const { return id_; }

private:
  Network& net_;
  std::string name_, id_;
  double x_, y_;
};

// Removes a module and its connections; undo restores module (same id, parameters, note,
// position) and connections (same ids).
class RemoveModuleCommand : public QUndoCommand {
public:
  RemoveModuleCommand(Network& net, const std::string& id);
  void redo() override;
  void undo() override;

private:
  Network& net_;
  ModuleNode node_;
  std::string name_;
  std::vector<Connection> connections_;
};

class ConnectCommand : public QUndoCommand {
public:
  ConnectCommand(Network& net, std::string from, int fromPort, std::string to, int toPort);
  void redo() override;
  void undo() override;
  const std::string& connectionId() const { return c_.id; }

private:
  Network& net_;
  Connection c_;
};

class DisconnectCommand : public QUndoCommand {
public:
  DisconnectCommand(Network& net, const std::string& connectionId);
  void redo() override;
  void undo() override;

private:
  Network& net_;
  Connection c_;
};

struct Move {
  std::string id;
  double fromX, fromY, toX, toY;
};

class MoveModulesCommand : public QUndoCommand {
public:
  MoveModulesCommand(Network& net, std::vector<Move> moves);
  void redo() override;
  void undo() override;

private:
  Network& net_;
  std::vector<Move> moves_;
};

// Consecutive edits of the same parameter merge into one undo step.
class SetParameterCommand : public QUndoCommand {
public:
  SetParameterCommand(Network& net, std::string id, std::string param, ParamValue value);
  void redo() override;
  void undo() override;
  int id() const override { return 1001; }
  bool mergeWith(const QUndoCommand* other) override;

private:
  Network& net_;
  std::string module_, param_;
  ParamValue old_, new_;
};

} // namespace tetflow::gui
