// huge_pages.h -- an allocator that asks the kernel for 2 MiB pages for large buffers.
//
// Why: a first touch of a fresh 4 KiB page costs a page fault, and on the virtual machines
// this project is measured on a fault costs about 11 µs (64 MiB zero-filled through 4 KiB
// pages: 183 ms; through transparent huge pages: 5.5 ms). A 1024×768 float image is 2,300
// faults, 25 ms of a 90 ms render; the light mesh's setup on a 451k-triangle scene touches
// 33 MiB. Linux's default transparent-huge-page mode is "madvise": only regions marked with
// MADV_HUGEPAGE get them, so large buffers are allocated 2 MiB aligned and marked. Small
// ones, and every buffer on systems without the advice, behave as std::allocator's.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory_resource>
#include <mutex>
#include <new>
#include <vector>

namespace lm {

/// From this size up, AllocateLarge uses huge pages unless told another threshold.
constexpr size_t kHugePagesFrom = size_t(256) << 10;

/// Allocates `bytes` (any size; from `hugeFrom` up rounded up to whole 2 MiB pages, 2 MiB
/// aligned and marked for huge pages: less than 2 MiB more, at most 1.75 MiB for the default
/// threshold, against 64 faults or more, 0.7 ms here, for 4 KiB pages); smaller ones aligned
/// to `align` (a power of two). Free with std::free. Throws std::bad_alloc.
void* AllocateLarge(size_t bytes, size_t align = alignof(std::max_align_t), size_t hugeFrom = kHugePagesFrom);

/// std::unique_ptr's deleter for AllocateLarge's memory.
struct FreeDeleter {
    void operator()(void* p) const noexcept { std::free(p); }
};

/// What AllocateLarge(bytes, align, hugeFrom) takes: `bytes`, rounded up to whole 2 MiB pages
/// from `hugeFrom` up (where transparent huge pages are on, each becomes resident on its
/// first touch). For figures of memory use.
size_t LargeAllocationBytes(size_t bytes, size_t hugeFrom = kHugePagesFrom);

/// Zero-filled memory whose pages are mapped on first touch (lazily, like calloc's): from
/// 256 KiB to kZeroedHugeLimit an anonymous mapping, 2 MiB aligned and marked for huge pages;
/// other sizes, or `huge` false (a sparse use), from calloc (beyond the limit a sparse use
/// would make whole 2 MiB pages resident). Release with ZeroedDeleter. Throws std::bad_alloc.
constexpr size_t kZeroedHugeLimit = size_t(64) << 20;
struct ZeroedDeleter {
    size_t mapped = 0;  // the mapping's length; 0: from calloc
    void operator()(void* p) const noexcept;
};
void* AllocateZeroed(size_t bytes, ZeroedDeleter* deleter, bool huge = true);

/// std::allocator's interface over AllocateLarge, for std::vector of big buffers (images,
/// the light mesh's per-triangle tables). Values are default-initialised by the vector as
/// usual; only where the pages come from changes. `HugeFrom`: AllocateLarge's threshold.
template <typename T, size_t HugeFrom = kHugePagesFrom>
struct HugePageAllocator {
    using value_type = T;
    template <typename U>
    struct rebind {
        using other = HugePageAllocator<U, HugeFrom>;
    };
    HugePageAllocator() noexcept = default;
    template <typename U>
    HugePageAllocator(const HugePageAllocator<U, HugeFrom>&) noexcept {}
    T* allocate(size_t n) {
        if (n > static_cast<size_t>(-1) / sizeof(T)) throw std::bad_alloc();
        return static_cast<T*>(AllocateLarge(n * sizeof(T), alignof(T), HugeFrom));
    }
    void deallocate(T* p, size_t) noexcept { std::free(p); }
    template <typename U>
    bool operator==(const HugePageAllocator<U, HugeFrom>&) const noexcept { return true; }
};

/// A std::pmr resource that hands out memory in turn from 2 MiB chunks on huge pages
/// (AllocateLarge) and releases it all at its end (deallocation does nothing): for buffers
/// that live as long as one job and are reused rather than freed, such as the soft
/// default's rows of tiles (render/soft_frame.cpp), whose vectors grow a few times and keep
/// their room, so what a growth leaves behind is bounded by what they hold. A request
/// larger than a chunk gets chunks of its own size rounded up to 2 MiB. Thread-safe (a
/// mutex: buffers are allocated when they grow, not per use).
class HugePageArena final : public std::pmr::memory_resource {
  public:
    static constexpr size_t kChunk = size_t(2) << 20;
    HugePageArena() = default;
    HugePageArena(const HugePageArena&) = delete;
    HugePageArena& operator=(const HugePageArena&) = delete;
    ~HugePageArena() override;
    /// The bytes of the chunks taken so far.
    size_t ChunkBytes() const;

  private:
    void* do_allocate(size_t bytes, size_t align) override;
    void do_deallocate(void*, size_t, size_t) override {}
    bool do_is_equal(const std::pmr::memory_resource& o) const noexcept override { return this == &o; }
    mutable std::mutex mutex_;
    std::vector<void*> chunks_;
    size_t used_ = 0, size_ = 0, total_ = 0;
};

}  // namespace lm
