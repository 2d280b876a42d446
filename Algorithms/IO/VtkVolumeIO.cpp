#include "VtkVolumeIO.h"

#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkExecutive.h>
#include <vtkImageData.h>
#include <vtkMatrix3x3.h>
#include <vtkMatrix4x4.h>
#include <vtkMetaImageReader.h>
#include <vtkMetaImageWriter.h>
#include <vtkNIFTIImageHeader.h>
#include <vtkNIFTIImageReader.h>
#include <vtkNIFTIImageWriter.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSmartPointer.h>
#include <vtkType.h>
#include <vtkXMLImageDataReader.h>
#include <vtkXMLImageDataWriter.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "VtkXmlPrecheck.h"

namespace fs = std::filesystem;

namespace tetflow {

namespace {

// Collects VTK error/warning events so they become exceptions instead of console text.
class VtkErrorCatcher : public vtkCommand {
public:
  static VtkErrorCatcher* New() { return new VtkErrorCatcher; }
  void Execute(vtkObject*, unsigned long event, void* data) override {
    const char* msg = static_cast<const char*>(data);
    std::string text = msg ? msg : "unknown VTK error";
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    // VTK prefixes messages with source file and line: keep the part after the last ": ".
    if (auto pos = text.find("): "); pos != std::string::npos) text = text.substr(pos + 3);
    if (event == vtkCommand::ErrorEvent) errors.push_back(text);
  }
  std::vector<std::string> errors;
  void attach(vtkObject* o) {
    o->AddObserver(vtkCommand::ErrorEvent, this);
    o->AddObserver(vtkCommand::WarningEvent, this);
  }
  void throwIfAny(const std::string& what) const {
    if (!errors.empty()) throw InputError(what + ": " + errors.front());
  }
};

void requireReadableFile(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path + ": file not found");
  if (fs::is_directory(path, ec)) throw InputError(path + ": is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open for reading");
}

VoxelType fromVtkType(int t, const std::string& what) {
  switch (t) {
    case VTK_CHAR:
    case VTK_SIGNED_CHAR: return VoxelType::Int8;
    case VTK_UNSIGNED_CHAR: return VoxelType::UInt8;
    case VTK_SHORT: return VoxelType::Int16;
    case VTK_UNSIGNED_SHORT: return VoxelType::UInt16;
    case VTK_INT: return VoxelType::Int32;
    case VTK_UNSIGNED_INT: return VoxelType::UInt32;
    case VTK_LONG:
    case VTK_LONG_LONG:
    case VTK_ID_TYPE: return sizeof(long) == 8 || t != VTK_LONG ? VoxelType::Int64 : VoxelType::Int32;
    case VTK_UNSIGNED_LONG:
    case VTK_UNSIGNED_LONG_LONG:
      return sizeof(unsigned long) == 8 || t != VTK_UNSIGNED_LONG ? VoxelType::UInt64 : VoxelType::UInt32;
    case VTK_FLOAT: return VoxelType::Float32;
    case VTK_DOUBLE: return VoxelType::Float64;
    default:
      throw InputError(what + ": VTK voxel type code " + std::to_string(t) +
                       " is not supported (integer or float scalars only)");
  }
}

int toVtkType(VoxelType t) {
  switch (t) {
    case VoxelType::Int8: return VTK_SIGNED_CHAR;
    case VoxelType::UInt8: return VTK_UNSIGNED_CHAR;
    case VoxelType::Int16: return VTK_SHORT;
    case VoxelType::UInt16: return VTK_UNSIGNED_SHORT;
    case VoxelType::Int32: return VTK_INT;
    case VoxelType::UInt32: return VTK_UNSIGNED_INT;
    case VoxelType::Int64: return VTK_LONG_LONG;
    case VoxelType::UInt64: return VTK_UNSIGNED_LONG_LONG;
    case VoxelType::Float32: return VTK_FLOAT;
    case VoxelType::Float64: return VTK_DOUBLE;
  }
  return VTK_VOID;
}

// Copy the voxels and size of a VTK image (origin/direction set by the caller).
RawVolume rawFromImage(vtkImageData* img, const std::string& what) {
  if (!img) throw InputError(what + ": no image could be read");
  vtkDataArray* arr = img->GetPointData() ? img->GetPointData()->GetScalars() : nullptr;
  if (!arr) throw InputError(what + ": the file holds no voxel values");
  if (arr->GetNumberOfComponents() != 1) {
    std::ostringstream m;
    m << what << ": voxels have " << arr->GetNumberOfComponents()
      << " components; only single-valued (scalar) volumes are supported";
    throw InputError(m.str());
  }
  RawVolume raw;
  int dims[3];
  img->GetDimensions(dims);
  // An inverted or empty extent gives dimensions below 1 (found by fuzzing: a negative voxel count
  // reached vector::resize).
  if (dims[0] < 1 || dims[1] < 1 || dims[2] < 1) {
    std::ostringstream m;
    m << what << ": the image's extent is empty or inverted (dimensions " << dims[0] << " x " << dims[1] << " x "
      << dims[2] << ")";
    throw InputError(m.str());
  }
  raw.grid.dims = {dims[0], dims[1], dims[2]};
  double sp[3];
  img->GetSpacing(sp);
  raw.grid.spacing = {sp[0], sp[1], sp[2]};
  raw.type = fromVtkType(arr->GetDataType(), what);
  const size_t n = static_cast<size_t>(raw.grid.voxelCount());
  if (static_cast<size_t>(arr->GetNumberOfTuples()) != n) {
    std::ostringstream m;
    m << what << ": holds " << arr->GetNumberOfTuples() << " voxel values, expected " << n;
    throw InputError(m.str());
  }
  raw.bytes.resize(n * voxelTypeSize(raw.type));
  if (n) std::memcpy(raw.bytes.data(), arr->GetVoidPointer(0), raw.bytes.size());
  return raw;
}

vtkSmartPointer<vtkImageData> imageFromRaw(const RawVolume& v, bool withDirection) {
  auto img = vtkSmartPointer<vtkImageData>::New();
  img->SetDimensions(static_cast<int>(v.grid.dims[0]), static_cast<int>(v.grid.dims[1]),
                     static_cast<int>(v.grid.dims[2]));
  img->SetSpacing(v.grid.spacing.data());
  img->SetOrigin(v.grid.origin.data());
  if (withDirection) {
    double d[9];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) d[3 * r + c] = v.grid.direction[r][c];
    img->SetDirectionMatrix(d);
  }
  img->AllocateScalars(toVtkType(v.type), 1);
  if (!v.bytes.empty())
    std::memcpy(img->GetScalarPointer(), v.bytes.data(), v.bytes.size());
  return img;
}

