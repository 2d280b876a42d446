// Leak suppressions of the sanitizer runtime, linked into every program of a
// TETFLOW_SANITIZE=address,undefined build (top-level CMakeLists.txt; README "Reliability"), so
// the suite and hand-run programs behave alike. Environment variables still override them.

// Leaks inside Debian's libraries, not in TetFlow, each with the test that shows it.
//
// VTK 9.1's XML reader leaks the data arrays it created for a piece when the piece's data are
// truncated or corrupt (vtkXMLUnstructuredGridReader::ReadPieceData -> vtkXMLReader::CreateArray,
// never released on that error path): MeshIOVtk.TruncatedVtu, MeshIOVtk.CorruptedVtuCompressionHeader,
// MeshIOVtk.CorruptedFilesNeverEscapeAsOtherErrors. Debian's VTK has no frame pointers, so the
// fast unwinder's stacks stop inside libvtkCommonCore (the array's New()); the second entry
// therefore names that library. With ASAN_OPTIONS=fast_unwind_on_malloc=0 the first entry
// matches on its own, at 3-4x the run time. TetFlow holds VTK objects only through vtkNew and
// vtkSmartPointer.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:vtkXMLReader::CreateArray\n"
         "leak:libvtkCommonCore\n"
         // The same reader's piece loop leaks its 8-byte per-piece buffer when a piece fails
         // (MeshIOVtk.CorruptedVtuCompressionHeader).
         "leak:vtkXMLUnstructuredDataReader::ReadXMLData\n"
         // The legacy reader leaks the vtkCellArray it made when CELL_TYPES cannot be parsed
         // (vtkUnstructuredGridReader::ReadMeshSimple's error return; found by fuzzing, the
         // input is Testing/Fuzz/corpus/vtk/finding-leak-cell-types, run by FuzzCorpus.vtk).
         // The stack names libvtkCommonDataModel (vtkCellArray::New) and the reader.
         "leak:vtkUnstructuredGridReader::ReadMeshSimple\n"
         "leak:libvtkCommonDataModel\n"
         // OpenCASCADE's STEP and IGES translators register their static parameters once per
         // process (STEPControl_Controller::Init / IGESControl_Controller::Init ->
         // Interface_Static::Init -> MoniTool_TypedValue::AddEnum, IFSelect_Editor,
         // GeomToStep_MakeDirection) and never free them: CadModel.StepWrittenAndReadBackIsTheSameModel,
         // CadModel.BadFilesNameTheFileAndTheFix, CadModel.IgesWrittenAndReadBackIsTheSameModel
         // (stacks seen with ASAN_OPTIONS=fast_unwind_on_malloc=0). Debian's OpenCASCADE has no
         // frame pointers, so the fast unwinder's stacks stop in its allocator (Standard_MMgrRaw,
         // libTKernel) or in the translator libraries; these entries match those. TetFlow holds
         // OpenCASCADE objects by value and through Handle() only.
         "leak:Standard_MMgrRaw\n"
         "leak:libTKXSBase\n"
         "leak:libTKSTEP\n"
         "leak:libTKIGES\n";
}

// ThreadSanitizer (TETFLOW_SANITIZE=thread, built with clang and LLVM's OpenMP; run with
// OMP_TOOL_LIBRARIES=libarcher.so so that OpenMP's barriers and reductions are seen). Reports
// whose synchronisation happens inside Debian's uninstrumented libraries, not in TetFlow:
//  - libomp itself (its allocator's ___kmp_free / memset and lock initialisation);
//  - VTK's SMP tools run some of VTK's own loops (in the XML writer's data model) on TBB worker
//    threads: memory VTK allocates there is freed later on the module's thread, after TBB's
//    join, which TSan cannot see because libtbb is not instrumented (reported on WriteMesh in
//    Cli.RunSucceedsPrintsOneLinePerModuleAndWritesRelativeToTheNet). called_from_lib makes TSan
//    ignore the allocations and frees VTK's data model and TBB make.
extern "C" const char* __tsan_default_suppressions() {
  return "called_from_lib:libomp.so.5\n"
         "race:libomp.so.5\n"
         "mutex:libomp.so.5\n"
         "called_from_lib:libvtkCommonDataModel-9.1.so.1\n"
         "called_from_lib:libtbb.so.12\n";
}
