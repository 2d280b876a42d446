#include "Palette.h"

#include <QLineEdit>
#include <QMimeData>
#include <QVBoxLayout>

#include "Canvas.h"
#include "GuiStyle.h"

namespace tetflow::gui {

QStringList PaletteTree::mimeTypes() const { return {kModuleMime}; }

QMimeData* PaletteTree::mimeData(const QList<QTreeWidgetItem*>& items) const {
  if (items.isEmpty() || items.front()->data(0, Qt::UserRole).toString().isEmpty()) return nullptr;
  auto* md = new QMimeData;
  md->setData(kModuleMime, items.front()->data(0, Qt::UserRole).toString().toUtf8());
  return md;
}

ModulePalette::ModulePalette(const ModuleRegistry& registry, QWidget* parent) : QWidget(parent) {
  auto* lay = new QVBoxLayout(this);
  lay->setContentsMargins(2, 2, 2, 2);
  filter_ = new QLineEdit;
  filter_->setPlaceholderText(tr("Filter modules…"));
  filter_->setClearButtonEnabled(true);
  tree_ = new PaletteTree;
  tree_->setHeaderHidden(true);
  tree_->setDragEnabled(true);
  tree_->setDragDropMode(QAbstractItemView::DragOnly);
  lay->addWidget(filter_);
  lay->addWidget(tree_);

  QTreeWidgetItem* cat = nullptr;
  for (const ModuleInfo* m : registry.all()) {
    if (!cat || cat->text(0) != qs(m->category)) {
      cat = new QTreeWidgetItem(tree_, {qs(m->category)});
      cat->setFlags(Qt::ItemIsEnabled);
      QFont f = cat->font(0);
      f.setBold(true);
      cat->setFont(0, f);
    }
    auto* it = new QTreeWidgetItem(cat, {qs(m->name)});
    it->setData(0, Qt::UserRole, qs(m->name));
    it->setFlags(Qt::ItemIsEnabled | Qt::ItemIsSelectable | Qt::ItemIsDragEnabled);
    QString ports;
    for (const auto& p : m->inputs) ports += QString("\n  in  %1: %2").arg(qs(p.name), portTypeName(p.type()));
    for (const auto& p : m->outputs) ports += QString("\n  out %1: %2").arg(qs(p.name), portTypeName(p.type()));
    it->setToolTip(0, qs(m->description) + ports);
  }
  tree_->expandAll();
  connect(filter_, &QLineEdit::textChanged, this, &ModulePalette::setFilter);
  connect(tree_, &QTreeWidget::itemDoubleClicked, this, [this](QTreeWidgetItem* it, int) {
    const QString name = it->data(0, Qt::UserRole).toString();
    if (!name.isEmpty()) emit addRequested(name);
  });
}

void ModulePalette::setFilter(const QString& text) {
  if (filter_->text() != text) filter_->setText(text); // re-enters via textChanged
  for (int c = 0; c < tree_->topLevelItemCount(); ++c) {
    QTreeWidgetItem* cat = tree_->topLevelItem(c);
    const bool catMatch = cat->text(0).contains(text, Qt::CaseInsensitive);
    int shown = 0;
    for (int i = 0; i < cat->childCount(); ++i) {
      QTreeWidgetItem* it = cat->child(i);
      const bool show = text.isEmpty() || catMatch || it->text(0).contains(text, Qt::CaseInsensitive);
      it->setHidden(!show);
      shown += show;
    }
    cat->setHidden(shown == 0);
  }
}

int ModulePalette::visibleModuleCount() const {
  int n = 0;
  for (int c = 0; c < tree_->topLevelItemCount(); ++c) {
    QTreeWidgetItem* cat = tree_->topLevelItem(c);
    if (cat->isHidden()) continue;
    for (int i = 0; i < cat->childCount(); ++i) n += !cat->child(i)->isHidden();
  }
  return n;
}

} // namespace tetflow::gui