void checkWritable(const RawVolume& v, const std::string& path) {
  v.grid.validate(path);
  for (int a = 0; a < 3; ++a)
    if (v.grid.dims[a] > std::numeric_limits<int>::max() / 2)
      throw InputError(path + ": volume too large for this format");
  if (v.bytes.size() != static_cast<size_t>(v.grid.voxelCount()) * voxelTypeSize(v.type))
    throw InputError(path + ": voxel data size does not match the dimensions");
}

// Run a VTK writer into an atomic temp file.
template <class Writer>
void runVtkWriter(Writer* w, const std::string& path, const std::string& tempSuffix = "") {
  AtomicOutputFile out(path);
  out.closeStream();
  const std::string temp = out.tempPath() + tempSuffix;
  vtkNew<VtkErrorCatcher> catcher;
  catcher->attach(w);
  w->SetFileName(temp.c_str());
  w->Write();
  if (!catcher->errors.empty() || w->GetErrorCode() != 0) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw InputError(path + ": writing failed" +
                     (catcher->errors.empty() ? std::string() : ": " + catcher->errors.front()));
  }
  if (!tempSuffix.empty()) {
    std::error_code ec;
    fs::rename(temp, out.tempPath(), ec);
    if (ec) throw InputError(path + ": cannot rename the written file (" + ec.message() + ")");
  }
  out.commit();
}

// ---- NIfTI header pre-check -------------------------------------------------------------

