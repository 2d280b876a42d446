#include "TerminalProgress.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>

namespace tetflow {

namespace {
constexpr auto kRedraw = std::chrono::milliseconds(200);
// A module gets its live line once it has run this long: quicker ones would only flash.
constexpr double kShowAfterSeconds = 0.25;
} // namespace

bool TerminalProgress::usable(int fd) {
  if (!::isatty(fd)) return false;
  const char* term = std::getenv("TERM");
  return term && *term && std::strcmp(term, "dumb") != 0;
}

TerminalProgress::TerminalProgress(const RunProgress& board, int fd) : board_(board), fd_(fd) {
  thread_ = std::thread([this] { loop(); });
}

TerminalProgress::~TerminalProgress() { stop(); }

void TerminalProgress::put(const std::string& s) const {
  size_t done = 0;
  while (done < s.size()) {
    const ssize_t n = ::write(fd_, s.data() + done, s.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return; // the terminal went away: nothing to be done about it
    done += size_t(n);
  }
}

std::string TerminalProgress::eraseText() const {
  if (shown_ == 0) return "";
  // Up to the first live line, column 0, clear to the end of the screen.
  return "\x1b[" + std::to_string(shown_) + "A\r\x1b[J";
}

std::string TerminalProgress::drawText() {
  struct winsize ws{};
  size_t cols = 80, rows = 24;
  if (::ioctl(fd_, TIOCGWINSZ, &ws) == 0) {
    if (ws.ws_col > 0) cols = ws.ws_col;
    if (ws.ws_row > 0) rows = ws.ws_row;
  }
  // One column short of the width, so that no line wraps (a wrapped line would break the count
  // the next erase moves up by).
  const size_t width = cols > 1 ? cols - 1 : 1;
  auto running = board_.running();
  std::erase_if(running, [](const RunProgress::Entry& e) { return e.seconds < kShowAfterSeconds; });
  const size_t room = rows > 3 ? rows - 2 : 1;
  std::string out;
  shown_ = 0;
  for (size_t i = 0; i < running.size(); ++i) {
    if (shown_ + 1 == room && running.size() > room) {
      out += "      ... and " + std::to_string(running.size() - i) + " more running\n";
      ++shown_;
      break;
    }
    out += liveProgressLine(running[i], width) + "\n";
    ++shown_;
  }
  return out;
}

void TerminalProgress::above(const std::function<void()>& print) {
  const std::lock_guard<std::mutex> lock(mutex_);
  put(eraseText());
  shown_ = 0;
  print();
  std::cout.flush();
  std::cerr.flush();
  if (!stopping_) put(drawText());
}

void TerminalProgress::stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  const std::lock_guard<std::mutex> lock(mutex_);
  put(eraseText());
  shown_ = 0;
}

void TerminalProgress::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, kRedraw, [this] { return stopping_; });
    if (stopping_) break;
    const auto t0 = std::chrono::steady_clock::now();
    std::string text = eraseText(); // before drawText(), which changes shown_
    text += drawText();
    put(text);
    redrawNs_ += std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
    ++redraws_;
  }
}

} // namespace tetflow
