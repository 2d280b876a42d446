#pragma once
// What travels on the wires (DESIGN §2). Every data object is immutable once sent and carries a
// process-unique identity, so the executor can tell whether a module's inputs changed.
#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "Algorithms/Cleaving/Materials.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/TetMesh.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {
class CadModel; // Algorithms/CAD/CadModel.h
}

namespace tetflow {

// Stable values: they appear in saved files and tool output.
enum class PortType : int {
  LabelVolume = 0,
  ScalarVolume = 1,
  Materials = 2,
  TetMesh = 3,
  Matrix = 4,
  Vector = 5,
  Report = 6,
  DenseMatrix = 7,
  CADModel = 8
};
const char* portTypeName(PortType t);
std::optional<PortType> portTypeFromName(const std::string& name);

class DataObject {
public:
  explicit DataObject(PortType t);
  virtual ~DataObject() = default;
  DataObject(const DataObject&) = delete;
  DataObject& operator=(const DataObject&) = delete;
  PortType type() const { return type_; }
  uint64_t id() const { return id_; } // unique in this process, never reused
  // One-line description for logs and tooltips ("LabelVolume 96x96x96, 5 labels").
  virtual std::string summary() const;

private:
  PortType type_;
  uint64_t id_;
};

using DataPtr = std::shared_ptr<const DataObject>;

template <class T, PortType P>
class DataOf : public DataObject {
public:
  static constexpr PortType kType = P;
  explicit DataOf(T v) : DataObject(P), value(std::move(v)) {}
  const T value;
  std::string summary() const override;
};

using LabelVolumeData = DataOf<LabelVolume, PortType::LabelVolume>;
using ScalarVolumeData = DataOf<ScalarVolume, PortType::ScalarVolume>;
using TetMeshData = DataOf<TetMesh, PortType::TetMesh>;
using ReportData = DataOf<Report, PortType::Report>;
// A set of indicator functions (or labels seen as such); shared, immutable.
using MaterialsData = DataOf<std::shared_ptr<const MaterialSet>, PortType::Materials>;
// A sparse matrix (e.g. AssembleFEMPoisson's reduced stiffness matrix K, both triangles stored,
// compressed, column-major); shared, immutable.
using MatrixData = DataOf<std::shared_ptr<const Eigen::SparseMatrix<double>>, PortType::Matrix>;
// A dense matrix (e.g. ComputeLeadField's lead field, electrodes x 3 sources); shared, immutable.
using DenseMatrixData = DataOf<std::shared_ptr<const Eigen::MatrixXd>, PortType::DenseMatrix>;
// A B-rep CAD model (ReadCADModel); shared, immutable.
using CadModelData = DataOf<std::shared_ptr<const CadModel>, PortType::CADModel>;
template <> std::string LabelVolumeData::summary() const;
template <> std::string ScalarVolumeData::summary() const;
template <> std::string TetMeshData::summary() const;
template <> std::string ReportData::summary() const;
template <> std::string MaterialsData::summary() const;
template <> std::string MatrixData::summary() const;
template <> std::string DenseMatrixData::summary() const;
template <> std::string CadModelData::summary() const;

template <class D, class T>
std::shared_ptr<const D> makeData(T&& value) {
  return std::make_shared<const D>(std::forward<T>(value));
}

} // namespace tetflow
