#pragma once
// Shared test helpers: a fresh temporary folder per test, removed afterwards, and small utilities.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace tetflow::test {

// Under AddressSanitizer (the sanitizer half of CI) the heaviest random-case loops run every other
// case: memory errors show on a few cases, and the Release half runs them all. sanitizerCases(n):
// how many of n cases to run (n, or half of it rounded up); sanitizerSkips(i): whether case i is
// left out (the odd ones).
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kUnderSanitizers = true;
#else
inline constexpr bool kUnderSanitizers = false;
#endif
inline constexpr int sanitizerCases(int n) { return kUnderSanitizers ? (n + 1) / 2 : n; }
inline constexpr bool sanitizerSkips(int i) { return kUnderSanitizers && i % 2 == 1; }

// A unique empty folder for one test; removed (with its contents) when the object dies.
class TempDir {
public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = info ? std::string(info->test_suite_name()) + "_" + info->name() : "t";
    for (char& c : name)
      if (c == '/') c = '_';
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("tetflow_" + name + "_" + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

private:
  std::filesystem::path path_;
};

// The largest magnitude of a vector's entries (0 for an empty one).
inline double maxAbs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// The `nth` number (0: the first) given for "key" in a JSON text such as `tetflow run --report`
// writes; NaN when there is none.
inline double reportNumber(const std::string& json, const std::string& key, size_t nth = 0) {
  size_t at = 0;
  for (size_t i = 0; i <= nth; ++i) {
    at = json.find("\"" + key + "\": ", at);
    if (at == std::string::npos) return std::nan("");
    at += key.size() + 4;
  }
  return std::stod(json.substr(at));
}

// A file's whole content ("" when it cannot be read).
inline std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A text file's lines, without their line ends (none when it cannot be read).
inline std::vector<std::string> readTextLines(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

inline void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// A shell command's exit status (-1 when it did not exit) and what it wrote to stdout (add
// " 2>&1" to the command for stderr too).
struct ShellResult {
  int code = -1;
  std::string out;
};
inline ShellResult runShell(const std::string& command) {
  ShellResult r;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// Expect `stmt` to throw ExceptionType whose what() contains every given fragment.
#define EXPECT_THROW_MSG(stmt, ExceptionType, ...)                                  \
  do {                                                                              \
    try {                                                                           \
      stmt;                                                                         \
      ADD_FAILURE() << "expected " #ExceptionType " from: " #stmt;                  \
    } catch (const ExceptionType& e_) {                                             \
      for (const std::string& frag_ : std::initializer_list<std::string>{__VA_ARGS__})                                 \
        EXPECT_NE(std::string(e_.what()).find(frag_), std::string::npos)            \
            << "message '" << e_.what() << "' lacks '" << frag_ << "'";             \
    }                                                                               \
  } while (0)

} // namespace tetflow::test
