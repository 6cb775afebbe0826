// libFuzzer target: the sphere-template cache-file reader (ParseSphereTemplates).
// Build and run with scripts/fuzz.sh; the work is in fuzz_entry_points.cpp.
#include <cstddef>
#include <cstdint>

#include "fuzz_entry_points.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return lm::fuzz::FuzzTemplateFile(data, size);
}
