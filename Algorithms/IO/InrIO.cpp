// INRIA image (.inr / .inr.gz) reader and writer, written from the format description in InrIO.h.
//
// Reader contract (in addition to InrIO.h):
//  - The header is the text from "#INRIMAGE-4#{" up to and including the line "##}"; the voxels
//    start right after that line (writers pad the header to a multiple of 256 bytes; a header of
//    another length is accepted). Headers longer than 1 MiB are refused.
//  - Required: XDIM, YDIM, TYPE, PIXSIZE. Defaults: ZDIM 1, VDIM 1 (any other VDIM is refused),
//    VX/VY/VZ 1, TX/TY/TZ 0, CPU little endian when absent. SCALE and unknown keys are ignored.
//  - A file starting with the gzip magic 1f 8b is inflated, whatever its name.
//  - The announced voxel data must be present: fewer bytes is a truncated-data InputError, checked
//    against the file size (or, compressed, against the most the compressed bytes can inflate to)
//    before any voxel memory is allocated. An uncompressed file with more bytes than announced is
//    refused as well (the header does not match the data); in a compressed file, bytes after the
//    announced data are not inflated and therefore not checked.
//  - The INR header has no axis directions: the grid is axis aligned, origin (TX,TY,TZ).
// Writer: little endian (CPU=decm), header padded to 256 bytes, TX/TY/TZ carry the origin. A grid
// with rotated or flipped axes cannot be stored and is refused (write NRRD instead).
#include "InrIO.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>
#include <system_error>
#include <vector>

#include "../Core/Errors.h"
#include "FileUtil.h"
#include "HeaderText.h"

namespace fs = std::filesystem;

namespace tetflow {
namespace {

using namespace headertext;

constexpr size_t kBlock = 256;
constexpr size_t kMaxHeader = size_t(1) << 20;
constexpr std::string_view kMagic = "#INRIMAGE-4#{";

// Length of the header (through the newline ending the "##}" line), or 0 when `text` does not
// contain the whole header yet.
size_t headerLength(std::string_view text, size_t from = 0) {
  while (true) {
    const size_t p = text.find("\n##}", from);
    if (p == std::string_view::npos) return 0;
    const size_t nl = text.find('\n', p + 4);
    if (nl == std::string_view::npos) return 0;
    if (trim(text.substr(p + 4, nl - p - 4)).empty()) return nl + 1;
    from = p + 1;
  }
}

void checkMagic(std::string_view text, const std::string& path) {
  const size_t n = std::min(text.size(), kMagic.size());
  if (text.substr(0, n) != kMagic.substr(0, n) || text.size() < kMagic.size())
    throw InputError(path + ": not an INR file: it must start with '#INRIMAGE-4#{'");
}

struct InrInfo {
  GridGeometry grid;
  VoxelType type = VoxelType::UInt8;
  bool bigEndian = false;
  int64_t count = 0;
  int64_t byteCount = 0;
};

[[noreturn]] void failAt(const std::string& path, int line, const std::string& msg) {
  throw InputError(path + ":" + std::to_string(line) + ": " + msg);
}

InrInfo parseHeader(std::string_view text, const std::string& path) {
  auto failLine = [&](int line, const std::string& msg) { failAt(path, line, msg); };
  struct Entry {
    std::string value;
    int line = 0;
  };
  std::optional<Entry> xdim, ydim, zdim, vdim, type, pixsize, cpu, vx, vy, vz, tx, ty, tz;
  int lineNo = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = trim(text.substr(pos, nl - pos));
    pos = nl + 1;
    ++lineNo;
    if (lineNo == 1) continue; // the magic, checked already
    if (line == "##}") break;
    if (line.empty() || line.front() == '#') continue; // padding, comments, #GEOMETRY...
    const size_t eq = line.find('=');
    if (eq == std::string_view::npos) failLine(lineNo, "expected KEY=VALUE, got " + shown(line));
    std::string key(trim(line.substr(0, eq)));
    for (char& c : key) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    Entry e{std::string(trim(line.substr(eq + 1))), lineNo};
    if (key == "XDIM")
      xdim = e;
    else if (key == "YDIM")
      ydim = e;
    else if (key == "ZDIM")
      zdim = e;
    else if (key == "VDIM")
      vdim = e;
    else if (key == "TYPE")
      type = e;
    else if (key == "PIXSIZE")
      pixsize = e;
    else if (key == "CPU")
      cpu = e;
    else if (key == "VX")
      vx = e;
    else if (key == "VY")
      vy = e;
    else if (key == "VZ")
      vz = e;
    else if (key == "TX")
      tx = e;
    else if (key == "TY")
      ty = e;
    else if (key == "TZ")
      tz = e;
    // SCALE and anything else: not needed.
  }

