#pragma once
// VTK's legacy unstructured-grid writer, made to stop within a fraction of a second when the
// running module is cancelled (docs/reliability.md, cancellation). VTK's writers have no
// cancellation of their own, but the legacy writer checks its stream after every array. This
// subclass makes the output fail once currentProgress() (Core/Progress.h) reports a cancellation;
// the caller then sees a failed Write() and checks the progress to throw Cancelled instead of
// reporting a write error. (.vtu files are written by our own writer, VtuWriter.h.)
#include <vtkUnstructuredGridWriter.h>

namespace tetflow {

class CancellableLegacyVtkWriter : public vtkUnstructuredGridWriter {
public:
  static CancellableLegacyVtkWriter* New();
  vtkTypeMacro(CancellableLegacyVtkWriter, vtkUnstructuredGridWriter);

protected:
  CancellableLegacyVtkWriter() = default;
  // The file stream VTK opens, behind a stream buffer that hands VTK's large array writes on in
  // 4 MiB pieces and fails the next one once the module is cancelled.
  ostream* OpenVTKFile() override;
};

} // namespace tetflow
