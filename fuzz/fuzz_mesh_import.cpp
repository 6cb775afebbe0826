// libFuzzer target: Assimp's importers as lightmesh drives them (ImportMeshInProcess: the
// regular-file IO system, the assertion handler, the glTF graph check, the node walk and its
// budgets), in-process so that the fuzzer sees the coverage. Crashes inside Assimp itself
// are findings here; in the renderer LoadMeshFile's child process turns them into one line.
// Build and run with scripts/fuzz.sh; the work is in fuzz_entry_points.cpp.
#include <cstddef>
#include <cstdint>

#include "fuzz_entry_points.h"
#include "lightmesh/util/log.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    lm::SetLogLevel(lm::LogLevel::Silent);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return lm::fuzz::FuzzMeshImport(data, size);
}