  InrInfo info;
  auto dimOf = [&](const std::optional<Entry>& e, const char* name, bool required) -> int64_t {
    if (!e) {
      if (required) throw InputError(path + ": the INR header has no " + name + " (image size)");
      return 1;
    }
    int64_t v = 0;
    if (!parseInt64(e->value, v) || v < 1)
      failLine(e->line, std::string(name) + " " + shown(e->value) + " must be a whole number >= 1");
    return v;
  };
  info.grid.dims = {dimOf(xdim, "XDIM", true), dimOf(ydim, "YDIM", true),
                    dimOf(zdim, "ZDIM", false)};
  const int64_t v = dimOf(vdim, "VDIM", false);
  if (v != 1)
    failLine(vdim->line, "VDIM=" + std::to_string(v) +
                             ": vector images are not supported; TetFlow reads scalar volumes "
                             "(VDIM=1)");

  if (!type) throw InputError(path + ": the INR header has no TYPE");
  if (!pixsize) throw InputError(path + ": the INR header has no PIXSIZE");
  const std::string t = canonical(type->value);
  if (t != "unsigned fixed" && t != "signed fixed" && t != "float")
    failLine(type->line, "unknown TYPE " + shown(type->value) +
                             " (expected 'unsigned fixed', 'signed fixed' or 'float')");
  const std::string ps = canonical(pixsize->value);
  int64_t bits = 0;
  {
    const size_t sp = ps.find(' ');
    if (sp == std::string::npos || ps.substr(sp + 1) != "bits" ||
        !parseInt64(ps.substr(0, sp), bits))
      failLine(pixsize->line, "PIXSIZE " + shown(pixsize->value) + " is not like '8 bits'");
  }
  if (t == "float") {
    if (bits == 32)
      info.type = VoxelType::Float32;
    else if (bits == 64)
      info.type = VoxelType::Float64;
    else
      failLine(pixsize->line,
               "PIXSIZE " + shown(pixsize->value) + " does not match TYPE float (32 or 64 bits)");
  } else {
    const bool sgn = t == "signed fixed";
    switch (bits) {
      case 8: info.type = sgn ? VoxelType::Int8 : VoxelType::UInt8; break;
      case 16: info.type = sgn ? VoxelType::Int16 : VoxelType::UInt16; break;
      case 32: info.type = sgn ? VoxelType::Int32 : VoxelType::UInt32; break;
      case 64: info.type = sgn ? VoxelType::Int64 : VoxelType::UInt64; break;
      default:
        failLine(pixsize->line, "PIXSIZE " + shown(pixsize->value) + " does not match TYPE " +
                                    shown(type->value) + " (8, 16, 32 or 64 bits)");
    }
  }

  if (cpu) {
    const std::string c = canonical(cpu->value);
    if (c == "decm" || c == "alpha" || c == "pc")
      info.bigEndian = false;
    else if (c == "sun" || c == "sgi")
      info.bigEndian = true;
    else
      failLine(cpu->line, "unknown CPU " + shown(cpu->value) +
                              " (decm, alpha, pc = little endian; sun, sgi = big endian)");
  }

  auto real = [&](const std::optional<Entry>& e, const char* name, double def, bool positive) {
    if (!e) return def;
    double x = 0;
    if (!parseDouble(e->value, x) || !std::isfinite(x))
      failLine(e->line, std::string(name) + " " + shown(e->value) + " is not a number");
    if (positive && !(x > 0))
      failLine(e->line,
               std::string(name) + "=" + e->value + ": the voxel size must be a positive number");
    return x;
  };
  info.grid.spacing = {real(vx, "VX", 1.0, true), real(vy, "VY", 1.0, true),
                       real(vz, "VZ", 1.0, true)};
  info.grid.origin = {real(tx, "TX", 0.0, false), real(ty, "TY", 0.0, false),
                      real(tz, "TZ", 0.0, false)};

