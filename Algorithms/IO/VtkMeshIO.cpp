// Tetrahedral meshes in VTK's files: XML unstructured grid (.vtu; our own writer, VtuWriter.h;
// read through VTK) and legacy VTK (.vtk, through VTK). The contracts are MeshIO.h's.
#include "VtkMeshIO.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <new>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkCellTypes.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkExecutive.h>
#include <vtkFieldData.h>
#include <vtkIdTypeArray.h>
#include <vtkTypeInt32Array.h>
#include <vtkTypeInt64Array.h>
#include <vtkIntArray.h>
#include <vtkLogger.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkUnstructuredGridReader.h>
#include <vtkUnstructuredGridWriter.h>
#include <vtkXMLUnstructuredGridReader.h>

#include "../Core/Errors.h"
#include "../Core/Progress.h"
#include "FileUtil.h"
#include "MeshFileText.h"
#include "VtkCancellableWriters.h"
#include "VtkXmlPrecheck.h"
#include "VtuWriter.h"

namespace fs = std::filesystem;

namespace tetflow {

using namespace mesh_io;

namespace {

constexpr const char* kMaterialArray = "material";


// "vtkClassName (0x1234): text\n\n" -> "text"
std::string cleanVtkMessage(std::string msg) {
  const auto pos = msg.find("): ");
  if (pos != std::string::npos && pos < 120) msg = msg.substr(pos + 3);
  while (!msg.empty() && std::isspace(static_cast<unsigned char>(msg.back()))) msg.pop_back();
  for (char& c : msg)
    if (c == '\n') c = ' ';
  return msg;
}

// Some VTK failures never reach an object observer: vtkDataReader reports a short binary or
// ASCII data block only through vtkGenericWarningMacro ("Error reading binary data!") and then
// returns the partial grid as a success; objects inside readers (decompressors, parsers) report
// errors without observers. VTK routes all of these through vtkLogger, so a callback registered
// once collects them for the thread that is currently inside one of our VTK calls (thread_local
// sink; other threads' messages are ignored). Captured: errors, and warnings mentioning an error.
thread_local std::vector<std::string>* t_vtkLogSink = nullptr;

void vtkLogToSink(void* /*userData*/, const vtkLogger::Message& m) {
  if (!t_vtkLogSink || !m.message) return;
  std::string text = m.message;
  if (m.verbosity <= vtkLogger::VERBOSITY_ERROR || text.find("rror") != std::string::npos)
    t_vtkLogSink->push_back(cleanVtkMessage(text));
}

// While alive, VTK log errors of this thread are appended to `sink`. Scopes nest (LIFO).
class VtkLogCapture {
public:
  explicit VtkLogCapture(std::vector<std::string>& sink) : previous_(t_vtkLogSink) {
    static std::once_flag once;
    std::call_once(once, [] {
      vtkLogger::AddCallback("tetflow.MeshIO.capture", &vtkLogToSink, nullptr,
                             vtkLogger::VERBOSITY_WARNING);
    });
    t_vtkLogSink = &sink;
  }
  ~VtkLogCapture() { t_vtkLogSink = previous_; }
  VtkLogCapture(const VtkLogCapture&) = delete;
  VtkLogCapture& operator=(const VtkLogCapture&) = delete;

private:
  std::vector<std::string>* previous_;
};

// Collects VTK error (and swallows warning) events so they become exceptions instead of console
// output. Attached to the reader/writer, its executive and, for XML readers, the internal parser;
// a VtkLogCapture on `errors` adds the messages that bypass observers.
class VtkMessageCollector : public vtkCommand {
public:
  static VtkMessageCollector* New() { return new VtkMessageCollector; }
  void Execute(vtkObject* /*caller*/, unsigned long event, void* callData) override {
    std::string msg =
        cleanVtkMessage(callData ? static_cast<const char*>(callData) : "unspecified VTK error");
    if (event == vtkCommand::ErrorEvent) errors.push_back(msg);
    else warnings.push_back(msg);
  }
  void watch(vtkObject* o) {
    if (!o) return;
    o->AddObserver(vtkCommand::ErrorEvent, this);
    o->AddObserver(vtkCommand::WarningEvent, this);
  }
  std::string firstError() const { return errors.empty() ? std::string() : errors.front(); }

