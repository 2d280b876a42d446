#pragma once
// VTK's unstructured-grid writers, made to stop within a fraction of a second when the running
// module is cancelled (README "Reliability", cancellation). VTK's writers have no cancellation of
// their own, but both stop as soon as their output fails: the XML writer checks its error code
// between compressed blocks and arrays, the legacy writer checks its stream after every array.
// These subclasses make the output fail once currentProgress() (Core/Progress.h) reports a
// cancellation; the caller then sees a failed Write() and checks the progress to throw Cancelled
// instead of reporting a write error.
#include <vtkUnstructuredGridWriter.h>
#include <vtkXMLUnstructuredGridWriter.h>

namespace tetflow {

class CancellableVtuWriter : public vtkXMLUnstructuredGridWriter {
public:
  static CancellableVtuWriter* New();
  vtkTypeMacro(CancellableVtuWriter, vtkXMLUnstructuredGridWriter);

protected:
  CancellableVtuWriter() = default;
  // Called after every compressed block (32 KiB) and array.
  void UpdateProgressDiscrete(float progress) override;
};

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
