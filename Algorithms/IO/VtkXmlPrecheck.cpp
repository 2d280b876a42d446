#include "VtkXmlPrecheck.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "Algorithms/Core/Errors.h"

namespace tetflow {

namespace {

using Attributes = std::map<std::string, std::string>;

struct Tag {
  std::string name;
  Attributes attrs;
  size_t begin = 0; // offset of '<'
  size_t end = 0;   // offset just past '>'
};

int base64Value(unsigned char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

class Precheck {
public:
  // Reads the file up to its appended data (the XML part; all of it when there is none), so the
  // check takes memory for the markup, not for the data.
  explicit Precheck(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    if (!in_) throw InputError(path + ": cannot open for reading"); // the readers checked it exists
    in_.seekg(0, std::ios::end);
    fileSize_ = uint64_t(std::max<std::streamoff>(0, in_.tellg()));
    in_.seekg(0);
    std::vector<char> chunk(1 << 20);
    const char* tag = "<AppendedData";
    while (in_.read(chunk.data(), std::streamsize(chunk.size())) || in_.gcount() > 0) {
      const size_t from = bytes_.size() > 16 ? bytes_.size() - 16 : 0;
      bytes_.insert(bytes_.end(), chunk.begin(), chunk.begin() + in_.gcount());
      const size_t at = find(tag, from);
      if (at != std::string::npos && find("_", at) != std::string::npos) break;
    }
    in_.clear();
  }

  void run() {
    const size_t appendedTag = find("<AppendedData", 0);
    const size_t xmlEnd = appendedTag == std::string::npos ? bytes_.size() : appendedTag;
    if (appendedTag != std::string::npos) {
      const std::optional<Tag> t = tagAt(appendedTag, bytes_.size());
      if (!t) return; // left to VTK
      appendedBase64_ = attr(t->attrs, "encoding") == "base64";
      const size_t underscore = find("_", t->end);
      if (underscore == std::string::npos) return;
      appendedStart_ = underscore + 1;
    }
    size_t pos = 0;
    while ((pos = find("<", pos)) != std::string::npos && pos < xmlEnd) {
      const std::optional<Tag> t = tagAt(pos, xmlEnd);
      if (!t) return; // damaged markup: VTK's parser reports it
      visit(*t);
      pos = t->end;
    }
  }

private:
  size_t find(const char* what, size_t from) const {
    const size_t n = std::strlen(what);
    if (from >= bytes_.size()) return std::string::npos;
    const auto it = std::search(bytes_.begin() + std::ptrdiff_t(from), bytes_.end(), what, what + n);
    return it == bytes_.end() ? std::string::npos : size_t(it - bytes_.begin());
  }

  // The tag starting at `at` ('<'), its name and attributes; nullopt if it is not well formed
  // before `limit`.
  std::optional<Tag> tagAt(size_t at, size_t limit) const {
    Tag t;
    t.begin = at;
    size_t i = at + 1;
    auto ch = [&](size_t k) { return static_cast<unsigned char>(bytes_[k]); };
    while (i < limit && (std::isalnum(ch(i)) || ch(i) == '_' || ch(i) == '?' || ch(i) == '!' || ch(i) == '/'))
      t.name.push_back(bytes_[i++]);
    if (t.name.rfind("!--", 0) == 0) { // comment: skip to its end
      const size_t e = find("-->", at);
      if (e == std::string::npos || e >= limit) return std::nullopt;
      t.end = e + 3;
      return t;
    }
    while (i < limit) {
      while (i < limit && std::isspace(ch(i))) ++i;
      if (i >= limit) return std::nullopt;
      if (bytes_[i] == '>') {
        t.end = i + 1;
        return t;
      }
      if (bytes_[i] == '/' || bytes_[i] == '?') {
        ++i;
        continue;
      }
      std::string key;
      while (i < limit && !std::isspace(ch(i)) && bytes_[i] != '=' && bytes_[i] != '>') key.push_back(bytes_[i++]);
      while (i < limit && std::isspace(ch(i))) ++i;
      if (i >= limit || bytes_[i] != '=') return std::nullopt;
      ++i;
      while (i < limit && std::isspace(ch(i))) ++i;
      if (i >= limit || (bytes_[i] != '"' && bytes_[i] != '\'')) return std::nullopt;
      const char quote = bytes_[i++];
      std::string value;
      while (i < limit && bytes_[i] != quote) value.push_back(bytes_[i++]);
      if (i >= limit) return std::nullopt;
      ++i;
      t.attrs[key] = value;
    }
    return std::nullopt;
  }

  static std::string attr(const Attributes& a, const char* key) {
    const auto it = a.find(key);
    return it == a.end() ? std::string() : it->second;
  }

  [[noreturn]] void fail(const Tag& t, const std::string& what) const {
    std::ostringstream m;
    m << path_ << ": <" << t.name;
    const std::string name = attr(t.attrs, "Name");
    if (!name.empty()) m << " Name=\"" << name << "\"";
    m << "> " << what << " (damaged file?)";
    throw InputError(m.str());
  }

  // A non-negative integer attribute, or nullopt when absent or not a number (left to VTK).
  std::optional<uint64_t> count(const Tag& t, const char* key) const {
    const std::string v = attr(t.attrs, key);
    if (v.empty()) return std::nullopt;
    char* e = nullptr;
    errno = 0;
    const long double x = std::strtold(v.c_str(), &e);
    if (e == v.c_str()) return std::nullopt;
    if (x < 0) fail(t, std::string("has a negative ") + key + " (" + v + ")");
    if (errno == ERANGE || x > 1.8e19L) fail(t, std::string("announces ") + key + " " + v + ", more than any file holds");
    return static_cast<uint64_t>(x);
  }

  // What the file could hold once decompressed, in values of at least one byte.
  double capacity() const {
    const double n = double(fileSize_);
    return compressed_ ? kVtkXmlMaxExpansion * n + 65536.0 : n;
  }

  void requireFits(const Tag& t, const char* what, double values) const {
    if (values > capacity()) {
      std::ostringstream m;
      m << "announces " << what << " " << static_cast<long double>(values) << " values but the file of "
        << fileSize_ << " bytes holds at most " << static_cast<long double>(capacity());
      fail(t, m.str());
    }
  }

  void visit(const Tag& t) {
    if (t.name == "VTKFile") {
      headerWord_ = attr(t.attrs, "header_type") == "UInt64" ? 8 : 4;
      bigEndian_ = attr(t.attrs, "byte_order") == "BigEndian";
      compressed_ = !attr(t.attrs, "compressor").empty();
    } else if (t.name == "Piece") {
      if (auto p = count(t, "NumberOfPoints")) requireFits(t, "NumberOfPoints x 3 =", 3.0 * double(*p));
      if (auto c = count(t, "NumberOfCells")) requireFits(t, "NumberOfCells", double(*c));
      if (auto e = extentPoints(t)) requireFits(t, "an Extent of", *e);
    } else if (t.name == "ImageData") {
      if (auto e = extentPoints(t, "WholeExtent")) requireFits(t, "a WholeExtent of", *e);
    } else if (t.name == "DataArray") {
      if (auto c = count(t, "NumberOfComponents")) requireFits(t, "NumberOfComponents", double(*c));
      const std::string format = attr(t.attrs, "format");
      if (format == "appended") {
        const auto off = count(t, "offset");
        if (!off || appendedStart_ == std::string::npos) return;
        if (*off >= fileSize_ - std::min<uint64_t>(fileSize_, appendedStart_))
          fail(t, "has offset " + std::to_string(*off) + " past the end of the appended data");
        checkArray(t, appendedStart_ + size_t(*off), appendedBase64_, size_t(fileSize_));
      } else if (format == "binary") {
        size_t start = t.end;
        while (start < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[start]))) ++start;
        size_t stop = find("<", start);
        if (stop == std::string::npos) stop = bytes_.size();
        checkArray(t, start, true, stop);
      }
    }
  }