// Reads the 348-byte NIfTI-1 header (gz or not) and checks that the file can hold the data it
// announces, before VTK allocates anything.
void precheckNifti(const std::string& path) {
  // Only the start of the file: the header (inflated from at most 64 KiB when gzipped) and the size.
  int64_t fileSize = 0;
  const std::vector<char> file = readFilePrefix(path, 64 * 1024, &fileSize);
  std::vector<char> hdr;
  const bool gz = looksGzipped(file.data(), file.size());
  if (gz) {
    hdr = gunzip(file.data(), file.size(), -1, path);
  } else {
    hdr.assign(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(std::min<size_t>(file.size(), 352)));
  }
  if (hdr.size() < 348) throw InputError(path + ": too short to be a NIfTI file (header is 348 bytes)");
  int32_t sizeofHdr;
  std::memcpy(&sizeofHdr, hdr.data(), 4);
  bool swap = false;
  if (sizeofHdr != 348) {
    byteSwapInPlace(reinterpret_cast<unsigned char*>(&sizeofHdr), 1, 4);
    if (sizeofHdr != 348)
      throw InputError(path + ": not a NIfTI-1 file (sizeof_hdr is not 348; NIfTI-2 is not supported)");
    swap = true;
  }
  auto i16 = [&](size_t off) {
    int16_t v;
    std::memcpy(&v, hdr.data() + off, 2);
    if (swap) byteSwapInPlace(reinterpret_cast<unsigned char*>(&v), 1, 2);
    return v;
  };
  auto f32 = [&](size_t off) {
    float v;
    std::memcpy(&v, hdr.data() + off, 4);
    if (swap) byteSwapInPlace(reinterpret_cast<unsigned char*>(&v), 1, 4);
    return v;
  };
  const int16_t ndim = i16(40);
  if (ndim < 1 || ndim > 7) {
    std::ostringstream m;
    m << path << ": header dim[0] = " << ndim << " is not in 1..7; the header is damaged";
    throw InputError(m.str());
  }
  int64_t count = 1;
  for (int a = 1; a <= ndim; ++a) {
    const int16_t d = i16(40 + 2 * a);
    if (d < 1) {
      std::ostringstream m;
      m << path << ": header dim[" << a << "] = " << d << "; every dimension must be >= 1";
      throw InputError(m.str());
    }
    if (a > 3 && d != 1) {
      std::ostringstream m;
      m << path << ": has " << ndim << " dimensions with dim[" << a << "] = " << d
        << "; only 3-D scalar volumes are supported (no time series or vectors)";
      throw InputError(m.str());
    }
    count *= d;
  }
  for (int a = 1; a <= std::min<int>(ndim, 3); ++a) {
    const float p = f32(76 + 4 * a);
    if (!std::isfinite(p) || p == 0.0f) {
      std::ostringstream m;
      m << path << ": voxel spacing pixdim[" << a << "] = " << p << "; it must be a positive number";
      throw InputError(m.str());
    }
  }
  // A single-file NIfTI-1 ("n+1"); the two-file form ("ni1", .hdr + .img) is not read here.
  if (std::memcmp(hdr.data() + 344, "n+1", 4) != 0) {
    const bool pair = std::memcmp(hdr.data() + 344, "ni1", 4) == 0;
    throw InputError(path + (pair ? ": is the header of a two-file NIfTI pair (magic 'ni1'); convert it to a single .nii file"
                                  : ": the NIfTI magic at byte 344 is not 'n+1'; the header is damaged or not NIfTI-1"));
  }
  const int16_t datatype = i16(70);
  const int16_t bitpix = i16(72);
  // Scalar types only, each with its size in bits.
  static const std::pair<int16_t, int16_t> kTypes[] = {{2, 8},    {4, 16},   {8, 32},   {16, 32},  {64, 64},
                                                       {256, 8},  {512, 16}, {768, 32}, {1024, 64}, {1280, 64}};
  int16_t typeBits = 0;
  for (const auto& [code, bits] : kTypes)
    if (code == datatype) typeBits = bits;
  if (typeBits == 0) {
    std::ostringstream m;
    m << path << ": header datatype = " << datatype << " (byte 70) is not a scalar type this reader supports "
      << "(2 uint8, 4 int16, 8 int32, 16 float32, 64 float64, 256 int8, 512 uint16, 768 uint32, 1024 int64, "
      << "1280 uint64); the header is damaged or holds complex/RGB data";
    throw InputError(m.str());
  }
  if (bitpix != typeBits) {
    std::ostringstream m;
    m << path << ": header bitpix = " << bitpix << " does not match datatype " << datatype << " (" << typeBits
      << " bits); the header is damaged";
    throw InputError(m.str());
  }
  const float voxOffset = f32(108);
  if (!std::isfinite(voxOffset) || voxOffset < 348.0f || voxOffset > 1.0e9f) {
    std::ostringstream m;
    m << path << ": header vox_offset = " << voxOffset << " (byte 108); in a single-file NIfTI the data start at "
      << "byte 348 or later, so the header is damaged";
    throw InputError(m.str());
  }
  const int64_t need = static_cast<int64_t>(voxOffset) + count * (bitpix / 8);
  const int64_t have = gz ? maxInflatedSize(fileSize) : fileSize;
  if (!gz && have > need) {
    std::ostringstream m;
    m << path << ": the header announces " << count << " voxels of " << bitpix / 8 << " bytes from byte "
      << voxOffset << " (" << need << " bytes in all) but the file has " << have
      << " bytes; dim or datatype in the header is wrong";
    throw InputError(m.str());
  }
  if (need > have) {
    std::ostringstream m;
    m << path << ": the header announces " << count << " voxels of " << bitpix / 8
      << " bytes (" << need << " bytes with the header) but the file "
      << (gz ? "cannot hold that much compressed" : "has only " + std::to_string(have) + " bytes")
      << "; the file is truncated or the header is wrong";
    throw InputError(m.str());
  }
}