  std::vector<std::string> errors;
  std::vector<std::string> warnings;
};

std::string vtkFailureText(const VtkMessageCollector& c, unsigned long code) {
  std::string text = c.firstError();
  if (text.empty() && code != vtkErrorCode::NoError) {
    // (vtkErrorCode::GetStringFromErrorCode lives in a VTK module we do not link.)
    switch (code) {
    case vtkErrorCode::FileNotFoundError: text = "file not found"; break;
    case vtkErrorCode::CannotOpenFileError: text = "cannot open the file"; break;
    case vtkErrorCode::UnrecognizedFileTypeError: text = "unrecognized file type"; break;
    case vtkErrorCode::PrematureEndOfFileError: text = "premature end of file"; break;
    case vtkErrorCode::FileFormatError: text = "file format error"; break;
    case vtkErrorCode::NoFileNameError: text = "no file name"; break;
    case vtkErrorCode::OutOfDiskSpaceError: text = "out of disk space"; break;
    default: text = "VTK error code " + std::to_string(code); break;
    }
  }
  if (text.empty()) text = "unknown VTK error";
  return text;
}

std::string cellTypeName(int type) {
  const char* n = vtkCellTypes::GetClassNameFromTypeId(type);
  return n ? n : "unknown cell";
}

// Cancellation check of the running module (if any) every 2^20 items of a copy loop.
void pollCancel(int64_t i) {
  if (const Progress* p = currentProgress()) p->checkCancelEvery(i);
}

vtkSmartPointer<vtkUnstructuredGrid> meshToGrid(const TetMesh& m) {
  auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();

  // The grid only lives while it is written, and `m` outlives it: point coordinates and double
  // fields are handed to VTK without a copy (save = 1: VTK never frees or changes them).
  auto borrow = [](vtkDoubleArray* a, const double* data, vtkIdType tuples, int components) {
    a->SetNumberOfComponents(components);
    a->SetArray(const_cast<double*>(data), tuples * components, 1);
  };
  vtkNew<vtkDoubleArray> xyz;
  static_assert(sizeof(Vec3) == 3 * sizeof(double));
  borrow(xyz.Get(), m.points.empty() ? nullptr : m.points.front().data(),
         static_cast<vtkIdType>(m.numPoints()), 3);
  vtkNew<vtkPoints> pts;
  pts->SetData(xyz);
  grid->SetPoints(pts);

  const vtkIdType nt = static_cast<vtkIdType>(m.numTets());
  vtkNew<vtkCellArray> cells;
  // 32-bit connectivity while it fits (half the memory and time of 64-bit; every VTK reader
  // reads either width), else 64-bit.
  auto fill = [&](auto* offsets, auto* conn) {
    offsets->SetNumberOfValues(nt + 1);
    conn->SetNumberOfValues(4 * nt);
    for (vtkIdType t = 0; t <= nt; ++t) {
      pollCancel(t);
      offsets->SetValue(t, 4 * t);
    }
    for (vtkIdType t = 0; t < nt; ++t) {
      pollCancel(t);
      for (int k = 0; k < 4; ++k) conn->SetValue(4 * t + k, m.tets[static_cast<size_t>(t)][k]);
    }
    cells->SetData(offsets, conn);
  };
  if (4 * nt <= std::numeric_limits<int32_t>::max()) {
    vtkNew<vtkTypeInt32Array> offsets, conn;
    fill(offsets.Get(), conn.Get());
  } else {
    vtkNew<vtkTypeInt64Array> offsets, conn;
    fill(offsets.Get(), conn.Get());
  }
  grid->SetCells(VTK_TETRA, cells);

  vtkNew<vtkIntArray> mat;
  mat->SetName(kMaterialArray);
  mat->SetNumberOfComponents(1);
  mat->SetNumberOfTuples(nt);
  for (vtkIdType t = 0; t < nt; ++t) {
    pollCancel(t);
    mat->SetValue(t, m.materials[static_cast<size_t>(t)]);
  }
  grid->GetCellData()->AddArray(mat);

  auto addFields = [&borrow](const std::map<std::string, Field>& fields, vtkDataSetAttributes* attr,
                       vtkIdType n) {
    for (const auto& [name, f] : fields) {
      vtkNew<vtkDoubleArray> a;
      a->SetName(name.c_str());
      borrow(a.Get(), f.values.data(), n, f.components); // sizes checked by validateStructure
      attr->AddArray(a);
    }
  };
  addFields(m.pointFields, grid->GetPointData(), static_cast<vtkIdType>(m.numPoints()));
  addFields(m.cellFields, grid->GetCellData(), nt);
  // The materials' names and conductivities as field data (materialFieldArrays, VtuWriter.h).
  const MaterialFieldArrays fa = materialFieldArrays(m);
  for (const auto& [name, label] : fa.names) {
    vtkNew<vtkIntArray> a;
    a->SetName(name.c_str());
    a->InsertNextValue(label);
    a->InsertNextValue(3);
    grid->GetFieldData()->AddArray(a);
  }
  if (!fa.conductivities.empty()) {
    vtkNew<vtkDoubleArray> a;
    a->SetName(kMaterialConductivitiesArray);
    a->SetNumberOfComponents(2);
    for (const auto& [label, c] : fa.conductivities) {
      const double row[2] = {double(label), c};
      a->InsertNextTuple(row);
    }
    grid->GetFieldData()->AddArray(a);
  }
  return grid;
}

// Convert arrays of one attribute set (point or cell data) to fields; the cell array "material"
// becomes the material labels when `materials` is given.
void readArrays(vtkDataSetAttributes* attr, vtkIdType count, const char* kind,
                std::map<std::string, Field>& fields, std::vector<int32_t>* materials,
                const std::string& path) {
  if (!attr) return;
  for (int i = 0; i < attr->GetNumberOfArrays(); ++i) {
    vtkDataArray* a = vtkDataArray::SafeDownCast(attr->GetAbstractArray(i));
    if (!a) continue; // string / variant arrays carry no numbers: ignored
    std::string name = a->GetName() ? a->GetName() : "";
    if (name.empty()) name = std::string(kind) + "_array_" + std::to_string(i);
    const int nc = a->GetNumberOfComponents();
    if (a->GetNumberOfTuples() != count) {
      std::ostringstream m;
      m << path << ": " << kind << " data array '" << name << "' has " << a->GetNumberOfTuples()
        << " tuples but the mesh has " << count << " " << kind << "s (damaged file?)";
      throw InputError(m.str());
    }
    if (materials && name == kMaterialArray) {
      if (nc != 1)
        throw InputError(path + ": cell data array 'material' has " + std::to_string(nc) +
                         " components; expected 1 (one integer label per tet)");
      materials->resize(static_cast<size_t>(count));
      for (vtkIdType t = 0; t < count; ++t) {
        const double v = a->GetComponent(t, 0);
        if (!(v == std::floor(v)) || v < std::numeric_limits<int32_t>::min() ||
            v > std::numeric_limits<int32_t>::max()) {
          std::ostringstream m;
          m << path << ": cell " << t << " has material value " << v
            << ", which is not a 32-bit integer label";
          throw InputError(m.str());
        }
        (*materials)[static_cast<size_t>(t)] = static_cast<int32_t>(v);
      }
      continue;
    }
    if (fields.count(name)) continue; // duplicate name: the first array wins
    Field f;
    f.components = nc;
    f.values.resize(static_cast<size_t>(count) * static_cast<size_t>(nc));
    std::vector<double> tuple(static_cast<size_t>(nc));
    for (vtkIdType t = 0; t < count; ++t) {
      a->GetTuple(t, tuple.data());
      std::copy(tuple.begin(), tuple.end(),
                f.values.begin() + static_cast<std::ptrdiff_t>(t) * nc);
    }
    fields.emplace(name, std::move(f));
  }
}

template <class IdArray>
void readConnectivity(IdArray* offsets, IdArray* conn, vtkUnsignedCharArray* types,
                      vtkIdType nCells, vtkIdType nPoints, TetMesh& m, const std::string& path) {
  const vtkIdType connSize = conn ? conn->GetNumberOfValues() : 0;
  if (!offsets || offsets->GetNumberOfValues() != nCells + 1 || offsets->GetValue(0) != 0 ||
      offsets->GetValue(nCells) != connSize)
    throw InputError(path + ": the cell connectivity is inconsistent (damaged file?)");
  m.tets.resize(static_cast<size_t>(nCells));
  for (vtkIdType c = 0; c < nCells; ++c) {
    const int type = types->GetValue(c);
    const auto b = offsets->GetValue(c), e = offsets->GetValue(c + 1);
    if (type != VTK_TETRA) {
      std::ostringstream msg;
      msg << path << ": cell " << c << " is a " << cellTypeName(type) << " (VTK cell type " << type
          << "); only tetrahedra (VTK_TETRA = " << VTK_TETRA << ") are supported";
      throw InputError(msg.str());
    }
    if (e - b != 4 || b < 0 || e > connSize) {
      std::ostringstream msg;
      msg << path << ": tetrahedron cell " << c << " has " << (e - b) << " points instead of 4";
      throw InputError(msg.str());
    }
    for (int k = 0; k < 4; ++k) {
      const auto id = conn->GetValue(b + k);
      if (id < 0 || id >= nPoints) {
        std::ostringstream msg;
        msg << path << ": cell " << c << " refers to point " << id << " but the file has "
            << nPoints << " points";
        throw InputError(msg.str());
      }
      m.tets[static_cast<size_t>(c)][k] = static_cast<int32_t>(id);
    }
  }
}

TetMesh gridToMesh(vtkUnstructuredGrid* g, const std::string& path) {
  if (!g) throw InputError(path + ": VTK produced no data (damaged file?)");
  TetMesh m;
  const vtkIdType np = g->GetNumberOfPoints();
  if (np > std::numeric_limits<int32_t>::max())
    throw InputError(path + ": too many points (" + std::to_string(np) + ") for 32-bit indices");
  m.points.resize(static_cast<size_t>(np));
  vtkPoints* pts = g->GetPoints();
  if (np > 0 && !pts) throw InputError(path + ": the file has no point coordinates");
  for (vtkIdType i = 0; i < np; ++i) pts->GetPoint(i, m.points[static_cast<size_t>(i)].data());

  vtkCellArray* cells = g->GetCells();
  const vtkIdType nc = cells ? cells->GetNumberOfCells() : 0;
  vtkUnsignedCharArray* types = g->GetCellTypesArray();
  if (nc > 0 && (!types || types->GetNumberOfValues() != nc))
    throw InputError(path + ": the number of cell types does not match the number of cells "
                            "(damaged file?)");
  if (nc > 0) {
    if (cells->IsStorage64Bit())
      readConnectivity(cells->GetOffsetsArray64(), cells->GetConnectivityArray64(), types, nc,
                       np, m, path);
    else
      readConnectivity(cells->GetOffsetsArray32(), cells->GetConnectivityArray32(), types, nc,
                       np, m, path);
  }
  m.materials.assign(static_cast<size_t>(nc), 0);
  readArrays(g->GetPointData(), np, "point", m.pointFields, nullptr, path);
  readArrays(g->GetCellData(), nc, "cell", m.cellFields, &m.materials, path);
  // The materials' names and conductivities (field data, materialFieldArrays in VtuWriter.h):
  // an integer array of (label) or (label, 3) is a material's name; other arrays are left alone.
  if (vtkFieldData* fd = g->GetFieldData()) {
    auto integral = [](vtkDataArray* a) { return a->GetDataType() != VTK_DOUBLE && a->GetDataType() != VTK_FLOAT; };
    auto label = [](double v) {
      return v >= std::numeric_limits<int32_t>::min() && v <= std::numeric_limits<int32_t>::max() && v == std::floor(v);
    };
    for (int i = 0; i < fd->GetNumberOfArrays(); ++i) {
      vtkDataArray* a = fd->GetArray(i);
      if (!a || !a->GetName() || a->GetNumberOfComponents() < 1) continue;
      const std::string name = a->GetName();
      const vtkIdType n = a->GetNumberOfTuples();
      if (name == kMaterialConductivitiesArray && a->GetNumberOfComponents() == 2) {
        for (vtkIdType t = 0; t < n; ++t) {
          const double L = a->GetComponent(t, 0), c = a->GetComponent(t, 1);
          if (label(L) && std::isfinite(c) && c > 0) m.materialConductivities[int32_t(L)] = c;
        }
      } else if (integral(a) && a->GetNumberOfComponents() == 1 && (n == 1 || (n == 2 && a->GetComponent(1, 0) == 3)) &&
                 label(a->GetComponent(0, 0))) {
        std::string shown = name;
        const std::string suffix = " (label " + std::to_string(int32_t(a->GetComponent(0, 0))) + ")";
        if (shown.size() > suffix.size() && shown.compare(shown.size() - suffix.size(), suffix.size(), suffix) == 0)
          shown.resize(shown.size() - suffix.size());
        m.materialNames[int32_t(a->GetComponent(0, 0))] = shown;
      }
    }
  }
  m.validateStructure(path);
  orientPositively(m);
  return m;
}

void checkVtkWritable(const std::string& path, const TetMesh& m) {
  auto check = [&](const std::map<std::string, Field>& fields, const char* kind) {
    for (const auto& entry : fields)
      if (entry.first.empty())
        throw InputError(path + ": a " + std::string(kind) +
                         " field has an empty name; VTK files need array names");
  };
  check(m.pointFields, "point");
  check(m.cellFields, "cell");
  if (m.cellFields.count(kMaterialArray))
    throw InputError(path + ": cell field name 'material' is reserved for the material labels; "
                            "rename the field");
}

template <class Writer>
void runVtkWriter(Writer* w, const std::string& path, vtkUnstructuredGrid* grid) {
  AtomicOutputFile out(path);
  out.closeStream();
  vtkNew<VtkMessageCollector> msgs;
  VtkLogCapture capture(msgs->errors);
  msgs->watch(w);
  msgs->watch(w->GetExecutive());
  w->SetFileName(out.tempPath().c_str());
  w->SetInputData(grid);
  int ok = 0;
  try {
    ok = w->Write();
  } catch (const std::bad_alloc&) {
    throw InputError(path + ": out of memory while writing; nothing was written");
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot write: " + e.what() + "; nothing was written");
  }
  // The cancellable writers stop by failing their output: that is a cancellation, not an error.
  if (const Progress* p = currentProgress()) p->checkCancel();
  if (!ok || !msgs->errors.empty() || w->GetErrorCode() != vtkErrorCode::NoError)
    throw InputError(path + ": cannot write: " + vtkFailureText(*msgs, w->GetErrorCode()) +
                     "; nothing was written");
  out.commit();
}

} // namespace

// Our own writer (VtuWriter.h) in VTK's layout: VTK's writer compressed on one thread, after
// copying the connectivity.
void writeVtu(const std::string& path, const TetMesh& m) {
  checkVtkWritable(path, m);
  writeVtuFile(path, m);
}

void writeVtkLegacy(const std::string& path, const TetMesh& m) {
  checkVtkWritable(path, m);
  auto grid = meshToGrid(m);
  vtkNew<CancellableLegacyVtkWriter> w;
  w->SetFileTypeToBinary();
  // 4.2 layout is read by every VTK version and by most other tools; 5.1 only by VTK >= 9.
  w->SetFileVersion(vtkUnstructuredGridWriter::VTK_LEGACY_READER_VERSION_4_2);
  runVtkWriter(w.Get(), path, grid);
}

namespace {

template <class Reader>
TetMesh runVtkReader(Reader* r, VtkMessageCollector* msgs, const std::string& path,
                     const char* what) {
  msgs->watch(r->GetExecutive());
  r->SetFileName(path.c_str());
  // VTK does not throw by design, but damaged sizes make its containers throw (std::bad_alloc,
  // std::length_error from a corrupt compression header): report those as damaged input too.
  try {
    r->Update();
  } catch (const std::bad_alloc&) {
    throw InputError(path + ": the file announces more data than can be allocated "
                            "(damaged file?)");
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot read " + what + " (damaged file?): " + e.what());
  }
  if (!msgs->errors.empty() || r->GetErrorCode() != vtkErrorCode::NoError)
    throw InputError(path + ": cannot read " + what + " (damaged or truncated file?): " +
                     vtkFailureText(*msgs, r->GetErrorCode()));
  return gridToMesh(r->GetOutput(), path);
}

} // namespace

TetMesh readVtu(const std::string& path) {
  requireExistingFile(path);
  vtkNew<vtkXMLUnstructuredGridReader> r;
  vtkNew<VtkMessageCollector> msgs;
  VtkLogCapture capture(msgs->errors);
  msgs->watch(r);
  r->SetReaderErrorObserver(msgs);
  r->SetParserErrorObserver(msgs);
  if (!r->CanReadFile(path.c_str()))
    throw InputError(path + ": not a VTK XML UnstructuredGrid (.vtu) file, or its header is "
                            "damaged");
  precheckVtkXml(path); // block headers and counts against the file, before VTK allocates
  return runVtkReader(r.Get(), msgs, path, "the VTK XML unstructured grid");
}

namespace {

// vtkUnstructuredGridReader (VTK 9.1) trusts the sizes a legacy file announces: a damaged
// "CELLS n size" block of the 4.x layout ("npts id id ..." per cell) makes
// vtkCellArray::AppendLegacyFormat run off its buffer (segfault), "CELL_TYPES n" smaller than the
// cell count makes it read past the type buffer, and absurd counts make it allocate wildly.
// So before VTK sees the file we find the POINTS / CELLS / CELL_TYPES lines (first upper-case
// occurrence each; streamed over the whole file, which must not hold a second section of any of
// them), compare the counts with each other and with the file size, and walk a 4.x CELLS block
// with bounds checks. Anything not found or in another layout is left to VTK.
class LegacyPrecheck {
public:
  explicit LegacyPrecheck(const std::string& path) : path_(path) {
    std::error_code ec;
    fileSize_ = static_cast<uint64_t>(fs::file_size(path, ec));
    if (ec) throw InputError(path + ": cannot determine the file size");
  }

