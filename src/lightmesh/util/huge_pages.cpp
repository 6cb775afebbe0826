// huge_pages.cpp -- large buffers on transparent huge pages (see huge_pages.h).
#include "lightmesh/util/huge_pages.h"

#include <sys/mman.h>

namespace lm {

void* AllocateLarge(size_t bytes) {
    constexpr size_t kHugePage = size_t(2) << 20;
    if (bytes >= kHugePage / 2) {
        const size_t rounded = (bytes + kHugePage - 1) & ~(kHugePage - 1);
        void* p = std::aligned_alloc(kHugePage, rounded);
        if (!p) throw std::bad_alloc();
        // Advice only: where transparent huge pages are off (or "always") nothing changes.
        madvise(p, rounded, MADV_HUGEPAGE);
        return p;
    }
    void* p = std::malloc(bytes ? bytes : 1);
    if (!p) throw std::bad_alloc();
    return p;
}

}  // namespace lm
