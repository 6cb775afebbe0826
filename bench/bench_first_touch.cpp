// bench_first_touch.cpp -- what a first touch of fresh memory costs on this machine: 2 MiB
// transparent huge pages (as util/huge_pages asks for large buffers) against 4 KiB pages.
// The light mesh's lazy structures and the image are touched first during the render, so
// this cost lands in the render phase of every process (README, "Where the time goes").
// Usage: bench_first_touch [pages (2 MiB each), 1-1024, default 16] [rounds, 1-1000, default 5]
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

constexpr size_t kHuge = size_t(2) << 20, kSmall = 4096;

// Microseconds per first touch of `pages` fresh 2 MiB regions, huge pages asked for or not,
// touching one byte per `stride`.
double FirstTouch(int pages, bool huge, size_t stride) {
    const size_t length = kHuge * static_cast<size_t>(pages);
    void* raw = mmap(nullptr, length + kHuge, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED) {
        std::perror("mmap");
        std::exit(1);
    }
    auto* p = reinterpret_cast<volatile char*>((reinterpret_cast<uintptr_t>(raw) + kHuge - 1) & ~(kHuge - 1));
    madvise(const_cast<char*>(p), length, huge ? MADV_HUGEPAGE : MADV_NOHUGEPAGE);
    const auto t0 = std::chrono::steady_clock::now();
    for (size_t offset = 0; offset < length; offset += stride) p[offset] = 1;
    const auto t1 = std::chrono::steady_clock::now();
    munmap(raw, length + kHuge);
    return std::chrono::duration<double, std::micro>(t1 - t0).count() / static_cast<double>(length / stride);
}

// argv[i] as a whole number in [1, max], or `fallback` if absent; anything else is a usage
// error (a count past max would map, and touch, more memory than a measurement needs).
int Count(int argc, char** argv, int i, int fallback, int max, const char* what) {
    if (argc <= i) return fallback;
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(argv[i], &end, 10);
    if (errno != 0 || end == argv[i] || *end != '\0' || v < 1 || v > max) {
        std::fprintf(stderr, "bench_first_touch: %s must be a whole number from 1 to %d, got \"%s\"\n", what, max,
                     argv[i]);
        std::exit(1);
    }
    return static_cast<int>(v);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc > 3) {
        std::fprintf(stderr, "usage: bench_first_touch [pages (2 MiB each), 1-1024] [rounds, 1-1000]\n");
        return 1;
    }
    const int pages = Count(argc, argv, 1, 16, 1024, "pages");
    const int rounds = Count(argc, argv, 2, 5, 1000, "rounds");
    std::printf("first touch of fresh memory, %d x 2 MiB per round\n", pages);
    std::vector<double> huge, small;
    for (int r = 0; r < rounds; ++r) {
        huge.push_back(FirstTouch(pages, true, kHuge));
        small.push_back(FirstTouch(pages, false, kSmall));
        std::printf("round %d: 2 MiB huge page %.1f us, 4 KiB page %.2f us (%.0f us per 2 MiB)\n", r + 1,
                    huge.back(), small.back(), small.back() * static_cast<double>(kHuge / kSmall));
    }
    std::sort(huge.begin(), huge.end());
    std::sort(small.begin(), small.end());
    std::printf("median: 2 MiB huge page %.1f us (min %.1f, max %.1f); 4 KiB page %.2f us\n", huge[huge.size() / 2],
                huge.front(), huge.back(), small[small.size() / 2]);
    return 0;
}
