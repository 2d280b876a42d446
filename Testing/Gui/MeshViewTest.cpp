// The 3D view (VTK in a QOpenGLWidget). Runs under xvfb-run (Qt's offscreen platform cannot host
// a QOpenGLWidget, PLATFORM.md): rendered-pixel checks (known background colour present and a fair
// share of other pixels), material toggles, clipping, field colouring, label-volume slices,
// re-creation of the GL context when the dock floats, and the main window showing the mesh of a
// CleaveMesh module after execution.
#include <QDockWidget>
#include <QImage>
#include <QListWidget>
#include <QStandardPaths>
#include <QtTest>

#include <cmath>

#include "Interface/Gui/Canvas.h"
#include "Interface/Gui/ExecutionController.h"
#include "Interface/Gui/MainWindow.h"
#include "Interface/Gui/MeshSurface.h"
#include "Interface/Gui/MeshView.h"
#include "Interface/Gui/VtkWidget.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "Modules/StandardModules.h"

using namespace tetflow;
using namespace tetflow::gui;

namespace {
// 10 mm cube as 6 Kuhn tets (positively oriented); tets 0-2 material 1, 3-5 material 2.
TetMesh cube() {
  TetMesh m;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) m.points.push_back({10.0 * i, 10.0 * j, 10.0 * k});
  const int axes[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& a : axes) {
    int v1 = 1 << a[0], v2 = v1 | (1 << a[1]);
    TetMesh::Tet t{0, v1, v2, 7};
    if (signedTetVolume(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]) < 0) std::swap(t[2], t[3]);
    m.tets.push_back(t);
    m.materials.push_back(m.tets.size() <= 3 ? 1 : 2);
  }
  Field pot;
  for (const auto& p : m.points) pot.values.push_back(0.5 * p[0]); // |grad| = 0.5
  m.pointFields["potential"] = pot;
  return m;
}

const QColor kBackground(82, 87, 110); // MeshView background 0.32, 0.34, 0.43

struct PixelStats {
  double background = 0, other = 0;
};
PixelStats stats(const QImage& img) {
  PixelStats s;
  const double n = double(img.width()) * img.height();
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      const QColor c = img.pixelColor(x, y);
      const bool bg = std::abs(c.red() - kBackground.red()) <= 3 && std::abs(c.green() - kBackground.green()) <= 3 &&
                      std::abs(c.blue() - kBackground.blue()) <= 3;
      (bg ? s.background : s.other) += 1;
    }
  s.background /= n;
  s.other /= n;
  return s;
}

// Waits for a fresh paintGL, then reads the widget's framebuffer.
QImage renderNow(VtkWidget* w) {
  const int before = w->renderCount();
  w->update();
  for (int i = 0; i < 500 && w->renderCount() <= before; ++i) QTest::qWait(10);
  if (w->renderCount() <= before) return {};
  return w->grabFramebuffer();
}
} // namespace

class MeshViewTest : public QObject {
  Q_OBJECT
  ModuleRegistry registry_;

private slots:
  void initTestCase() {
    QStandardPaths::setTestModeEnabled(true);
    registerStandardModules(registry_);
  }

  void surfaceExtraction() {
    const TetMesh m = cube();
    const MeshTopology topo = MeshTopology::build(m);
    QCOMPARE(topo.labels, std::vector<int32_t>({1, 2}));
    const auto all = extractSurface(m, topo, [](int) { return true; }, ClipPlane{});
    QCOMPARE(all.faces.size(), size_t(12)); // 6 cube sides x 2 triangles
    // Outward orientation: each face normal points away from the cube centre.
    for (const auto& f : all.faces) {
      const Vec3 n = cross(m.points[f[1]] - m.points[f[0]], m.points[f[2]] - m.points[f[0]]);
      const Vec3 c = (1.0 / 3.0) * (m.points[f[0]] + m.points[f[1]] + m.points[f[2]]);
      QVERIFY(dot(n, c - Vec3{5, 5, 5}) > 0);
    }
    const auto one = extractSurface(m, topo, [](int l) { return l == 1; }, ClipPlane{});
    QVERIFY(one.faces.size() > 0 && one.faces.size() != 12);
    const auto grad = computeGradientMagnitude(m, m.pointFields.at("potential").values);
    for (double g : grad) QVERIFY(std::abs(g - 0.5) < 1e-12);
    const auto md = computeMinDihedral(m);
    for (double a : md) QVERIFY(a > 30 && a < 90);
  }

  // Over the memory budget the view builds nothing and says why; within it, it shows the mesh.
  void refusesAMeshOverTheMemoryBudget() {
    MeshView mv;
    tetflow::setMemoryLimit(1); // 1 byte: nothing fits
    mv.showData(makeData<TetMeshData>(cube()), {}, "cube");
    tetflow::setMemoryLimit(0);
    QVERIFY(!mv.data());
    QVERIFY2(mv.statusText().contains("showing cube (6 tets) in 3D would need") &&
                 mv.statusText().contains("raise the memory limit"),
             qPrintable(mv.statusText()));
    mv.showData(makeData<TetMeshData>(cube()), {}, "cube");
    QVERIFY(mv.data());
    QCOMPARE(mv.visibleFaceCount(), size_t(12));
  }

