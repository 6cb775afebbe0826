#include "lightmesh/util/huge_pages.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace lm {
namespace huge_pages_test {
namespace {

TEST(HugePages, LargeBuffersAreAlignedToHugePagesAndSmallOnesWork) {
    for (size_t bytes : {size_t(0), size_t(1), size_t(4096), size_t(1) << 19, size_t(1) << 20, (size_t(5) << 20) + 3}) {
        void* p = AllocateLarge(bytes);
        ASSERT_NE(p, nullptr) << bytes;
        std::memset(p, 0xAB, bytes);
        if (bytes >= (size_t(1) << 18)) {
            EXPECT_EQ(reinterpret_cast<uintptr_t>(p) % (size_t(2) << 20), 0u) << bytes;
        }
        // What it takes: whole huge pages from 256 KiB up.
        const size_t expected = bytes < (size_t(1) << 18) ? bytes : bytes <= (size_t(2) << 20) ? size_t(2) << 20 : size_t(6) << 20;
        EXPECT_EQ(LargeAllocationBytes(bytes), expected) << bytes;
        std::free(p);
    }
    struct alignas(64) Wide {
        float v[16];
    };
    for (size_t n : {1, 3, 100}) {  // below the huge-page size: the type's alignment still holds
        std::vector<Wide, HugePageAllocator<Wide>> w(n);
        EXPECT_EQ(reinterpret_cast<uintptr_t>(w.data()) % 64, 0u) << n;
    }
    // Another threshold: below it plain memory, from it whole huge pages.
    EXPECT_EQ(LargeAllocationBytes(size_t(1) << 20, size_t(2) << 20), size_t(1) << 20);
    EXPECT_EQ(LargeAllocationBytes((size_t(2) << 20) + 1, size_t(2) << 20), size_t(4) << 20);
    std::vector<Wide, HugePageAllocator<Wide, size_t(2) << 20>> big((size_t(3) << 20) / sizeof(Wide)), small(1000);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(big.data()) % (size_t(2) << 20), 0u);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(small.data()) % 64, 0u);
    std::vector<int, HugePageAllocator<int>> a(1 << 20, 7), b(1 << 20, 7);
    EXPECT_EQ(a, b);
    a.push_back(8);
    EXPECT_EQ(a.back(), 8);
    EXPECT_EQ(a.size(), (size_t(1) << 20) + 1);
}

// Zeroed memory is zero whatever its size, huge-page aligned between 256 KiB and the limit,
// and released by its deleter (mapped or from calloc).
TEST(HugePages, ZeroedMemoryIsZeroAndAlignedWhereItIsMapped) {
    for (size_t bytes : {size_t(1), size_t(100000), size_t(1) << 20, (size_t(3) << 20) + 5, kZeroedHugeLimit + 1}) {
        ZeroedDeleter deleter;
        auto* p = static_cast<unsigned char*>(AllocateZeroed(bytes, &deleter));
        ASSERT_NE(p, nullptr);
        EXPECT_EQ(deleter.mapped != 0, bytes >= (size_t(1) << 18) && bytes <= kZeroedHugeLimit) << bytes;
        if (deleter.mapped) {
            EXPECT_EQ(reinterpret_cast<uintptr_t>(p) % (size_t(2) << 20), 0u) << bytes;
            EXPECT_GE(deleter.mapped, bytes);
        }
        size_t nonZero = 0;
        for (size_t i = 0; i < bytes; i += 4093) nonZero += p[i] != 0;
        EXPECT_EQ(nonZero + p[bytes - 1], 0u) << bytes;
        p[bytes - 1] = 1;
        deleter(p);
    }
}

// Where the kernel gives huge pages on request (transparent huge pages "madvise" or
// "always"), filling a 16 MiB buffer must fault far fewer times than its 4,096 small pages.
TEST(HugePages, FillingALargeBufferTakesFewPageFaults) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    GTEST_SKIP() << "a sanitizer's shadow memory takes faults of its own";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
    GTEST_SKIP() << "a sanitizer's shadow memory takes faults of its own";
#endif
#endif
    std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    if (!std::getline(mode, line) || line.find("[never]") != std::string::npos)
        GTEST_SKIP() << "no transparent huge pages here";
    auto faults = [] {
        rusage u{};
        getrusage(RUSAGE_SELF, &u);
        return u.ru_minflt;
    };
    const size_t bytes = size_t(16) << 20;
    void* p = AllocateLarge(bytes);
    const long before = faults();
    std::memset(p, 1, bytes);
    const long taken = faults() - before;
    std::free(p);
    EXPECT_LT(taken, 3 * 4096 / 4) << "page faults filling 16 MiB";
}

// The arena: aligned pieces from 2 MiB chunks, one chunk for many small requests, a chunk
// of its own for a large one, the pieces disjoint and writable.
TEST(HugePages, ArenaHandsOutAlignedDisjointPiecesFromChunks) {
    HugePageArena arena;
    std::vector<std::pair<char*, size_t>> pieces;
    for (int k = 0; k < 1000; ++k) {
        const size_t bytes = 1 + static_cast<size_t>(k * 37 % 500), align = size_t(1) << (k % 7);
        char* p = static_cast<char*>(arena.allocate(bytes, align));
        EXPECT_EQ(reinterpret_cast<uintptr_t>(p) % align, 0u);
        std::memset(p, k & 0xff, bytes);
        pieces.emplace_back(p, bytes);
    }
    EXPECT_EQ(arena.ChunkBytes(), HugePageArena::kChunk);  // about 250 kB: one chunk
    for (size_t k = 0; k < pieces.size(); ++k)
        EXPECT_EQ(static_cast<unsigned char>(pieces[k].first[pieces[k].second - 1]), k & 0xff) << k;
    char* big = static_cast<char*>(arena.allocate(5 * HugePageArena::kChunk + 1, 64));
    std::memset(big, 1, 5 * HugePageArena::kChunk + 1);
    EXPECT_EQ(arena.ChunkBytes(), 7 * HugePageArena::kChunk);  // 6 chunks for it
    // A pmr vector on it grows and keeps its values.
    std::pmr::vector<int> v(&arena);
    for (int k = 0; k < 100000; ++k) v.push_back(k);
    EXPECT_EQ(v[99999], 99999);
}

}  // namespace
}  // namespace huge_pages_test
}  // namespace lm
