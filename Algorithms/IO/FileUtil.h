#pragma once
// File helpers shared by all readers and writers.
//  - readFileBytes: whole file into memory, InputError naming the file when it cannot be read.
//  - AtomicOutputFile: writes go to a temporary file beside the target, which replaces the target
//    only on commit() (rename); an uncommitted temporary is removed. No half-written outputs.
//  - gzip helpers on zlib, with a size limit so a lying header cannot make us allocate wildly.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace tetflow {

std::vector<char> readFileBytes(const std::string& path);
// The first min(file size, maxBytes) bytes of `path`, and the whole file's size in *fileSize.
std::vector<char> readFilePrefix(const std::string& path, size_t maxBytes, int64_t* fileSize);

// Lower-case extension including compound ".gz" ones: "a/b.NII.gz" -> ".nii.gz", "x.nrrd" -> ".nrrd".
std::string fileExtension(const std::string& path);

// True when `data` starts with the gzip magic bytes 1f 8b.
bool looksGzipped(const char* data, size_t n);

// Decompress a gzip (or zlib) stream. Exactly `expected` bytes are required when expected >= 0:
// fewer is a truncated-data InputError; more is ignored, or with `exact` an InputError too
// (inflating stops one byte past `expected` either way). `what` names the file in messages.
std::vector<char> gunzip(const char* data, size_t n, int64_t expected, const std::string& what, bool exact = false);
// Upper bound of what deflate can expand `compressedBytes` into (used to refuse absurd headers).
int64_t maxInflatedSize(int64_t compressedBytes);
std::string gzipCompress(const char* data, size_t n, int level = 6);

class AtomicOutputFile {
public:
  // Opens a temporary file in the target's folder. Throws InputError naming `target` when the
  // folder does not exist or is not writable.
  explicit AtomicOutputFile(const std::string& target, bool binary = true);
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

  std::ofstream& stream() { return out_; }
  const std::string& tempPath() const { return temp_; }
  const std::string& target() const { return target_; }
  // Flush, close, check for write errors, rename over the target. Throws InputError on failure.
  void commit();
  // For writers that produce the temp file themselves (e.g. VTK): close our stream first.
  void closeStream();

private:
  std::string target_;
  std::string temp_;
  std::ofstream out_;
  bool committed_ = false;
};

// NumPy format 1.0 header of a little-endian float64, C-order array of `shape` (padded so the
// data starts at a multiple of 64 bytes); the caller writes the values after it.
void writeNpyFloat64Header(std::ostream& out, const std::vector<size_t>& shape);

} // namespace tetflow
