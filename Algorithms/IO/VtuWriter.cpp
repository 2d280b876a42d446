// .vtu writer (see VtuWriter.h), written from the VTK file-format documentation and checked
// against files of VTK 9.1's vtkXMLUnstructuredGridWriter (MeshIOVtu tests).
//
// Compressed appended array: UInt64 words [number of blocks, block size, size of the last block
// when it is partial (0 when it is full or there is no data), compressed size of each block],
// then the zlib streams of the blocks back to back. An array's offset attribute counts bytes from
// just past the '_' that opens the appended data.
//
// Streaming: the compressed sizes are known only after compression, yet both the block header
// and the offsets of later arrays precede the data. So the block header is written as a
// placeholder and rewritten once the array's blocks are out, and every DataArray tag ends in a
// run of spaces that finally receives its offset and range (as VTK pads its own offsets).
// Nothing larger than one chunk of blocks is held in memory.
#include "VtuWriter.h"

#include <omp.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <new>
#include <stdexcept>
#include <map>
#include <string>
#include <vector>

#include "../Core/Errors.h"
#include "../Core/Progress.h"
#include "FileUtil.h"
#include "XmlText.h"

namespace tetflow {

namespace {

// VTK's default block size: with it the appended data are byte for byte what VTK's writer makes.
constexpr size_t kBlockBytes = 32768;
// Level 1, as with VTK's writer before: there level 5 (VTK's default) took 1.3 s instead of 0.5 s
// on the default net's 840 k tets, for a file 2 % smaller; every zlib reader reads either.
constexpr int kZlibLevel = 1;
// Blocks that level 1 shrinks to more than this share of their size are written as stored
// (level 0) zlib blocks: the quality fields of a mesh (doubles with every bit in use)
// shrink by about 16 % at 47 MB/s per core, where storing them runs at memory speed. The file
// stays a zlib-compressed .vtu that every reader reads.
constexpr double kStoreRatio = 0.8;
// ... judged group by group: the first block of every group of this many is compressed, and the
// group's other blocks are stored when it kept more than kStoreRatio of its size. A mesh's quality fields
// vary along the array (untouched lattice tets repeat a few values, cut ones do not).
constexpr uint64_t kGroupBlocks = 8;
constexpr unsigned char kVtkTetra = 10; // VTK_TETRA
// ` RangeMin="…" RangeMax="…" offset="…"` with 24-character doubles and a 20-digit offset.
constexpr size_t kPatchWidth = 104;

enum class Type { Int32, Int64, Float64, UInt8 };

const char* typeName(Type t) {
  switch (t) {
  case Type::Int32: return "Int32";
  case Type::Int64: return "Int64";
  case Type::Float64: return "Float64";
  case Type::UInt8: return "UInt8";
  }
  return "";
}

size_t typeSize(Type t) {
  switch (t) {
  case Type::Int32: return 4;
  case Type::Int64: return 8;
  case Type::Float64: return 8;
  case Type::UInt8: return 1;
  }
  return 1;
}

// One DataArray. Its bytes are the mesh's own memory (`data`) when the mesh stores them as the
// file does, else `make(first, count, out)` writes values [first, first + count) into `out`.
struct Array {
  std::string name;
  Type type = Type::Float64;
  int components = 1;
  uint64_t values = 0; // tuples x components
  const void* data = nullptr;
  std::function<void(uint64_t first, size_t count, void* out)> make;
  bool range = false; // only for single-component arrays backed by `data`
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  uint64_t offset = 0;
  std::streamoff patchAt = 0;
};

struct Section {
  const char* tag;
  std::vector<Array> arrays;
};

// compress2 with the stream kept from block to block: after deflateReset zlib emits what a fresh
// deflateInit would (so the output is compress2's), without allocating its ~270 KB state for
// every 32 KiB block.
class Deflater {
public:
  explicit Deflater(int level) {
    if (deflateInit(&zs_, level) != Z_OK) throw std::bad_alloc();
  }
  ~Deflater() { deflateEnd(&zs_); }
  Deflater(const Deflater&) = delete;
  Deflater& operator=(const Deflater&) = delete;

