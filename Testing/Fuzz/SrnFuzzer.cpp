// libFuzzer target for the .srn loader (Dataflow/NetworkFile): every input is loaded with the
// standard modules registered, as `tetflow validate` does. A bad network may be refused only with
// NetworkLoadError (an InputError); anything else is a finding. A loaded network is saved again
// and re-loaded: save -> load must accept what load accepted. In a fuzzing build (TETFLOW_FUZZ_SRN)
// this file defines libFuzzer's entry points; in a normal build fuzz_corpus calls fuzzSrnInput.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "Algorithms/Core/Errors.h"
#include "Dataflow/NetworkFile.h"
#include "Fuzz/FuzzFile.h"
#include "Fuzz/FuzzTargets.h"
#include "Modules/StandardModules.h"

using namespace tetflow;

void fuzz::fuzzSrnInput(const uint8_t* data, size_t size) {
  static const ModuleRegistry registry = [] {
    ModuleRegistry r;
    registerStandardModules(r);
    return r;
  }();
  const std::string xml(reinterpret_cast<const char*>(data), size);
  const std::string dir = fuzz::scratchDir().string();
  std::string saved;
  try {
    const Network net = loadNetworkFromString(xml, "fuzz.srn", dir, registry);
    saved = saveNetworkToString(net);
  } catch (const InputError&) {
    return;
  }
  try {
    (void)loadNetworkFromString(saved, "fuzz-saved.srn", dir, registry);
  } catch (const InputError&) {
    std::abort(); // a network we saved ourselves must load
  }
}

#ifdef TETFLOW_FUZZ_SRN
extern "C" int LLVMFuzzerInitialize(int*, char***) { return 0; }

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::fuzzSrnInput(data, size);
  return 0;
}
#endif
