// huge_pages.cpp -- large buffers on transparent huge pages (see huge_pages.h).
#include "lightmesh/util/huge_pages.h"

#include <sys/mman.h>

#include <algorithm>
#include <cstdint>

namespace lm {
namespace {
constexpr size_t kHugePage = size_t(2) << 20;

size_t RoundToHugePages(size_t bytes) { return (bytes + kHugePage - 1) & ~(kHugePage - 1); }
}  // namespace

size_t LargeAllocationBytes(size_t bytes, size_t hugeFrom) {
    return bytes >= hugeFrom ? RoundToHugePages(bytes) : bytes;
}

void* AllocateLarge(size_t bytes, size_t align, size_t hugeFrom) {
    if (bytes >= hugeFrom) {
        const size_t rounded = RoundToHugePages(bytes);
        void* p = std::aligned_alloc(kHugePage, rounded);
        if (!p) throw std::bad_alloc();
        // Advice only: where transparent huge pages are off (or "always") nothing changes.
        madvise(p, rounded, MADV_HUGEPAGE);
        return p;
    }
    void* p = align <= alignof(std::max_align_t)
                  ? std::malloc(bytes ? bytes : 1)
                  : std::aligned_alloc(align, (std::max<size_t>(bytes, 1) + align - 1) & ~(align - 1));
    if (!p) throw std::bad_alloc();
    return p;
}

void* AllocateZeroed(size_t bytes, ZeroedDeleter* deleter, bool huge) {
    deleter->mapped = 0;
    if (huge && bytes >= kHugePagesFrom && bytes <= kZeroedHugeLimit) {
        const size_t length = RoundToHugePages(bytes);
        // Map a huge page more than needed and unmap the slack on both sides of the 2 MiB
        // aligned part.
        void* raw = mmap(nullptr, length + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw != MAP_FAILED) {
            const uintptr_t begin = reinterpret_cast<uintptr_t>(raw);
            const uintptr_t aligned = (begin + kHugePage - 1) & ~(kHugePage - 1);
            if (aligned > begin) munmap(raw, aligned - begin);
            const size_t tail = begin + length + kHugePage - (aligned + length);
            if (tail) munmap(reinterpret_cast<void*>(aligned + length), tail);
            madvise(reinterpret_cast<void*>(aligned), length, MADV_HUGEPAGE);
            deleter->mapped = length;
            return reinterpret_cast<void*>(aligned);
        }
    }
    void* p = std::calloc(std::max<size_t>(bytes, 1), 1);
    if (!p) throw std::bad_alloc();
    return p;
}

void ZeroedDeleter::operator()(void* p) const noexcept {
    if (!p) return;
    if (mapped) munmap(p, mapped);
    else std::free(p);
}

HugePageArena::~HugePageArena() {
    for (void* c : chunks_) std::free(c);
}

size_t HugePageArena::ChunkBytes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return total_;
}

void* HugePageArena::do_allocate(size_t bytes, size_t align) {
    std::lock_guard<std::mutex> lock(mutex_);
    size_t at = (used_ + align - 1) & ~(align - 1);
    if (chunks_.empty() || at + bytes > size_) {
        if (bytes > static_cast<size_t>(-1) - kChunk) throw std::bad_alloc();
        size_ = std::max(kChunk, (bytes + kChunk - 1) / kChunk * kChunk);
        chunks_.reserve(chunks_.size() + 1);
        chunks_.push_back(AllocateLarge(size_, std::max<size_t>(align, 64), kChunk));
        total_ += size_;
        at = 0;
    }
    used_ = at + bytes;
    return static_cast<char*>(chunks_.back()) + at;
}

}  // namespace lm