  // Compressed size, or 0 on failure (a zlib stream is never empty).
  size_t compress(const unsigned char* in, size_t n, unsigned char* out, size_t capacity) {
    if (deflateReset(&zs_) != Z_OK) return 0;
    zs_.next_in = const_cast<Bytef*>(in);
    zs_.avail_in = static_cast<uInt>(n);
    zs_.next_out = out;
    zs_.avail_out = static_cast<uInt>(capacity);
    return deflate(&zs_, Z_FINISH) == Z_STREAM_END ? static_cast<size_t>(zs_.total_out) : 0;
  }

private:
  z_stream zs_{};
};

template <class T>
void appendNumber(std::string& out, T v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v); // shortest exact form for doubles
  out.append(buf, r.ptr);
}

class Writer {
public:
  Writer(const std::string& path, std::ofstream& out, const VtuWriteOptions& options,
         uint64_t totalBytes)
      : path_(path), out_(out), progress_(currentProgress()),
        chunk_(static_cast<size_t>(std::max(1, options.blocksPerChunk))), store_(options.storeIncompressible),
        bound_(compressBound(kBlockBytes)), total_(totalBytes) {
    const size_t threads = static_cast<size_t>(std::max(1, omp_get_max_threads()));
    for (size_t t = 0; t < threads; ++t) {
      deflaters_.push_back(std::make_unique<Deflater>(kZlibLevel));
      if (store_) storers_.push_back(std::make_unique<Deflater>(0));
    }
    scratch_.resize(threads * kBlockBytes);
    buffer_.resize(chunk_ * bound_);
    sizes_.resize(chunk_);
    lo_.resize(chunk_);
    hi_.resize(chunk_);
  }

  void write(const void* p, size_t n) {
    errno = 0;
    out_.write(static_cast<const char*>(p), static_cast<std::streamsize>(n));
    if (!out_) fail();
  }
  std::streamoff tell() {
    const std::streamoff at = out_.tellp();
    if (at < 0) fail();
    return at;
  }
  void seek(std::streamoff at) {
    errno = 0;
    out_.seekp(at);
    if (!out_) fail();
  }

  void writeArray(Array& a) {
    const size_t valueSize = typeSize(a.type);
    const uint64_t bytes = a.values * valueSize;
    const uint64_t blocks = (bytes + kBlockBytes - 1) / kBlockBytes;
    const uint64_t perBlock = kBlockBytes / valueSize; // every type size divides the block size
    std::vector<uint64_t> header(3 + blocks);
    header[0] = blocks;
    header[1] = kBlockBytes;
    header[2] = bytes % kBlockBytes;
    const std::streamoff headerAt = tell();
    write(header.data(), header.size() * sizeof(uint64_t));

    // Block k of the current chunk into its slot, by thread t's deflater or (store) storer.
    std::atomic<bool> failed{false};
    auto block = [&](uint64_t first, size_t k, size_t t, bool store) {
      const uint64_t v0 = (first + k) * perBlock;
      const size_t n = static_cast<size_t>(std::min(perBlock, a.values - v0));
      const unsigned char* src;
      if (a.data) {
        src = static_cast<const unsigned char*>(a.data) + v0 * valueSize;
      } else {
        unsigned char* own = scratch_.data() + t * kBlockBytes;
        a.make(v0, n, own);
        src = own;
      }
      Deflater& z = store ? *storers_[t] : *deflaters_[t];
      sizes_[k] = z.compress(src, n * valueSize, buffer_.data() + k * bound_, bound_);
      if (sizes_[k] == 0) failed.store(true, std::memory_order_relaxed);
      if (a.range) blockRange(a, v0, n, lo_[k], hi_[k]);
    };
    // Whether each group of kGroupBlocks blocks is stored, decided by its first block (compressed
    // first): fixed groups of the array, so the file is the same for any chunk size.
    std::vector<uint8_t> storeGroup((blocks + kGroupBlocks - 1) / kGroupBlocks, 0);
    auto leads = [](uint64_t b) { return b % kGroupBlocks == 0; };
    for (uint64_t first = 0; first < blocks; first += chunk_) {
      if (progress_) progress_->checkCancel();
      const int count = static_cast<int>(std::min<uint64_t>(chunk_, blocks - first));
#pragma omp parallel for schedule(dynamic, 1)
      for (int k = 0; k < count; ++k)
        if (leads(first + uint64_t(k))) block(first, size_t(k), size_t(omp_get_thread_num()), false);
      for (int k = 0; k < count; ++k) {
        const uint64_t b = first + uint64_t(k);
        if (!leads(b)) continue;
        const double raw = double(std::min<uint64_t>(kBlockBytes, bytes - b * kBlockBytes));
        storeGroup[b / kGroupBlocks] = store_ && double(sizes_[size_t(k)]) > kStoreRatio * raw;
      }
#pragma omp parallel for schedule(dynamic, 1)
      for (int k = 0; k < count; ++k) {
        const uint64_t b = first + uint64_t(k);
        if (!leads(b)) block(first, size_t(k), size_t(omp_get_thread_num()), storeGroup[b / kGroupBlocks] != 0);
      }
      if (failed.load()) throw ProcessingError(path_ + ": zlib compression failed");
      // Blocks were compressed into fixed slots; packed together they go out in one write.
      size_t packed = 0;
      for (size_t k = 0; k < static_cast<size_t>(count); ++k) {
        std::memmove(buffer_.data() + packed, buffer_.data() + k * bound_, sizes_[k]);
        packed += sizes_[k];
        header[3 + first + k] = sizes_[k];
        if (a.range) {
          a.lo = std::min(a.lo, lo_[k]);
          a.hi = std::max(a.hi, hi_[k]);
        }
      }
      write(buffer_.data(), packed);
      done_ += std::min<uint64_t>(bytes - first * kBlockBytes, uint64_t(count) * kBlockBytes);
      if (progress_ && total_ > 0) progress_->report(double(done_) / double(total_));
    }
    const std::streamoff end = tell();
    seek(headerAt);
    write(header.data(), header.size() * sizeof(uint64_t));
    seek(end);
  }

