#include "VtkWidget.h"

#include <QMouseEvent>
#include <QOpenGLContext>
#include <QOpenGLExtraFunctions>
#include <QOpenGLFunctions>
#include <QSurfaceFormat>
#include <QWheelEvent>

#include <vtkCommand.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkGenericRenderWindowInteractor.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkOpenGLFramebufferObject.h>
#include <vtkRenderer.h>

#include <cstdlib>

namespace tetflow::gui {

void VtkWidget::setDefaultSurfaceFormat() {
  QSurfaceFormat f;
  f.setRenderableType(QSurfaceFormat::OpenGL);
  f.setVersion(3, 2);
  f.setProfile(QSurfaceFormat::CoreProfile);
  f.setSwapBehavior(QSurfaceFormat::DoubleBuffer);
  f.setRedBufferSize(8);
  f.setGreenBufferSize(8);
  f.setBlueBufferSize(8);
  f.setAlphaBufferSize(8);
  f.setDepthBufferSize(24);
  f.setStencilBufferSize(0);
  f.setSamples(0);
  QSurfaceFormat::setDefaultFormat(f);
}

void VtkWidget::preferXcb() {
  if (!std::getenv("QT_QPA_PLATFORM")) setenv("QT_QPA_PLATFORM", "xcb", 1);
}

VtkWidget::VtkWidget(QWidget* parent) : QOpenGLWidget(parent) {
  window_ = vtkSmartPointer<vtkGenericOpenGLRenderWindow>::New();
  window_->SetReadyForRendering(false);
  window_->SetFrameBlitModeToNoBlit();
  window_->SetMultiSamples(0);
  renderer_ = vtkSmartPointer<vtkRenderer>::New();
  window_->AddRenderer(renderer_);
  interactor_ = vtkSmartPointer<vtkGenericRenderWindowInteractor>::New();
  interactor_->SetRenderWindow(window_);
  interactor_->EnableRenderOff(); // renders happen in paintGL only
  interactor_->Enable();
  auto style = vtkSmartPointer<vtkInteractorStyleTrackballCamera>::New();
  interactor_->SetInteractorStyle(style);
  interactor_->AddObserver(vtkCommand::RenderEvent, this, &VtkWidget::onWindowEvent);
  window_->AddObserver(vtkCommand::WindowMakeCurrentEvent, this, &VtkWidget::onWindowEvent);
  window_->AddObserver(vtkCommand::WindowIsCurrentEvent, this, &VtkWidget::onWindowEvent);
  window_->AddObserver(vtkCommand::WindowFrameEvent, this, &VtkWidget::onWindowEvent);
  setMouseTracking(false);
  setFocusPolicy(Qt::StrongFocus);
  setMinimumSize(200, 200);
}

VtkWidget::~VtkWidget() {
  // ~QOpenGLWidget destroys the context after this body ran: stop listening first.
  if (context()) disconnect(context(), &QOpenGLContext::aboutToBeDestroyed, this, &VtkWidget::releaseGL);
  if (context()) {
    makeCurrent(); // outside VTK's events this is the right call (releases GL resources)
    releaseGL();
    doneCurrent();
  }
  window_->RemoveAllObservers();
  interactor_->RemoveAllObservers();
}

void VtkWidget::onWindowEvent(vtkObject*, unsigned long event, void* callData) {
  switch (event) {
    case vtkCommand::WindowMakeCurrentEvent: {
      QOpenGLContext* ctx = context();
      if (ctx && ctx->surface() && QOpenGLContext::currentContext() != ctx) ctx->makeCurrent(ctx->surface());
      break;
    }
    case vtkCommand::WindowIsCurrentEvent: {
      bool& current = *static_cast<bool*>(callData);
      current = context() && QOpenGLContext::currentContext() == context();
      break;
    }
    case vtkCommand::WindowFrameEvent:
      if (!inPaint_) update();
      break;
    case vtkCommand::RenderEvent: update(); break;
    default: break;
  }
}

void VtkWidget::initializeGL() {
  connect(context(), &QOpenGLContext::aboutToBeDestroyed, this, &VtkWidget::releaseGL, Qt::UniqueConnection);
  window_->SetOwnContext(0);
  window_->SetReadyForRendering(true);
  window_->OpenGLInitContext();
}

void VtkWidget::releaseGL() {
  if (!window_->GetReadyForRendering()) return;
  window_->Finalize();
  window_->SetReadyForRendering(false);
}

void VtkWidget::resizeGL(int w, int h) {
  const double dpr = devicePixelRatioF();
  const int dw = int(w * dpr), dh = int(h * dpr);
  interactor_->UpdateSize(dw, dh); // also sizes the render window
  window_->SetSize(dw, dh);
}

void VtkWidget::paintGL() {
  if (!window_->GetReadyForRendering()) return;
  inPaint_ = true;
  window_->Render();
  inPaint_ = false;
  ++renders_;
  QOpenGLExtraFunctions* f = context()->extraFunctions();
  f->glBindFramebuffer(GL_DRAW_FRAMEBUFFER, defaultFramebufferObject());
  const GLenum buf = GL_COLOR_ATTACHMENT0;
  f->glDrawBuffers(1, &buf);
  const GLboolean scissor = f->glIsEnabled(GL_SCISSOR_TEST);
  if (scissor) f->glDisable(GL_SCISSOR_TEST);
  const int* src = window_->GetRenderFramebuffer()->GetLastSize();
  const double dpr = devicePixelRatioF();
  const int dw = int(width() * dpr), dh = int(height() * dpr);
  window_->BlitDisplayFramebuffer(0, 0, 0, src[0], src[1], 0, 0, dw, dh, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  // Clear alpha to 1: otherwise the composition blends the image with what lies behind it.
  GLboolean mask[4];
  f->glGetBooleanv(GL_COLOR_WRITEMASK, mask);
  GLfloat clear[4];
  f->glGetFloatv(GL_COLOR_CLEAR_VALUE, clear);
  f->glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_TRUE);
  f->glClearColor(0, 0, 0, 1);
  f->glClear(GL_COLOR_BUFFER_BIT);
  f->glColorMask(mask[0], mask[1], mask[2], mask[3]);
  f->glClearColor(clear[0], clear[1], clear[2], clear[3]);
  if (scissor) f->glEnable(GL_SCISSOR_TEST);
}

void VtkWidget::setEventPosition(QMouseEvent* e) {
  const double dpr = devicePixelRatioF();
  const QPointF p = e->position();
  interactor_->SetEventInformationFlipY(int(p.x() * dpr), int(p.y() * dpr),
                                        (e->modifiers() & Qt::ControlModifier) ? 1 : 0,
                                        (e->modifiers() & Qt::ShiftModifier) ? 1 : 0, 0,
                                        e->type() == QEvent::MouseButtonDblClick ? 1 : 0);
}

void VtkWidget::mousePressEvent(QMouseEvent* e) {
  setEventPosition(e);
  switch (e->button()) {
    case Qt::LeftButton: interactor_->InvokeEvent(vtkCommand::LeftButtonPressEvent); break;
    case Qt::MiddleButton: interactor_->InvokeEvent(vtkCommand::MiddleButtonPressEvent); break;
    case Qt::RightButton: interactor_->InvokeEvent(vtkCommand::RightButtonPressEvent); break;
    default: break;
  }
  e->accept();
}

void VtkWidget::mouseReleaseEvent(QMouseEvent* e) {
  setEventPosition(e);
  switch (e->button()) {
    case Qt::LeftButton: interactor_->InvokeEvent(vtkCommand::LeftButtonReleaseEvent); break;
    case Qt::MiddleButton: interactor_->InvokeEvent(vtkCommand::MiddleButtonReleaseEvent); break;
    case Qt::RightButton: interactor_->InvokeEvent(vtkCommand::RightButtonReleaseEvent); break;
    default: break;
  }
  e->accept();
}

void VtkWidget::mouseMoveEvent(QMouseEvent* e) {
  setEventPosition(e);
  interactor_->InvokeEvent(vtkCommand::MouseMoveEvent);
  e->accept();
}

void VtkWidget::wheelEvent(QWheelEvent* e) {
  const double dpr = devicePixelRatioF();
  interactor_->SetEventInformationFlipY(int(e->position().x() * dpr), int(e->position().y() * dpr),
                                        (e->modifiers() & Qt::ControlModifier) ? 1 : 0,
                                        (e->modifiers() & Qt::ShiftModifier) ? 1 : 0);
  if (e->angleDelta().y() > 0) interactor_->InvokeEvent(vtkCommand::MouseWheelForwardEvent);
  else if (e->angleDelta().y() < 0) interactor_->InvokeEvent(vtkCommand::MouseWheelBackwardEvent);
  e->accept();
}

} // namespace tetflow::gui
