// libFuzzer target: the JSON scene-file loader (and a tiny render of what it accepts).
// Build and run with scripts/fuzz.sh; the work is in fuzz_entry_points.cpp.
#include <tbb/global_control.h>

#include <cstddef>
#include <cstdint>

#include "fuzz_entry_points.h"
#include "lightmesh/util/log.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    lm::SetLogLevel(lm::LogLevel::Silent);
    // One thread: a crash's stack is the input's, and runs are reproducible.
    static tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return lm::fuzz::FuzzSceneFile(data, size);
}