// ---- MetaImage header scan --------------------------------------------------------------

struct MetaHeader {
  std::vector<int64_t> dims;
  size_t elementSize = 0;
  int channels = 1;
  bool compressed = false;
  std::string dataFile;
  int64_t headerBytes = 0; // bytes up to and including the ElementDataFile line
  bool hasTransform = false;
  double transform[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  int ndims = 0;      // NDims (0 when absent)
  int dimSizeLine = 0, spacingLine = 0, ndimsLine = 0;
  std::vector<double> spacing; // ElementSpacing (or ElementSize when no spacing is given)
};

MetaHeader scanMetaHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open for reading");
  MetaHeader h;
  std::string line;
  int lineNo = 0;
  bool sawDataFile = false;
  auto fail = [&](const std::string& msg) {
    throw InputError(path + ":" + std::to_string(lineNo) + ": " + msg);
  };
  while (std::getline(in, line)) {
    ++lineNo;
    h.headerBytes += static_cast<int64_t>(line.size()) + 1;
    if (h.headerBytes > 1 << 20) fail("no ElementDataFile line in the first MiB; not a MetaImage file");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto eq = line.find('=');
    if (eq == std::string::npos) {
      if (line.find_first_not_of(" \t") == std::string::npos) continue;
      fail("expected 'Key = Value', found '" + line.substr(0, 60) + "'; not a MetaImage header");
    }
    auto trim = [](std::string s) {
      const auto b = s.find_first_not_of(" \t");
      const auto e = s.find_last_not_of(" \t");
      return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
    };
    const std::string key = trim(line.substr(0, eq));
    const std::string val = trim(line.substr(eq + 1));
    std::istringstream vs(val);
    if (key == "NDims") {
      if (!(vs >> h.ndims) || h.ndims < 1) fail("NDims = '" + val + "' is not a positive whole number");
      h.ndimsLine = lineNo;
    } else if (key == "DimSize") {
      int64_t d;
      while (vs >> d) {
        if (d < 1) fail("DimSize has " + std::to_string(d) + "; every dimension must be >= 1");
        h.dims.push_back(d);
      }
      if (!vs.eof()) fail("DimSize = '" + val + "' has a value that is not a whole number");
      h.dimSizeLine = lineNo;
    } else if (key == "ElementSpacing" || (key == "ElementSize" && h.spacingLine == 0)) {
      h.spacing.clear();
      double x;
      while (vs >> x) {
        if (!std::isfinite(x) || x <= 0.0)
          fail(key + " has " + std::to_string(x) + "; every voxel spacing must be a positive number of mm");
        h.spacing.push_back(x);
      }
      if (!vs.eof()) fail(key + " = '" + val + "' has a value that is not a number");
      h.spacingLine = lineNo;
    } else if (key == "ElementType") {
      static const std::pair<const char*, size_t> types[] = {
          {"MET_CHAR", 1}, {"MET_UCHAR", 1}, {"MET_SHORT", 2}, {"MET_USHORT", 2},
          {"MET_INT", 4}, {"MET_UINT", 4}, {"MET_LONG", 4}, {"MET_ULONG", 4},
          {"MET_LONG_LONG", 8}, {"MET_ULONG_LONG", 8}, {"MET_FLOAT", 4}, {"MET_DOUBLE", 8}};
      for (const auto& [n, s] : types)
        if (val == n) h.elementSize = s;
      if (!h.elementSize) fail("ElementType '" + val + "' is not supported");
    } else if (key == "ElementNumberOfChannels") {
      vs >> h.channels;
      if (h.channels != 1) fail("ElementNumberOfChannels = " + val + "; only scalar volumes are supported");
    } else if (key == "CompressedData") {
      h.compressed = (val == "True" || val == "true" || val == "TRUE");
    } else if (key == "TransformMatrix" || key == "Rotation" || key == "Orientation") {
      std::vector<double> m;
      double x;
      while (vs >> x) m.push_back(x);
      if (m.size() == 9) {
        h.hasTransform = true;
        std::copy(m.begin(), m.end(), h.transform);
      } else if (!(m.size() == 4 && m[0] == 1 && m[1] == 0 && m[2] == 0 && m[3] == 1)) {
        fail(key + " must have 9 values for a 3-D image");
      }
    } else if (key == "ElementDataFile") {
      h.dataFile = val;
      sawDataFile = true;
      break;
    }
  }
  if (!sawDataFile) throw InputError(path + ": no ElementDataFile line; not a MetaImage header");
  if (h.dims.empty()) throw InputError(path + ": no DimSize line in the MetaImage header");
  if (h.elementSize == 0) throw InputError(path + ": no ElementType line in the MetaImage header");
  if (h.dims.size() > 3) throw InputError(path + ": has more than 3 dimensions; only 3-D volumes are supported");
  if (h.ndims != 0 && size_t(h.ndims) != h.dims.size()) {
    lineNo = h.ndimsLine;
    fail("NDims = " + std::to_string(h.ndims) + " but DimSize (line " + std::to_string(h.dimSizeLine) + ") has " +
         std::to_string(h.dims.size()) + " values; they must agree");
  }
  if (!h.spacing.empty() && h.spacing.size() != h.dims.size()) {
    lineNo = h.spacingLine;
    fail("the voxel spacing has " + std::to_string(h.spacing.size()) + " values but DimSize has " +
         std::to_string(h.dims.size()) + "; give one spacing per dimension");
  }
  return h;
}