  // Points of an "x0 x1 y0 y1 z0 z1" extent attribute; nullopt when absent or not six integers.
  std::optional<double> extentPoints(const Tag& t, const char* key = "Extent") const {
    std::istringstream in(attr(t.attrs, key));
    long long e[6];
    for (auto& v : e)
      if (!(in >> v)) return std::nullopt;
    double n = 1.0;
    for (int a = 0; a < 3; ++a) {
      if (e[2 * a + 1] < e[2 * a]) return std::nullopt; // empty: VTK's call
      n *= double(e[2 * a + 1]) - double(e[2 * a]) + 1.0;
    }
    return n;
  }

  // Bytes [start, min(stop, start + n)) of the file: from the markup read, or read from the file.
  std::vector<char> slice(size_t start, size_t stop, size_t n) const {
    if (start >= stop) return {};
    const size_t end = std::min(stop, start + n);
    if (end <= bytes_.size())
      return std::vector<char>(bytes_.begin() + std::ptrdiff_t(start), bytes_.begin() + std::ptrdiff_t(end));
    std::vector<char> out(end - start);
    in_.clear();
    in_.seekg(std::streamoff(start));
    in_.read(out.data(), std::streamsize(out.size()));
    out.resize(size_t(std::max<std::streamsize>(0, in_.gcount())));
    return out;
  }