  const auto& d = info.grid.dims;
  int64_t count = 0, bytes = 0;
  if (__builtin_mul_overflow(d[0], d[1], &count) || __builtin_mul_overflow(count, d[2], &count) ||
      __builtin_mul_overflow(count, static_cast<int64_t>(voxelTypeSize(info.type)), &bytes))
    throw InputError(path + ": the image size " + std::to_string(d[0]) + " x " +
                     std::to_string(d[1]) + " x " + std::to_string(d[2]) + " overflows");
  info.count = count;
  info.byteCount = bytes;
  info.grid.validate(path);
  return info;
}

std::string inflatePrefix(const std::vector<char>& packed, size_t want, const std::string& path) {
  std::vector<char> v;
  try {
    v = gunzip(packed.data(), packed.size(), static_cast<int64_t>(want), path);
  } catch (const InputError&) {
    // The stream is shorter than `want` (or corrupt): inflating all of it is bounded by `want`,
    // and a corrupt stream fails again with its own message.
    v = gunzip(packed.data(), packed.size(), -1, path);
  }
  return std::string(v.begin(), v.end());
}

const char* inrType(VoxelType t) {
  switch (t) {
    case VoxelType::Int8:
    case VoxelType::Int16:
    case VoxelType::Int32:
    case VoxelType::Int64: return "signed fixed";
    case VoxelType::UInt8:
    case VoxelType::UInt16:
    case VoxelType::UInt32:
    case VoxelType::UInt64: return "unsigned fixed";
    case VoxelType::Float32:
    case VoxelType::Float64: return "float";
  }
  return "?";
}

std::string fmt(double x) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

} // namespace

RawVolume readInr(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path + ": file not found");
  if (fs::is_directory(path, ec)) throw InputError(path + ": is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open for reading (" + std::strerror(errno) + ")");
  const auto fsize = fs::file_size(path, ec);
  if (ec) throw InputError(path + ": cannot determine the file size (" + ec.message() + ")");
  const int64_t fileSize = static_cast<int64_t>(fsize);

  char head[2] = {0, 0};
  in.read(head, 2);
  const bool gz = in.gcount() == 2 && looksGzipped(head, 2);

  RawVolume raw;
  if (gz) {
    in.close();
    std::vector<char> packed = readFileBytes(path);
    std::string text = inflatePrefix(packed, 4096, path);
    checkMagic(text, path);
    size_t hlen = headerLength(text);
    if (hlen == 0 && text.size() >= 4096) {
      text = inflatePrefix(packed, kMaxHeader, path);
      hlen = headerLength(text);
    }
    if (hlen == 0)
      throw InputError(path + (text.size() >= kMaxHeader
                                   ? ": the INR header has no end line '##}' within 1 MiB"
                                   : ": the INR header is truncated (no end line '##}')"));
    const InrInfo info = parseHeader(std::string_view(text).substr(0, hlen), path);
    const int64_t total = static_cast<int64_t>(hlen) + info.byteCount;
    if (total > maxInflatedSize(static_cast<int64_t>(packed.size())))
      throw InputError(path + ": the header announces " + std::to_string(info.byteCount) +
                       " bytes of voxel data but the file's " + std::to_string(packed.size()) +
                       " compressed bytes cannot hold that much; the header is wrong or the "
                       "file is truncated");
    std::vector<char> all;
    try {
      all = gunzip(packed.data(), packed.size(), total, path);
    } catch (const InputError& e) {
      const std::string m = e.what();
      if (m.find("truncated") == std::string::npos) throw;
      throw InputError(m + " (" + std::to_string(hlen) + " header bytes + " +
                       std::to_string(info.byteCount) + " bytes of voxel data)");
    }
    std::vector<char>().swap(packed);
    raw.grid = info.grid;
    raw.type = info.type;
    raw.bytes.assign(all.begin() + static_cast<std::ptrdiff_t>(hlen), all.end());
    if (voxelTypeSize(info.type) > 1 && info.bigEndian == hostIsLittleEndian())
      byteSwapInPlace(raw.bytes.data(), static_cast<size_t>(info.count), voxelTypeSize(info.type));
    return raw;
  }

  // Uncompressed: read the header block by block, then the voxels straight into place.
  std::string text(head, static_cast<size_t>(in.gcount()));
  size_t hlen = 0;
  std::vector<char> block(4 * kBlock);
  size_t searched = 0; // text before this offset holds no complete end line
  while (true) {
    if (text.size() >= kMagic.size()) checkMagic(text, path);
    hlen = headerLength(text, searched);
    if (hlen != 0) break;
    // An end line may straddle the next block: search again from a little before the end.
    searched = text.size() > 64 ? text.size() - 64 : 0;
    if (text.size() >= kMaxHeader)
      throw InputError(path + ": the INR header has no end line '##}' within 1 MiB");
    in.read(block.data(), static_cast<std::streamsize>(block.size()));
    const std::streamsize got = in.gcount();
    if (got <= 0) {
      checkMagic(text, path);
      throw InputError(path + ": the INR header is truncated (no end line '##}')");
    }
    text.append(block.data(), static_cast<size_t>(got));
  }
  const InrInfo info = parseHeader(std::string_view(text).substr(0, hlen), path);
  const int64_t available = fileSize - static_cast<int64_t>(hlen);
  if (available < info.byteCount)
    throw InputError(path + ": voxel data are truncated: the file holds " +
                     std::to_string(available) + " bytes after the header, expected " +
                     std::to_string(info.byteCount) + " (" + std::to_string(info.count) + " " +
                     voxelTypeName(info.type) + " values)");
  if (available > info.byteCount)
    throw InputError(path + ": the header does not match the data: the file holds " +
                     std::to_string(available) + " bytes after the header, expected " +
                     std::to_string(info.byteCount) + " (" + std::to_string(info.count) + " " +
                     voxelTypeName(info.type) + " values); check XDIM/YDIM/ZDIM/PIXSIZE");
  raw.grid = info.grid;
  raw.type = info.type;
  raw.bytes.resize(static_cast<size_t>(info.byteCount));
  in.clear();
  in.seekg(static_cast<std::streamoff>(hlen), std::ios::beg);
  if (info.byteCount > 0 && !in.read(reinterpret_cast<char*>(raw.bytes.data()),
                                     static_cast<std::streamsize>(info.byteCount)))
    throw InputError(path + ": read error (the file changed while reading or an I/O error)");
  if (voxelTypeSize(info.type) > 1 && info.bigEndian == hostIsLittleEndian())
    byteSwapInPlace(raw.bytes.data(), static_cast<size_t>(info.count), voxelTypeSize(info.type));
  return raw;
}