  void run() {
    std::ifstream in(path_, std::ios::binary);
    if (!in) throw InputError(path_ + ": cannot open for reading");
    std::string l1, l2, l3;
    std::getline(in, l1);
    std::getline(in, l2);
    std::getline(in, l3);
    const std::string tag = "Version ";
    const auto vpos = l1.find(tag);
    if (vpos != std::string::npos) major_ = std::atoi(l1.c_str() + vpos + tag.size());
    for (char& c : l3) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    binary_ = l3.rfind("BINARY", 0) == 0;
    findLines(in);

    if (points_.found && points_.tokens.size() >= 3) {
      const int64_t n = count(points_, 1);
      // ASCII values need at least one byte each (a bound against absurd counts only).
      const uint64_t each = binary_ ? typeSize(points_.tokens[2]) : 1;
      if (each) requireFits(points_, static_cast<uint64_t>(n) * 3, each, "POINTS");
    }
    int64_t nCells = -1;
    if (cells_.found && cells_.tokens.size() >= 3) {
      const int64_t a = count(cells_, 1), b = count(cells_, 2);
      if (major_ >= 5) {
        if (a < 1) fail(cells_, "announces no cell offsets");
        requireFits(cells_, static_cast<uint64_t>(a) + static_cast<uint64_t>(b), binary_ ? 4 : 1,
                    "CELLS");
        nCells = a - 1;
      } else {
        requireFits(cells_, static_cast<uint64_t>(b), binary_ ? 4 : 1, "CELLS");
        walkLegacyCells(a, b);
        nCells = a;
      }
    }
    if (types_.found && types_.tokens.size() >= 2) {
      const int64_t n = count(types_, 1);
      requireFits(types_, static_cast<uint64_t>(n), binary_ ? 4 : 1, "CELL_TYPES");
      if (nCells >= 0 && n != nCells) {
        std::ostringstream m;
        m << path_ << ": CELLS announces " << nCells << " cells but CELL_TYPES " << n
          << " types (damaged file?)";
        throw InputError(m.str());
      }
    }
  }

private:
  struct Line {
    bool found = false;
    uint64_t dataStart = 0; // offset just past the line's '\n'
    uint64_t keyAt = 0;     // offset of the '\n' before the keyword
    std::vector<std::string> tokens;
  };

