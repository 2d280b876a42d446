#pragma once
// Colours shared by the canvas, the legend and the 3D view (Interface only; Qt allowed here).
#include <QColor>
#include <QString>

#include "Dataflow/Executor.h"
#include "Dataflow/PortTypes.h"

namespace tetflow::gui {

// One colour per port type (wires and ports), stable across sessions.
inline QColor portColor(PortType t) {
  switch (t) {
    case PortType::LabelVolume: return QColor(230, 140, 40);   // orange
    case PortType::ScalarVolume: return QColor(225, 205, 50);  // yellow
    case PortType::Materials: return QColor(170, 100, 220);    // purple
    case PortType::TetMesh: return QColor(70, 185, 90);        // green
    case PortType::Matrix: return QColor(60, 130, 230);        // blue
    case PortType::Vector: return QColor(60, 200, 210);        // cyan
    case PortType::Report: return QColor(200, 200, 200);       // grey
    case PortType::DenseMatrix: return QColor(40, 80, 170);    // dark blue
    case PortType::CADModel: return QColor(200, 90, 120);      // rose
  }
  return Qt::white;
}

// Module status colours (box frame, progress bar).
inline QColor statusColor(ModuleStatus s) {
  switch (s) {
    case ModuleStatus::Idle: return QColor(110, 110, 120);
    case ModuleStatus::Waiting: return QColor(215, 185, 60);
    case ModuleStatus::Running: return QColor(60, 150, 240);
    case ModuleStatus::Done: return QColor(70, 190, 90);
    case ModuleStatus::Error: return QColor(225, 60, 60);
    case ModuleStatus::Skipped: return QColor(150, 150, 150);
    case ModuleStatus::Cancelled: return QColor(180, 110, 200);
  }
  return Qt::gray;
}

// Categorical colours for material labels (index by position in the sorted label list).
inline QColor materialColor(int index) {
  static const QColor palette[] = {
      QColor(230, 185, 150), QColor(240, 235, 215), QColor(90, 160, 230), QColor(225, 120, 120),
      QColor(130, 200, 120), QColor(200, 140, 220), QColor(240, 200, 80), QColor(100, 210, 200),
      QColor(170, 120, 80),  QColor(150, 150, 230), QColor(230, 110, 180), QColor(160, 190, 90)};
  const int n = int(sizeof palette / sizeof palette[0]);
  return palette[((index % n) + n) % n];
}

// Colour of a material label value: 0 (background/air) is grey, labels 1, 2, ... follow the
// palette (head phantom: 1 scalp, 2 skull, 3 CSF, 4 brain get skin, bone, blue, pink).
inline QColor labelColor(int label) {
  if (label == 0) return QColor(110, 110, 115);
  return materialColor(label > 0 ? label - 1 : -label + 5);
}

inline QString qs(const std::string& s) { return QString::fromStdString(s); }
inline std::string ss(const QString& s) { return s.toStdString(); }

} // namespace tetflow::gui
