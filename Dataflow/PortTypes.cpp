#include "PortTypes.h"

#include "Algorithms/CAD/CadModel.h"

#include <sstream>

namespace tetflow {

namespace {
std::atomic<uint64_t> g_nextDataId{1};
constexpr std::pair<PortType, const char*> kPortNames[] = {
    {PortType::LabelVolume, "LabelVolume"}, {PortType::ScalarVolume, "ScalarVolume"},
    {PortType::Materials, "Materials"},     {PortType::TetMesh, "TetMesh"},
    {PortType::Matrix, "Matrix"},           {PortType::Vector, "Vector"},
    {PortType::Report, "Report"},           {PortType::DenseMatrix, "DenseMatrix"},
    {PortType::CADModel, "CADModel"}};

std::string gridSummary(const GridGeometry& g) {
  std::ostringstream s;
  s << g.dims[0] << "x" << g.dims[1] << "x" << g.dims[2] << " @ " << g.spacing[0] << "x"
    << g.spacing[1] << "x" << g.spacing[2] << " mm";
  return s.str();
}
} // namespace

const char* portTypeName(PortType t) {
  for (const auto& [p, n] : kPortNames)
    if (p == t) return n;
  return "?";
}

std::optional<PortType> portTypeFromName(const std::string& name) {
  for (const auto& [p, n] : kPortNames)
    if (name == n) return p;
  return std::nullopt;
}

DataObject::DataObject(PortType t) : type_(t), id_(g_nextDataId.fetch_add(1)) {}

std::string DataObject::summary() const { return portTypeName(type_); }

template <>
std::string LabelVolumeData::summary() const {
  return "LabelVolume " + gridSummary(value.grid);
}
template <>
std::string ScalarVolumeData::summary() const {
  return "ScalarVolume " + gridSummary(value.grid);
}
template <>
std::string TetMeshData::summary() const {
  std::ostringstream s;
  s << "TetMesh " << value.numPoints() << " vertices, " << value.numTets() << " tets";
  return s.str();
}
template <>
std::string ReportData::summary() const {
  return "Report with " + std::to_string(value.entries().size()) + " entries";
}

template <>
std::string MaterialsData::summary() const {
  return "Materials: " + (value ? value->describe() : std::string("none"));
}

template <>
std::string MatrixData::summary() const {
  if (!value) return "Matrix: none";
  std::ostringstream s;
  s << "Matrix " << value->rows() << "x" << value->cols() << ", " << value->nonZeros() << " non-zeros";
  return s.str();
}

template <>
std::string DenseMatrixData::summary() const {
  if (!value) return "DenseMatrix: none";
  std::ostringstream s;
  s << "DenseMatrix " << value->rows() << "x" << value->cols();
  return s.str();
}

template <>
std::string CadModelData::summary() const {
  if (!value) return "CADModel: none";
  std::ostringstream s;
  s << "CADModel " << value->solids().size() << " solid(s), " << value->patches().size() << " patches, "
    << value->curves().size() << " curves";
  return s.str();
}

} // namespace tetflow