void precheckMeta(const std::string& path, const MetaHeader& h) {
  int64_t count = 1;
  for (int64_t d : h.dims) {
    if (d > (int64_t(1) << 40) / count) throw InputError(path + ": DimSize is absurdly large");
    count *= d;
  }
  const int64_t need = count * static_cast<int64_t>(h.elementSize);
  std::error_code ec;
  int64_t have = 0;
  std::string dataPath;
  if (h.dataFile == "LOCAL") {
    have = static_cast<int64_t>(fs::file_size(path, ec)) - h.headerBytes;
    dataPath = path;
  } else if (std::any_of(h.dataFile.begin(), h.dataFile.end(),
                         [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; })) {
    throw InputError(path + ": ElementDataFile holds control characters; not a file name (damaged header?)");
  } else if (h.dataFile.rfind("LIST", 0) == 0 || h.dataFile.find('%') != std::string::npos) {
    // Multi-file layouts: VTK's MetaIO formats a '%' pattern with vsnprintf, so a damaged header
    // becomes a format string (found by fuzzing: a crash inside vtkmetaio). Not supported.
    throw InputError(path + ": ElementDataFile '" + h.dataFile.substr(0, 60) +
                     "' is a multi-file layout (LIST or a numbered pattern), which is not supported; "
                     "combine the slices into one .mha or .nrrd file");
  } else {
    fs::path p = fs::path(h.dataFile);
    if (p.is_relative()) p = fs::path(path).parent_path() / p;
    dataPath = p.string();
    if (!fs::exists(p, ec))
      throw InputError(path + ": its data file '" + dataPath + "' (ElementDataFile) does not exist");
    have = static_cast<int64_t>(fs::file_size(p, ec));
  }
  // The data must be what the header says: zlib/gzip data when CompressedData is True, and
  // exactly sizes x type bytes when it is not.
  if (!dataPath.empty() && have >= 2) {
    std::ifstream d(dataPath, std::ios::binary);
    d.seekg(h.dataFile == "LOCAL" ? h.headerBytes : 0);
    unsigned char b[2] = {0, 0};
    d.read(reinterpret_cast<char*>(b), 2);
    const bool zlib = (b[0] & 0x0f) == 8 && ((unsigned(b[0]) << 8) | b[1]) % 31 == 0;
    const bool gzip = b[0] == 0x1f && b[1] == 0x8b;
    if (h.compressed && !zlib && !gzip)
      throw InputError(path + ": CompressedData = True but the data (" + dataPath +
                       ") do not start with a zlib or gzip header; set CompressedData = False if they are raw");
  }
  if (!h.compressed && have > need) {
    std::ostringstream m;
    m << path << ": the header announces " << count << " voxels of " << h.elementSize << " bytes (" << need
      << " bytes) but the data hold " << have << " bytes; DimSize or ElementType is wrong";
    throw InputError(m.str());
  }
  if (h.compressed) have = maxInflatedSize(have);
  if (need > have) {
    std::ostringstream m;
    m << path << ": the header announces " << count << " voxels of " << h.elementSize
      << " bytes (" << need << " bytes) but " << (h.compressed ? "the compressed data cannot hold that much"
                                                            : "the data holds only " + std::to_string(have) + " bytes")
      << "; the file is truncated or the header is wrong";
    throw InputError(m.str());
  }
}

