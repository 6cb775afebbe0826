// parallel.h -- tbb::parallel_for, plus the happens-before edges ThreadSanitizer cannot see.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#if defined(__SANITIZE_THREAD__)
#define LIGHTMESH_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define LIGHTMESH_TSAN 1
#endif
#endif

#ifdef LIGHTMESH_TSAN
extern "C" void __tsan_acquire(void* addr);
extern "C" void __tsan_release(void* addr);
#endif

namespace lm {

/// In a ThreadSanitizer build (the tsan preset), TBB's own synchronisation is invisible:
/// it lives in libtbb, which is not instrumented, so every write before a parallel loop
/// and every read of its results after it would be reported as a race. These mark the
/// edges a parallel loop guarantees on `sync` objects; elsewhere they compile to nothing.
inline void TsanRelease([[maybe_unused]] void* sync) {
#ifdef LIGHTMESH_TSAN
    __tsan_release(sync);
#endif
}
inline void TsanAcquire([[maybe_unused]] void* sync) {
#ifdef LIGHTMESH_TSAN
    __tsan_acquire(sync);
#endif
}

/// tbb::parallel_for(range, body). What happens before the call happens before every
/// body, and every body before the return -- and nothing more, so races between bodies
/// are still reported (the bodies only acquire `start` and only release `done`).
template <typename Range, typename Body>
void ParallelFor(const Range& range, const Body& body) {
    char start = 0, done = 0;
    TsanRelease(&start);
    tbb::parallel_for(range, [&](const Range& r) {
        TsanAcquire(&start);
        body(r);
        TsanRelease(&done);
    });
    TsanAcquire(&done);
}

/// tbb::parallel_for(first, last, body): body(i) for every i in [first, last).
template <typename Index, typename Body>
void ParallelFor(Index first, Index last, const Body& body) {
    ParallelFor(tbb::blocked_range<Index>(first, last), [&](const tbb::blocked_range<Index>& r) {
        for (Index i = r.begin(); i != r.end(); ++i) body(i);
    });
}

}  // namespace lm