  void findLines(std::ifstream& in) {
    in.clear();
    in.seekg(0);
    constexpr size_t kChunk = 1 << 22, kKeep = 512;
    std::vector<char> chunk(kChunk);
    std::string window;
    uint64_t windowStart = 0;
    auto look = [&](const char* key, Line& line) {
      if (!line.found) {
        const auto k = window.find(key);
        if (k == std::string::npos) return;
        const auto eol = window.find('\n', k + 1);
        if (eol == std::string::npos) return; // line incomplete: next round
        std::istringstream ls(window.substr(k + 1, eol - k - 1));
        for (std::string t; ls >> t;) line.tokens.push_back(t);
        line.dataStart = windowStart + eol + 1;
        line.keyAt = windowStart + k;
        line.found = true;
      }
      // A second section of the same kind: VTK would read both, and a damaged second CELLS block
      // ran vtkCellArray::AppendLegacyFormat off its buffer (found by fuzzing).
      const uint64_t from = line.keyAt + 1 > windowStart ? line.keyAt + 1 - windowStart : 0;
      if (from < window.size() && window.find(key, size_t(from)) != std::string::npos) {
        std::string name(key + 1);
        name.pop_back();
        throw InputError(path_ + ": has more than one " + name + " section (damaged file?)");
      }
    };
    while (true) { // the whole file: sections after the first of each kind are refused
      in.read(chunk.data(), static_cast<std::streamsize>(kChunk));
      const size_t got = static_cast<size_t>(in.gcount());
      if (got == 0) break;
      window.append(chunk.data(), got);
      look("\nPOINTS ", points_);
      look("\nCELLS ", cells_);
      look("\nCELL_TYPES ", types_);
      if (window.size() > kKeep) {
        const size_t drop = window.size() - kKeep;
        window.erase(0, drop);
        windowStart += drop;
      }
    }
  }