void rasToLps(Mat3& d, Vec3& o) {
  for (int c = 0; c < 3; ++c) {
    d[0][c] = -d[0][c];
    d[1][c] = -d[1][c];
  }
  o[0] = -o[0];
  o[1] = -o[1];
}

// Run a VTK reader on `path`; its error events become an InputError naming the file.
template <class Reader>
void runVtkReader(Reader* reader, const std::string& path) {
  vtkNew<VtkErrorCatcher> catcher;
  catcher->attach(reader);
  catcher->attach(reader->GetExecutive());
  reader->SetFileName(path.c_str());
  reader->Update();
  catcher->throwIfAny(path);
}

} // namespace

RawVolume readNifti(const std::string& path) {
  requireReadableFile(path);
  precheckNifti(path);
  vtkNew<vtkNIFTIImageReader> reader;
  runVtkReader(reader.Get(), path);
  RawVolume raw = rawFromImage(reader->GetOutput(), path);
  vtkMatrix4x4* m = reader->GetQFormMatrix();
  if (!m) m = reader->GetSFormMatrix();
  Mat3 d = identity3();
  Vec3 o{0, 0, 0};
  if (m) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) d[r][c] = m->GetElement(r, c);
      o[r] = m->GetElement(r, 3);
    }
  }
  rasToLps(d, o);
  raw.grid.direction = d;
  raw.grid.origin = o;
  raw.grid.validate(path);
  const double slope = reader->GetRescaleSlope(), inter = reader->GetRescaleIntercept();
  if (slope != 0.0 && std::isfinite(slope) && (slope != 1.0 || inter != 0.0)) {
    // Apply the calibration: v = stored * slope + intercept, kept as float64.
    RawVolume scaled;
    scaled.grid = raw.grid;
    scaled.type = VoxelType::Float64;
    const int64_t n = raw.grid.voxelCount();
    scaled.bytes.resize(static_cast<size_t>(n) * 8);
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
      const double v = raw.valueAsDouble(i) * slope + inter;
      std::memcpy(scaled.bytes.data() + i * 8, &v, 8);
    }
    return scaled;
  }
  return raw;
}

RawVolume readMetaImage(const std::string& path) {
  requireReadableFile(path);
  const MetaHeader h = scanMetaHeader(path);
  precheckMeta(path, h);
  vtkNew<vtkMetaImageReader> reader;
  runVtkReader(reader.Get(), path);
  RawVolume raw = rawFromImage(reader->GetOutput(), path);
  double o[3];
  reader->GetOutput()->GetOrigin(o);
  raw.grid.origin = {o[0], o[1], o[2]};
  if (h.hasTransform)
    for (int a = 0; a < 3; ++a)
      for (int r = 0; r < 3; ++r) raw.grid.direction[r][a] = h.transform[3 * a + r];
  raw.grid.validate(path);
  return raw;
}

