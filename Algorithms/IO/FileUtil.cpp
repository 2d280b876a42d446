#include "FileUtil.h"

#include "Algorithms/Core/Progress.h"

#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <limits>
#include <sstream>
#include <system_error>
#include <unistd.h>

#include "../Core/Errors.h"

namespace fs = std::filesystem;

namespace tetflow {

std::vector<char> readFilePrefix(const std::string& path, size_t maxBytes, int64_t* fileSize) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path + ": file not found");
  if (fs::is_directory(path, ec)) throw InputError(path + ": is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open for reading (" + std::strerror(errno) + ")");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(path + ": cannot determine the file size");
  in.seekg(0, std::ios::beg);
  if (fileSize) *fileSize = static_cast<int64_t>(size);
  const size_t n = std::min(static_cast<size_t>(size), maxBytes);
  std::vector<char> bytes(n);
  if (n > 0 && !in.read(bytes.data(), static_cast<std::streamsize>(n)))
    throw InputError(path + ": read error (" + std::strerror(errno) + ")");
  return bytes;
}

std::vector<char> readFileBytes(const std::string& path) {
  return readFilePrefix(path, std::numeric_limits<size_t>::max(), nullptr);
}

std::string fileExtension(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  auto dot = name.rfind('.');
  if (dot == std::string::npos) return "";
  std::string ext = name.substr(dot);
  if (ext == ".gz" && dot > 0) {
    auto dot2 = name.rfind('.', dot - 1);
    if (dot2 != std::string::npos) ext = name.substr(dot2);
  }
  return ext;
}

bool looksGzipped(const char* data, size_t n) {
  return n >= 2 && static_cast<unsigned char>(data[0]) == 0x1f &&
         static_cast<unsigned char>(data[1]) == 0x8b;
}

int64_t maxInflatedSize(int64_t compressedBytes) {
  // deflate's maximum compression ratio is 1032:1; add slack for headers.
  return compressedBytes * 1032 + 1024;
}

std::vector<char> gunzip(const char* data, size_t n, int64_t expected, const std::string& what, bool exact) {
  if (expected >= 0 && expected > maxInflatedSize(static_cast<int64_t>(n))) {
    std::ostringstream m;
    m << what << ": the header announces " << expected << " bytes of data but " << n
      << " compressed bytes cannot hold that much; the header or the file is wrong";
    throw InputError(m.str());
  }
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw ProcessingError(what + ": zlib init failed");
  std::vector<char> out;
  if (expected >= 0) out.resize(static_cast<size_t>(expected));
  else out.resize(std::max<size_t>(n * 4, 4096));
  size_t produced = 0;
  size_t consumed = 0;
  int ret = Z_OK;
  while (true) {
    if (produced == out.size()) {
      if (expected >= 0) break; // got everything we need
      out.resize(out.size() * 2);
    }
    const size_t inChunk = std::min<size_t>(n - consumed, 1u << 30);
    const size_t outChunk = std::min<size_t>(out.size() - produced, 1u << 30);
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + consumed));
    zs.avail_in = static_cast<uInt>(inChunk);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
    zs.avail_out = static_cast<uInt>(outChunk);
    ret = inflate(&zs, Z_NO_FLUSH);
    consumed += inChunk - zs.avail_in;
    produced += outChunk - zs.avail_out;
    if (ret == Z_STREAM_END) {
      // Concatenated gzip members: continue with the next one if input remains.
      if (consumed < n && looksGzipped(data + consumed, n - consumed)) {
        inflateReset(&zs);
        continue;
      }
      break;
    }
    if (ret == Z_BUF_ERROR && zs.avail_in == 0 && consumed == n) break; // input ran out
    if (ret != Z_OK && ret != Z_BUF_ERROR) {
      inflateEnd(&zs);
      throw InputError(what + ": compressed data is corrupt (" +
                       (zs.msg ? std::string(zs.msg) : std::string("zlib error")) + ")");
    }
  }
  if (exact && expected >= 0 && produced == out.size() && ret != Z_STREAM_END) {
    // Everything announced arrived: one more byte means the data are larger than the header says.
    char extra = 0;
    zs.next_out = reinterpret_cast<Bytef*>(&extra);
    zs.avail_out = 1;
    int more = Z_OK;
    do {
      const size_t inChunk = std::min<size_t>(n - consumed, 1u << 30);
      zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + consumed));
      zs.avail_in = static_cast<uInt>(inChunk);
      more = inflate(&zs, Z_NO_FLUSH);
      consumed += inChunk - zs.avail_in;
    } while (more == Z_OK && zs.avail_out == 1 && consumed < n);
    if (zs.avail_out == 0) {
      inflateEnd(&zs);
      std::ostringstream m;
      m << what << ": the compressed data hold more than the " << expected
        << " bytes the header announces; the sizes or the type in the header are wrong";
      throw InputError(m.str());
    }
  }
  inflateEnd(&zs);
  if (expected >= 0 && static_cast<int64_t>(produced) < expected) {
    std::ostringstream m;
    m << what << ": compressed data is truncated: it holds " << produced << " bytes, expected "
      << expected;
    throw InputError(m.str());
  }
  out.resize(produced);
  return out;
}

