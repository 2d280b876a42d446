// The 3D view (VTK in a QOpenGLWidget). Runs under xvfb-run (Qt's offscreen platform cannot host
// a QOpenGLWidget, PLATFORM.md): rendered-pixel checks (known background colour present and a fair
// share of other pixels), material toggles, clipping, field colouring, label-volume slices,
// re-creation of the GL context when the dock floats, the main window showing the mesh of a
// CleaveMesh module after execution, colour scales (diverging, log), and every shipped net's
// parameter values shown whole at the default window size beside the 3D view.
#include <QComboBox>
#include <QDir>
#include <QDockWidget>
#include <QImage>
#include <QListWidget>
#include <QStandardPaths>
#include <QTemporaryDir>
#include <QtTest>

#include <functional>

#include <algorithm>
#include <cmath>

#include <vtkLookupTable.h>

#include "Interface/Gui/Canvas.h"
#include "Interface/Gui/ExecutionController.h"
#include "Interface/Gui/MainWindow.h"
#include "Interface/Gui/MeshSurface.h"
#include "Interface/Gui/MeshView.h"
#include "Interface/Gui/VtkWidget.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "Modules/StandardModules.h"
#include "ParameterCheck.h"

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

// n x n x n cubes of `size` mm, 6 Kuhn tets each, one material; `potential` is a current dipole's
// (along z, just off the centre so that no vertex sits on it): u = p.(x - x0) / |x - x0|^3.
TetMesh dipoleBox(int n, double size) {
  TetMesh m;
  const double h = size / n;
  auto id = [n](int i, int j, int k) { return int32_t((k * (n + 1) + j) * (n + 1) + i); };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.points.push_back({h * i, h * j, h * k});
  const int axes[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& a : axes) {
          int c[3] = {0, 0, 0};
          auto corner = [&] { return id(i + c[0], j + c[1], k + c[2]); };
          const int32_t v0 = corner();
          c[a[0]] = 1;
          const int32_t v1 = corner();
          c[a[1]] = 1;
          const int32_t v2 = corner();
          c[a[2]] = 1;
          const int32_t v3 = corner();
          TetMesh::Tet t{v0, v1, v2, v3};
          if (signedTetVolume(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]) < 0) std::swap(t[2], t[3]);
          m.tets.push_back(t);
          m.materials.push_back(1);
        }
  const Vec3 x0{0.5 * size + 0.3 * h, 0.5 * size + 0.2 * h, 0.5 * size + 0.4 * h};
  Field pot;
  for (const auto& p : m.points) {
    const Vec3 d = p - x0;
    const double r = std::sqrt(dot(d, d));
    pot.values.push_back(d[2] / (r * r * r));
  }
  m.pointFields["potential"] = pot;
  return m;
}

