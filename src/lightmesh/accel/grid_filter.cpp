// grid_filter.cpp -- the nested grid's leaf-cell triangle filter: a ray against the
// triangles of a cell's blocks (TriBlock), 8 at a time with AVX2 or 4 with SSE, with the
// watertight test's exact arithmetic. The queries call it through the BlockFilter pointers
// the build chooses (grid_build.cpp).
#include "lightmesh/accel/grid.h"
#include "lightmesh/accel/grid_internal.h"
#include "lightmesh/accel/grid_lanes.h"

#include <cstring>

#include "lightmesh/geometry/triangle.h"
#include "lightmesh/math/simd.h"

namespace lm::grid_detail {
namespace {

// ---- The leaf cells' triangle test, W triangles at a time ---------------------------
//
// A cell's triangles sit in blocks of 8 (TriBlock), coordinate by coordinate. The ray's
// watertight-frame edge functions (IntersectPrepared: translate by the origin, shear,
// three 2D cross products) are computed for a whole block with SIMD, with the very
// operations and order of the scalar test, so lane k holds exactly the scalar values. A
// lane is dropped only where the scalar test would return at its first rejection (signs
// both ways and none zero), which most tested triangles do; the few others, and every
// exact edge or vertex case, go through IntersectPrepared itself. So the answers, ties
// included, are brute force's bit for bit, and a triangle tested in several cells gets the
// same answer each time (no mailbox is needed: a repeat costs one SIMD lane).

// The ray's constants of the filter, broadcast to W lanes.
template <int W>
struct FilterRay {
    using VF = typename SimdVectors<W>::F;
    VF ox, oy, oz, sx, sy, sz, tMin, tMax;
    int kx, ky, kz;
    [[gnu::always_inline]] explicit FilterRay(const detail::PreparedRay& r) : kx(r.kx), ky(r.ky), kz(r.kz) {
        const VF zero = {};
        ox = zero + r.o[r.kx];
        oy = zero + r.o[r.ky];
        oz = zero + r.o[r.kz];
        sx = zero + r.sx;
        sy = zero + r.sy;
        sz = zero + r.sz;
        tMin = zero + r.tMin;
        tMax = zero + r.tMax;
    }
};

// Lanes h … h+W-1 of a block against the ray (WatertightLanes): all ones in *hits exactly
// where IntersectPrepared hits, with its t in *t, and in *ties where an edge function is
// exactly zero (the tie-breaks, left to the scalar test). With `bary`, the hits' b0, b1, b2
// as IntersectPrepared computes them (1 / det, then the products) into bary[0 … 2], W
// lanes each. Returns false, without computing det and t, when no lane can hit (most
// blocks a ray meets).
template <int W>
[[gnu::always_inline]] inline bool FilterLanes(const NestedGridAccel::TriBlock& block, int h, const FilterRay<W>& r,
                                               typename SimdVectors<W>::I* hits, typename SimdVectors<W>::I* ties,
                                               typename SimdVectors<W>::F* t, typename SimdVectors<W>::F* bary) {
    using VF = typename SimdVectors<W>::F;
    using VI = typename SimdVectors<W>::I;
    auto at = [&](int row) -> const VF& { return *reinterpret_cast<const VF*>(&block.v[row][h]); };
    const int kx = r.kx, ky = r.ky, kz = r.kz;
    const WatertightLanes<VF, VI> lanes(at(kx), at(ky), at(kz), at(3 + kx), at(3 + ky), at(3 + kz), at(6 + kx),
                                        at(6 + ky), at(6 + kz), r.ox, r.oy, r.oz, r.sx, r.sy);
    *ties = lanes.zeroEdge;
    if (!AnyLane(lanes.inside)) {
        *hits = VI{};
        *t = VF{};
        if (bary) bary[0] = bary[1] = bary[2] = VF{};
        return AnyLane(lanes.zeroEdge);
    }
    VF u, v, w, det;
    lanes.Hits(r.sz, r.tMin, r.tMax, hits, t, &u, &v, &w, &det);
    if (bary) {
        const VF inv = (VF{} + 1.0f) / det;
        bary[0] = u * inv, bary[1] = v * inv, bary[2] = w * inv;
    }
    return true;
}

// With kFirstHit (occlusion) the blocks after the first that holds a hit are not tested:
// any hit decides an occlusion query.
template <bool kBary, bool kFirstHit = false>
[[gnu::always_inline]] inline uint64_t Filter4(const NestedGridAccel::TriBlock* blocks, uint32_t count,
                                               const detail::PreparedRay& ray, float* t, uint64_t* ties, float* bary) {
    *ties = 0;
    if (!ray.valid) return 0;
    const FilterRay<4> r(ray);
    uint64_t hitBits = 0, tieBits = 0;
    for (uint32_t b = 0; b < count; ++b)
        for (int h = 0; h < 8; h += 4) {
            SimdVectors<4>::I hits, tie;
            SimdVectors<4>::F tv, bv[3];
            if (!FilterLanes<4>(blocks[b], h, r, &hits, &tie, &tv, kBary ? bv : nullptr)) continue;
            std::memcpy(t + 8 * b + h, &tv, sizeof tv);
            if constexpr (kBary)
                for (int k = 0; k < 3; ++k) std::memcpy(bary + 64 * k + 8 * b + h, &bv[k], sizeof bv[k]);
            hitBits |= uint64_t(LaneBits<4>(hits)) << (8 * b + h);
            tieBits |= uint64_t(LaneBits<4>(tie)) << (8 * b + h);
            if (kFirstHit && hitBits) {
                *ties = tieBits;
                return hitBits;
            }
        }
    *ties = tieBits;
    return hitBits;
}
#if defined(__x86_64__) || defined(__i386__)
template <bool kBary, bool kFirstHit = false>
[[gnu::always_inline]] __attribute__((target("avx2"))) inline uint64_t Filter8(const NestedGridAccel::TriBlock* blocks,
                                                                               uint32_t count, const detail::PreparedRay& ray,
                                                                               float* t, uint64_t* ties, float* bary) {
    *ties = 0;
    if (!ray.valid) return 0;
    const FilterRay<8> r(ray);
    uint64_t hitBits = 0, tieBits = 0;
    for (uint32_t b = 0; b < count; ++b) {
        SimdVectors<8>::I hits, tie;
        SimdVectors<8>::F tv, bv[3];
        if (!FilterLanes<8>(blocks[b], 0, r, &hits, &tie, &tv, kBary ? bv : nullptr)) continue;
        std::memcpy(t + 8 * b, &tv, sizeof tv);
        if constexpr (kBary)
            for (int k = 0; k < 3; ++k) std::memcpy(bary + 64 * k + 8 * b, &bv[k], sizeof bv[k]);
        hitBits |= uint64_t(LaneBits<8>(hits)) << (8 * b);
        tieBits |= uint64_t(LaneBits<8>(tie)) << (8 * b);
        if (kFirstHit && hitBits) break;
    }
    *ties = tieBits;
    return hitBits;
}
#endif
}  // namespace

uint64_t FilterBlocks4(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                       float* t, uint64_t* ties, float*) {
    return Filter4<false>(blocks, count, ray, t, ties, nullptr);
}
uint64_t FilterBlocks4Bary(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                           float* t, uint64_t* ties, float* bary) {
    return Filter4<true>(blocks, count, ray, t, ties, bary);
}
uint64_t FilterBlocks4Any(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                          float* t, uint64_t* ties, float*) {
    return Filter4<false, true>(blocks, count, ray, t, ties, nullptr);
}
#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("avx2"))) uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count,
                                                       const detail::PreparedRay& ray, float* t, uint64_t* ties, float*) {
    return Filter8<false>(blocks, count, ray, t, ties, nullptr);
}
__attribute__((target("avx2"))) uint64_t FilterBlocks8Bary(const NestedGridAccel::TriBlock* blocks, uint32_t count,
                                                           const detail::PreparedRay& ray, float* t, uint64_t* ties,
                                                           float* bary) {
    return Filter8<true>(blocks, count, ray, t, ties, bary);
}
__attribute__((target("avx2"))) uint64_t FilterBlocks8Any(const NestedGridAccel::TriBlock* blocks, uint32_t count,
                                                          const detail::PreparedRay& ray, float* t, uint64_t* ties,
                                                          float*) {
    return Filter8<false, true>(blocks, count, ray, t, ties, nullptr);
}
bool HasAvx2() { return __builtin_cpu_supports("avx2"); }
#else
uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                       float* t, uint64_t* ties, float* bary) {
    return FilterBlocks4(blocks, count, ray, t, ties, bary);
}
uint64_t FilterBlocks8Bary(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                           float* t, uint64_t* ties, float* bary) {
    return FilterBlocks4Bary(blocks, count, ray, t, ties, bary);
}
uint64_t FilterBlocks8Any(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                          float* t, uint64_t* ties, float* bary) {
    return FilterBlocks4Any(blocks, count, ray, t, ties, bary);
}
bool HasAvx2() { return false; }
#endif

}  // namespace lm::grid_detail
