// Node-editor behaviour (QtTest, runs under QT_QPA_PLATFORM=offscreen; no 3D view there):
// palette, adding modules, dragging wires with the mouse, refusing bad wires, undo/redo, moving,
// parameter edits through the panel, every shipped net's parameter values shown whole at the
// default window size, save -> same bytes, and executing a small network off the GUI thread with
// statuses on the canvas.
#include <QComboBox>
#include <QDir>
#include <QDockWidget>
#include <QDropEvent>
#include <QMimeData>
#include <QTreeWidget>
#include <QFile>
#include <QFileInfo>
#include <QMessageBox>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QTimer>
#include <QRegularExpression>
#include <QSet>
#include <QSignalSpy>
#include <QStandardPaths>
#include <QTemporaryDir>
#include <QTableWidget>
#include <QThread>
#include <QToolButton>
#include <QUndoStack>
#include <QtTest>

#include "Interface/Gui/Canvas.h"
#include "Interface/Gui/ExecutionController.h"
#include "Interface/Gui/MainWindow.h"
#include "Interface/Gui/Palette.h"
#include "Interface/Gui/ParameterPanel.h"
#include "Interface/Gui/ReportView.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "Modules/StandardModules.h"
#include "ParameterCheck.h"

using namespace tetflow;
using namespace tetflow::gui;

namespace {
QByteArray readAll(const QString& path) {
  QFile f(path);
  return f.open(QIODevice::ReadOnly) ? f.readAll() : QByteArray();
}
} // namespace

class NodeEditorTest : public QObject {
  Q_OBJECT
  ModuleRegistry registry_;
  std::unique_ptr<MainWindow> win_;

  NetworkScene* scene() { return win_->scene(); }
  Network& net() { return win_->network(); }
  QPoint viewPos(QPointF scenePos) { return win_->view()->mapFromScene(scenePos); }
  // Drags with the left button held, in steps, like a user.
  void drag(QPointF fromScene, QPointF toScene) {
    QWidget* vp = win_->view()->viewport();
    const QPoint a = viewPos(fromScene), b = viewPos(toScene);
    QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, a);
    for (int i = 1; i <= 5; ++i) QTest::mouseMove(vp, a + (b - a) * i / 5);
    QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, b);
  }
  // A small sphere phantom -> regular lattice (3 mm) -> CleaveMesh, wired on the canvas.
  void addSphereLatticeCleave(std::string& ph, std::string& bg, std::string& cm) {
    ph = scene()->addModule("CreatePhantom", {0, 0});
    net().setParameterText(ph, "kind", "sphere");
    net().setParameterText(ph, "radius", "10");
    net().setParameterText(ph, "voxel_size", "1");
    bg = scene()->addModule("GenerateBackgroundMesh", {0, 120});
    net().setParameterText(bg, "cell_size", "3");
    cm = scene()->addModule("CleaveMesh", {0, 240});
    QVERIFY(scene()->tryConnect(ph, 0, bg, 0).isEmpty());
    QVERIFY(scene()->tryConnect(ph, 0, cm, 0).isEmpty());
    QVERIFY(scene()->tryConnect(bg, 0, cm, 1).isEmpty());
  }
  PortItem* out(const std::string& id, int i) { return scene()->moduleItem(id)->outputPort(i); }
  PortItem* in(const std::string& id, int i) { return scene()->moduleItem(id)->inputPort(i); }

