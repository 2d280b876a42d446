#pragma once
// Module palette: the registry as a tree by category, a filter box, double-click or drag onto
// the canvas to add a module.
#include <QTreeWidget>
#include <QWidget>

#include "Dataflow/ModuleRegistry.h"

class QLineEdit;

namespace tetflow::gui {

class PaletteTree : public QTreeWidget {
  Q_OBJECT
public:
  using QTreeWidget::QTreeWidget;

protected:
  QMimeData* mimeData(const QList<QTreeWidgetItem*>& items) const override;
  QStringList mimeTypes() const override;
};

class ModulePalette : public QWidget {
  Q_OBJECT
public:
  ModulePalette(const ModuleRegistry& registry, QWidget* parent = nullptr);
  void setFilter(const QString& text);
  QTreeWidget* tree() const { return tree_; }
  // Number of module rows currently visible (tests).
  int visibleModuleCount() const;

signals:
  void addRequested(const QString& moduleName);

private:
  PaletteTree* tree_;
  QLineEdit* filter_;
};

} // namespace tetflow::gui
