// tetflow-gui: the Qt6 node editor.
//
//   tetflow-gui [NET.srn] [--execute] [--select ID] [--clip AXIS:FRACTION] [--color FIELD]
//               [--show-report] [--screenshot FILE.png] [--size WxH] [--output-dir DIR]
//
// --screenshot executes (implies --execute), waits for the run, selects --select (if given),
// renders, saves a picture of the whole window and exits (status 0 when the file was written
// and every module succeeded). The manual's screenshots are made this way (scripts/gui-screenshot.sh).
#include <QApplication>
#include <QCommandLineParser>
#include <QDir>
#include <QFileInfo>
#include <QImage>
#include <QThread>
#include <QTimer>

#include <cstdio>

#include "Canvas.h"
#include "Interface/HugePages.h"
#include "ExecutionController.h"
#include "MainWindow.h"
#include "MeshView.h"
#include "Modules/StandardModules.h"
#include "VtkWidget.h"

using namespace tetflow;
using namespace tetflow::gui;

int main(int argc, char** argv) {
  tetflow::useTransparentHugePages(argv); // first: it may exec the program again
  VtkWidget::preferXcb();              // Debian's VTK is GLX-only (PLATFORM.md 4)
  VtkWidget::setDefaultSurfaceFormat(); // before QApplication (PLATFORM.md 2)
  QApplication app(argc, argv);
  QApplication::setApplicationName("tetflow-gui");
  QApplication::setOrganizationName("TetFlow");

  QCommandLineParser parser;
  parser.setApplicationDescription("TetFlow node editor");
  parser.addHelpOption();
  parser.addPositionalArgument("network", "network file (.srn) to open");
  QCommandLineOption execOpt("execute", "execute the network after opening it");
  QCommandLineOption selOpt("select", "select module ID (its parameters, report and 3D view)", "ID");
  QCommandLineOption shotOpt("screenshot", "execute, select, save a picture of the window to FILE and exit", "FILE");
  QCommandLineOption sizeOpt("size", "window size WxH (default 1280x800)", "WxH", "1280x800");
  QCommandLineOption clipOpt("clip", "3D view clipping plane AXIS:FRACTION, e.g. y:0.5", "AXIS:F");
  QCommandLineOption colorOpt("color", "3D view colouring: material or a field name", "FIELD");
  QCommandLineOption outOpt("output-dir", "write relative output files under DIR (as `tetflow run`)", "DIR");
  QCommandLineOption reportOpt("show-report", "bring the Report tab to the front");
  QCommandLineOption memOpt("max-memory",
                            "memory budget, e.g. 8G or 512M, for this session (as `tetflow run`; "
                            "Network > Memory Limit sets a lasting one)",
                            "SIZE");
  parser.addOptions({execOpt, selOpt, shotOpt, sizeOpt, clipOpt, colorOpt, outOpt, reportOpt, memOpt});
  parser.process(app);

  ModuleRegistry registry;
  registerStandardModules(registry);
  MainWindow win(registry);
  if (parser.isSet(memOpt)) {
    QString error;
    if (!win.setMemoryLimit(parser.value(memOpt), &error, false)) {
      std::fprintf(stderr, "tetflow-gui: %s\n", qPrintable(error));
      return 2;
    }
  }
  const QStringList size = parser.value(sizeOpt).split('x');
  if (size.size() == 2) win.resize(size[0].toInt(), size[1].toInt());

  const QString shot = parser.value(shotOpt);
  if (!shot.isEmpty()) win.setInteractive(false);
  const QStringList args = parser.positionalArguments();
  if (!args.isEmpty() && !win.openFile(args.front())) {
    std::fprintf(stderr, "tetflow-gui: cannot open %s\n", qPrintable(args.front()));
    if (!shot.isEmpty()) return 3;
  }
  if (parser.isSet(outOpt)) {
    QDir().mkpath(parser.value(outOpt));
    win.network().setOutputDir(QFileInfo(parser.value(outOpt)).absoluteFilePath().toStdString());
  }
  win.show();

  auto applyViewOptions = [&] {
    if (parser.isSet(selOpt)) win.selectModule(parser.value(selOpt));
    if (parser.isSet(reportOpt)) win.raiseReport();
    if (MeshView* mv = win.meshView()) {
      if (parser.isSet(colorOpt)) mv->setColorBy(parser.value(colorOpt));
      if (parser.isSet(clipOpt)) {
        const QStringList c = parser.value(clipOpt).split(':');
        const int axis = QString("xyz").indexOf(c.value(0).toLower());
        mv->setClip(true, axis < 0 ? 0 : axis, c.value(1, "0.5").toDouble(), c.value(2) != "below");
      }
    }
  };

  if (!shot.isEmpty()) {
    int status = 0;
    QTimer::singleShot(0, &win, [&] {
      win.view()->fitAll();
      if (!win.executeAll() || !win.execution()->waitForFinished(600000)) status = 1;
      else if (!win.execution()->lastSummary().success) status = 1;
      applyViewOptions();
      // Let the docks settle and the 3D view paint.
      for (int i = 0; i < 20; ++i) {
        QApplication::processEvents();
        QThread::msleep(25);
      }
      const QImage img = win.grab().toImage();
      if (img.isNull() || !img.save(shot)) {
        std::fprintf(stderr, "tetflow-gui: cannot write %s\n", qPrintable(shot));
        status = 4;
      } else {
        std::printf("tetflow-gui: wrote %s (%dx%d)\n", qPrintable(shot), img.width(), img.height());
      }
      app.exit(status);
    });
    return app.exec();
  }

  if (parser.isSet(execOpt)) {
    QTimer::singleShot(0, &win, [&] {
      win.executeAll();
      QObject::connect(win.execution(), &ExecutionController::finished, &win, [&] { applyViewOptions(); },
                       Qt::SingleShotConnection);
    });
  } else if (parser.isSet(selOpt) || parser.isSet(clipOpt)) {
    QTimer::singleShot(0, &win, applyViewOptions);
  }
  return app.exec();
}
