#pragma once
// VTK rendering inside a Qt6 QOpenGLWidget without VTK's Qt module (PLATFORM.md "VTK inside a
// Qt6 widget"): a vtkGenericOpenGLRenderWindow that uses the widget's GL context, renders into
// its own framebuffer in paintGL, and is blitted into the widget's framebuffer object.
//
//  - the default QSurfaceFormat (OpenGL 3.2 core) must be set before QApplication exists:
//    call VtkWidget::setDefaultSurfaceFormat() first thing in main();
//  - VTK's WindowMakeCurrentEvent makes the Qt context current only when it is not (never via
//    QOpenGLWidget::makeCurrent(), which rebinds Qt's framebuffer behind VTK);
//  - when the widget is reparented Qt recreates the context: VTK's resources are released in
//    the context's aboutToBeDestroyed and re-initialised in the next initializeGL;
//  - interactor renders are turned into update() so every render happens inside paintGL.
#include <QOpenGLWidget>

#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkGenericRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

namespace tetflow::gui {

class VtkWidget : public QOpenGLWidget {
  Q_OBJECT
public:
  explicit VtkWidget(QWidget* parent = nullptr);
  ~VtkWidget() override;
  vtkRenderer* renderer() const { return renderer_; }
  vtkGenericOpenGLRenderWindow* renderWindow() const { return window_; }
  static void setDefaultSurfaceFormat();
  // Forces platform xcb when QT_QPA_PLATFORM is unset (Debian's VTK is GLX-only).
  static void preferXcb();
  int renderCount() const { return renders_; }

protected:
  void initializeGL() override;
  void resizeGL(int w, int h) override;
  void paintGL() override;
  void mousePressEvent(QMouseEvent* e) override;
  void mouseReleaseEvent(QMouseEvent* e) override;
  void mouseMoveEvent(QMouseEvent* e) override;
  void wheelEvent(QWheelEvent* e) override;

private slots:
  void releaseGL();

private:
  void onWindowEvent(vtkObject*, unsigned long event, void* callData);
  void setEventPosition(QMouseEvent* e);

  vtkSmartPointer<vtkGenericOpenGLRenderWindow> window_;
  vtkSmartPointer<vtkGenericRenderWindowInteractor> interactor_;
  vtkSmartPointer<vtkRenderer> renderer_;
  bool inPaint_ = false;
  int renders_ = 0;
};

} // namespace tetflow::gui
