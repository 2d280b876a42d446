#include "MainWindow.h"

#include <QAction>
#include <QApplication>
#include <QCloseEvent>
#include <QDateTime>
#include <QDir>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QGuiApplication>
#include <QInputDialog>
#include <QLabel>
#include <QLineEdit>
#include <QLocale>
#include <QMenuBar>
#include <QMessageBox>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QSettings>
#include <QStatusBar>
#include <QToolBar>
#include <QUndoStack>

#include <deque>
#include <set>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "Canvas.h"
#include "ExecutionController.h"
#include "GuiStyle.h"
#include "MeshView.h"
#include "Palette.h"
#include "ParameterPanel.h"
#include "ReportView.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Dataflow/NetworkFile.h"

namespace tetflow::gui {

MainWindow::MainWindow(const ModuleRegistry& registry, QWidget* parent)
    : QMainWindow(parent), registry_(registry) {
  undo_ = new QUndoStack(this);
  scene_ = new NetworkScene(undo_, this);
  view_ = new NetworkView(scene_);
  setCentralWidget(view_);
  exec_ = new ExecutionController(this);
  scene_->setLiveProgressSource([this](const std::string& id) { return exec_->liveProgress(id); });
  createDocks();
  createActions();
  {
    // The memory limit chosen last time (Network > Memory Limit...); --max-memory overrides it.
    const QString saved = QSettings("TetFlow", "tetflow-gui").value("memoryLimit").toString();
    if (!saved.isEmpty()) setMemoryLimit(saved, nullptr, false); // an unreadable one is ignored
  }

  connect(scene_, &NetworkScene::message, this, &MainWindow::log);
  connect(scene_, &QGraphicsScene::selectionChanged, this, &MainWindow::onSelectionChanged);
  connect(scene_, &NetworkScene::parameterChanged, params_, &ParameterPanel::onParameterChanged);
  connect(scene_, &NetworkScene::parameterChanged, this, [this](const QString& id, const QString&) {
    // A prediction from values that changed no longer holds, here or below.
    for (const auto& d : net_->downstreamClosure({ss(id)})) scene_->setModuleNote(d, {});
  });
  connect(scene_, &NetworkScene::moduleRemoved, params_, &ParameterPanel::onModuleRemoved);
  connect(scene_, &NetworkScene::moduleContextAction, this, &MainWindow::onContextAction);
  connect(params_, &ParameterPanel::message, this, &MainWindow::log);
  connect(palette_, &ModulePalette::addRequested, this, [this](const QString& name) {
    const QPointF c = view_->mapToScene(view_->viewport()->rect().center());
    const double off = 20.0 * (addCount_++ % 8);
    const std::string id = scene_->addModule(ss(name), c + QPointF(-80 + off, -30 + off));
    selectModule(qs(id));
  });
  connect(view_, &NetworkView::dropModule, this, [this](const QString& name, QPointF pos) {
    const std::string id = scene_->addModule(ss(name), pos - QPointF(80, 29));
    selectModule(qs(id));
  });
  // A file dropped on the canvas opens like File > Open: a network, or a label volume to mesh.
  connect(view_, &NetworkView::dropFile, this, [this](const QString& path) {
    if (maybeSave()) openFile(path);
  });
  connect(undo_, &QUndoStack::cleanChanged, this, [this] { updateTitle(); });
  connect(exec_, &ExecutionController::moduleStatus, this, &MainWindow::onModuleStatus);
  connect(exec_, &ExecutionController::moduleProgress, this,
          [this](const QString& id, const QString& stage, double f) { scene_->setModuleProgress(ss(id), stage, f); });
  connect(exec_, &ExecutionController::finished, this, &MainWindow::onExecutionFinished);

  auto net = std::make_unique<Network>(registry_);
  net->setBaseDir(ss(QDir::currentPath()));
  attachNetwork(std::move(net));
  resize(1280, 800);
}

MainWindow::~MainWindow() {
  scene_->setNetwork(nullptr);
  if (exec_->isRunning()) {
    exec_->cancel();
    exec_->waitForFinished();
  }
}

void MainWindow::createDocks() {
  setDockNestingEnabled(true);
  // The left column (palette over parameters) runs the window's full height; the log and report
  // sit under the canvas and the 3D view.
  setCorner(Qt::BottomLeftCorner, Qt::LeftDockWidgetArea);
  palette_ = new ModulePalette(registry_);
  auto* palDock = new QDockWidget(tr("Modules"), this);
  palDock->setObjectName("modules");
  palDock->setWidget(palette_);
  addDockWidget(Qt::LeftDockWidgetArea, palDock);

  params_ = new ParameterPanel(undo_);
  auto* parDock = new QDockWidget(tr("Parameters"), this);
  parDock->setObjectName("parameters");
  parDock->setWidget(params_);
  addDockWidget(Qt::LeftDockWidgetArea, parDock);
  splitDockWidget(palDock, parDock, Qt::Vertical);

  viewDock_ = new QDockWidget(tr("3D view"), this);
  viewDock_->setObjectName("view3d");
  // Qt's offscreen platform crashes with a QOpenGLWidget in a shown window (PLATFORM.md 5).
  if (QGuiApplication::platformName() == "offscreen") {
    auto* l = new QLabel(tr("3D view unavailable on the offscreen platform"));
    l->setAlignment(Qt::AlignCenter);
    viewDock_->setWidget(l);
  } else {
    mesh_ = new MeshView;
    viewDock_->setWidget(mesh_);
  }
  addDockWidget(Qt::RightDockWidgetArea, viewDock_);

  log_ = new QPlainTextEdit;
  log_->setReadOnly(true);
  log_->setMaximumBlockCount(5000);
  logDock_ = new QDockWidget(tr("Log"), this);
  logDock_->setObjectName("log");
  logDock_->setWidget(log_);
  addDockWidget(Qt::BottomDockWidgetArea, logDock_);

  report_ = new ReportView;
  reportDock_ = new QDockWidget(tr("Report"), this);
  reportDock_->setObjectName("report");
  reportDock_->setWidget(report_);
  addDockWidget(Qt::BottomDockWidgetArea, reportDock_);
  tabifyDockWidget(logDock_, reportDock_);
  logDock_->raise();
  // Wide enough for every module's names and values side by side; the palette short (it has a
  // filter), the parameters tall enough for the longest module without scrolling.
  resizeDocks({palDock, viewDock_}, {params_->preferredWidth(registry_), 520}, Qt::Horizontal);
  resizeDocks({palDock, parDock}, {170, 630}, Qt::Vertical);
  resizeDocks({logDock_}, {210}, Qt::Vertical);
}

void MainWindow::createActions() {
  QMenu* file = menuBar()->addMenu(tr("&File"));
  QToolBar* tb = addToolBar(tr("Main"));
  tb->setObjectName("maintoolbar");
  auto add = [&](QMenu* m, const QString& text, QKeySequence key, auto slot, bool toolbar = false) {
    QAction* a = m->addAction(text);
    if (!key.isEmpty()) a->setShortcut(key);
    connect(a, &QAction::triggered, this, slot);
    if (toolbar) tb->addAction(a);
    return a;
  };
  add(file, tr("&New"), QKeySequence::New, [this] { if (maybeSave()) newNetwork(); }, true);
  add(file, tr("&Open…"), QKeySequence::Open, [this] { open(); }, true);
  recentMenu_ = file->addMenu(tr("Open &Recent"));
  add(file, tr("&Save"), QKeySequence::Save, [this] { save(); }, true);
  add(file, tr("Save &As…"), QKeySequence::SaveAs, [this] { saveAs(); });
  file->addSeparator();
  add(file, tr("&Quit"), QKeySequence::Quit, [this] { close(); });
  rebuildRecentMenu();

  QMenu* edit = menuBar()->addMenu(tr("&Edit"));
  QAction* undo = undo_->createUndoAction(this, tr("&Undo"));
  undo->setShortcut(QKeySequence::Undo);
  QAction* redo = undo_->createRedoAction(this, tr("&Redo"));
  redo->setShortcut(QKeySequence::Redo);
  edit->addAction(undo);
  edit->addAction(redo);
  tb->addSeparator();
  tb->addAction(undo);
  tb->addAction(redo);
  edit->addSeparator();
  add(edit, tr("&Delete"), QKeySequence::Delete, [this] { scene_->deleteSelection(); });
  add(edit, tr("Select &All"), QKeySequence::SelectAll, [this] {
    for (auto& [id, m] : scene_->moduleItems()) m->setSelected(true);
  });

  QMenu* viewMenu = menuBar()->addMenu(tr("&View"));
  add(viewMenu, tr("Zoom &In"), QKeySequence::ZoomIn, [this] { view_->zoomBy(1.2); });
  add(viewMenu, tr("Zoom &Out"), QKeySequence::ZoomOut, [this] { view_->zoomBy(1 / 1.2); });
  add(viewMenu, tr("&Fit Network"), QKeySequence(Qt::CTRL | Qt::Key_0), [this] { view_->fitAll(); }, true);
  viewMenu->addSeparator();
  for (QDockWidget* d : findChildren<QDockWidget*>()) viewMenu->addAction(d->toggleViewAction());

  QMenu* run = menuBar()->addMenu(tr("&Network"));
  tb->addSeparator();
  executeAct_ = add(run, tr("&Execute All"), QKeySequence(Qt::CTRL | Qt::Key_E), [this] { executeAll(); }, true);
  executeAct_->setShortcuts({QKeySequence(Qt::CTRL | Qt::Key_E), QKeySequence(Qt::Key_F5)});
  add(run, tr("Execute &Selected and Downstream"), QKeySequence(Qt::SHIFT | Qt::Key_F5), [this] {
    const auto ids = scene_->selectedModuleIds();
    if (!ids.empty()) executeFrom(qs(ids.front()));
  });
  add(run, tr("Execute &Up to Selected"), QKeySequence(Qt::CTRL | Qt::Key_F5), [this] {
    const auto ids = scene_->selectedModuleIds();
    if (!ids.empty()) executeUpTo(qs(ids.front()));
  });
  cancelAct_ = add(run, tr("&Cancel"), QKeySequence(Qt::Key_Escape), [this] { cancelExecution(); }, true);
  cancelAct_->setEnabled(false);
  run->addSeparator();
  add(run, tr("&Memory Limit..."), QKeySequence(), [this] { editMemoryLimit(); });
}

bool MainWindow::setMemoryLimit(const QString& size, QString* error, bool remember) {
  int64_t bytes = 0;
  if (!size.trimmed().isEmpty()) {
    try {
      bytes = parseMemorySize(size.trimmed().toStdString(), "memory limit");
    } catch (const InputError& e) {
      if (error) *error = QString::fromStdString(e.what());
      return false;
    }
  }
  tetflow::setMemoryLimit(bytes);
  memoryText_ = bytes ? size.trimmed() : QString();
  if (remember) QSettings("TetFlow", "tetflow-gui").setValue("memoryLimit", memoryText_);
  log(bytes ? tr("Memory limit %1: a module or 3D view that would need more than what is left of it "
                 "is refused before it allocates")
                  .arg(memoryLimitText())
            : tr("No memory limit: modules and the 3D view are checked against the machine's "
                 "available memory (%1 now)")
                  .arg(QString::fromStdString(formatBytes(double(memoryAvailable())))));
  return true;
}

QString MainWindow::memoryLimitText() const {
  return tetflow::memoryLimit() ? memoryText_ : QString();
}

void MainWindow::editMemoryLimit() {
  QString text = memoryLimitText();
  for (;;) {
    bool ok = false;
    text = QInputDialog::getText(
        this, tr("Memory Limit"),
        tr("Largest amount of memory a run may take, e.g. 8G or 512M.\nEmpty: the machine's "
           "available memory (%1 now).")
            .arg(QString::fromStdString(formatBytes(double(memoryAvailable())))),
        QLineEdit::Normal, text, &ok);
    if (!ok) return;
    QString error;
    if (setMemoryLimit(text, &error)) return;
    QMessageBox::warning(this, tr("Memory Limit"), error);
  }
}

void MainWindow::attachNetwork(std::unique_ptr<Network> net) {
  params_->setNetwork(nullptr);
  scene_->setNetwork(nullptr);
  net_ = std::move(net);
  scene_->setNetwork(net_.get());
  params_->setNetwork(net_.get());
  undo_->clear();
  exec_->reset();
  report_->showMessage(tr("Select a module to see its report"));
  if (mesh_) mesh_->clearData(tr("Execute the network and select a module with a mesh or volume output"));
  updateTitle();
  view_->fitAll();
}

void MainWindow::raiseReport() { reportDock_->raise(); }

bool MainWindow::isModified() const { return !undo_->isClean(); }

void MainWindow::updateTitle() {
  setWindowModified(isModified());
  setWindowTitle(QString("TetFlow — %1[*]").arg(file_.isEmpty() ? tr("untitled.srn") : QFileInfo(file_).fileName()));
}

void MainWindow::log(const QString& text) {
  log_->appendPlainText(QTime::currentTime().toString("HH:mm:ss  ") + text);
}

void MainWindow::newNetwork() {
  if (exec_->isRunning()) {
    log(tr("Cancel the running execution first"));
    return;
  }
  auto net = std::make_unique<Network>(registry_);
  net->setBaseDir(ss(QDir::currentPath()));
  file_.clear();
  attachNetwork(std::move(net));
}

namespace {
bool isVolumeFile(const QString& path) {
  for (const auto& ext : volumeExtensions())
    if (path.endsWith(qs(ext), Qt::CaseInsensitive)) return true;
  return false;
}
} // namespace

bool MainWindow::offerMeshing(const QString& volumePath) {
  MeshBackground b = MeshBackground::Regular;
  if (interactive_) {
    QMessageBox box(QMessageBox::Question, tr("Mesh a label volume"),
                    tr("%1 is a label volume. Mesh it with the network tetflow mesh uses?")
                        .arg(QFileInfo(volumePath).fileName()),
                    QMessageBox::Cancel, this);
    box.setInformativeText(tr("The sizes follow the voxels; the mesh is written beside the volume. Change any "
                              "parameter before Execute All, and File > Save keeps the network."));
    QPushButton* regular = box.addButton(tr("Regular lattice"), QMessageBox::AcceptRole);
    QPushButton* octree = box.addButton(tr("Adaptive (octree)"), QMessageBox::AcceptRole);
    QPushButton* particles = box.addButton(tr("Adaptive (particles)"), QMessageBox::AcceptRole);
    regular->setObjectName("meshRegular");
    octree->setObjectName("meshOctree");
    particles->setObjectName("meshParticles");
    box.setDefaultButton(regular);
    box.exec();
    if (box.clickedButton() == octree) b = MeshBackground::Octree;
    else if (box.clickedButton() == particles) b = MeshBackground::Particles;
    else if (box.clickedButton() != regular) return false;
  }
  return meshVolume(volumePath, b);
}

bool MainWindow::meshVolume(const QString& volumePath, MeshBackground background) {
  if (exec_->isRunning()) {
    log(tr("Cancel the running execution before opening another network"));
    return false;
  }
  const QFileInfo info(volumePath);
  MeshLabelsOptions o;
  o.labels = ss(info.absoluteFilePath());
  o.output = ss(info.absolutePath()) + "/" + defaultMeshFileName(o.labels);
  o.background = background;
  std::vector<std::string> lines;
  std::unique_ptr<Network> net;
  try {
    const LabelVolume v = readLabelVolume(o.labels); // the voxel size and the label outside (read again when run)
    o.exterior = exteriorLabelOf(v);
    lines = chooseMeshSizes(o, v.grid);
    net = std::make_unique<Network>(buildMeshLabelsNetwork(registry_, o));
  } catch (const std::exception& e) {
    log(tr("Cannot mesh %1: %2").arg(volumePath, qs(e.what())));
    if (interactive_) QMessageBox::critical(this, tr("Cannot mesh the volume"), qs(e.what()));
    return false;
  }
  net->setBaseDir(ss(info.absolutePath()));
  file_.clear();
  attachNetwork(std::move(net));
  log(tr("Meshing network for %1: %2 background").arg(info.absoluteFilePath(), meshBackgroundName(background)));
  for (const auto& l : lines) log("  " + qs(l));
  log(tr("  the mesh goes to %1; Execute All runs it, File > Save keeps the network").arg(qs(o.output)));
  log(tr("  \"Execute up to here\" on m2 (GenerateBackgroundMesh) shows the predicted tet count before cleaving"));
  return true;
}

bool MainWindow::openFile(const QString& path) {
  if (exec_->isRunning()) {
    log(tr("Cancel the running execution before opening another network"));
    return false;
  }
  if (isVolumeFile(path)) return offerMeshing(path);
  std::unique_ptr<Network> net;
  try {
    net = std::make_unique<Network>(loadNetwork(ss(path), registry_));
  } catch (const NetworkLoadError& e) {
    log(tr("Cannot open %1:").arg(path));
    for (const auto& p : e.problems())
      log(QString("  line %1%2: %3").arg(p.line).arg(p.moduleId.empty() ? "" : ", module " + qs(p.moduleId), qs(p.message)));
    if (interactive_) QMessageBox::critical(this, tr("Cannot open network"), qs(e.what()));
    return false;
  } catch (const std::exception& e) {
    log(tr("Cannot open %1: %2").arg(path, qs(e.what())));
    if (interactive_) QMessageBox::critical(this, tr("Cannot open network"), qs(e.what()));
    return false;
  }
  file_ = QFileInfo(path).absoluteFilePath();
  attachNetwork(std::move(net));
  addRecent(file_);
  log(tr("Opened %1 (%2 modules, %3 connections)")
          .arg(file_)
          .arg(net_->modules().size())
          .arg(net_->connections().size()));
  return true;
}

bool MainWindow::saveFile(const QString& path) {
  try {
    saveNetwork(ss(path), *net_);
  } catch (const std::exception& e) {
    log(tr("Cannot save %1: %2").arg(path, qs(e.what())));
    if (interactive_) QMessageBox::critical(this, tr("Cannot save network"), qs(e.what()));
    return false;
  }
  file_ = QFileInfo(path).absoluteFilePath();
  // Relative file names in the network now mean "relative to this file's folder".
  net_->setBaseDir(ss(QFileInfo(file_).absolutePath()));
  undo_->setClean();
  addRecent(file_);
  updateTitle();
  log(tr("Saved %1").arg(file_));
  return true;
}

bool MainWindow::save() { return file_.isEmpty() ? saveAs() : saveFile(file_); }

bool MainWindow::saveAs() {
  QString path = QFileDialog::getSaveFileName(this, tr("Save network"), file_.isEmpty() ? QDir::currentPath() : file_,
                                              tr("SCIRun networks (*.srn)"));
  if (path.isEmpty()) return false;
  if (!path.endsWith(".srn")) path += ".srn";
  return saveFile(path);
}

void MainWindow::open() {
  if (!maybeSave()) return;
  const QString path = QFileDialog::getOpenFileName(this, tr("Open network"),
                                                    file_.isEmpty() ? QDir::currentPath() : QFileInfo(file_).absolutePath(),
                                                    tr("SCIRun networks (*.srn);;Label volumes to mesh (*.nii *.nii.gz "
                                                       "*.nrrd *.nhdr *.mha *.mhd *.inr *.inr.gz *.vti);;All files (*)"));
  if (!path.isEmpty()) openFile(path);
}

bool MainWindow::maybeSave() {
  if (!isModified() || !interactive_) return true;
  const auto r = QMessageBox::warning(this, tr("Unsaved changes"),
                                      tr("The network has unsaved changes. Save them?"),
                                      QMessageBox::Save | QMessageBox::Discard | QMessageBox::Cancel);
  if (r == QMessageBox::Save) return save();
  return r == QMessageBox::Discard;
}

void MainWindow::addRecent(const QString& path) {
  QSettings s("TetFlow", "tetflow-gui");
  QStringList list = s.value("recentFiles").toStringList();
  list.removeAll(path);
  list.prepend(path);
  while (list.size() > 8) list.removeLast();
  s.setValue("recentFiles", list);
  rebuildRecentMenu();
}

void MainWindow::rebuildRecentMenu() {
  recentMenu_->clear();
  QSettings s("TetFlow", "tetflow-gui");
  const QStringList list = s.value("recentFiles").toStringList();
  for (const QString& f : list) {
    QAction* a = recentMenu_->addAction(QFileInfo(f).fileName() + "  —  " + QFileInfo(f).absolutePath());
    connect(a, &QAction::triggered, this, [this, f] {
      if (maybeSave()) openFile(f);
    });
  }
  recentMenu_->setEnabled(!list.isEmpty());
}

void MainWindow::closeEvent(QCloseEvent* e) {
  if (!maybeSave()) {
    e->ignore();
    return;
  }
  if (exec_->isRunning()) {
    exec_->cancel();
    exec_->waitForFinished();
  }
  e->accept();
}

bool MainWindow::executeAll() {
  return startExecution({}, false, tr("Executing %1 modules…").arg(net_->modules().size()));
}

bool MainWindow::executeFrom(const QString& id) {
  return net_->module(ss(id)) && startExecution({ss(id)}, false, tr("Executing %1 and downstream…").arg(id));
}

bool MainWindow::executeUpTo(const QString& id) {
  return net_->module(ss(id)) && startExecution({ss(id)}, true, tr("Executing up to %1…").arg(id));
}

bool MainWindow::startExecution(const std::vector<std::string>& only, bool upstreamOnly, const QString& message) {
  if (!exec_->start(*net_, only, 0, upstreamOnly)) {
    log(tr("The network is already executing"));
    return false;
  }
  executeAct_->setEnabled(false);
  cancelAct_->setEnabled(true);
  log(message);
  return true;
}

void MainWindow::cancelExecution() {
  if (exec_->isRunning()) {
    exec_->cancel();
    log(tr("Cancelling…"));
  }
}

void MainWindow::onModuleStatus(const QString& id, int status) {
  scene_->setModuleStatus(ss(id), ModuleStatus(status));
}

void MainWindow::onExecutionFinished(bool success) {
  executeAct_->setEnabled(true);
  cancelAct_->setEnabled(false);
  const auto& sum = exec_->lastSummary();
  for (const auto& id : sum.order) {
    const ModuleState* st = exec_->state(id);
    if (!st) continue;
    scene_->setModuleStatus(id, st->status, st->seconds);
    QString line = QString("%1 %2 %3 %4 s").arg(qs(id), qs(st->moduleName),
                                                st->reused ? "reused" : moduleStatusName(st->status))
                       .arg(st->seconds, 0, 'f', 3);
    if (st->status == ModuleStatus::Error) line += "  " + qs(st->error);
    if (st->status == ModuleStatus::Skipped) line += tr("  (not run: upstream %1 failed)").arg(qs(st->skippedBecause));
    log(line);
    if (!st->reused)
      for (const auto& m : st->messages) log("    " + qs(m));
  }
  showPredictions(sum.order);
  if (!exec_->lastError().isEmpty()) log(tr("Execution failed: %1").arg(exec_->lastError()));
  log(tr("%1: %2 ran, %3 reused, %4 failed, %5 skipped, %6 cancelled in %7 s")
          .arg(success ? tr("Done") : tr("Finished with problems"))
          .arg(sum.ran).arg(sum.reused).arg(sum.failed).arg(sum.skipped).arg(sum.cancelled)
          .arg(sum.seconds, 0, 'f', 2));
  const auto sel = scene_->selectedModuleIds();
  if (sel.size() == 1) showModuleResults(sel.front());
}

void MainWindow::showPredictions(const std::vector<std::string>& ids) {
  // GenerateBackgroundMesh's predicted_tets (Algorithms/BackgroundMesh/TetBudget.h): the size of
  // the mesh CleaveMesh will make from this background, on the box before cleaving runs.
  auto count = [](double n) {
    return n >= 1e6 ? QString::number(n / 1e6, 'f', 2) + " M" : n >= 1e4 ? QString::number(n / 1e3, 'f', 0) + " k"
                                                                         : QString::number(n, 'f', 0);
  };
  for (const auto& id : ids) {
    const ModuleState* st = exec_->state(id);
    if (!st || st->status != ModuleStatus::Done || !st->report.has("predicted_tets")) continue;
    const double tets = st->report.number("predicted_tets");
    QString tip = tr("predicted after cleaving: %1 tets").arg(QLocale().toString(qlonglong(tets)));
    if (st->report.has("predicted_cut_tets"))
      tip += tr(" (%1 of them in cut cells)").arg(QLocale().toString(qlonglong(st->report.number("predicted_cut_tets"))));
    if (st->report.has("tets"))
      tip += tr("; background %1 tets").arg(QLocale().toString(qlonglong(st->report.number("tets"))));
    if (st->report.has("max_tets")) tip += tr("; max_tets %1").arg(QLocale().toString(qlonglong(st->report.number("max_tets"))));
    scene_->setModuleNote(id, tr("≈%1 tets").arg(count(tets)), tip);
    if (!st->reused) log(QString("    %1: %2").arg(qs(id), tip));
  }
}

void MainWindow::selectModule(const QString& id) {
  scene_->clearSelection();
  if (ModuleItem* m = scene_->moduleItem(ss(id))) {
    m->setSelected(true);
    view_->ensureVisible(m);
  }
}

void MainWindow::onSelectionChanged() {
  const auto ids = scene_->selectedModuleIds();
  if (ids.size() != 1) {
    if (ids.empty()) params_->showModule("");
    return;
  }
  if (params_->moduleId() != ids.front()) params_->showModule(ids.front());
  showModuleResults(ids.front());
}

void MainWindow::showModuleResults(const std::string& id) {
  const ModuleNode* node = net_->module(id);
  if (!node) return;
  if (exec_->isRunning()) {
    report_->showMessage(tr("%1 (%2): executing…").arg(qs(id), qs(node->info->name)));
    return;
  }
  const ModuleState* st = exec_->state(id);
  const QString title = QString("%1 (%2)").arg(qs(id), qs(node->info->name));
  if (!st || st->moduleName != node->info->name || st->status == ModuleStatus::Idle) {
    report_->showMessage(tr("%1: not executed yet").arg(title));
    if (mesh_) mesh_->clearData(tr("%1: not executed yet").arg(title));
    return;
  }
  // A failed gate (EvaluateQuality gate = pass_on) keeps its report and its mesh: both are shown.
  if (st->status == ModuleStatus::Error && !st->passedOn) report_->showMessage(title + ": " + qs(st->error));
  else report_->showReport(QString("%1 — %2, %3 s%4")
                               .arg(title, moduleStatusName(st->status))
                               .arg(st->seconds, 0, 'f', 3)
                               .arg(st->passedOn ? " — " + qs(st->error) : QString()),
                           st->report);
  if (!mesh_) return;
  DataPtr shown;
  for (const auto& d : st->outputs)
    if (d && d->type() == PortType::TetMesh) {
      shown = d;
      break;
    }
  if (!shown)
    for (const auto& d : st->outputs)
      if (d && d->type() == PortType::LabelVolume) {
        shown = d;
        break;
      }
  if (shown) mesh_->showData(shown, labelNames(shown), title);
  else mesh_->clearData(tr("%1 has no mesh or label volume output").arg(title));
}

std::map<int, QString> MainWindow::labelNames(const DataPtr& data) {
  // The tissue names the data carries (a label table read with the volume, the head phantom's).
  const std::map<int32_t, std::string>* names = nullptr;
  if (data->type() == PortType::TetMesh) names = &static_cast<const TetMeshData&>(*data).value.materialNames;
  else if (data->type() == PortType::LabelVolume) names = &static_cast<const LabelVolumeData&>(*data).value.labelNames;
  std::map<int, QString> out;
  if (names)
    for (const auto& [label, name] : *names) out[label] = QString::fromStdString(name);
  return out;
}

void MainWindow::showModuleLog(const std::string& id) {
  logDock_->raise();
  const ModuleState* st = exec_->state(id);
  if (!st || st->status == ModuleStatus::Idle) {
    log(tr("%1: not executed yet").arg(qs(id)));
    return;
  }
  log(tr("%1: %2, %3 s").arg(qs(id), moduleStatusName(st->status)).arg(st->seconds, 0, 'f', 3));
  for (const auto& s : st->stages) log(QString("    stage %1: %2 s").arg(qs(s.name)).arg(s.seconds, 0, 'f', 3));
  for (const auto& m : st->messages) log("    " + qs(m));
  if (!st->error.empty()) log("    error: " + qs(st->error));
}

void MainWindow::onContextAction(const QString& id, const QString& action) {
  if (action == "execute") executeFrom(id);
  else if (action == "upto") executeUpTo(id);
  else if (action == "report") {
    selectModule(id);
    reportDock_->raise();
    showModuleResults(ss(id));
  } else if (action == "log") showModuleLog(ss(id));
}

} // namespace tetflow::gui