  [[noreturn]] void fail(const Line& l, const std::string& problem) const {
    std::string text;
    for (const auto& t : l.tokens) text += (text.empty() ? "" : " ") + t;
    throw InputError(path_ + ": '" + text + "' " + problem + " (damaged or truncated file?)");
  }

  int64_t count(const Line& l, size_t k) const {
    int64_t v = -1;
    const std::string& t = l.tokens[k];
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size() || v < 0)
      fail(l, "has an invalid count");
    return v;
  }

  // `values` entries of at least `each` bytes must fit between the line and the end of the file.
  void requireFits(const Line& l, uint64_t values, uint64_t each, const char* what) const {
    const uint64_t avail = fileSize_ > l.dataStart ? fileSize_ - l.dataStart : 0;
    if (values > avail / each)
      fail(l, std::string("announces more ") + what + " data than the rest of the file holds");
  }

  static uint64_t typeSize(const std::string& type) {
    std::string t = type;
    for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (t == "float" || t == "int" || t == "unsigned_int") return 4;
    if (t == "double" || t == "vtktypeint64" || t == "vtktypeuint64") return 8;
    if (t == "short" || t == "unsigned_short") return 2;
    if (t == "char" || t == "unsigned_char" || t == "signed_char") return 1;
    return 0; // other types: left to VTK
  }

