// Internal to Algorithms/IO: see MeshFileText.h.
#include "MeshFileText.h"

#include <algorithm>
#include <charconv>
#include <filesystem>

#include "../Core/Errors.h"
#include "../Core/Progress.h"

namespace fs = std::filesystem;

namespace tetflow::mesh_io {

void appendDouble(std::string& out, double v) {
  char buf[40];
  auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 17);
  out.append(buf, r.ptr);
}

void appendInt(std::string& out, int64_t v) {
  char buf[24];
  auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

void TextSink::flush() {
  if (!buf_.empty()) s_.write(buf_.data(), static_cast<std::streamsize>(buf_.size()));
  buf_.clear();
}

void TextSink::maybeFlush() {
  if (buf_.size() <= (1u << 20)) return;
  flush();
  // Every MiB written: a cancelled run stops here (the atomic output file is then discarded).
  if (const Progress* p = currentProgress()) p->checkCancel();
}

void requireExistingFile(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path + ": file not found");
  if (fs::is_directory(path, ec)) throw InputError(path + ": is a folder, not a mesh file");
}

void orientPositively(TetMesh& m) {
  for (size_t t = 0; t < m.tets.size(); ++t)
    if (m.tetVolume(t) < 0.0) std::swap(m.tets[t][0], m.tets[t][1]);
}

size_t boundedReserve(int64_t announced, size_t fileBytes, size_t minBytesPerItem) {
  return static_cast<size_t>(std::min<int64_t>(announced,
                                               static_cast<int64_t>(fileBytes / minBytesPerItem)));
}

} // namespace tetflow::mesh_io
