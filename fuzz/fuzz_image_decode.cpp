// libFuzzer target: the image decoders of materials' textures (libpng, libjpeg-turbo,
// stb_image's TGA and BMP readers, and OpenEXR). Build and run with scripts/fuzz.sh; the work is in
// fuzz_entry_points.cpp.
#include <cstddef>
#include <cstdint>

#include "fuzz_entry_points.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    return lm::fuzz::FuzzImageDecode(data, size);
}