  // 4.x layout: `size` ints forming exactly `n` records "npts id_1 .. id_npts".
  void walkLegacyCells(int64_t n, int64_t size) {
    std::ifstream in(path_, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(cells_.dataStart));
    int64_t pos = 0, cell = 0;
    auto bad = [&](const std::string& why) {
      std::ostringstream m;
      m << "is inconsistent at cell " << cell << ": " << why;
      fail(cells_, m.str());
    };
    std::vector<unsigned char> buf;
    size_t bufPos = 0;
    auto next = [&]() -> int64_t {
      if (binary_) {
        if (bufPos + 4 > buf.size()) {
          const size_t left = static_cast<size_t>(std::min<int64_t>(size - pos, 1 << 20)) * 4;
          buf.resize(left);
          in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(left));
          if (static_cast<size_t>(in.gcount()) != left) bad("the file ends inside the block");
          bufPos = 0;
        }
        const unsigned char* p = buf.data() + bufPos;
        bufPos += 4;
        const uint32_t u = (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) |
                           (uint32_t(p[2]) << 8) | uint32_t(p[3]);
        ++pos;
        return static_cast<int32_t>(u);
      }
      long long v = 0;
      if (!(in >> v)) bad("expected an integer");
      ++pos;
      return v;
    };
    for (; cell < n; ++cell) {
      if (pos >= size) bad("the block ends before the announced cells");
      const int64_t npts = next();
      if (npts < 0 || npts > size - pos) bad("point count " + std::to_string(npts));
      for (int64_t k = 0; k < npts; ++k) next();
    }
    if (pos != size) bad("the block holds more values than the announced cells use");
  }

  std::string path_;
  uint64_t fileSize_ = 0;
  int major_ = 0;
  bool binary_ = false;
  Line points_, cells_, types_;
};

} // namespace

TetMesh readVtkLegacy(const std::string& path) {
  requireExistingFile(path);
  LegacyPrecheck(path).run();
  vtkNew<vtkUnstructuredGridReader> r;
  vtkNew<VtkMessageCollector> msgs;
  VtkLogCapture capture(msgs->errors);
  msgs->watch(r);
  r->ReadAllScalarsOn();
  r->ReadAllVectorsOn();
  r->ReadAllNormalsOn();
  r->ReadAllTensorsOn();
  r->ReadAllColorScalarsOn();
  r->ReadAllTCoordsOn();
  r->ReadAllFieldsOn();
  r->SetFileName(path.c_str());
  if (!r->IsFileUnstructuredGrid()) {
    std::string why = msgs->firstError();
    throw InputError(path + ": not a legacy VTK UNSTRUCTURED_GRID file" +
                     (why.empty() ? std::string() : " (" + why + ")"));
  }
  return runVtkReader(r.Get(), msgs, path, "the legacy VTK unstructured grid");
}

} // namespace tetflow