// Share of values whose place on the lookup table's scale is outside its middle fifth: how much
// of the surface shows a colour other than the scale's middle one.
double offMiddle(const std::vector<double>& values, vtkLookupTable* lut) {
  const double* r = lut->GetRange();
  const bool log = lut->GetScale() == VTK_SCALE_LOG10;
  auto place = [&](double v) {
    v = std::clamp(v, r[0], r[1]);
    return log ? (std::log10(v) - std::log10(r[0])) / (std::log10(r[1]) - std::log10(r[0])) : (v - r[0]) / (r[1] - r[0]);
  };
  double n = 0;
  for (double v : values) n += std::abs(place(v) - 0.5) > 0.1;
  return n / double(values.size());
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

  // Opens each shipped net in a main window, runs it with its outputs in a temporary folder, and
  // hands the window to `check` after each successful run.
  void runShippedNets(std::initializer_list<const char*> files,
                      const std::function<void(MainWindow&, const std::string&)>& check) {
    MainWindow win(registry_);
    win.setInteractive(false);
    win.show();
    QVERIFY(QTest::qWaitForWindowExposed(&win));
    const QDir nets(TETFLOW_SOURCE_DIR "/Nets");
    QTemporaryDir out;
    for (const char* f : files) {
      QVERIFY2(win.openFile(nets.filePath(f)), f);
      win.network().setOutputDir(out.path().toStdString());
      QVERIFY(win.executeAll());
      QVERIFY(win.execution()->waitForFinished(300000));
      QVERIFY2(win.execution()->lastSummary().success, f);
      check(win, f);
    }
  }

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

  // Issue 27, item 4: a dipole's potential gets a diverging scale symmetric about zero, magnitudes
  // a log scale, chosen by the field's kind; the Scale box overrides it per field.
  void signedFieldsDivergeAndMagnitudesAreLog() {
    QCOMPARE(MeshView::automaticScale("potential", false, -2, 3), MeshView::ColorScale::Diverging);
    QCOMPARE(MeshView::automaticScale("potential", false, 0, 1), MeshView::ColorScale::Linear);
    QCOMPARE(MeshView::automaticScale("|∇potential|", true, 0, 5), MeshView::ColorScale::Log);
    QCOMPARE(MeshView::automaticScale("current_density", false, 0, 5), MeshView::ColorScale::Log);
    QCOMPARE(MeshView::automaticScale("grad_magnitude", false, 0, 5), MeshView::ColorScale::Log);
    QCOMPARE(MeshView::automaticScale("min_dihedral", false, 10, 70), MeshView::ColorScale::Linear);

    MeshView mv;
    mv.resize(640, 480);
    mv.show();
    QVERIFY(QTest::qWaitForWindowExposed(&mv));
    const TetMesh box = dipoleBox(12, 60);
    mv.showData(makeData<TetMeshData>(TetMesh(box)), {}, "dipole");
    QVERIFY(!mv.scaleBox()->isEnabled()); // material colours: no scale
    mv.setColorBy("potential");
    QCOMPARE(mv.colorScale(), MeshView::ColorScale::Diverging);
    QCOMPARE(mv.scaleBox()->currentText(), QString("diverging"));
    QVERIFY(mv.scaleBox()->isEnabled());
    const auto [lo, hi] = mv.colorRange();
    QCOMPARE(lo, -hi);
    double maxAbs = 0;
    for (double v : box.pointFields.at("potential").values) maxAbs = std::max(maxAbs, std::abs(v));
    QVERIFY(hi > 0 && hi <= maxAbs);
    vtkLookupTable* lut = mv.lookupTable();
    QCOMPARE(lut->GetScale(), VTK_SCALE_LINEAR);
    double c[3];
    lut->GetColor(0.0, c); // white at zero
    QVERIFY2(c[0] > 0.85 && c[1] > 0.85 && c[2] > 0.85, qPrintable(QString("%1 %2 %3").arg(c[0]).arg(c[1]).arg(c[2])));
    lut->GetColor(hi, c); // red above
    QVERIFY(c[0] > c[2] + 0.4);
    lut->GetColor(-hi, c); // blue below
    QVERIFY(c[2] > c[0] + 0.4);
    // The surface is not one colour: much of it lies outside the middle of the scale, far more
    // than on a linear scale over the field's min..max, where the singular peaks squeeze
    // everything else into the middle.
    const double diverging = offMiddle(mv.shownValues(), lut);
    // The render has red and blue pixels (the scalar bar alone makes under 1 % of each).
    const QImage img = renderNow(mv.vtkWidget());
    QVERIFY(!img.isNull());
    double red = 0, blue = 0;
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) {
        const QColor p = img.pixelColor(x, y);
        const bool background = std::abs(p.red() - kBackground.red()) + std::abs(p.green() - kBackground.green()) +
                                    std::abs(p.blue() - kBackground.blue()) <= 9;
        red += !background && p.red() > p.blue() + 30;
        blue += !background && p.blue() > p.red() + 30;
      }
    const double pixels = double(img.width()) * img.height();
    QVERIFY2(red / pixels > 0.02 && blue / pixels > 0.02, qPrintable(QString("red %1 blue %2").arg(red / pixels).arg(blue / pixels)));

    // The user's choice: linear over min..max, kept for this field.
    mv.scaleBox()->setCurrentText("linear");
    QCOMPARE(mv.colorScale(), MeshView::ColorScale::Linear);
    const auto [llo, lhi] = mv.colorRange();
    QVERIFY(llo < -maxAbs * 0.5 && lhi > maxAbs * 0.5);
    const double linear = offMiddle(mv.shownValues(), lut);
    qInfo("surface off the middle colour: diverging %.2f, linear %.2f; red pixels %.3f, blue %.3f", diverging, linear,
          red / pixels, blue / pixels);
    QVERIFY2(diverging > 0.3 && diverging > 3 * linear,
             qPrintable(QString("off the middle colour: diverging %1, linear %2").arg(diverging).arg(linear)));

    // A magnitude: log10 over a positive range.
    mv.setColorBy("|∇potential|");
    QCOMPARE(mv.colorScale(), MeshView::ColorScale::Log);
    QCOMPARE(mv.scaleBox()->currentText(), QString("log"));
    QCOMPARE(lut->GetScale(), VTK_SCALE_LOG10);
    const auto [glo, ghi] = mv.colorRange();
    QVERIFY(glo > 0 && ghi > 10 * glo);
    QVERIFY(mv.scalarBarVisible());
    mv.setColorBy("potential"); // the choice for the potential was kept
    QCOMPARE(mv.colorScale(), MeshView::ColorScale::Linear);
    mv.setColorScale(MeshView::ColorScale::Diverging);
    QCOMPARE(mv.colorRange()[0], -mv.colorRange()[1]);
    mv.setColorBy("min_dihedral");
    QCOMPARE(mv.colorScale(), MeshView::ColorScale::Linear);
    mv.setColorBy("material");
    QVERIFY(!mv.scaleBox()->isEnabled());
  }

  // Issue 27, item 4, with the 3D view there (the node-editor test runs without one): at the
  // default size every parameter of every shipped net is shown whole, also once a run has filled
  // the 3D view (its toolbar and status line must not widen the window).
  void parameterValuesVisibleBesideThe3DView() {
    MainWindow win(registry_);
    win.setInteractive(false);
    win.show();
    QVERIFY(QTest::qWaitForWindowExposed(&win));
    QVERIFY(win.meshView());
    QCOMPARE(win.size(), QSize(1280, 800));
    const QDir nets(TETFLOW_SOURCE_DIR "/Nets");
    ShownParameters shown;
    for (const QString& f : nets.entryList({"*.srn"})) {
      QVERIFY2(win.openFile(nets.filePath(f)), qPrintable(f));
      for (const ModuleNode& m : win.network().modules()) {
        const QString problem = shown.check(win, m, f);
        QVERIFY2(problem.isEmpty(), qPrintable(problem));
      }
    }
    QVERIFY(shown.checked > 100);
    // The EEG net executed (the 3D view and its status line filled): every module again.
    QTemporaryDir out;
    QVERIFY(win.openFile(nets.filePath("head_dipole.srn")));
    win.network().setOutputDir(out.path().toStdString());
    QVERIFY(win.executeAll());
    QVERIFY(win.execution()->waitForFinished(120000));
    QVERIFY(win.execution()->lastSummary().success);
    for (const ModuleNode& m : win.network().modules()) {
      const QString problem = shown.check(win, m, "head_dipole.srn (executed)");
      QVERIFY2(problem.isEmpty(), qPrintable(problem));
    }
    // The solve's module with its potential on the diverging scale and its longest status line.
    win.selectModule("m4");
    win.meshView()->setColorBy("potential");
    QCOMPARE(win.meshView()->colorScale(), MeshView::ColorScale::Diverging);
    const QString problem = shown.check(win, *win.network().module("m4"), "head_dipole.srn (potential shown)");
    QVERIFY2(problem.isEmpty(), qPrintable(problem));
    QCOMPARE(win.meshView()->colorScale(), MeshView::ColorScale::Diverging);
    qInfo("least room left under a form: %d px (%s)", shown.tightest, qPrintable(shown.tightestAt));
  }

  // Issue 28's sphere nets run in the node editor as headless: the smooth-sphere EEG net (three
  // source models against the analytic series) and the MEG net (Sarvas), each to the end, with the
  // potential shown on the diverging scale.
  void sphereNetsRunInTheNodeEditor() {
    runShippedNets({"eeg_sphere_cad.srn", "meg_sphere.srn"}, [](MainWindow& win, const std::string& f) {
      win.selectModule("m4");
      win.meshView()->setColorBy("potential");
      QCOMPARE(win.meshView()->colorScale(), MeshView::ColorScale::Diverging);
      if (f == "eeg_sphere_cad.srn") // the figures CadModulesTest checks headless
        for (const char* an : {"m5", "m7", "m9"}) {
          const ModuleState* st = win.execution()->state(an);
          QVERIFY(st);
          QVERIFY2(st->report.number("rdm") < 0.025, an);
        }
    });
  }

  void meshLabelsNetsRunInTheNodeEditor() {
    // The nets that start from a label volume file (issue 30) run in the node editor and show
    // the head's tissues.
    runShippedNets({"mesh_labels.srn", "mesh_labels_adaptive.srn"}, [](MainWindow& win, const std::string&) {
      win.selectModule("m3");
      QCOMPARE(win.meshView()->materialLabels(), std::vector<int>({0, 1, 2, 3, 4, 5}));
    });
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