private slots:
  void initTestCase() {
    QStandardPaths::setTestModeEnabled(true); // recent-files settings stay out of ~/.config
    registerStandardModules(registry_);
  }
  void init() {
    win_ = std::make_unique<MainWindow>(registry_);
    win_->setInteractive(false);
    win_->resize(1200, 800);
    win_->show();
    QVERIFY(QTest::qWaitForWindowExposed(win_.get()));
    win_->view()->resetTransform();
    win_->view()->centerOn(200, 200);
  }
  void cleanup() { win_.reset(); }

  // Network > Memory Limit: the budget the modules and the 3D view check (README "Reliability").
  void memoryLimitIsSetCheckedAndRemembered() {
    QString error;
    QVERIFY(!win_->setMemoryLimit("lots", &error));
    QVERIFY2(error.contains("memory limit") && error.contains("lots"), qPrintable(error));
    QVERIFY(win_->setMemoryLimit("1.5G", &error));
    QCOMPARE(tetflow::memoryLimit(), int64_t(1536) * 1024 * 1024);
    QCOMPARE(win_->memoryLimitText(), QString("1.5G"));
    // A new window (a new session) starts with the remembered limit.
    tetflow::setMemoryLimit(0);
    {
      MainWindow again(registry_);
      QCOMPARE(again.memoryLimitText(), QString("1.5G"));
      QCOMPARE(tetflow::memoryLimit(), int64_t(1536) * 1024 * 1024);
      QVERIFY(again.setMemoryLimit("", &error));
    }
    QCOMPARE(tetflow::memoryLimit(), int64_t(0));
    QCOMPARE(MainWindow(registry_).memoryLimitText(), QString());
  }

  void paletteListsRegistryAndFilters() {
    ModulePalette* p = win_->palette();
    QCOMPARE(p->visibleModuleCount(), int(registry_.all().size()));
    p->setFilter("cleave");
    QCOMPARE(p->visibleModuleCount(), 1);
    p->setFilter("ImproveMesh"); // the mesh improvement module is offered like every other
    QCOMPARE(p->visibleModuleCount(), 1);
    p->setFilter("Meshing"); // category
    QVERIFY(p->visibleModuleCount() >= 3);
    p->setFilter("");
    // Dragging a palette entry onto the canvas adds the module where it is dropped.
    QTreeWidgetItem* cleave = p->tree()->findItems("CleaveMesh", Qt::MatchExactly | Qt::MatchRecursive).value(0);
    QVERIFY(cleave);
    QMimeData* md = p->tree()->model()->mimeData({p->tree()->indexFromItem(cleave)});
    QVERIFY(md && md->hasFormat(kModuleMime));
    const QPoint dropAt = viewPos({300, 300});
    QDragEnterEvent enter(dropAt, Qt::CopyAction, md, Qt::LeftButton, Qt::NoModifier);
    QApplication::sendEvent(win_->view()->viewport(), &enter);
    QVERIFY(enter.isAccepted());
    QDragMoveEvent move(dropAt, Qt::CopyAction, md, Qt::LeftButton, Qt::NoModifier);
    QApplication::sendEvent(win_->view()->viewport(), &move);
    QDropEvent drop(dropAt, Qt::CopyAction, md, Qt::LeftButton, Qt::NoModifier);
    QApplication::sendEvent(win_->view()->viewport(), &drop);
    delete md;
    QCOMPARE(net().modules().size(), size_t(1));
    QCOMPARE(net().modules()[0].info->name, std::string("CleaveMesh"));
    QVERIFY(std::abs(net().modules()[0].x - 220) <= 1 && std::abs(net().modules()[0].y - 271) <= 1);
    win_->undoStack()->undo();
    QCOMPARE(net().modules().size(), size_t(0));
    // Double-click adds through the network model.
    QSignalSpy spy(p, &ModulePalette::addRequested);
    emit p->addRequested("CreatePhantom");
    QCOMPARE(net().modules().size(), size_t(1));
    QVERIFY(scene()->moduleItem(net().modules()[0].id));
  }

  void dragWireConnectsCompatiblePorts() {
    const auto a = scene()->addModule("CreatePhantom", {100, 50});
    const auto b = scene()->addModule("GenerateBackgroundMesh", {100, 250});
    QCOMPARE(a, std::string("m1"));
    QCOMPARE(b, std::string("m2"));
    QVERIFY(scene()->moduleItem(b));
    // While dragging: compatible inputs highlighted, incompatible dimmed.
    QWidget* vp = win_->view()->viewport();
    const QPoint start = viewPos(out(a, 0)->scenePos());
    QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, start);
    QTest::mouseMove(vp, start + QPoint(0, 40));
    QVERIFY(scene()->isDraggingWire());
    QCOMPARE(in(b, 0)->highlight(), 1);
    QCOMPARE(out(b, 0)->highlight(), -1);
    QTest::mouseMove(vp, viewPos(in(b, 0)->scenePos()));
    QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, viewPos(in(b, 0)->scenePos()));
    QVERIFY(!scene()->isDraggingWire());
    QCOMPARE(net().connections().size(), size_t(1));
    const Connection& c = net().connections()[0];
    QCOMPARE(c.from, a);
    QCOMPARE(c.to, b);
    QCOMPARE(c.toPort, 0);
    QVERIFY(scene()->wireItem(c.id));
    QCOMPARE(in(b, 0)->highlight(), 0); // feedback cleared
    // Dragging from an input back to an output works too (second CleaveMesh input).
    const auto cm = scene()->addModule("CleaveMesh", {100, 450});
    drag(in(cm, 1)->scenePos(), out(b, 0)->scenePos());
    QVERIFY(net().inputConnection(cm, 1));
  }

  void badWiresAreRefused() {
    const auto a = scene()->addModule("CreatePhantom", {100, 50});
    const auto q = scene()->addModule("EvaluateQuality", {100, 250});
    const auto b = scene()->addModule("GenerateBackgroundMesh", {400, 50});
    // Type: LabelVolume -> TetMesh input.
    drag(out(a, 0)->scenePos(), in(q, 0)->scenePos());
    QCOMPARE(net().connections().size(), size_t(0));
    QVERIFY(win_->logView()->toPlainText().contains("refused"));
    // One wire per input.
    drag(out(a, 0)->scenePos(), in(b, 0)->scenePos());
    QCOMPARE(net().connections().size(), size_t(1));
    const auto a2 = scene()->addModule("CreatePhantom", {400, -150});
    drag(out(a2, 0)->scenePos(), in(b, 0)->scenePos());
    QCOMPARE(net().connections().size(), size_t(1));
    // Cycle: CleaveMesh -> EvaluateQuality -> back into CleaveMesh's background input.
    const auto cm = scene()->addModule("CleaveMesh", {700, 50});
    QVERIFY(scene()->tryConnect(cm, 0, q, 0).isEmpty());
    const QString why = scene()->tryConnect(q, 0, cm, 1);
    QVERIFY2(!why.isEmpty(), "cycle must be refused");
    QVERIFY(!net().inputConnection(cm, 1));
    // The same refusal shows while dragging: the port is dimmed.
    QWidget* vp = win_->view()->viewport();
    QTest::mousePress(vp, Qt::LeftButton, Qt::NoModifier, viewPos(out(q, 0)->scenePos()));
    QTest::mouseMove(vp, viewPos(out(q, 0)->scenePos() + QPointF(30, 60)));
    QCOMPARE(in(cm, 1)->highlight(), -1);
    QVERIFY(!in(cm, 1)->refusal().isEmpty());
    QTest::mouseRelease(vp, Qt::LeftButton, Qt::NoModifier, viewPos(in(cm, 1)->scenePos()));
    QVERIFY(!net().inputConnection(cm, 1));
  }

  void undoRedoAddConnectDeleteMove() {
    QUndoStack* u = win_->undoStack();
    const auto a = scene()->addModule("CreatePhantom", {100, 50});
    const auto b = scene()->addModule("GenerateBackgroundMesh", {100, 250});
    drag(out(a, 0)->scenePos(), in(b, 0)->scenePos());
    QCOMPARE(net().connections().size(), size_t(1));
    const std::string cid = net().connections()[0].id;
    QCOMPARE(u->count(), 3);
    u->undo();
    QCOMPARE(net().connections().size(), size_t(0));
    QVERIFY(!scene()->wireItem(cid));
    u->undo();
    QVERIFY(!net().module(b));
    QVERIFY(!scene()->moduleItem(b));
    u->redo();
    u->redo();
    QVERIFY(net().module(b));
    QCOMPARE(net().connections().size(), size_t(1));
    QCOMPARE(net().connections()[0].id, cid); // same ids again

    // Delete a connected module with the keyboard; undo restores module, parameters and wire.
    net().setParameterText(a, "kind", "sphere"); // direct model edit: canvas follows too
    scene()->clearSelection();
    scene()->moduleItem(a)->setSelected(true);
    win_->view()->setFocus();
    QTest::keyClick(win_->view()->viewport(), Qt::Key_Delete);
    QVERIFY(!net().module(a));
    QCOMPARE(net().connections().size(), size_t(0));
    u->undo();
    QVERIFY(net().module(a));
    QCOMPARE(std::get<std::string>(net().module(a)->params.at("kind")), std::string("sphere"));
    QCOMPARE(net().connections().size(), size_t(1));
    QVERIFY(scene()->wireItem(cid));

    // Move by dragging the title; positions land in the model (whole numbers); undo moves back.
    ModuleItem* item = scene()->moduleItem(b);
    const QPointF before = item->pos();
    drag(item->pos() + QPointF(60, 10), item->pos() + QPointF(60 + 80, 10 + 40));
    const ModuleNode* nb = net().module(b);
    QCOMPARE(nb->x, before.x() + 80);
    QCOMPARE(nb->y, before.y() + 40);
    QCOMPARE(item->pos(), QPointF(nb->x, nb->y));
    u->undo();
    QCOMPARE(net().module(b)->x, before.x());
    QCOMPARE(item->pos(), before);
  }

  void rubberBandSelectsZoomAndFit() {
    const auto a = scene()->addModule("CreatePhantom", {100, 50});
    const auto b = scene()->addModule("GenerateBackgroundMesh", {100, 200});
    const auto c = scene()->addModule("CleaveMesh", {600, 50});
    scene()->clearSelection();
    drag({60, 20}, {320, 290}); // from empty canvas around a and b
    QCOMPARE(scene()->selectedModuleIds(), std::vector<std::string>({a, b}));
    QVERIFY(!scene()->moduleItem(c)->isSelected());
    const double s0 = win_->view()->transform().m11();
    win_->view()->zoomBy(1.5);
    QVERIFY(win_->view()->transform().m11() > s0);
    win_->view()->fitAll();
    for (const auto& id : {a, b, c}) {
      const QRect r = win_->view()->mapFromScene(scene()->moduleItem(id)->sceneBoundingRect()).boundingRect();
      QVERIFY(win_->view()->viewport()->rect().contains(r));
    }
  }

  void parameterPanelValidatesAndUndoes() {
    const auto b = scene()->addModule("GenerateBackgroundMesh", {100, 250});
    win_->selectModule(QString::fromStdString(b));
    ParameterPanel* p = win_->parameters();
    QCOMPARE(p->moduleId(), b);
    QVERIFY(qobject_cast<DoubleSpin*>(p->editor("cell_size")));
    QVERIFY(qobject_cast<QComboBox*>(p->editor("kind")));
    QCOMPARE(qobject_cast<DoubleSpin*>(p->editor("cell_size"))->text(), QString("4"));
    QVERIFY(!p->applyText("cell_size", "-1").isEmpty()); // out of range: refused
    QVERIFY(!p->applyText("cell_size", "abc").isEmpty());
    QCOMPARE(std::get<double>(net().module(b)->params.at("cell_size")), 4.0);
    const int before = win_->undoStack()->count();
    // Typing into the spin box (Enter commits, keyboard tracking off).
    auto* spin = qobject_cast<DoubleSpin*>(p->editor("cell_size"));
    spin->setFocus();
    spin->selectAll();
    QTest::keyClicks(spin, "2.5");
    QTest::keyClick(spin, Qt::Key_Return);
    QCOMPARE(std::get<double>(net().module(b)->params.at("cell_size")), 2.5);
    QCOMPARE(win_->undoStack()->count(), before + 1);
    QVERIFY(win_->isModified());
    win_->undoStack()->undo();
    QCOMPARE(std::get<double>(net().module(b)->params.at("cell_size")), 4.0);
    QCOMPARE(spin->value(), 4.0); // the panel follows the model
    // Path parameters get a file picker; enums a combo box with the choices.
    const auto w = scene()->addModule("WriteMesh", {400, 250});
    win_->selectModule(QString::fromStdString(w));
    QVERIFY(p->editor("filename"));
    QVERIFY(p->editor("filename")->parentWidget()->findChild<QToolButton*>());
  }

  // Issue 27, item 4: at the default window size every parameter of every module of every shipped
  // net shows its name (with its unit) and its whole value, without scrolling.
  void everyParameterValueIsVisibleAtTheDefaultSize() {
    win_ = std::make_unique<MainWindow>(registry_); // as the application starts: no resize
    win_->setInteractive(false);
    win_->show();
    QVERIFY(QTest::qWaitForWindowExposed(win_.get()));
    QCOMPARE(win_->size(), QSize(1280, 800));
    const QDir nets(TETFLOW_SOURCE_DIR "/Nets");
    const QStringList files = nets.entryList({"*.srn"});
    QVERIFY(!files.isEmpty());
    ShownParameters shown;
    for (const QString& f : files) {
      QVERIFY2(win_->openFile(nets.filePath(f)), qPrintable(f));
      for (const ModuleNode& m : net().modules()) {
        const QString problem = shown.check(*win_, m, f);
        QVERIFY2(problem.isEmpty(), qPrintable(problem));
      }
    }
    QVERIFY(shown.checked > 100);
    QVERIFY(shown.longest >= 15); // the longest list (AssembleFEMPoisson) was among them
    const auto* dock = win_->findChild<QDockWidget*>("parameters");
    qInfo("parameter dock %d x %d px, %d parameters checked; least room left under a form: %d px (%s)",
          dock->width(), dock->height(), shown.checked, shown.tightest, qPrintable(shown.tightestAt));
  }

  void saveWritesTheSameBytes() {
    const QDir nets(TETFLOW_SOURCE_DIR "/Nets");
    QTemporaryDir tmp;
    const QStringList files = nets.entryList({"*.srn"});
    QVERIFY(!files.isEmpty());
    for (const QString& f : files) {
      QVERIFY2(win_->openFile(nets.filePath(f)), qPrintable(f));
      QVERIFY(!win_->isModified());
      QCOMPARE(scene()->moduleItems().size(), net().modules().size());
      const QString out = tmp.filePath(f);
      QVERIFY(win_->saveFile(out));
      QCOMPARE(readAll(out), readAll(nets.filePath(f)));
      // Edit + undo is clean again and still saves the same bytes.
      const auto& m0 = net().modules().front();
      drag(scene()->moduleItem(m0.id)->pos() + QPointF(50, 10), scene()->moduleItem(m0.id)->pos() + QPointF(90, 30));
      QVERIFY(win_->isModified());
      win_->undoStack()->undo();
      QVERIFY(!win_->isModified());
      QVERIFY(win_->saveFile(out));
      QCOMPARE(readAll(out), readAll(nets.filePath(f)));
    }
  }

  void executesOffTheGuiThreadWithStatuses() {
    // Small sphere phantom -> lattice -> cleave -> quality, plus a broken branch.
    std::string ph, bg, cm;
    addSphereLatticeCleave(ph, bg, cm);
    if (QTest::currentTestFailed()) return;
    const auto q = scene()->addModule("EvaluateQuality", {0, 360});
    QVERIFY(scene()->tryConnect(cm, 0, q, 0).isEmpty());
    const auto bad = scene()->addModule("CleaveMesh", {300, 240}); // background not connected
    const auto badq = scene()->addModule("EvaluateQuality", {300, 360});
    QVERIFY(scene()->tryConnect(ph, 0, bad, 0).isEmpty());
    QVERIFY(scene()->tryConnect(bad, 0, badq, 0).isEmpty());

    QThread* guiThread = QThread::currentThread();
    bool allOnGuiThread = true;
    int statusSignals = 0;
    connect(win_->execution(), &ExecutionController::moduleStatus, this, [&](const QString&, int) {
      allOnGuiThread &= QThread::currentThread() == guiThread;
      ++statusSignals;
    });
    QVERIFY(win_->executeAll());
    QVERIFY(win_->execution()->isRunning());
    // Editing while it runs is allowed (the executor works on a snapshot).
    net().setPosition(q, 10, 370);
    QVERIFY(win_->execution()->waitForFinished(60000));
    QVERIFY(allOnGuiThread);
    QVERIFY(statusSignals >= 6);
    for (const auto& id : {ph, bg, cm, q}) QCOMPARE(scene()->moduleItem(id)->status(), ModuleStatus::Done);
    QCOMPARE(scene()->moduleItem(bad)->status(), ModuleStatus::Error);
    QCOMPARE(scene()->moduleItem(badq)->status(), ModuleStatus::Skipped);
    QVERIFY(scene()->moduleItem(cm)->statusText().startsWith("done"));
    QVERIFY(scene()->moduleItem(cm)->statusText().contains(" s"));
    QVERIFY(win_->logView()->toPlainText().contains("input port 1"));

    // Selecting EvaluateQuality shows its report with the dihedral histogram.
    win_->selectModule(QString::fromStdString(q));
    QVERIFY(win_->reportView()->table()->rowCount() > 10);
    QCOMPARE(win_->reportView()->plot()->mode(), PlotWidget::Mode::Histogram);

    // Execute this and downstream (Executor::Options::only): upstream results are reused.
    emit scene()->moduleContextAction(QString::fromStdString(cm), "execute");
    QVERIFY(win_->execution()->waitForFinished(60000));
    QCOMPARE(win_->execution()->lastSummary().ran, 2); // cm and q; ph and bg were current
  }

  void upToHereShowsThePredictedTetCountBeforeCleaving() {
    // Execute up to the background (context menu "Execute up to here"): CleaveMesh does not run,
    // and the background's box shows the mesh size it predicts (its report's predicted_tets).
    std::string ph, bg, cm;
    addSphereLatticeCleave(ph, bg, cm);
    if (QTest::currentTestFailed()) return;
    emit scene()->moduleContextAction(QString::fromStdString(bg), "upto");
    QVERIFY(win_->execution()->waitForFinished(60000));
    QCOMPARE(win_->execution()->lastSummary().ran, 2);
    QCOMPARE(scene()->moduleItem(bg)->status(), ModuleStatus::Done);
    QCOMPARE(scene()->moduleItem(cm)->status(), ModuleStatus::Idle);
    const ModuleState* st = win_->execution()->state(bg);
    QVERIFY(st && st->report.has("predicted_tets"));
    const double predicted = st->report.number("predicted_tets");
    QVERIFY(predicted > 100);
    const QString expect = predicted >= 1e4 ? QString::number(predicted / 1e3, 'f', 0) + " k" : QString::number(predicted, 'f', 0);
    QCOMPARE(scene()->moduleItem(bg)->note(), QString("≈%1 tets").arg(expect));
    QVERIFY(scene()->moduleItem(bg)->statusText().endsWith(QString("≈%1 tets").arg(expect)));
    QVERIFY(scene()->moduleItem(bg)->toolTip().contains("predicted after cleaving"));
    QVERIFY(win_->logView()->toPlainText().contains("predicted after cleaving"));

    // Then the whole network: the background is reused, CleaveMesh makes about that many tets.
    QVERIFY(win_->executeAll());
    QVERIFY(win_->execution()->waitForFinished(60000));
    QCOMPARE(win_->execution()->lastSummary().ran, 1);
    const double tets = win_->execution()->state(cm)->report.number("tets");
    QVERIFY2(tets > 0.7 * predicted && tets < 1.4 * predicted,
             qPrintable(QString("predicted %1, cleaved %2").arg(predicted).arg(tets)));
    QVERIFY(!scene()->moduleItem(bg)->note().isEmpty()); // reused: the prediction still holds

    // A changed value upstream: the prediction is gone until the background runs again.
    net().setParameterText(ph, "radius", "9");
    QVERIFY(scene()->moduleItem(bg)->note().isEmpty());
    QVERIFY(scene()->moduleItem(cm)->note().isEmpty());
  }

  void runningModuleShowsItsStageAndElapsedTime() {
    // The default net's head phantom -> lattice -> cleave: CleaveMesh runs for seconds, through
    // named stages. While it runs its box says how long it has run and which stage it is in.
    const auto ph = scene()->addModule("CreatePhantom", {0, 0});
    net().setParameterText(ph, "kind", "head");
    net().setParameterText(ph, "voxel_size", "2");
    const auto bg = scene()->addModule("GenerateBackgroundMesh", {0, 120});
    net().setParameterText(bg, "cell_size", "4");
    const auto cm = scene()->addModule("CleaveMesh", {0, 240});
    QVERIFY(scene()->tryConnect(ph, 0, bg, 0).isEmpty());
    QVERIFY(scene()->tryConnect(ph, 0, cm, 0).isEmpty());
    QVERIFY(scene()->tryConnect(bg, 0, cm, 1).isEmpty());
    QVERIFY(win_->executeAll());
    ModuleItem* item = scene()->moduleItem(cm);
    const QRegularExpression live(R"(^running ([0-9.]+) s · ([a-z /]+))");
    QSet<QString> stages, elapsed;
    QString tip;
    while (win_->execution()->isRunning()) {
      QTest::qWait(50);
      if (item->status() != ModuleStatus::Running) continue;
      const auto m = live.match(item->statusText());
      if (!m.hasMatch()) continue;
      elapsed.insert(m.captured(1));
      stages.insert(m.captured(2).trimmed());
      tip = item->toolTip();
    }
    QVERIFY(win_->execution()->waitForFinished(60000));
    QCOMPARE(item->status(), ModuleStatus::Done);
    QVERIFY2(elapsed.size() >= 2, qPrintable(QStringList(elapsed.values()).join(", ")));
    QVERIFY2(!stages.isEmpty(), "no stage shown while CleaveMesh ran");
    QVERIFY2(tip.contains("running"), qPrintable(tip)); // the whole line is in the tooltip
    QVERIFY(item->statusText().startsWith("done"));
    QVERIFY(!item->toolTip().contains("running"));
  }

  void openingALabelVolumeOffersToMeshIt() {
    // A copy of the bundled head: the mesh is written beside the volume.
    QTemporaryDir dir;
    const QString volume = dir.filePath("my_head.nii.gz");
    QVERIFY(QFile::copy(TETFLOW_SOURCE_DIR "/Testing/Data/layered_head_4mm.nii.gz", volume));
    // Answered "Adaptive (octree)": the octree net, its sizes from the 4 mm voxels.
    win_->setInteractive(true);
    bool answered = false;
    QTimer::singleShot(0, this, [&] {
      for (QWidget* w : QApplication::topLevelWidgets())
        if (auto* box = qobject_cast<QMessageBox*>(w))
          if (auto* b = box->findChild<QPushButton*>("meshOctree")) {
            b->click();
            answered = true;
          }
    });
    QVERIFY(win_->openFile(volume));
    win_->setInteractive(false);
    QVERIFY(answered);
    QCOMPARE(net().modules().size(), size_t(6));
    auto text = [&](const char* id, const char* p) {
      const ModuleNode* m = net().module(id);
      return QString::fromStdString(formatParam(*m->info->param(p), m->params.at(p)));
    };
    QCOMPARE(text("m1", "filename"), QFileInfo(volume).absoluteFilePath());
    QCOMPARE(text("m2", "kind"), QString("octree_bcc"));
    QCOMPARE(text("m6", "min_size"), QString("16"));
    QCOMPARE(text("m6", "max_size"), QString("64"));
    QCOMPARE(text("m5", "filename"), QFileInfo(dir.filePath("my_head.vtu")).absoluteFilePath());
    QVERIFY(scene()->moduleItem("m6") != nullptr);
    // Without prompts (and as dropped on the canvas): the regular lattice; it runs and writes
    // the mesh beside the volume.
    emit win_->view()->dropFile(volume);
    QCOMPARE(net().modules().size(), size_t(5));
    QCOMPARE(text("m2", "cell_size"), QString("16"));
    QCOMPARE(text("m3", "strip_exterior"), QString("0")); // the air around the head, as tetflow mesh strips it
    QVERIFY(win_->executeAll());
    QVERIFY(win_->execution()->waitForFinished(120000));
    QVERIFY(win_->execution()->lastSummary().success);
    QVERIFY(QFileInfo::exists(dir.filePath("my_head.vtu")));
    // A file that is not a volume it can read: refused by name, the network kept.
    QVERIFY(!win_->meshVolume(dir.filePath("nothing.nii.gz"), MeshBackground::Regular));
    QVERIFY(win_->logView()->toPlainText().contains("nothing.nii.gz"));
    QCOMPARE(net().modules().size(), size_t(5));
  }

  void reportParsers() {
    QStringList labels;
    QVector<double> counts;
    QVERIFY(parseHistogram("0-5:0 5-10:3 10-15:12", labels, counts));
    QCOMPARE(labels, QStringList({"0-5", "5-10", "10-15"}));
    QCOMPARE(counts, QVector<double>({0, 3, 12}));
    QCOMPARE(parseSeries("1 0.5; 1e-3,2e-9"), QVector<double>({1, 0.5, 1e-3, 2e-9}));
    QCOMPARE(parseSeries("0:1 1:0.1"), QVector<double>({1, 0.1}));
    Report r;
    r.set("iterations", 3);
    r.set("residual_history", std::string("1 0.1 0.001 1e-9"));
    ReportView v;
    v.showReport("FEM", r);
    QCOMPARE(v.plot()->mode(), PlotWidget::Mode::LogSeries);
    QCOMPARE(v.table()->rowCount(), 2);
  }
};

QTEST_MAIN(NodeEditorTest)
#include "NodeEditorTest.moc"
