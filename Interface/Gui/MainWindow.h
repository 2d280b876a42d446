#pragma once
// tetflow-gui main window: network canvas (centre), module palette and parameter panel (left),
// 3D view (right), log and report (bottom). The window never owns the network's rules: it holds
// the current tetflow::Network, the canvas observes it, and every edit goes through the network
// API (undoable commands). Execution runs off the GUI thread (ExecutionController).
#include <QMainWindow>

#include <map>
#include <memory>

#include "Dataflow/Network.h"
#include "Modules/MeshLabelsNet.h"

class QUndoStack;
class QPlainTextEdit;
class QDockWidget;
class QMenu;
class QAction;

namespace tetflow::gui {

class NetworkScene;
class NetworkView;
class ModulePalette;
class ParameterPanel;
class ReportView;
class MeshView;
class ExecutionController;

class MainWindow : public QMainWindow {
  Q_OBJECT
public:
  explicit MainWindow(const ModuleRegistry& registry, QWidget* parent = nullptr);
  ~MainWindow() override;

  Network& network() { return *net_; }
  NetworkScene* scene() const { return scene_; }
  NetworkView* view() const { return view_; }
  QUndoStack* undoStack() const { return undo_; }
  ModulePalette* palette() const { return palette_; }
  ParameterPanel* parameters() const { return params_; }
  ReportView* reportView() const { return report_; }
  MeshView* meshView() const { return mesh_; } // nullptr on platforms without OpenGL
  ExecutionController* execution() const { return exec_; }
  QPlainTextEdit* logView() const { return log_; }
  const QString& currentFile() const { return file_; }
  bool isModified() const;

  // Commands (also used by tests and the command line; no dialogs unless prompts are enabled).
  // A network (.srn), or a label volume file: then offerMeshing(path).
  bool openFile(const QString& path);
  // Offers to mesh a label volume with the network `tetflow mesh` builds (Modules/MeshLabelsNet.h):
  // regular lattice, adaptive octree or particles. Without prompts (tests): the regular lattice.
  bool offerMeshing(const QString& volumePath);
  // That network for the volume, with sizes from its voxels, the mesh written beside it; it
  // replaces the open network, unsaved (File > Save keeps it). False (logged) when the volume
  // cannot be read.
  bool meshVolume(const QString& volumePath, MeshBackground background);
  bool saveFile(const QString& path);
  void newNetwork();
  bool executeAll();
  bool executeFrom(const QString& moduleId); // this module and everything downstream
  // This module and whatever upstream of it is stale, nothing downstream: a background's
  // predicted tet count shows on its box before CleaveMesh runs.
  bool executeUpTo(const QString& moduleId);
  void cancelExecution();
  void selectModule(const QString& id);
  // Unsaved-changes prompts and error message boxes (off for tests/screenshots).
  void setInteractive(bool on) { interactive_ = on; }
  void log(const QString& text);
  void raiseReport(); // bring the Report tab to the front
  // Memory budget of the modules and the 3D view (docs/reliability.md): "8G", "512 MB", ...;
  // empty = the machine's available memory. Kept in the settings when `remember` is set. Returns
  // false with the reason in *error for a size that cannot be read.
  bool setMemoryLimit(const QString& size, QString* error = nullptr, bool remember = true);
  QString memoryLimitText() const; // "" when none

protected:
  void closeEvent(QCloseEvent* e) override;

private slots:
  void onSelectionChanged();
  void onModuleStatus(const QString& id, int status);
  void onExecutionFinished(bool success);
  void onContextAction(const QString& id, const QString& action);

private:
  void createActions();
  void editMemoryLimit(); // Network > Memory Limit... dialog
  QString memoryText_;    // the limit as the user wrote it
  void createDocks();
  void attachNetwork(std::unique_ptr<Network> net);
  bool maybeSave();
  bool save();
  bool saveAs();
  void open();
  void addRecent(const QString& path);
  void rebuildRecentMenu();
  void updateTitle();
  void showModuleResults(const std::string& id);
  void showModuleLog(const std::string& id);
  void showPredictions(const std::vector<std::string>& ids); // predicted_tets on the boxes
  // Starts a run (ExecutionController::start) and sets the actions; false, logged, while one runs.
  bool startExecution(const std::vector<std::string>& only, bool upstreamOnly, const QString& message);
  static std::map<int, QString> labelNames(const DataPtr& data);

  const ModuleRegistry& registry_;
  std::unique_ptr<Network> net_;
  QUndoStack* undo_;
  NetworkScene* scene_;
  NetworkView* view_;
  ModulePalette* palette_ = nullptr;
  ParameterPanel* params_ = nullptr;
  ReportView* report_ = nullptr;
  MeshView* mesh_ = nullptr;
  QPlainTextEdit* log_ = nullptr;
  QDockWidget* logDock_ = nullptr;
  QDockWidget* reportDock_ = nullptr;
  QDockWidget* viewDock_ = nullptr;
  ExecutionController* exec_;
  QString file_;
  QMenu* recentMenu_ = nullptr;
  QAction* executeAct_ = nullptr;
  QAction* cancelAct_ = nullptr;
  bool interactive_ = true;
  int addCount_ = 0;
};

} // namespace tetflow::gui
