#include "VtkCancellableWriters.h"

#include <algorithm>
#include <memory>
#include <ostream>
#include <streambuf>

#include <vtkObjectFactory.h>

#include "Algorithms/Core/Progress.h"

namespace tetflow {

namespace {

bool moduleCancelled() {
  const Progress* p = currentProgress();
  return p && p->cancelRequested();
}

// Forwards to another stream buffer; large writes go on in pieces with a cancellation check
// before each, and the first piece after a cancellation fails (so the stream sets badbit).
class CancellableBuf : public std::streambuf {
public:
  explicit CancellableBuf(std::streambuf* target) : target_(target) {}

protected:
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    constexpr std::streamsize kPiece = std::streamsize(4) << 20;
    std::streamsize done = 0;
    while (done < n) {
      if (moduleCancelled()) return done;
      const std::streamsize piece = std::min(kPiece, n - done);
      const std::streamsize wrote = target_->sputn(s + done, piece);
      done += wrote;
      if (wrote < piece) break;
    }
    return done;
  }
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    return target_->sputc(traits_type::to_char_type(c));
  }
  int sync() override { return target_->pubsync(); }
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override {
    return target_->pubseekoff(off, dir, which);
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override {
    return target_->pubseekpos(pos, which);
  }

private:
  std::streambuf* target_;
};

// What OpenVTKFile hands to VTK, which deletes it in CloseVTKFile: owns the file stream VTK
// opened and writes through a CancellableBuf over it.
class CancellableStream : public std::ostream {
public:
  explicit CancellableStream(std::ostream* file)
      : std::ostream(nullptr), file_(file), buf_(file->rdbuf()) {
    rdbuf(&buf_);
  }

private:
  std::unique_ptr<std::ostream> file_;
  CancellableBuf buf_;
};

} // namespace

vtkStandardNewMacro(CancellableLegacyVtkWriter);

ostream* CancellableLegacyVtkWriter::OpenVTKFile() {
  ostream* file = vtkUnstructuredGridWriter::OpenVTKFile();
  if (!file) return nullptr;
  return new CancellableStream(file);
}

} // namespace tetflow