  [[noreturn]] void fail() const {
    const int e = errno;
    throw InputError(path_ + ": cannot write: " + (e ? std::strerror(e) : "I/O error") +
                     "; nothing was written");
  }

private:
  // NaN is left out, as in VTK's own ranges.
  static void blockRange(const Array& a, uint64_t v0, size_t n, double& lo, double& hi) {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    auto scan = [&](const auto* v) {
      for (size_t i = 0; i < n; ++i) {
        const double x = static_cast<double>(v[v0 + i]);
        if (x < lo) lo = x;
        if (x > hi) hi = x;
      }
    };
    if (a.type == Type::Int32) scan(static_cast<const int32_t*>(a.data));
    else scan(static_cast<const double*>(a.data));
  }

  const std::string& path_;
  std::ofstream& out_;
  Progress* progress_;
  const size_t chunk_;
  const bool store_; // storeIncompressible
  const size_t bound_; // compressed size of a block at worst
  const uint64_t total_;
  uint64_t done_ = 0;
  std::vector<std::unique_ptr<Deflater>> deflaters_; // one per thread
  std::vector<std::unique_ptr<Deflater>> storers_;   // one per thread, level 0 (none when not storing)
  std::vector<unsigned char> scratch_;               // one block per thread, for made arrays
  std::vector<unsigned char> buffer_;                // one slot of bound_ bytes per block
  std::vector<size_t> sizes_;
  std::vector<double> lo_, hi_;
};

// VTK's offsets are where each cell ends: 4, 8, 12, ...
template <class T>
void makeOffsets(uint64_t first, size_t count, void* out) {
  T* o = static_cast<T*>(out);
  for (size_t i = 0; i < count; ++i) o[i] = static_cast<T>(4 * (first + i + 1));
}

Array fieldArray(const std::string& name, const Field& f) {
  Array a;
  a.name = name;
  a.type = Type::Float64;
  a.components = f.components;
  a.values = f.values.size();
  a.data = f.values.data();
  a.range = f.components == 1;
  return a;
}

std::vector<Section> layout(const TetMesh& m, bool wideCells) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double));
  static_assert(sizeof(TetMesh::Tet) == 4 * sizeof(int32_t));
  const uint64_t nt = m.numTets();
  std::vector<Section> s{{"PointData", {}}, {"CellData", {}}, {"Points", {}}, {"Cells", {}}};
  for (const auto& [name, f] : m.pointFields) s[0].arrays.push_back(fieldArray(name, f));

  Array material;
  material.name = "material";
  material.type = Type::Int32;
  material.values = nt;
  material.data = m.materials.data();
  material.range = true;
  s[1].arrays.push_back(material);
  for (const auto& [name, f] : m.cellFields) s[1].arrays.push_back(fieldArray(name, f));

  Array points;
  points.name = "Points";
  points.components = 3;
  points.values = 3 * uint64_t(m.numPoints());
  points.data = m.points.data();
  s[2].arrays.push_back(points);

  Array conn, offsets, types;
  conn.name = "connectivity";
  offsets.name = "offsets";
  types.name = "types";
  conn.values = 4 * nt;
  offsets.values = types.values = nt;
  if (wideCells) {
    conn.type = offsets.type = Type::Int64;
    conn.make = [&m](uint64_t first, size_t count, void* out) {
      int64_t* o = static_cast<int64_t*>(out);
      for (uint64_t i = first; i < first + count; ++i) *o++ = m.tets[i / 4][i % 4];
    };
    offsets.make = makeOffsets<int64_t>;
  } else {
    conn.type = offsets.type = Type::Int32;
    conn.data = m.tets.data(); // stored as the file wants them: 4 int32 per tet
    offsets.make = makeOffsets<int32_t>;
  }
  types.type = Type::UInt8;
  types.make = [](uint64_t, size_t count, void* out) { std::memset(out, kVtkTetra, count); };
  s[3].arrays = {conn, offsets, types};
  return s;
}

