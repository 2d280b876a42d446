#include "MeshView.h"

#include <QCheckBox>
#include <QComboBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QListWidget>
#include <QPainter>
#include <QPushButton>
#include <QSlider>
#include <QVBoxLayout>

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDoubleArray.h>
#include <vtkImageActor.h>
#include <vtkImageData.h>
#include <vtkImageMapper3D.h>
#include <vtkLookupTable.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cmath>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "GuiStyle.h"
#include "VtkWidget.h"

namespace tetflow::gui {

namespace {
enum ChoiceKind { kMaterial, kCellField, kComputedMinDihedral, kPointField, kGradient };
struct Choice {
  QString label;
  ChoiceKind kind;
  std::string field;
};

std::vector<Choice> choicesFor(const TetMesh& m) {
  std::vector<Choice> c{{"material", kMaterial, ""}};
  for (const auto& [name, f] : m.cellFields)
    if (f.components == 1 && f.values.size() == m.numTets()) c.push_back({qs(name), kCellField, name});
  if (!m.cellFields.count("min_dihedral")) c.push_back({"min_dihedral", kComputedMinDihedral, ""});
  for (const auto& [name, f] : m.pointFields)
    if (f.components == 1 && f.values.size() == m.numPoints() && name != "lattice_kind") {
      c.push_back({qs(name), kPointField, name});
      c.push_back({QString("|∇%1|").arg(qs(name)), kGradient, name});
    }
  return c;
}

const TetMesh* meshOf(const DataPtr& d) {
  auto* m = dynamic_cast<const TetMeshData*>(d.get());
  return m ? &m->value : nullptr;
}
const LabelVolume* volumeOf(const DataPtr& d) {
  auto* v = dynamic_cast<const LabelVolumeData*>(d.get());
  return v ? &v->value : nullptr;
}

// The q-quantile (0..1) of v (nearest rank); v is reordered. v must not be empty.
double quantile(std::vector<double>& v, double q) {
  const size_t k = std::min(v.size() - 1, size_t(std::floor(q * double(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
  return v[k];
}
} // namespace

MeshView::MeshView(QWidget* parent) : QWidget(parent) {
  auto* lay = new QVBoxLayout(this);
  lay->setContentsMargins(2, 2, 2, 2);
  auto* bar = new QHBoxLayout;
  colorBy_ = new QComboBox;
  colorBy_->setToolTip(tr("Colour the surface by material or by a field"));
  scaleBox_ = new QComboBox;
  scaleBox_->addItems({"linear", "diverging", "log"}); // the order of ColorScale
  scaleBox_->setToolTip(tr("Colour scale of the field: linear (min to max), diverging (blue-white-red, "
                           "symmetric about 0, for signed fields such as potentials) or log (for "
                           "magnitudes such as |∇u| or current density). Chosen by the field's kind; "
                           "a choice here is kept for the field"));
  edges_ = new QCheckBox(tr("Edges"));
  clip_ = new QCheckBox(tr("Clip"));
  clip_->setToolTip(tr("Clipping plane: removes the tets on one side to show the inside"));
  clipAxis_ = new QComboBox;
  clipAxis_->addItems({"x", "y", "z"});
  clipPos_ = new QSlider(Qt::Horizontal);
  clipPos_->setRange(0, 1000);
  clipPos_->setValue(500);
  clipFlip_ = new QCheckBox(tr("Flip"));
  reset_ = new QPushButton(tr("Reset camera"));
  // Two rows: colour (field, scale, edges, camera), then the clipping plane.
  bar->addWidget(new QLabel(tr("Colour")));
  bar->addWidget(colorBy_, 1);
  bar->addWidget(scaleBox_);
  bar->addWidget(edges_);
  bar->addWidget(reset_);
  lay->addLayout(bar);
  auto* clipBar = new QHBoxLayout;
  clipPos_->setMinimumWidth(120);
  clipBar->addWidget(clip_);
  clipBar->addWidget(clipAxis_);
  clipBar->addWidget(clipPos_, 1);
  clipBar->addWidget(clipFlip_);
  lay->addLayout(clipBar);
  auto* mid = new QHBoxLayout;
  vtk_ = new VtkWidget;
  legend_ = new QListWidget;
  legend_->setMaximumWidth(130);
  legend_->setToolTip(tr("Materials: untick to hide"));
  mid->addWidget(vtk_, 1);
  mid->addWidget(legend_);
  lay->addLayout(mid, 1);
  status_ = new QLabel;
  status_->setWordWrap(true); // a long line wraps instead of widening the window
  lay->addWidget(status_);

  plane_.keepAbove = true; // keep the far half: the cut faces the default camera
  clipFlip_->setToolTip(tr("Keep the other side of the plane"));
  vtkRenderer* ren = vtk_->renderer();
  ren->SetBackground(0.32, 0.34, 0.43);
  poly_ = vtkPolyData::New();
  mapper_ = vtkPolyDataMapper::New();
  mapper_->SetInputData(poly_);
  actor_ = vtkActor::New();
  actor_->SetMapper(mapper_);
  actor_->GetProperty()->SetEdgeColor(0.12, 0.12, 0.12);
  actor_->VisibilityOff();
  ren->AddActor(actor_);
  lut_ = vtkLookupTable::New();
  lut_->SetHueRange(0.667, 0.0);
  lut_->Build();
  scalarBar_ = vtkScalarBarActor::New();
  scalarBar_->SetLookupTable(lut_);
  scalarBar_->SetNumberOfLabels(5);
  scalarBar_->SetWidth(0.12);
  scalarBar_->SetHeight(0.6);
  scalarBar_->SetPosition(0.74, 0.15); // its labels, to the right of the bar, stay in a narrow view
  scalarBar_->UnconstrainedFontSizeOn();
  scalarBar_->GetTitleTextProperty()->SetFontSize(14);
  scalarBar_->GetTitleTextProperty()->SetJustificationToCentered();
  scalarBar_->GetLabelTextProperty()->SetFontSize(12);
  scalarBar_->SetTextPad(4);
  scalarBar_->VisibilityOff();
  ren->AddViewProp(scalarBar_);
  image_ = vtkImageData::New();
  for (auto*& s : slices_) {
    s = vtkImageActor::New();
    s->GetMapper()->SetInputData(image_);
    s->VisibilityOff();
    ren->AddViewProp(s);
  }

  connect(colorBy_, &QComboBox::currentTextChanged, this, [this](const QString& t) {
    if (!syncing_) setColorBy(t);
  });
  connect(scaleBox_, &QComboBox::currentIndexChanged, this, [this](int i) {
    if (!syncing_ && i >= 0) setColorScale(ColorScale(i));
  });
  connect(edges_, &QCheckBox::toggled, this, [this](bool on) {
    if (!syncing_) setEdgesVisible(on);
  });
  auto clipChanged = [this] {
    if (!syncing_)
      setClip(clip_->isChecked(), clipAxis_->currentIndex(), clipPos_->value() / 1000.0, !clipFlip_->isChecked());
  };
  connect(clip_, &QCheckBox::toggled, this, clipChanged);
  connect(clipAxis_, &QComboBox::currentIndexChanged, this, clipChanged);
  connect(clipPos_, &QSlider::valueChanged, this, clipChanged);
  connect(clipFlip_, &QCheckBox::toggled, this, clipChanged);
  connect(reset_, &QPushButton::clicked, this, &MeshView::resetCamera);
  connect(legend_, &QListWidget::itemChanged, this, [this](QListWidgetItem* it) {
    if (!syncing_) setMaterialVisible(it->data(Qt::UserRole).toInt(), it->checkState() == Qt::Checked);
  });
  clearData(tr("Execute the network and select a module with a mesh or volume output"));
}

MeshView::~MeshView() {
  actor_->Delete();
  mapper_->Delete();
  poly_->Delete();
  scalarBar_->Delete();
  lut_->Delete();
  for (auto* s : slices_) s->Delete();
  image_->Delete();
}

QString MeshView::labelName(int label) const {
  auto it = names_.find(label);
  return it != names_.end() ? QString("%1 %2").arg(label).arg(it->second) : tr("label %1").arg(label);
}

std::vector<int> MeshView::materialLabels() const {
  std::vector<int> v;
  for (const auto& [l, on] : visible_) v.push_back(l);
  return v;
}

bool MeshView::scalarBarVisible() const { return scalarBar_->GetVisibility(); }

QString MeshView::statusText() const { return status_->text(); }

void MeshView::clearData(const QString& message) {
  data_.reset();
  faces_ = {};
  topo_ = {};
  computedCellFields_.clear();
  visible_.clear();
  actor_->VisibilityOff();
  scalarBar_->VisibilityOff();
  for (auto* s : slices_) s->VisibilityOff();
  status_->setText(message);
  syncControls();
  vtk_->update();
}

void MeshView::showData(const DataPtr& data, const std::map<int, QString>& labelNames, const QString& title) {
  if (!data || (!meshOf(data) && !volumeOf(data))) {
    clearData(tr("%1: nothing to show in 3D").arg(title));
    return;
  }
  if (data == data_) {
    title_ = title;
    names_ = labelNames;
    return; // same object: keep camera, clip and toggles
  }
  if (const TetMesh* m = meshOf(data)) {
    // Memory before it is spent (docs/reliability.md): face adjacency, centroids, the sort's
    // keys and VTK's copy of the points come to about 110 bytes per tet (measured on the head
    // phantom); 128 is asked for. Over budget, the view says so instead of building.
    try {
      requireMemory(double(kViewBytesPerTet) * double(m->numTets()),
                    "showing " + title.toStdString() + " (" + std::to_string(m->numTets()) + " tets) in 3D",
                    [](double) { return std::string("hide this view, raise the memory limit, or view a coarser mesh"); });
    } catch (const InputError& e) {
      clearData(QString::fromStdString(e.what()));
      return;
    }
  }
  title_ = title;
  names_ = labelNames;
  const bool sameKind = data_ && data_->type() == data->type();
  data_ = data;
  computedCellFields_.clear();
  std::map<int, bool> oldVisible = visible_;
  visible_.clear();
  if (const TetMesh* m = meshOf(data)) {
    topo_ = MeshTopology::build(*m);
    for (int32_t l : topo_.labels) visible_[l] = oldVisible.count(l) ? oldVisible[l] : true;
    // points once per mesh
    vtkPoints* pts = vtkPoints::New(VTK_DOUBLE);
    pts->SetNumberOfPoints(vtkIdType(m->numPoints()));
    for (size_t i = 0; i < m->numPoints(); ++i) pts->SetPoint(vtkIdType(i), m->points[i].data());
    poly_->SetPoints(pts);
    pts->Delete();
    bool known = false;
    for (const auto& c : choicesFor(*m)) known |= c.label == colorField_;
    if (!known) colorField_ = "material";
    for (auto* s : slices_) s->VisibilityOff();
    rebuildMesh();
  } else {
    const LabelVolume& v = *volumeOf(data);
    topo_ = {};
    // Background (label 0) starts hidden so the tissue slices are not covered by air.
    for (const auto& [l, n] : labelCounts(v)) visible_[l] = oldVisible.count(l) ? oldVisible[l] : l != 0;
    actor_->VisibilityOff();
    scalarBar_->VisibilityOff();
    rebuildVolume();
  }
  syncControls();
  (void)sameKind;
  resetCamera();
}

void MeshView::syncControls() {
  syncing_ = true;
  colorBy_->clear();
  const TetMesh* m = meshOf(data_);
  if (m)
    for (const auto& c : choicesFor(*m)) colorBy_->addItem(c.label);
  else colorBy_->addItem("material");
  colorBy_->setCurrentText(colorField_);
  colorBy_->setEnabled(m != nullptr);
  scaleBox_->setCurrentIndex(int(scale_));
  scaleBox_->setEnabled(m != nullptr && colorField_ != "material");
  edges_->setEnabled(m != nullptr);
  edges_->setChecked(edgesOn_);
  clip_->setText(volumeOf(data_) ? tr("Slice") : tr("Clip"));
  legend_->clear();
  for (const auto& [label, on] : visible_) {
    QPixmap pm(14, 14);
    pm.fill(labelColor(label));
    auto* it = new QListWidgetItem(QIcon(pm), labelName(label));
    it->setData(Qt::UserRole, label);
    it->setFlags(Qt::ItemIsEnabled | Qt::ItemIsUserCheckable);
    it->setCheckState(on ? Qt::Checked : Qt::Unchecked);
    legend_->addItem(it);
  }
  syncing_ = false;
}

void MeshView::rebuildMesh() {
  const TetMesh* m = meshOf(data_);
  if (!m) return;
  plane_.position = topo_.lo[plane_.axis] + clipFraction_ * (topo_.hi[plane_.axis] - topo_.lo[plane_.axis]);
  faces_ = extractSurface(*m, topo_, [this](int32_t l) {
    auto it = visible_.find(l);
    return it == visible_.end() || it->second;
  }, plane_);
  vtkCellArray* cells = vtkCellArray::New();
  cells->AllocateExact(vtkIdType(faces_.faces.size()), vtkIdType(3 * faces_.faces.size()));
  for (const auto& f : faces_.faces) {
    const vtkIdType ids[3] = {f[0], f[1], f[2]};
    cells->InsertNextCell(3, ids);
  }
  poly_->SetPolys(cells);
  cells->Delete();
  actor_->SetVisibility(!faces_.faces.empty());
  meshStatus_ = tr("%1: %2 tets, %3 vertices, %4 materials; %5 faces shown")
                    .arg(title_)
                    .arg(m->numTets())
                    .arg(m->numPoints())
                    .arg(topo_.labels.size())
                    .arg(faces_.faces.size());
  updateColors(); // also the status line
  vtk_->update();
}

MeshView::ColorScale MeshView::automaticScale(const QString& field, bool magnitude, double lo, double hi) {
  magnitude = magnitude || field.endsWith("magnitude") || field.endsWith("current_density");
  if (magnitude && lo >= 0 && hi > 0) return ColorScale::Log;
  if (lo < 0 && hi > 0) return ColorScale::Diverging;
  return ColorScale::Linear;
}

void MeshView::updateColors() {
  const TetMesh* m = meshOf(data_);
  if (!m) return;
  Choice choice{"material", kMaterial, ""};
  for (const auto& c : choicesFor(*m))
    if (c.label == colorField_) choice = c;
  poly_->GetCellData()->SetScalars(nullptr);
  poly_->GetPointData()->SetScalars(nullptr);
  actor_->GetProperty()->SetEdgeVisibility(edgesOn_);
  shownValues_.clear();
  if (choice.kind == kMaterial) {
    vtkUnsignedCharArray* rgb = vtkUnsignedCharArray::New();
    rgb->SetNumberOfComponents(3);
    rgb->SetNumberOfTuples(vtkIdType(faces_.faces.size()));
    for (size_t i = 0; i < faces_.tet.size(); ++i) {
      const int label = m->materials.empty() ? 0 : m->materials[size_t(faces_.tet[i])];
      const QColor c = labelColor(label);
      const unsigned char v[3] = {uchar(c.red()), uchar(c.green()), uchar(c.blue())};
      rgb->SetTypedTuple(vtkIdType(i), v);
    }
    poly_->GetCellData()->SetScalars(rgb);
    rgb->Delete();
    mapper_->ScalarVisibilityOn();
    mapper_->SetScalarModeToUseCellData();
    mapper_->SetColorModeToDirectScalars();
    scalarBar_->VisibilityOff();
    scaleBox_->setEnabled(false);
    status_->setText(meshStatus_);
    poly_->Modified();
    return;
  }
  const std::vector<double>* values = nullptr;
  bool pointData = false;
  if (choice.kind == kCellField) values = &m->cellFields.at(choice.field).values;
  else if (choice.kind == kPointField) {
    values = &m->pointFields.at(choice.field).values;
    pointData = true;
  } else {
    auto it = computedCellFields_.find(choice.label);
    if (it == computedCellFields_.end()) {
      std::vector<double> v = choice.kind == kComputedMinDihedral
                                  ? computeMinDihedral(*m)
                                  : computeGradientMagnitude(*m, m->pointFields.at(choice.field).values);
      it = computedCellFields_.emplace(choice.label, std::move(v)).first;
    }
    values = &it->second;
  }
  double lo = 1e300, hi = -1e300;
  for (double v : *values)
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (lo > hi) lo = hi = 0;
  // The values on the surface shown (they set the diverging and log ranges).
  if (pointData) {
    std::vector<char> seen(values->size(), 0);
    for (const auto& f : faces_.faces)
      for (int v : f)
        if (!seen[size_t(v)]) {
          seen[size_t(v)] = 1;
          shownValues_.push_back((*values)[size_t(v)]);
        }
  } else {
    for (int t : faces_.tet) shownValues_.push_back((*values)[size_t(t)]);
  }
  std::vector<double> finite;
  finite.reserve(shownValues_.size());
  for (double v : shownValues_)
    if (std::isfinite(v)) finite.push_back(v);

  auto chosen = scaleChosen_.find(colorField_);
  scale_ = chosen != scaleChosen_.end() ? chosen->second : automaticScale(choice.label, choice.kind == kGradient, lo, hi);
  QString note;
  double a = lo, b = hi;
  if (scale_ == ColorScale::Log) {
    std::vector<double> pos;
    for (double v : finite)
      if (v > 0) pos.push_back(v);
    if (pos.empty())
      for (double v : *values)
        if (std::isfinite(v) && v > 0) pos.push_back(v);
    if (pos.empty()) {
      note = tr("log scale: no positive values, shown linear");
    } else {
      b = *std::max_element(pos.begin(), pos.end());
      a = std::max(quantile(pos, 0.02), b * 1e-6);
      if (a >= b) a = b / 10;
      note = tr("log scale %1 to %2 (2nd percentile of the shown values > 0 to max)").arg(a, 0, 'g', 3).arg(b, 0, 'g', 3);
    }
  } else if (scale_ == ColorScale::Diverging) {
    std::vector<double> mag;
    for (double v : finite) mag.push_back(std::abs(v));
    double r = mag.empty() ? 0.0 : quantile(mag, 0.98);
    if (!(r > 0)) r = std::max(std::abs(lo), std::abs(hi));
    if (!(r > 0)) r = 1e-12;
    a = -r;
    b = r;
    note = tr("diverging scale ±%1 (98th percentile of |value| shown; all: %2 to %3)")
               .arg(r, 0, 'g', 3).arg(lo, 0, 'g', 3).arg(hi, 0, 'g', 3);
  }
  const bool log = scale_ == ColorScale::Log && b > a && a > 0;
  if (!log && scale_ != ColorScale::Diverging) {
    a = lo;
    b = hi;
  }
  if (b <= a) b = a + 1e-12;
  range_ = {a, b};

  vtkDoubleArray* arr = vtkDoubleArray::New();
  arr->SetName(choice.label.toUtf8().constData());
  // Log: zeros and values below the range take the bottom colour.
  auto shown = [&](double v) { return log && !(v >= a) ? a : v; };
  if (pointData) {
    arr->SetNumberOfTuples(vtkIdType(values->size()));
    for (size_t i = 0; i < values->size(); ++i) arr->SetValue(vtkIdType(i), shown((*values)[i]));
    poly_->GetPointData()->SetScalars(arr);
    mapper_->SetScalarModeToUsePointData();
  } else {
    arr->SetNumberOfTuples(vtkIdType(faces_.tet.size()));
    for (size_t i = 0; i < faces_.tet.size(); ++i) arr->SetValue(vtkIdType(i), shown((*values)[size_t(faces_.tet[i])]));
    poly_->GetCellData()->SetScalars(arr);
    mapper_->SetScalarModeToUseCellData();
  }
  arr->Delete();
  lut_->SetNumberOfTableValues(256);
  if (scale_ == ColorScale::Diverging) {
    // Blue - white - red (Moreland's cool-warm end points), linear in RGB on each half.
    const double cold[3] = {0.23, 0.30, 0.75}, mid[3] = {0.95, 0.95, 0.95}, warm[3] = {0.71, 0.02, 0.15};
    lut_->SetScaleToLinear();
    for (int i = 0; i < 256; ++i) {
      const double t = i / 255.0;
      const double* e = t < 0.5 ? cold : warm;
      const double w = t < 0.5 ? 1 - 2 * t : 2 * t - 1; // weight of the end colour
      lut_->SetTableValue(i, mid[0] + w * (e[0] - mid[0]), mid[1] + w * (e[1] - mid[1]), mid[2] + w * (e[2] - mid[2]), 1.0);
    }
  } else {
    if (log) lut_->SetScaleToLog10();
    else lut_->SetScaleToLinear();
    lut_->SetHueRange(0.667, 0.0);
    lut_->SetSaturationRange(1, 1);
    lut_->SetValueRange(1, 1);
    lut_->ForceBuild();
  }
  lut_->SetTableRange(a, b);
  mapper_->SetLookupTable(lut_);
  mapper_->UseLookupTableScalarRangeOn();
  mapper_->SetColorModeToMapScalars();
  mapper_->ScalarVisibilityOn();
  scalarBar_->SetLookupTable(lut_);
  scalarBar_->SetTitle(choice.label.toUtf8().constData());
  scalarBar_->VisibilityOn();
  syncing_ = true;
  scaleBox_->setCurrentIndex(int(scale_));
  scaleBox_->setEnabled(true);
  syncing_ = false;
  status_->setText(meshStatus_ + (note.isEmpty() ? QString() : "; " + choice.label + ": " + note));
  poly_->Modified();
}

void MeshView::setColorScale(ColorScale scale) {
  if (colorField_ == "material") return;
  scaleChosen_[colorField_] = scale;
  updateColors();
  vtk_->update();
}

void MeshView::rebuildVolume() {
  const LabelVolume* v = volumeOf(data_);
  if (!v) return;
  const auto& g = v->grid;
  const int nx = int(g.dims[0]), ny = int(g.dims[1]), nz = int(g.dims[2]);
  image_->SetDimensions(nx, ny, nz);
  image_->SetSpacing(g.spacing[0], g.spacing[1], g.spacing[2]);
  image_->SetOrigin(g.origin[0], g.origin[1], g.origin[2]);
  image_->AllocateScalars(VTK_UNSIGNED_CHAR, 4);
  auto* px = static_cast<unsigned char*>(image_->GetScalarPointer());
  std::map<int, QColor> colors;
  for (const auto& [l, on] : visible_) colors[l] = labelColor(l);
  for (size_t i = 0; i < v->data.size(); ++i) {
    const int l = v->data[i];
    const QColor& c = colors[l];
    const bool on = visible_[l];
    px[4 * i + 0] = uchar(c.red());
    px[4 * i + 1] = uchar(c.green());
    px[4 * i + 2] = uchar(c.blue());
    px[4 * i + 3] = on ? 255 : 0;
  }
  image_->Modified();
  const int n[3] = {nx, ny, nz};
  int at[3] = {nx / 2, ny / 2, nz / 2};
  if (plane_.enabled) at[plane_.axis] = std::clamp(int(std::lround(clipFraction_ * (n[plane_.axis] - 1))), 0, n[plane_.axis] - 1);
  slices_[0]->SetDisplayExtent(at[0], at[0], 0, ny - 1, 0, nz - 1);
  slices_[1]->SetDisplayExtent(0, nx - 1, at[1], at[1], 0, nz - 1);
  slices_[2]->SetDisplayExtent(0, nx - 1, 0, ny - 1, at[2], at[2]);
  for (int k = 0; k < 3; ++k) {
    slices_[k]->SetVisibility(true);
    slices_[k]->Modified();
  }
  status_->setText(tr("%1: label volume %2 x %3 x %4, spacing %5 x %6 x %7 mm; slices at %8, %9, %10")
                       .arg(title_).arg(nx).arg(ny).arg(nz)
                       .arg(g.spacing[0]).arg(g.spacing[1]).arg(g.spacing[2])
                       .arg(at[0]).arg(at[1]).arg(at[2]));
  vtk_->update();
}

QStringList MeshView::colorChoices() const {
  QStringList l;
  if (const TetMesh* m = meshOf(data_))
    for (const auto& c : choicesFor(*m)) l << c.label;
  return l;
}

void MeshView::setColorBy(const QString& field) {
  colorField_ = field;
  if (colorBy_->currentText() != field) {
    syncing_ = true;
    colorBy_->setCurrentText(field);
    syncing_ = false;
  }
  updateColors();
  vtk_->update();
}

void MeshView::setEdgesVisible(bool on) {
  edgesOn_ = on;
  actor_->GetProperty()->SetEdgeVisibility(on);
  vtk_->update();
}

void MeshView::setClip(bool enabled, int axis, double fraction, bool keepAbove) {
  plane_.enabled = enabled;
  plane_.axis = std::clamp(axis, 0, 2);
  plane_.keepAbove = keepAbove;
  clipFraction_ = std::clamp(fraction, 0.0, 1.0);
  syncing_ = true;
  clip_->setChecked(enabled);
  clipAxis_->setCurrentIndex(plane_.axis);
  clipPos_->setValue(int(std::lround(clipFraction_ * 1000)));
  clipFlip_->setChecked(!keepAbove);
  syncing_ = false;
  if (meshOf(data_)) rebuildMesh();
  else if (volumeOf(data_)) rebuildVolume();
}

void MeshView::setMaterialVisible(int label, bool on) {
  if (!visible_.count(label)) return;
  visible_[label] = on;
  syncing_ = true;
  for (int i = 0; i < legend_->count(); ++i)
    if (legend_->item(i)->data(Qt::UserRole).toInt() == label)
      legend_->item(i)->setCheckState(on ? Qt::Checked : Qt::Unchecked);
  syncing_ = false;
  if (meshOf(data_)) rebuildMesh();
  else if (volumeOf(data_)) rebuildVolume();
}

void MeshView::resetCamera() {
  vtkRenderer* ren = vtk_->renderer();
  vtkCamera* cam = ren->GetActiveCamera();
  cam->SetPosition(0, -1, 0.35); // LPS: look from the front (-y), slightly above
  cam->SetFocalPoint(0, 0, 0);
  cam->SetViewUp(0, 0, 1);
  cam->Azimuth(-35);
  ren->ResetCamera();
  cam->Dolly(1.25); // ResetCamera leaves a wide margin around the bounding sphere
  ren->ResetCameraClippingRange();
  vtk_->update();
}

} // namespace tetflow::gui
