// visibility_image.cpp -- the per-light visibility image (see the header).
#include "lightmesh/render/visibility_image.h"

#include <limits>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

VisibilityImage::VisibilityImage(int w, int h, size_t l) : width(w), height(h), lights(l) {
    if (w < 1 || h < 1) ThrowError("visibility image %dx%d: the size must be at least 1x1", w, h);
    const double bytes = static_cast<double>(w) * static_cast<double>(h) * static_cast<double>(l) * sizeof(float);
    const uint64_t physical = PhysicalMemoryBytes();
    if (physical && bytes > static_cast<double>(physical / 2))
        ThrowError("the visibility of %zu lights at %dx%d would need %s, more than half of this machine's %s", l, w, h,
                   FormatBytes(static_cast<uint64_t>(bytes)).c_str(), FormatBytes(physical).c_str());
    values.assign(static_cast<size_t>(w) * static_cast<size_t>(h) * l, 0.0f);
}

void FinishVisibility(float* out, size_t lights, int hits) {
    if (hits == 0) {
        for (size_t l = 0; l < lights; ++l) out[l] = std::numeric_limits<float>::quiet_NaN();
        return;
    }
    if (hits == 1) return;
    const float n = static_cast<float>(hits);
    for (size_t l = 0; l < lights; ++l) out[l] /= n;
}

}  // namespace lm