  // Decodes `count` header words of the array data at `start` (raw bytes or base64 text ending at
  // `stop`); nullopt when the data end first.
  std::optional<std::vector<uint64_t>> words(size_t start, bool base64, size_t stop, size_t count) const {
    const size_t need = count * headerWord_;
    std::vector<unsigned char> raw;
    raw.reserve(need);
    // Base64 needs 4 characters per 3 bytes (and a little room for line breaks).
    const std::vector<char> text = slice(start, stop, base64 ? need / 3 * 4 + 1024 : need);
    if (!base64) {
      if (text.size() < need) return std::nullopt;
      raw.assign(text.begin(), text.begin() + std::ptrdiff_t(need));
    } else {
      uint32_t acc = 0;
      int bits = 0;
      for (size_t i = 0; i < text.size() && raw.size() < need; ++i) {
        const unsigned char c = static_cast<unsigned char>(text[i]);
        if (c == '=') break;
        const int v = base64Value(c);
        if (v < 0) {
          if (std::isspace(c)) continue;
          return std::nullopt;
        }
        acc = (acc << 6) | uint32_t(v);
        bits += 6;
        if (bits >= 8) {
          bits -= 8;
          raw.push_back(static_cast<unsigned char>((acc >> bits) & 0xff));
        }
      }
      if (raw.size() < need) return std::nullopt;
    }
    std::vector<uint64_t> w(count, 0);
    for (size_t k = 0; k < count; ++k)
      for (size_t b = 0; b < headerWord_; ++b) {
        const size_t byte = bigEndian_ ? b : headerWord_ - 1 - b;
        w[k] = (w[k] << 8) | raw[k * headerWord_ + byte];
      }
    return w;
  }

  void checkArray(const Tag& t, size_t start, bool base64, size_t stop) const {
    // Bytes that follow the array's start (decoded size for base64).
    const double avail = base64 ? double(stop - std::min(stop, start)) * 0.75 : double(stop - std::min(stop, start));
    if (!compressed_) {
      const auto h = words(start, base64, stop, 1);
      if (!h) fail(t, "ends inside its size header");
      if (double((*h)[0]) > avail - double(headerWord_)) {
        std::ostringstream m;
        m << "announces " << (*h)[0] << " bytes of data but only " << static_cast<long long>(avail) - int64_t(headerWord_)
          << " follow";
        fail(t, m.str());
      }
      return;
    }
    const auto first = words(start, base64, stop, 1);
    if (!first) fail(t, "ends inside its compression header");
    const uint64_t blocks = (*first)[0];
    if (double(blocks) * double(headerWord_) > avail) {
      std::ostringstream m;
      m << "announces " << blocks << " compressed blocks, more than the " << static_cast<long long>(avail)
        << " bytes that follow could hold";
      fail(t, m.str());
    }
    const auto h = words(start, base64, stop, 3 + size_t(blocks));
    if (!h) fail(t, "ends inside its compression header of " + std::to_string(blocks) + " blocks");
    const uint64_t blockSize = (*h)[1], lastSize = (*h)[2];
    const double left = avail - double(3 + blocks) * double(headerWord_);
    double sum = 0.0;
    for (uint64_t b = 0; b < blocks; ++b) {
      const uint64_t c = (*h)[3 + size_t(b)];
      sum += double(c);
      if (double(c) > left || sum > left) {
        std::ostringstream m;
        m << "announces a compressed block " << b << " of " << c << " bytes but only "
          << static_cast<long long>(std::max(0.0, left)) << " bytes follow its header";
        fail(t, m.str());
      }
    }
    if (blocks == 0) return;
    if (lastSize > blockSize) {
      std::ostringstream m;
      m << "announces a last block of " << lastSize << " bytes, larger than its block size " << blockSize;
      fail(t, m.str());
    }
    const double uncompressed = double(blocks - 1) * double(blockSize) + double(lastSize ? lastSize : blockSize);
    const double bound = kVtkXmlMaxExpansion * std::max(sum, 1.0) + 65536.0;
    if (double(blockSize) > bound || uncompressed > bound) {
      std::ostringstream m;
      m << "announces " << static_cast<long double>(uncompressed) << " uncompressed bytes (blocks of " << blockSize
        << ") from " << static_cast<long long>(sum) << " compressed bytes; no compressor expands that much";
      fail(t, m.str());
    }
  }

  std::string path_;
  mutable std::ifstream in_;
  uint64_t fileSize_ = 0;
  std::vector<char> bytes_; // the XML part (the whole file when nothing is appended)
  size_t headerWord_ = 4;
  bool bigEndian_ = false;
  bool compressed_ = false;
  size_t appendedStart_ = std::string::npos;
  bool appendedBase64_ = false;
};

} // namespace

void precheckVtkXml(const std::string& path) {
  Precheck(path).run();
}

} // namespace tetflow