std::string gzipCompress(const char* data, size_t n, int level) {
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw ProcessingError("zlib deflate init failed");
  std::string out;
  out.resize(deflateBound(&zs, static_cast<uLong>(std::min<size_t>(n, 1u << 30))) + 64);
  size_t produced = 0, consumed = 0;
  int ret = Z_OK;
  while (ret != Z_STREAM_END) {
    const size_t inChunk = std::min<size_t>(n - consumed, 1u << 30);
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + consumed));
    zs.avail_in = static_cast<uInt>(inChunk);
    if (out.size() - produced < 65536) out.resize(out.size() * 2 + 65536);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
    const size_t outChunk = std::min<size_t>(out.size() - produced, 1u << 30);
    zs.avail_out = static_cast<uInt>(outChunk);
    const bool last = consumed + inChunk == n;
    ret = deflate(&zs, last ? Z_FINISH : Z_NO_FLUSH);
    consumed += inChunk - zs.avail_in;
    produced += outChunk - zs.avail_out;
    if (ret == Z_STREAM_ERROR) {
      deflateEnd(&zs);
      throw ProcessingError("zlib deflate failed");
    }
  }
  deflateEnd(&zs);
  out.resize(produced);
  return out;
}

namespace {
std::atomic<unsigned> g_tempCounter{0};
}

AtomicOutputFile::AtomicOutputFile(const std::string& target, bool binary) : target_(target) {
  if (target.empty()) throw InputError("output file name is empty");
  fs::path p(target);
  fs::path dir = p.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(target + ": cannot write: folder '" + dir.string() +
                     "' does not exist (create it first)");
  if (fs::is_directory(p, ec)) throw InputError(target + ": cannot write: it is a folder");
  std::ostringstream t;
  t << (dir / p.filename()).parent_path().string() << "/." << p.filename().string() << ".tmp-"
    << ::getpid() << "-" << g_tempCounter.fetch_add(1);
  temp_ = t.str();
  out_.open(temp_, binary ? std::ios::binary | std::ios::out | std::ios::trunc
                          : std::ios::out | std::ios::trunc);
  if (!out_)
    throw InputError(target + ": cannot write to folder '" + dir.string() + "' (" +
                     std::strerror(errno) + ")");
}

AtomicOutputFile::~AtomicOutputFile() {
  if (!committed_) {
    if (out_.is_open()) out_.close();
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

void AtomicOutputFile::closeStream() {
  if (out_.is_open()) out_.close();
}

void AtomicOutputFile::commit() {
  if (out_.is_open()) {
    out_.flush();
    const bool ok = static_cast<bool>(out_);
    out_.close();
    if (!ok || out_.fail())
      throw InputError(target_ + ": write failed (disk full or I/O error); nothing was written");
  }
  // A cancelled run keeps the old file: the temp file goes (destructor), the target stays.
  if (Progress* p = currentProgress()) p->checkCancel();
  std::error_code ec;
  fs::rename(temp_, target_, ec);
  if (ec) throw InputError(target_ + ": cannot replace the file (" + ec.message() + ")");
  committed_ = true;
}

void writeNpyFloat64Header(std::ostream& s, const std::vector<size_t>& shape) {
  std::ostringstream h;
  h << "{'descr': '<f8', 'fortran_order': False, 'shape': (";
  for (size_t i = 0; i < shape.size(); ++i) h << shape[i] << (shape.size() == 1 || i + 1 < shape.size() ? ", " : "");
  h << "), }";
  std::string header = h.str();
  const size_t total = 10 + header.size() + 1; // magic(6) version(2) length(2) header '\n'
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  const uint16_t len = uint16_t(header.size());
  s.write("\x93NUMPY\x01\x00", 8);
  const char lenBytes[2] = {char(len & 0xff), char(len >> 8)};
  s.write(lenBytes, 2);
  s.write(header.data(), std::streamsize(header.size()));
}

} // namespace tetflow