// The deferred attributes of a DataArray tag, padded to kPatchWidth.
std::string patchText(const Array& a) {
  std::string t;
  if (a.range && std::isfinite(a.lo) && std::isfinite(a.hi)) {
    t += " RangeMin=\"";
    appendNumber(t, a.lo);
    t += "\" RangeMax=\"";
    appendNumber(t, a.hi);
    t += '"';
  }
  t += " offset=\"";
  appendNumber(t, a.offset);
  t += '"';
  if (t.size() > kPatchWidth) throw std::logic_error("VtuWriter: kPatchWidth too small");
  t.resize(kPatchWidth, ' ');
  return t;
}

// The materials' names and conductivities as field data, in ASCII (materialFieldArrays, VtuWriter.h).
std::string materialFieldData(const TetMesh& m) {
  const MaterialFieldArrays f = materialFieldArrays(m);
  if (f.names.empty() && f.conductivities.empty()) return {};
  std::string x = "    <FieldData>\n";
  for (const auto& [name, label] : f.names) {
    x += "      <DataArray type=\"Int32\" Name=\"" + xmlEscape(name) + "\" NumberOfTuples=\"2\" format=\"ascii\">\n        ";
    appendNumber(x, label);
    x += " 3\n      </DataArray>\n";
  }
  if (!f.conductivities.empty()) {
    x += "      <DataArray type=\"Float64\" Name=\"" + std::string(kMaterialConductivitiesArray) +
         "\" NumberOfComponents=\"2\" NumberOfTuples=\"";
    appendNumber(x, f.conductivities.size());
    x += "\" format=\"ascii\">\n       ";
    for (const auto& [label, c] : f.conductivities) {
      x += ' ';
      appendNumber(x, double(label));
      x += ' ';
      appendNumber(x, c);
    }
    x += "\n      </DataArray>\n";
  }
  return x + "    </FieldData>\n";
}

} // namespace

MaterialFieldArrays materialFieldArrays(const TetMesh& m) {
  MaterialFieldArrays f;
  std::map<std::string, int> uses;
  for (const auto& [L, name] : m.materialNames) ++uses[name];
  for (const auto& [L, name] : m.materialNames)
    if (!name.empty()) f.names.push_back({uses[name] > 1 ? name + " (label " + std::to_string(L) + ")" : name, L});
  f.conductivities.assign(m.materialConductivities.begin(), m.materialConductivities.end());
  return f;
}

void writeVtuFile(const std::string& path, const TetMesh& m, const VtuWriteOptions& options) {
  const uint64_t nt = m.numTets();
  const bool wide =
      options.int64Cells || 4 * nt > uint64_t(std::numeric_limits<int32_t>::max());
  std::vector<Section> sections = layout(m, wide);

  std::string xml = "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"";
  xml += std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian";
  xml += "\" header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">\n"
         "  <UnstructuredGrid>\n";
  xml += materialFieldData(m);
  xml += "    <Piece NumberOfPoints=\"";
  appendNumber(xml, uint64_t(m.numPoints()));
  xml += "\" NumberOfCells=\"";
  appendNumber(xml, nt);
  xml += "\">\n";
  uint64_t totalBytes = 0;
  for (Section& s : sections) {
    xml += "      <" + std::string(s.tag) + ">\n";
    for (Array& a : s.arrays) {
      xml += "        <DataArray type=\"" + std::string(typeName(a.type)) + "\" Name=\"" +
             xmlEscape(a.name) + '"';
      if (a.components > 1) {
        xml += " NumberOfComponents=\"";
        appendNumber(xml, a.components);
        xml += '"';
      }
      xml += " format=\"appended\"";
      a.patchAt = static_cast<std::streamoff>(xml.size());
      xml.append(kPatchWidth, ' ');
      xml += "/>\n";
      totalBytes += a.values * typeSize(a.type);
    }
    xml += "      </" + std::string(s.tag) + ">\n";
  }
  xml += "    </Piece>\n"
         "  </UnstructuredGrid>\n"
         "  <AppendedData encoding=\"raw\">\n"
         "   _";

  AtomicOutputFile file(path);
  Writer w(path, file.stream(), options, totalBytes);
  if (const Progress* p = currentProgress()) p->checkCancel();
  w.write(xml.data(), xml.size());
  const std::streamoff dataStart = w.tell();
  for (Section& s : sections)
    for (Array& a : s.arrays) {
      a.offset = static_cast<uint64_t>(w.tell() - dataStart);
      w.writeArray(a);
    }
  const std::string tail = "\n  </AppendedData>\n</VTKFile>\n";
  w.write(tail.data(), tail.size());
  for (const Section& s : sections)
    for (const Array& a : s.arrays) {
      w.seek(a.patchAt);
      const std::string t = patchText(a);
      w.write(t.data(), t.size());
    }
  file.commit();
}

} // namespace tetflow