RawVolume readVti(const std::string& path) {
  requireReadableFile(path);
  precheckVtkXml(path); // block headers and extents against the file, before VTK allocates
  vtkNew<vtkXMLImageDataReader> reader;
  runVtkReader(reader.Get(), path);
  vtkImageData* img = reader->GetOutput();
  RawVolume raw = rawFromImage(img, path);
  // VTK image extents may start anywhere: the origin is that of voxel (extent min).
  int ext[6];
  img->GetExtent(ext);
  double p[3];
  const double ijk[3] = {double(ext[0]), double(ext[2]), double(ext[4])};
  img->TransformContinuousIndexToPhysicalPoint(ijk, p);
  raw.grid.origin = {p[0], p[1], p[2]};
  vtkMatrix3x3* dm = img->GetDirectionMatrix();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) raw.grid.direction[r][c] = dm->GetElement(r, c);
  raw.grid.validate(path);
  return raw;
}

void writeNifti(const std::string& path, const RawVolume& v) {
  checkWritable(v, path);
  auto img = imageFromRaw(v, false);
  img->SetOrigin(0, 0, 0);
  Mat3 d = v.grid.direction;
  Vec3 o = v.grid.origin;
  rasToLps(d, o); // the same flip maps LPS to RAS
  vtkNew<vtkMatrix4x4> m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m->SetElement(r, c, d[r][c]);
    m->SetElement(r, 3, o[r]);
  }
  vtkNew<vtkNIFTIImageWriter> w;
  w->SetInputData(img);
  if (det(d) > 0) w->SetQFormMatrix(m);
  else w->SetSFormMatrix(m);
  // VTK picks compression from the file name: keep the real extension on the temp file.
  runVtkWriter(w.Get(), path, fileExtension(path) == ".nii.gz" ? ".nii.gz" : ".nii");
}

void writeMetaImage(const std::string& path, const RawVolume& v) {
  checkWritable(v, path);
  if (!v.grid.isAxisAligned())
    throw InputError(path + ": VTK's MetaImage writer cannot store rotated or flipped axes; "
                            "write .nrrd or .nii.gz instead");
  const std::string ext = fileExtension(path);
  auto img = imageFromRaw(v, false);
  vtkNew<vtkMetaImageWriter> w;
  w->SetInputData(img);
  w->SetCompression(true);
  if (ext == ".mhd") {
    // Header + a sibling compressed data file. VTK writes both, with their final names, into a
    // fresh hidden folder beside the target; then both are renamed into place.
    fs::path target(path);
    fs::path dir = target.parent_path();
    if (dir.empty()) dir = ".";
    const std::string rawName = target.stem().string() + ".zraw";
    AtomicOutputFile probe(path); // checks the folder is writable; removes its temp on exit
    probe.closeStream();
    const fs::path work = fs::path(probe.tempPath() + ".d");
    std::error_code ec;
    fs::create_directory(work, ec);
    if (ec) throw InputError(path + ": cannot create a temporary folder (" + ec.message() + ")");
    struct Cleanup {
      fs::path p;
      ~Cleanup() { std::error_code e; fs::remove_all(p, e); }
    } cleanup{work};
    vtkNew<VtkErrorCatcher> catcher;
    catcher->attach(w);
    const std::string hdrTemp = (work / target.filename()).string();
    const std::string rawTemp = (work / rawName).string();
    w->SetFileName(hdrTemp.c_str());
    w->SetRAWFileName(rawTemp.c_str());
    w->Write();
    if (!catcher->errors.empty() || w->GetErrorCode() != 0)
      throw InputError(path + ": writing failed" +
                       (catcher->errors.empty() ? std::string() : ": " + catcher->errors.front()));
    fs::rename(rawTemp, dir / rawName, ec);
    if (!ec) fs::rename(hdrTemp, target, ec);
    if (ec) throw InputError(path + ": cannot move the written files into place (" + ec.message() + ")");
    return;
  }
  runVtkWriter(w.Get(), path, ".mha");
}

void writeVti(const std::string& path, const RawVolume& v) {
  checkWritable(v, path);
  auto img = imageFromRaw(v, true);
  vtkNew<vtkXMLImageDataWriter> w;
  w->SetInputData(img);
  w->SetDataModeToAppended();
  w->SetCompressorTypeToZLib();
  runVtkWriter(w.Get(), path);
}

} // namespace tetflow