void writeInr(const std::string& path, const RawVolume& v) {
  v.grid.validate(path + ": cannot write");
  const size_t size = voxelTypeSize(v.type);
  if (size == 0) throw InputError(path + ": cannot write: unknown voxel type");
  const size_t expected = static_cast<size_t>(v.grid.voxelCount()) * size;
  if (v.bytes.size() != expected)
    throw InputError(path + ": cannot write: the volume holds " + std::to_string(v.bytes.size()) +
                     " bytes of voxel data, expected " + std::to_string(expected));
  if (!v.grid.isAxisAligned())
    throw InputError(path + ": cannot write: the INR format stores no axis directions and this "
                            "volume has rotated or flipped axes; save it as .nrrd instead");

  std::ostringstream h;
  h << kMagic << "\n"
    << "XDIM=" << v.grid.dims[0] << "\n"
    << "YDIM=" << v.grid.dims[1] << "\n"
    << "ZDIM=" << v.grid.dims[2] << "\n"
    << "VDIM=1\n"
    << "TYPE=" << inrType(v.type) << "\n"
    << "PIXSIZE=" << size * 8 << " bits\n"
    << "SCALE=2**0\n"
    << "CPU=decm\n"
    << "VX=" << fmt(v.grid.spacing[0]) << "\n"
    << "VY=" << fmt(v.grid.spacing[1]) << "\n"
    << "VZ=" << fmt(v.grid.spacing[2]) << "\n"
    << "TX=" << fmt(v.grid.origin[0]) << "\n"
    << "TY=" << fmt(v.grid.origin[1]) << "\n"
    << "TZ=" << fmt(v.grid.origin[2]) << "\n";
  std::string header = h.str();
  const std::string end = "##}\n";
  const size_t used = header.size() + end.size();
  header.append((used + kBlock - 1) / kBlock * kBlock - used, '\n');
  header += end;

  AtomicOutputFile out(path);
  const bool little = hostIsLittleEndian();
  std::string extension = fileExtension(path);
  const bool gz = extension.size() >= 3 && extension.compare(extension.size() - 3, 3, ".gz") == 0;
  if (gz) {
    std::string all;
    all.reserve(header.size() + v.bytes.size());
    all += header;
    all.append(reinterpret_cast<const char*>(v.bytes.data()), v.bytes.size());
    if (!little && size > 1)
      byteSwapInPlace(reinterpret_cast<unsigned char*>(all.data() + header.size()),
                      static_cast<size_t>(v.grid.voxelCount()), size);
    const std::string packed = gzipCompress(all.data(), all.size());
    out.stream().write(packed.data(), static_cast<std::streamsize>(packed.size()));
  } else {
    out.stream().write(header.data(), static_cast<std::streamsize>(header.size()));
    if (!little && size > 1) {
      std::vector<unsigned char> swapped = v.bytes;
      byteSwapInPlace(swapped.data(), static_cast<size_t>(v.grid.voxelCount()), size);
      out.stream().write(reinterpret_cast<const char*>(swapped.data()),
                         static_cast<std::streamsize>(swapped.size()));
    } else {
      out.stream().write(reinterpret_cast<const char*>(v.bytes.data()),
                         static_cast<std::streamsize>(v.bytes.size()));
    }
  }
  out.commit();
}

} // namespace tetflow
