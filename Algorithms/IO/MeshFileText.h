#pragma once
// Internal to Algorithms/IO: what the mesh formats' readers and writers share (MeshIO.cpp,
// VtkMeshIO.cpp, GmshIO.cpp, TetGenIO.cpp). Nothing outside Algorithms/IO includes this file.
//  - appendDouble / appendInt: locale-free number text (doubles with 17 digits: exact round trip);
//  - TextSink: buffered text into an AtomicOutputFile's stream, polling cancellation every MiB;
//  - TokenLines: the whitespace-separated tokens of a text file's non-empty lines ('#' comments);
//  - requireExistingFile, orientPositively (readers hand out positively oriented tets),
//    boundedReserve (a lying header cannot make a reader allocate wildly).
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "../Core/Errors.h"
#include "../Core/TetMesh.h"
#include "FileUtil.h"

namespace tetflow::mesh_io {

// %.17g without locale influence: round-trips every double exactly.
void appendDouble(std::string& out, double v);
void appendInt(std::string& out, int64_t v);

// Buffered text output into an AtomicOutputFile stream.
class TextSink {
public:
  explicit TextSink(std::ofstream& s) : s_(s) { buf_.reserve(1 << 20); }
  ~TextSink() { flush(); }
  TextSink& operator<<(std::string_view t) {
    buf_.append(t);
    maybeFlush();
    return *this;
  }
  TextSink& operator<<(char c) {
    buf_.push_back(c);
    maybeFlush();
    return *this;
  }
  TextSink& num(int64_t v) {
    appendInt(buf_, v);
    return *this;
  }
  TextSink& real(double v) {
    appendDouble(buf_, v);
    return *this;
  }
  // Raw bytes (binary sections of a file that is otherwise text).
  TextSink& bytes(const void* p, size_t n) {
    buf_.append(static_cast<const char*>(p), n);
    maybeFlush();
    return *this;
  }
  void flush();

private:
  void maybeFlush();
  std::ofstream& s_;
  std::string buf_;
};

// InputError naming `path` when it does not exist or is a folder.
void requireExistingFile(const std::string& path);

// Swaps the first two corners of every tet with negative volume.
void orientPositively(TetMesh& m);

// Bound reservations by the file size so a lying header cannot make us allocate wildly.
size_t boundedReserve(int64_t announced, size_t fileBytes, size_t minBytesPerItem);

// Whitespace-separated tokens of the non-empty lines of a text file; '#' starts a comment.
class TokenLines {
public:
  explicit TokenLines(const std::string& path) : path_(path), data_(readFileBytes(path)) {}

  // Next line with at least one token; false at the end of the file.
  bool next() {
    tokens_.clear();
    while (pos_ < data_.size()) {
      size_t end = pos_;
      while (end < data_.size() && data_[end] != '\n') ++end;
      ++line_;
      std::string_view l(data_.data() + pos_, end - pos_);
      pos_ = end + 1;
      const size_t hash = l.find('#');
      if (hash != std::string_view::npos) l = l.substr(0, hash);
      size_t i = 0;
      while (i < l.size()) {
        while (i < l.size() && isSpace(l[i])) ++i;
        size_t j = i;
        while (j < l.size() && !isSpace(l[j])) ++j;
        if (j > i) tokens_.push_back(l.substr(i, j - i));
        i = j;
      }
      if (!tokens_.empty()) return true;
    }
    return false;
  }
  size_t size() const { return tokens_.size(); }
  size_t line() const { return line_; }
  size_t bytes() const { return data_.size(); }
  const std::string& path() const { return path_; }

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path_ + ", line " + std::to_string(line_) + ": " + problem);
  }

  int64_t integer(size_t k, const char* what) const {
    std::string_view t = token(k, what);
    if (!t.empty() && t[0] == '+') t.remove_prefix(1);
    int64_t v = 0;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size())
      fail(std::string("expected an integer ") + what + ", found '" + std::string(token(k, what)) +
           "'");
    return v;
  }
  double real(size_t k, const char* what) const {
    std::string_view t = token(k, what);
    if (!t.empty() && t[0] == '+') t.remove_prefix(1);
    double v = 0;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(v))
      fail(std::string("expected a finite number ") + what + ", found '" +
           std::string(token(k, what)) + "'");
    return v;
  }

private:
  static bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
  std::string_view token(size_t k, const char* what) const {
    if (k >= tokens_.size()) fail(std::string("missing ") + what);
    return tokens_[k];
  }

  std::string path_;
  std::vector<char> data_;
  size_t pos_ = 0;
  size_t line_ = 0;
  std::vector<std::string_view> tokens_;
};


} // namespace tetflow::mesh_io
