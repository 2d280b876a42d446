#pragma once
// 3D view of the selected module's output (VTK in a QOpenGLWidget, see VtkWidget.h).
//
// TetMesh: boundary surface of the visible materials, coloured by material (legend with label
// names and colours; tick a material off to hide it), or by a field with a scalar bar: every
// 1-component cell field (min_dihedral … from EvaluateQuality), "min_dihedral" computed here
// when the mesh has none, every 1-component point field (e.g. potential) and |∇| of it per tet.
// Field colour scales: linear (rainbow over the field's min..max), diverging (blue-white-red,
// symmetric about 0, ±the 98th percentile of |value| on the shown surface) for signed fields such
// as a dipole's potential, log10 (rainbow from the 2nd percentile of the shown positive values to
// their maximum; zeros take the bottom colour) for magnitudes (|∇u|, grad_magnitude,
// current_density). The scale follows the field's kind when a field is chosen; the Scale box
// overrides it for that field.
// A clipping plane (axis, position, side) removes whole tets so the inside shows; element edges
// on/off; reset camera.
// LabelVolume: three orthogonal slices through the volume coloured by label (the clip axis and
// position move the slice of that axis); hidden labels are transparent (label 0 starts hidden).
#include <QWidget>

#include <array>
#include <map>
#include <memory>
#include <vector>

#include "Dataflow/PortTypes.h"
#include "MeshSurface.h"

class QComboBox;
class QCheckBox;
class QSlider;
class QListWidget;
class QLabel;
class QPushButton;
class vtkActor;
class vtkPolyData;
class vtkPolyDataMapper;
class vtkScalarBarActor;
class vtkImageActor;
class vtkImageData;
class vtkLookupTable;

namespace tetflow::gui {

class VtkWidget;

class MeshView : public QWidget {
  Q_OBJECT
public:
  explicit MeshView(QWidget* parent = nullptr);
  ~MeshView() override;

  // Bytes per tet the view asks the memory budget for before it builds a mesh's surface.
  static constexpr int64_t kViewBytesPerTet = 128;

  // Show a TetMesh or LabelVolume (other types: cleared with a message). Label names are shown
  // in the legend (label value -> name); a new data object resets the camera. A mesh whose view
  // would need more than the memory budget (MemoryBudget.h) is not built: the view shows why.
  void showData(const DataPtr& data, const std::map<int, QString>& labelNames, const QString& title);
  void clearData(const QString& message);

  enum class ColorScale { Linear = 0, Diverging = 1, Log = 2 };
  // The scale a field gets unless the user picks another: log for magnitudes (magnitude = |∇| of
  // a point field, or a name ending in "magnitude" or "current_density") without negative values,
  // diverging for fields with both signs, else linear. lo/hi: the field's finite min and max.
  static ColorScale automaticScale(const QString& field, bool magnitude, double lo, double hi);

  // Controls (also driven by the widgets).
  void setColorBy(const QString& field); // "material" or a field name from colorChoices()
  void setColorScale(ColorScale scale);  // for the field shown now (kept for it)
  QStringList colorChoices() const;
  void setEdgesVisible(bool on);
  // fraction 0..1 of the bounding box along `axis`; keepAbove keeps tets with centroid >= plane.
  void setClip(bool enabled, int axis, double fraction, bool keepAbove = true);
  void setMaterialVisible(int label, bool visible);
  void resetCamera();

  // State for tests.
  VtkWidget* vtkWidget() const { return vtk_; }
  size_t visibleFaceCount() const { return faces_.faces.size(); }
  std::vector<int> materialLabels() const;
  bool scalarBarVisible() const;
  QListWidget* legend() const { return legend_; }
  ColorScale colorScale() const { return scale_; }         // in effect for the field shown
  std::array<double, 2> colorRange() const { return range_; } // the lookup table's range
  vtkLookupTable* lookupTable() const { return lut_; }
  QComboBox* scaleBox() const { return scaleBox_; }
  // The field values on the shown surface (per vertex of a shown face, or per shown face).
  const std::vector<double>& shownValues() const { return shownValues_; }
  const DataPtr& data() const { return data_; }
  QString statusText() const; // the line under the view (what is shown, or why nothing is)

private:
  void rebuildMesh();
  void rebuildVolume();
  void updateColors();
  void syncControls();
  QString labelName(int label) const;
  int labelIndex(int label) const;

  VtkWidget* vtk_;
  QComboBox* colorBy_;
  QComboBox* scaleBox_;
  QCheckBox* edges_;
  QCheckBox* clip_;
  QComboBox* clipAxis_;
  QSlider* clipPos_;
  QCheckBox* clipFlip_;
  QPushButton* reset_;
  QListWidget* legend_;
  QLabel* status_;

  DataPtr data_;
  QString title_;
  std::map<int, QString> names_;
  std::map<int, bool> visible_;
  MeshTopology topo_;
  SurfaceFaces faces_;
  std::map<QString, std::vector<double>> computedCellFields_;
  ClipPlane plane_;
  double clipFraction_ = 0.5;
  QString colorField_ = "material";
  std::map<QString, ColorScale> scaleChosen_; // the user's scale per field
  ColorScale scale_ = ColorScale::Linear;
  std::array<double, 2> range_{0, 1};
  std::vector<double> shownValues_;
  QString meshStatus_;
  bool edgesOn_ = false;
  bool syncing_ = false;

  vtkActor* actor_ = nullptr;
  vtkPolyData* poly_ = nullptr;
  vtkPolyDataMapper* mapper_ = nullptr;
  vtkScalarBarActor* scalarBar_ = nullptr;
  vtkLookupTable* lut_ = nullptr;
  vtkImageData* image_ = nullptr;
  vtkImageActor* slices_[3] = {nullptr, nullptr, nullptr};
};

} // namespace tetflow::gui
