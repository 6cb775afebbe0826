// grid_lanes.h -- the nested grid's SIMD lanes (private to the grid): lane masks and the
// watertight triangle test's arithmetic for W lanes at once, shared by the leaf cells' block
// filter (grid_filter.cpp) and the packets' leaf test (grid_packet_walk.h).
#pragma once

#include <cstdint>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include "lightmesh/math/simd.h"

namespace lm::grid_detail {

// One bit per lane of a W-lane mask. The 8-lane one is compiled for AVX2 and is not
// always_inline: the packet walk's body (grid_packet_walk.h) is generic code that calls it
// and is itself inlined into an AVX2 entry point, where this one is then inlined too (an
// always_inline AVX2 function called from code without the target is an error in GCC and
// clang). The mask comes by reference: a 32-byte vector passed by value outside AVX code
// would change the ABI.
template <int W>
inline uint32_t LaneBits(const typename SimdVectors<W>::I& m);
template <>
[[gnu::always_inline]] inline uint32_t LaneBits<4>(const SimdVectors<4>::I& m) {
#if defined(__x86_64__) || defined(__i386__)
    return static_cast<uint32_t>(_mm_movemask_ps(reinterpret_cast<__m128>(m)));
#else
    return uint32_t(m[0] != 0) | uint32_t(m[1] != 0) << 1 | uint32_t(m[2] != 0) << 2 | uint32_t(m[3] != 0) << 3;
#endif
}
#if defined(__x86_64__) || defined(__i386__)
template <>
__attribute__((target("avx2"))) inline uint32_t LaneBits<8>(const SimdVectors<8>::I& m) {
    return static_cast<uint32_t>(_mm256_movemask_ps(reinterpret_cast<__m256>(m)));
}
#endif

// Whether any lane of a W-lane mask is set, in generic vector code (so that it inlines into
// the AVX2 filter without a target attribute of its own).
[[gnu::always_inline]] inline bool AnyLane(const SimdVectors<4>::I& m) {
    typedef long long Halves __attribute__((vector_size(16)));
    const Halves x = reinterpret_cast<Halves>(m);
    return (x[0] | x[1]) != 0;
}
[[gnu::always_inline]] inline bool AnyLane(const SimdVectors<8>::I& m) {
    typedef long long Quarters __attribute__((vector_size(32)));
    const Quarters x = reinterpret_cast<Quarters>(m);
    return (x[0] | x[1] | x[2] | x[3]) != 0;
}

// IntersectPrepared's arithmetic, its very operations in its order, for W lanes at once: a
// triangle's vertices and the ray's origin and shear in the ray's frame (x, y across it,
// z along it), each a vector, so that either side may be the one broadcast (FilterLanes:
// 8 triangles against one ray; the packets' leaf test: one triangle against 8 rays). Lane
// by lane the values are the scalar test's, so a lane without an exactly zero edge
// function is decided here exactly as that test decides it.
template <typename VF, typename VI>
struct WatertightLanes {
    VF aZ, bZ, cZ, cu, cv, cw;
    VI inside;    // no edge function exactly zero, and their signs agree
    VI zeroEdge;  // an edge function exactly zero: the tie-breaks, left to the scalar test

    [[gnu::always_inline]] WatertightLanes(const VF& Ax, const VF& Ay, const VF& Az, const VF& Bx, const VF& By,
                                           const VF& Bz, const VF& Cx, const VF& Cy, const VF& Cz, const VF& ox,
                                           const VF& oy, const VF& oz, const VF& sx, const VF& sy) {
        const VF zero = {};
        aZ = Az - oz, bZ = Bz - oz, cZ = Cz - oz;
        const VF ax = (Ax - ox) - sx * aZ, ay = (Ay - oy) - sy * aZ;
        const VF bx = (Bx - ox) - sx * bZ, by = (By - oy) - sy * bZ;
        const VF cx = (Cx - ox) - sx * cZ, cy = (Cy - oy) - sy * cZ;
        cu = cx * by - cy * bx, cv = ax * cy - ay * cx, cw = bx * ay - by * ax;
        const VI neg = (cu < zero) | (cv < zero) | (cw < zero);
        const VI pos = (cu > zero) | (cv > zero) | (cw > zero);
        zeroEdge = (cu == zero) | (cv == zero) | (cw == zero);
        inside = ~(neg & pos) & ~zeroEdge;
    }
    // For the `inside` lanes, as IntersectPrepared without a zero edge: d0 = u + v + w,
    // sign = d0 > 0 ? 1 : -1, (u, v, w) ·= sign, det = u + v + w > 0, t = (u·az + v·bz +
    // w·cz) / det within (tMin, tMax). Those hits into *hits (an output, not a return value:
    // no 32-byte vector returned outside AVX code); *t, *uOut, *v, *w and *det are the scalar
    // test's values (b0 = u / det, b1 = v / det and b2 = w / det as it computes them).
    [[gnu::always_inline]] void Hits(const VF& sz, const VF& tMin, const VF& tMax, VI* hits, VF* t, VF* uOut, VF* v,
                                     VF* w, VF* det) const {
        const VF zero = {};
        const VF d0 = cu + cv + cw;
        const VI positive = d0 > zero;
        const VF one = zero + 1.0f, minusOne = zero - 1.0f;
        const VF sign =
            reinterpret_cast<VF>((positive & reinterpret_cast<VI>(one)) | (~positive & reinterpret_cast<VI>(minusOne)));
        const VF u = cu * sign;
        *uOut = u;
        *v = cv * sign, *w = cw * sign;
        *det = u + *v + *w;
        const VF az = sz * aZ, bz = sz * bZ, cz = sz * cZ;
        *t = (u * az + *v * bz + *w * cz) / *det;
        *hits = inside & (d0 != zero) & (*det > zero) & (*t > tMin) & (*t < tMax);
    }
};

}  // namespace lm::grid_detail