  void rendersMeshTogglesClipsAndColours() {
    MeshView mv;
    mv.resize(640, 480);
    mv.show();
    QVERIFY(QTest::qWaitForWindowExposed(&mv));
    mv.showData(makeData<TetMeshData>(cube()), {{1, "inner"}, {2, "outer"}}, "cube");
    QCOMPARE(mv.visibleFaceCount(), size_t(12));
    QCOMPARE(mv.legend()->count(), 2);
    QVERIFY(mv.legend()->item(0)->text().contains("inner"));
    PixelStats s = stats(renderNow(mv.vtkWidget()));
    QVERIFY2(s.background > 0.2, qPrintable(QString("background %1").arg(s.background)));
    QVERIFY2(s.other > 0.05, qPrintable(QString("mesh pixels %1").arg(s.other)));

    // Hide material 2 (through the legend's check box).
    mv.legend()->item(1)->setCheckState(Qt::Unchecked);
    const size_t oneMaterial = mv.visibleFaceCount();
    QVERIFY(oneMaterial > 0 && oneMaterial != 12);
    mv.setMaterialVisible(2, true);
    QCOMPARE(mv.visibleFaceCount(), size_t(12));

    // Clipping removes tets and exposes inner faces; the picture stays a picture.
    mv.setClip(true, 0, 0.5, true);
    const size_t clipped = mv.visibleFaceCount();
    QVERIFY(clipped > 0 && clipped != 12);
    s = stats(renderNow(mv.vtkWidget()));
    QVERIFY(s.background > 0.2 && s.other > 0.03);
    mv.setClip(false, 0, 0.5);
    QCOMPARE(mv.visibleFaceCount(), size_t(12));

    // Field colouring with a scalar bar.
    QVERIFY(mv.colorChoices().contains("min_dihedral"));
    QVERIFY(mv.colorChoices().contains("potential"));
    QVERIFY(mv.colorChoices().contains("|∇potential|"));
    mv.setColorBy("potential");
    QVERIFY(mv.scalarBarVisible());
    mv.setColorBy("min_dihedral");
    mv.setEdgesVisible(true);
    s = stats(renderNow(mv.vtkWidget()));
    QVERIFY(s.background > 0.2 && s.other > 0.05);
    mv.setColorBy("material");
    QVERIFY(!mv.scalarBarVisible());
  }

  void rendersLabelVolumeSlices() {
    LabelVolume v;
    GridGeometry g;
    g.dims = {20, 20, 20};
    g.spacing = {1, 1, 1};
    v.allocate(g, 0);
    for (int k = 0; k < 20; ++k)
      for (int j = 0; j < 20; ++j)
        for (int i = 0; i < 20; ++i)
          if ((i - 10) * (i - 10) + (j - 10) * (j - 10) + (k - 10) * (k - 10) < 49) v.at(i, j, k) = 3;
    MeshView mv;
    mv.resize(500, 400);
    mv.show();
    QVERIFY(QTest::qWaitForWindowExposed(&mv));
    mv.showData(makeData<LabelVolumeData>(std::move(v)), {}, "volume");
    QCOMPARE(mv.materialLabels(), std::vector<int>({0, 3}));
    const PixelStats s = stats(renderNow(mv.vtkWidget()));
    QVERIFY2(s.background > 0.1 && s.other > 0.05, qPrintable(QString("%1 %2").arg(s.background).arg(s.other)));
  }

  void mainWindowShowsCleavedMeshAndSurvivesFloatingDock() {
    MainWindow win(registry_);
    win.setInteractive(false);
    win.resize(1280, 800);
    win.show();
    QVERIFY(QTest::qWaitForWindowExposed(&win));
    QVERIFY(win.meshView());
    NetworkScene* sc = win.scene();
    Network& net = win.network();
    const auto ph = sc->addModule("CreatePhantom", {0, 0});
    net.setParameterText(ph, "kind", "head");
    net.setParameterText(ph, "voxel_size", "6");
    const auto bg = sc->addModule("GenerateBackgroundMesh", {0, 120});
    net.setParameterText(bg, "cell_size", "12");
    const auto cm = sc->addModule("CleaveMesh", {0, 240});
    net.setParameterText(cm, "strip_exterior", "0");
    QVERIFY(sc->tryConnect(ph, 0, bg, 0).isEmpty());
    QVERIFY(sc->tryConnect(ph, 0, cm, 0).isEmpty());
    QVERIFY(sc->tryConnect(bg, 0, cm, 1).isEmpty());
    QVERIFY(win.executeAll());
    QVERIFY(win.execution()->waitForFinished(60000));
    QVERIFY(win.execution()->lastSummary().success);
    win.selectModule(QString::fromStdString(cm));
    MeshView* mv = win.meshView();
    QVERIFY(mv->data());
    // Scalp, skull and brain survive this coarse lattice (the 2 mm CSF layer may be lost).
    const auto labels = mv->materialLabels();
    QVERIFY(labels.size() >= 3 && labels.front() == 1 && labels.back() == 4);
    const size_t full = mv->visibleFaceCount();
    QVERIFY(full > 0);
    PixelStats s = stats(renderNow(mv->vtkWidget()));
    QVERIFY(s.background > 0.1 && s.other > 0.05);
    mv->setClip(true, 1, 0.5, true);
    QVERIFY(mv->visibleFaceCount() != full);

    // Floating the dock reparents the widget: Qt recreates the GL context (PLATFORM.md 3).
    auto* dock = win.findChild<QDockWidget*>("view3d");
    QVERIFY(dock);
    dock->setFloating(true);
    QTest::qWait(200);
    s = stats(renderNow(mv->vtkWidget()));
    QVERIFY2(s.background > 0.1 && s.other > 0.05, qPrintable(QString("%1 %2").arg(s.background).arg(s.other)));
    dock->setFloating(false);
    QTest::qWait(200);
    s = stats(renderNow(mv->vtkWidget()));
    QVERIFY(s.background > 0.1 && s.other > 0.05);
  }
};

int main(int argc, char** argv) {
  VtkWidget::preferXcb();
  VtkWidget::setDefaultSurfaceFormat();
  QApplication app(argc, argv);
  MeshViewTest t;
  return QTest::qExec(&t, argc, argv);
}
#include "MeshViewTest.moc"
