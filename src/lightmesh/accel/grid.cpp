// grid.cpp -- the nested uniform grid of the paper's section 2: the queries, by 3D-DDA
// traversal, and their SIMD triangle filter. The build is grid_build.cpp.
#include "lightmesh/accel/grid.h"
#include "lightmesh/accel/grid_internal.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <new>
#include <tuple>
#include <utility>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/math/simd.h"

namespace lm {
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

// One bit per lane of a W-lane mask.
template <int W>
[[gnu::always_inline]] inline uint32_t LaneBits(typename SimdVectors<W>::I m);
template <>
[[gnu::always_inline]] inline uint32_t LaneBits<4>(SimdVectors<4>::I m) {
#if defined(__x86_64__) || defined(__i386__)
    return static_cast<uint32_t>(_mm_movemask_ps(reinterpret_cast<__m128>(m)));
#else
    return uint32_t(m[0] != 0) | uint32_t(m[1] != 0) << 1 | uint32_t(m[2] != 0) << 2 | uint32_t(m[3] != 0) << 3;
#endif
}
#if defined(__x86_64__) || defined(__i386__)
template <>
[[gnu::always_inline]] __attribute__((target("avx2"))) inline uint32_t LaneBits<8>(SimdVectors<8>::I m) {
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

}  // namespace

namespace grid_detail {

namespace {
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

}  // namespace grid_detail

namespace {

// One leaf cell as the walk hands it to a query: its lanes in the blocks, and the cell's
// exit along the ray.
struct CellSpan {
    const NestedGridAccel::TriBlock* blocks;  // all of them
    uint32_t first, count;                    // the cell's lanes: first … first + count - 1
    NestedGridAccel::BlockFilter filter;         // t only (counts)
    NestedGridAccel::BlockFilter nearestFilter;  // t, b0, b1, b2 (closest hit)
    NestedGridAccel::BlockFilter anyFilter;      // t only, up to the first block with a hit (occlusion)
    float tCellExit;
    const CutoutMask* cut = nullptr;  // the mesh's cut-outs (null: none; every hit is solid)
    const TriangleMesh* mesh = nullptr;
};

// Whether the hit of triangle `id` (lane k of `blocks`) is solid: always without cut-outs;
// for a cut-out triangle the alpha test at IntersectPrepared's barycentrics (brute force's
// IntersectTriangle's, bit for bit). `th` carries them already when `bary` says so.
[[gnu::always_inline]] inline bool SolidHit(const CellSpan& c, const NestedGridAccel::TriBlock* blocks, uint32_t k,
                                            const detail::PreparedRay& ray, TriangleHit th, bool bary) {
    const uint32_t id = blocks[k / 8].id[k % 8];
    if (!c.cut->IsCutout(id)) return true;
    if (!bary) {
        float v[9];
        for (int row = 0; row < 9; ++row) v[row] = blocks[k / 8].v[row][k % 8];
        if (!detail::IntersectPrepared(ray, v, &th)) return false;
    }
    return c.cut->Solid(*c.mesh, id, th.b1, th.b2);
}

// Calls test(id, hit) for triangles of the cell the ray hits (IntersectPrepared's answer on
// the block's copy of its vertices), in the cell's order, until test returns true (then
// returns true). With kNearestOnly, of the hits the filter decides alone (no tie-break)
// in one call only the nearest (the lowest id at equal t) is handed on: a closest-hit
// query keeps no other. Hits the filter decided carry only t (b0, b1, b2 are not computed)
// unless kNearestOnly, whose filter computes them as the scalar test does (re-running that
// test on the nearest hit for them was ~9 % of a camera ray's instructions).
//
// With kAnyHit (occlusion: the first hit ends the query) the filter stops at the first block
// that holds a hit, and a hit of a neighbouring cell's lane in a shared block counts too:
// every lane of the blocks is a triangle of the mesh (the last block's spare lanes are
// degenerate and never hit), and the filter's hit is IntersectPrepared's, so that triangle
// is one brute force finds on the ray as well. Exact, and a blocked segment skips the rest
// of its cell's blocks. (So kAnyHit is for a query that any hit ends: the filter's hits
// return true without calling `test`, which sees only the tie-breaks' hits.)
template <bool kNearestOnly, bool kAnyHit = false, typename Test>
[[gnu::always_inline]] inline bool ForEachHit(const CellSpan& c, const detail::PreparedRay& ray, Test&& test) {
    // The blocks that hold the cell's lanes, up to 8 (64 lanes) per filter call; lanes of
    // the neighbouring cells that share the first and last block are masked off.
    const uint64_t begin = c.first, end = begin + c.count;
    for (uint64_t b0 = begin / 8; b0 * 8 < end; b0 += 8) {
        const uint64_t base = b0 * 8, stop = std::min(end, base + 64);
        const NestedGridAccel::TriBlock* blocks = c.blocks + b0;
        float t[64];  // not over-aligned: the walk's frame needs no realignment
        float bary[kNearestOnly ? 3 * 64 : 1];
        uint64_t ties;
        uint64_t hits = (kNearestOnly ? c.nearestFilter : kAnyHit ? c.anyFilter : c.filter)(
            blocks, static_cast<uint32_t>((stop - base + 7) / 8), ray, t, &ties, bary);
        const uint64_t lo = begin > base ? begin - base : 0, hi = stop - base;
        const uint64_t own = (hi == 64 ? ~uint64_t(0) : (uint64_t(1) << hi) - 1) & ~((uint64_t(1) << lo) - 1);
        if constexpr (kAnyHit) {
            if (hits && !c.cut) return true;  // any hit ends an occlusion query
            // With cut-outs, any solid hit (a neighbouring cell's lane too: every lane is a
            // triangle of the mesh).
            for (uint64_t m = hits; m; m &= m - 1) {
                TriangleHit th;
                th.t = t[__builtin_ctzll(m)];
                if (SolidHit(c, blocks, static_cast<uint32_t>(__builtin_ctzll(m)), ray, th, false)) return true;
            }
            hits = 0;
        }
        hits &= own;
        ties &= own;
        auto scalar = [&](uint32_t k) {
            const NestedGridAccel::TriBlock& block = blocks[k / 8];
            float v[9];
            for (int row = 0; row < 9; ++row) v[row] = block.v[row][k % 8];
            TriangleHit th;
            return detail::IntersectPrepared(ray, v, &th) && (!c.cut || SolidHit(c, blocks, k, ray, th, true)) &&
                   test(block.id[k % 8], th);
        };
        if constexpr (kNearestOnly) {
            while (hits) {
                // Lanes are in id order, so the first of equal t has the lowest id.
                uint32_t nearest = static_cast<uint32_t>(__builtin_ctzll(hits));
                for (uint64_t m = hits & (hits - 1); m; m &= m - 1) {
                    const uint32_t k = static_cast<uint32_t>(__builtin_ctzll(m));
                    if (t[k] < t[nearest]) nearest = k;
                }
                const TriangleHit th{t[nearest], bary[nearest], bary[64 + nearest], bary[128 + nearest]};
                // A hole of a cut-out triangle: the next nearest.
                if (c.cut && !SolidHit(c, blocks, nearest, ray, th, true)) {
                    hits &= ~(uint64_t(1) << nearest);
                    continue;
                }
                if (test(blocks[nearest / 8].id[nearest % 8], th)) return true;
                break;
            }
        } else {
            for (; hits; hits &= hits - 1) {
                const uint32_t k = static_cast<uint32_t>(__builtin_ctzll(hits));
                TriangleHit th;
                th.t = t[k];
                if (c.cut && !SolidHit(c, blocks, k, ray, th, false)) continue;
                if (test(blocks[k / 8].id[k % 8], th)) return true;
            }
        }
        for (; ties; ties &= ties - 1)
            if (scalar(static_cast<uint32_t>(__builtin_ctzll(ties)))) return true;
    }
    return false;
}

// The three kinds of query the one traversal serves. Cell() tests a leaf cell's triangles
// and returns true to stop the walk.
struct ClosestQuery {
    explicit ClosestQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    Hit best;
    bool found = false;

    static constexpr bool kClosest = true;

    // A hit of triangle `id` (IntersectPrepared's answer for this ray).
    void Offer(uint32_t id, float t, float b1, float b2) {
        // ray.tMax is just above the best t, so equal-t hits arrive here too: brute force
        // keeps the lowest primitive id among them, and so do we.
        if (found && t == best.t && id > best.prim) return;
        best = Hit{t, id, b1, b2};
        found = true;
        ray.tMax = NextFloatUp(t);
    }
    [[gnu::always_inline]] bool Cell(const CellSpan& c) {
        ForEachHit<true>(c, ray, [&](uint32_t id, const TriangleHit& th) {
            Offer(id, th.t, th.b1, th.b2);
            return false;
        });
        // Every triangle that could be hit before the ray leaves this cell overlaps this
        // cell (or an earlier one), so a hit within the cell is final.
        return found && best.t <= c.tCellExit;
    }
    // For packets: the farthest t a hit could still improve on, and whether the ray is done
    // whatever it meets later.
    float Cap() const { return found ? best.t : Infinity; }
    bool Finished() const { return false; }
    // The id a hit at t == Cap() must be below to win.
    int CapId() const { return found ? int(best.prim) : INT32_MAX; }
};

struct AnyQuery {
    explicit AnyQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    bool found = false;

    [[gnu::always_inline]] bool Cell(const CellSpan& c) {
        found = ForEachHit<false, true>(c, ray, [](uint32_t, const TriangleHit&) { return true; });
        return found;
    }
    static constexpr bool kClosest = false;

    float Cap() const { return found ? -Infinity : Infinity; }
    bool Finished() const { return found; }
    int CapId() const { return INT32_MAX; }
};

struct CountQuery {
    explicit CountQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    // The triangles hit so far: a triangle spanning cells is met in each of them and must
    // count once. Hits are few (crossings along one ray), so a linear search of a small
    // array is the cheapest exact set.
    static constexpr int kLocal = 64;
    uint32_t local[kLocal];
    int count = 0;
    std::vector<uint32_t> overflow;

    bool Counted(uint32_t id) const {
        const int n = std::min(count, kLocal);
        for (int i = 0; i < n; ++i)
            if (local[i] == id) return true;
        return std::find(overflow.begin(), overflow.end(), id) != overflow.end();
    }
    [[gnu::always_inline]] bool Cell(const CellSpan& c) {
        ForEachHit<false>(c, ray, [&](uint32_t id, const TriangleHit&) {
            if (Counted(id)) return false;
            if (count < kLocal)
                local[count] = id;
            else
                overflow.push_back(id);
            ++count;
            return false;
        });
        return false;
    }
};

}  // namespace

// ---------------------------------------------------------------------------------------
// Traversal: one 3D-DDA (Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray
// Tracing", 1987) for all three query kinds.

template <typename Query>
bool NestedGridAccel::Walk(uint32_t nodeIndex, const Ray& ray, const Vec3& invD, float tEnter, float tExit, Query& query) const {
    const Node& g = nodes_[nodeIndex];
    // The plane crossings are recomputed from the plane's index at every step rather than
    // accumulated (nextT += deltaT), so their error does not grow along a long ray.
    auto planeT = [&](int a, int k) { return (g.lo[a] + float(k) * g.cellSize[a] - ray.o[a]) * invD[a]; };
    // The cell of the ray's point at t along axis a, clamped: rounding may put the point a
    // hair outside. (A truncating conversion is floor for f >= 0; std::floor would be a
    // libm call.)
    auto cellAt = [&](int a, float t) {
        const float f = (ray.o[a] + ray.d[a] * t - g.lo[a]) * g.invCellSize[a];
        return !(f > 0) ? 0 : (f >= float(g.res[a]) ? g.res[a] - 1 : int(f));
    };
    const int sx = ray.d.x > 0 ? 1 : (ray.d.x < 0 ? -1 : 0), sy = ray.d.y > 0 ? 1 : (ray.d.y < 0 ? -1 : 0),
              sz = ray.d.z > 0 ? 1 : (ray.d.z < 0 ? -1 : 0);
    const int ox = sx > 0, oy = sy > 0, oz = sz > 0;  // the far plane of a cell
    const int stopX = sx > 0 ? g.res[0] : -1, stopY = sy > 0 ? g.res[1] : -1, stopZ = sz > 0 ? g.res[2] : -1;
    const uint32_t strideY = uint32_t(g.res[0]), strideZ = uint32_t(g.res[0] * g.res[1]);
    const uint32_t dx = uint32_t(sx), dy = uint32_t(sy) * strideY, dz = uint32_t(sz) * strideZ;
    // The loop state in scalars, so it stays in registers (indexing small arrays by the
    // axis of each step goes through memory and serialises the steps).
    int cx, cy, cz;
    float tx, ty, tz;
    uint32_t idx;
    auto enter = [&](float t) {
        cx = cellAt(0, t);
        cy = cellAt(1, t);
        cz = cellAt(2, t);
        tx = sx ? planeT(0, cx + ox) : Infinity;
        ty = sy ? planeT(1, cy + oy) : Infinity;
        tz = sz ? planeT(2, cz + oz) : Infinity;
        idx = g.firstCell + uint32_t(cx) + uint32_t(cy) * strideY + uint32_t(cz) * strideZ;
    };
    enter(tEnter);
    float tCell = tEnter;
    // The cells' content boxes (CellRef), the three axes in the lanes of one vector. Along
    // an axis the ray moves on, t of a box face is t of the cell's low plane plus its steps
    // times the t across one step (signed); t of the cell's low plane is the walk's t of its
    // far plane (tx, ty, tz) or one cell before it. The box is grown by rounding's reach, in
    // t. An axis the ray does not move along, and the fourth lane, get (-∞, ∞): the cell
    // holds the ray's coordinate there.
    using F4 = SimdVectors<4>::F;
    using I4 = SimdVectors<4>::I;
    typedef uint16_t U16x4 __attribute__((vector_size(8)));
    const float reach = RoundingReach(std::max({std::abs(ray.o.x), std::abs(ray.o.y), std::abs(ray.o.z)}));
    const F4 invV = {invD.x, invD.y, invD.z, 0.0f};
    const F4 absInv = {std::abs(invD.x), std::abs(invD.y), std::abs(invD.z), 0.0f};
    const I4 moves = {sx ? -1 : 0, sy ? -1 : 0, sz ? -1 : 0, 0};
    const F4 sizeV = {g.cellSize.x, g.cellSize.y, g.cellSize.z, 0.0f};
    const F4 zeroV = {};
    const F4 stepV = reinterpret_cast<F4>(reinterpret_cast<I4>(sizeV * (1.0f / kBoxSteps) * invV) & moves);
    const F4 lowV = reinterpret_cast<F4>(reinterpret_cast<I4>(invV > zeroV ? -sizeV * invV : zeroV) & moves);
    const F4 padV = reinterpret_cast<F4>(reinterpret_cast<I4>(reach * absInv) & moves);
    const I4 nearRest = ~moves & reinterpret_cast<I4>(zeroV - Infinity);
    const I4 farRest = ~moves & reinterpret_cast<I4>(zeroV + Infinity);
    // Whether the ray's stretch [tCell, tCellExit] through the cell meets its content box.
    // (A NaN lane is dropped by the min / max, or fails the last comparison: the cell is
    // then tested.)
    auto meetsBox = [&](const CellRef& ref, float tCellExit) {
        U16x4 qLo, qHi;
        std::memcpy(&qLo, ref.box, sizeof qLo);
        std::memcpy(&qHi, ref.box + 4, sizeof qHi);
        const F4 tLow = F4{tx, ty, tz, 0.0f} + lowV;
        const F4 t0 = tLow + __builtin_convertvector(__builtin_convertvector(qLo, I4), F4) * stepV;
        const F4 t1 = tLow + __builtin_convertvector(__builtin_convertvector(qHi, I4), F4) * stepV;
        F4 n = reinterpret_cast<F4>((reinterpret_cast<I4>((t0 < t1 ? t0 : t1) - padV) & moves) | nearRest);
        F4 f = reinterpret_cast<F4>((reinterpret_cast<I4>((t0 > t1 ? t0 : t1) + padV) & moves) | farRest);
        const F4 n2 = __builtin_shufflevector(n, n, 2, 3, 0, 1), f2 = __builtin_shufflevector(f, f, 2, 3, 0, 1);
        n = n > n2 ? n : n2;
        f = f < f2 ? f : f2;
        const F4 n1 = __builtin_shufflevector(n, n, 1, 0, 3, 2), f1 = __builtin_shufflevector(f, f, 1, 0, 3, 2);
        n = n > n1 ? n : n1;
        f = f < f1 ? f : f1;
        const float lo = n[0] > tCell ? n[0] : tCell, hi = f[0] < tCellExit ? f[0] : tCellExit;
        return !(lo > hi);
    };
    const uint64_t* occupied = occupied_.data();
    // Empty space (top level): an empty cell knows how far the empty cells ahead of the ray
    // reach, by the cubes of the ray's octant where they were computed, else the centred
    // boxes (either way value - 1 cells ahead along each axis are empty); nullptr without.
    const uint8_t* empty =
        nodeIndex == 0 ? jumpReach_ + size_t((sx < 0) | (sy < 0) << 1 | (sz < 0) << 2) * jumpReachStride_ : nullptr;
    for (;;) {
        const float tNext = std::min(tx, std::min(ty, tz));
        const float tCellExit = std::min(tNext, tExit);
        // Most cells are empty; their bit (a small array that stays in cache) spares the
        // load from the much larger cells_.
        if ((occupied[idx >> 6] >> (idx & 63)) & 1) {
            const CellRef& ref = cells_[idx];
            if (!meetsBox(ref, tCellExit)) {
                // Nothing the cell holds is on this stretch of the ray.
            } else if (ref.count & kChildBit) {
                if (Walk(ref.count & ~kChildBit, ray, invD, tCell, tCellExit, query)) return true;
            } else {
                const CellSpan span{blocks_.get(), ref.first, ref.count, filter_,     nearestFilter_,
                                    anyFilter_,    tCellExit, mesh_.cutouts.get(), &mesh_};
                if (query.Cell(span)) return true;
            }
        } else if (empty && empty[idx] > 2) {
            // Every cell within empty[idx] - 1 steps of this one on each axis, towards the
            // ray's octant, is empty: go to where the ray leaves that box (the box's far
            // planes; the ray started in this cell, so it is inside the box until then) and
            // start there as at the entry. The cell of
            // that point is rounded like the entry's, which the cells' growth covers; t
            // only increases, so the walk ends. A re-entry costs about what three or four
            // steps do (the three cells and crossings recomputed), so a box one cell deep
            // (empty[idx] == 2), which spares at most a step or two, is stepped through
            // (callgrind, bench_accel's camera rays: 4.5 % fewer instructions on the
            // gazebo, 2.5 % on the stadium; 3 or 4 gained no more).
            const int k = empty[idx] - 1;
            float tJump = tExit;
            if (sx) tJump = std::min(tJump, planeT(0, sx > 0 ? std::min(cx + k, g.res[0] - 1) + 1 : std::max(cx - k, 0)));
            if (sy) tJump = std::min(tJump, planeT(1, sy > 0 ? std::min(cy + k, g.res[1] - 1) + 1 : std::max(cy - k, 0)));
            if (sz) tJump = std::min(tJump, planeT(2, sz > 0 ? std::min(cz + k, g.res[2] - 1) + 1 : std::max(cz - k, 0)));
            if (tJump > tNext && tJump > tCell) {
                if (!(tJump < tExit)) return false;
                tCell = tJump;
                enter(tJump);
                continue;
            }
        }
        // Written so that a NaN (from a ray the caller built out of overflowed values)
        // ends the walk instead of stepping along an axis the ray does not move on.
        if (!(tNext < tExit)) return false;
        tCell = tNext;
        // Step across the nearest plane (at a tie, either: the other follows at once).
        if (tx == tNext) {
            cx += sx;
            if (cx == stopX) return false;
            idx += dx;
            tx = planeT(0, cx + ox);
        } else if (ty == tNext) {
            cy += sy;
            if (cy == stopY) return false;
            idx += dy;
            ty = planeT(1, cy + oy);
        } else {
            cz += sz;
            if (cz == stopZ) return false;
            idx += dz;
            tz = planeT(2, cz + oz);
        }
    }
}

namespace {

// Clips the ray's (tMin, tMax) to the box into [*t0, *t1], with 1/d per axis in *invD (∞
// where d is 0: such an axis cannot be crossed, so the ray only has to start between its
// slabs, and 0 · ∞ never happens). False if the ray misses the box or does not move.
[[gnu::always_inline]] inline bool ClipToBox(const Ray& ray, const Bounds3& box, Vec3* invD, float* t0, float* t1) {
    float lo = ray.tMin, hi = ray.tMax;
    bool moves = false;
    for (int a = 0; a < 3; ++a) {
        const float d = ray.d[a];
        if (d == 0) {
            if (!(ray.o[a] >= box.lo[a] && ray.o[a] <= box.hi[a])) return false;
            (*invD)[a] = Infinity;
            continue;
        }
        moves = true;
        (*invD)[a] = 1.0f / d;
        float tn = (box.lo[a] - ray.o[a]) * (*invD)[a];
        float tf = (box.hi[a] - ray.o[a]) * (*invD)[a];
        if (tn > tf) std::swap(tn, tf);
        lo = std::max(lo, tn);
        hi = std::min(hi, tf);
    }
    *t0 = lo;
    *t1 = hi;
    return moves && lo <= hi;
}

}  // namespace

template <typename Query>
void NestedGridAccel::Traverse(const Ray& ray, Query& query) const {
    Vec3 invD;
    float t0, t1;
    if (ClipToBox(ray, box_, &invD, &t0, &t1)) Walk(0, ray, invD, t0, t1, query);
}

// ---------------------------------------------------------------------------------------
// Packets: coherent grid traversal (Wald, Ize, Kensler, Knoll & Parker, "Ray Tracing
// Animated Scenes using Coherent Grid Traversal", SIGGRAPH 2006) on the nested grid.
//
// The rays of a packet share the sign of their direction along one axis K. A level is
// walked slice by slice along K (a slice: the cells with one K index). In a slice each
// ray's stretch [a, b] covers a rectangle of cells, padded by how far rounding may put a
// computed point; the packet visits the union of the rectangles once, and hands each
// occupied cell to the rays whose rectangle holds it (a sub-grid is walked the same way
// for those rays). So a ray tests every cell its own walk would, and perhaps a few more,
// with the same exact triangle test and tie rule. A ray is finished when its best hit lies
// before the next slice's entry plane moved back by the padding: every triangle through a
// point before that plane overlaps a cell of a slice already visited, one in the ray's
// rectangle there. Each ray therefore ends with the answer its own walk gives.

struct NestedGridAccel::PacketLanes {
    static constexpr int kMax = kPacketSize;
    int width = 0;           // lanes the vector loops run over (a multiple of 8)
    int K = 0, U = 1, V = 2;  // the slicing axis and the other two
    int s = 1;               // the rays' direction along K
    float pad = 0;           // world units: how far rounding may put a computed point
    float slope = 0;         // top-level cells a ray moves sideways (U or V) per slice, at most
    uint64_t live = 0;       // lanes still walking the top level
    // What the top level's slices are skipped by: the empty cubes of the rays' octant when
    // they share one (octantReach_), else the centred boxes (emptyReach_), or nullptr.
    const uint8_t* skipReach = nullptr;
    alignas(32) float oK[kMax], oU[kMax], oV[kMax], dK[kMax], dU[kMax], dV[kMax], invK[kMax];
    alignas(32) float t0[kMax], t1[kMax];  // each ray's range clipped to the box
    alignas(32) float cap[kMax];           // Query::Cap(): hits beyond it cannot win
    const Ray* ray[kMax];
    Vec3 invD[kMax];
    // The watertight test's frame (PreparedRay's axes) of the first lane, the lanes that
    // share it (in a coherent packet, nearly all), and their rays in it: a leaf cell tests
    // one triangle against W of them at once (PacketLeaf in grid_packet_walk.inc).
    int fkx = 0, fky = 1, fkz = 2;
    uint64_t frameLanes = 0;
    alignas(32) float fox[kMax], foy[kMax], foz[kMax], fsx[kMax], fsy[kMax], fsz[kMax], ftMin[kMax], ftMax[kMax];
    alignas(32) int capId[kMax];  // Query::CapId()
};

// One slice of one level as the packet's rays cross it: each ray's stretch [a, b], the
// rectangle [uLo, uHi] × [vLo, vHi] its points there lie in (padded by the packet's `pad`),
// and the cells (u0 … u1) × (v0 … v1) of that rectangle; empty ranges for rays not in the
// slice.
struct NestedGridAccel::SliceLanes {
    static constexpr int kMax = kPacketSize;
    alignas(32) float a[kMax], b[kMax];
    alignas(32) float uLo[kMax], uHi[kMax], vLo[kMax], vHi[kMax];
    alignas(32) int u0[kMax], u1[kMax];
    alignas(32) int v0[kMax], v1[kMax];
};

namespace {

// Whether the rays' directions lie within a narrow cone (cosine to their mean direction at
// least kCoherentCos): only then does a packet's footprint stay a few cells wide. The light
// mesh's segments to a point from around it, and a point's rays to several lights, are
// not; a tile's camera rays, or its shadow rays to one light, mostly are.
constexpr float kCoherentCos = 0.9f;
bool Coherent(const Ray* rays, size_t count, Vec3* mean) {
    Vec3 sum(0, 0, 0);
    for (size_t i = 0; i < count; ++i) {
        const float len2 = LengthSquared(rays[i].d);
        if (!(len2 > 0 && len2 < Infinity)) return false;
        sum += rays[i].d / std::sqrt(len2);
    }
    const float len = Length(sum);
    if (!(len > 0)) return false;
    *mean = sum / len;
    // cos >= kCoherentCos, squared (no second square root per ray).
    for (size_t i = 0; i < count; ++i) {
        const float dot = Dot(rays[i].d, *mean);
        if (!(dot > 0 && dot * dot >= kCoherentCos * kCoherentCos * LengthSquared(rays[i].d))) return false;
    }
    return true;
}

}  // namespace

template <typename Query>
void NestedGridAccel::PacketWalk(uint32_t nodeIndex, PacketLanes& p, uint64_t lanes, const float* tLo,
                                 const float* tHi, Query* q) const {
#if defined(__x86_64__) || defined(__i386__)
    if (simdWidth_ == 8) {
        PacketWalkLanes8(nodeIndex, p, lanes, tLo, tHi, q);
        return;
    }
#endif
    PacketWalkLanes4(nodeIndex, p, lanes, tLo, tHi, q);
}

// The packet's walk of one level, 4 lanes at a time (SSE, the x86-64 baseline) and 8 (AVX2,
// compiled for it with a target attribute on each definition, which GCC and clang both honour,
// and chosen at run time): one body, grid_packet_walk.inc.
#define LM_PACKET_LANES 4
#define LM_PACKET_TARGET
#define LM_PACKET_WALK_LANES PacketWalkLanes4
#define LM_PACKET_LEAF PacketLeaf4
#include "lightmesh/accel/grid_packet_walk.inc"
#undef LM_PACKET_LANES
#undef LM_PACKET_TARGET
#undef LM_PACKET_WALK_LANES
#undef LM_PACKET_LEAF
#if defined(__x86_64__) || defined(__i386__)
#define LM_PACKET_LANES 8
#define LM_PACKET_TARGET __attribute__((target("avx2")))
#define LM_PACKET_WALK_LANES PacketWalkLanes8
#define LM_PACKET_LEAF PacketLeaf8
#include "lightmesh/accel/grid_packet_walk.inc"
#undef LM_PACKET_LANES
#undef LM_PACKET_TARGET
#undef LM_PACKET_WALK_LANES
#undef LM_PACKET_LEAF
#endif

template <typename Query>
void NestedGridAccel::TraceMany(const Ray* rays, size_t count, Query* q) const {
    // One packet: InPackets hands over at most kPacketSize rays.
    Vec3 mean;
    if (count < 4 || !Coherent(rays, count, &mean)) {
        for (size_t i = 0; i < count; ++i) Traverse(rays[i], q[i]);
        return;
    }
    // The slicing axis: the mean direction's largest; Coherent's cone keeps every ray's
    // component along it of the mean's sign and away from zero.
    const int K = MaxDimension(Abs(mean));
    const int n = int(count);
    PacketLanes p;
    p.K = K;
    p.U = K == 0 ? 1 : 0;
    p.V = K == 2 ? 1 : 2;
    p.s = mean[K] > 0 ? 1 : -1;
    p.width = (n + 7) & ~7;
    float originAbs = 0;
    for (int i = 0; i < p.width; ++i) {
        p.oK[i] = p.oU[i] = p.oV[i] = p.dK[i] = p.dU[i] = p.dV[i] = p.invK[i] = 0;
        p.t0[i] = p.t1[i] = p.cap[i] = 0;
        p.fox[i] = p.foy[i] = p.foz[i] = p.fsx[i] = p.fsy[i] = p.fsz[i] = p.ftMin[i] = p.ftMax[i] = 0;
        p.capId[i] = 0;
        if (i >= n) continue;
        const Ray& ray = rays[i];
        float t0, t1;
        // A ray that misses the box has nothing to hit; one not along the packet's
        // sign (impossible inside the cone, kept for safety) walks alone.
        if (!ClipToBox(ray, box_, &p.invD[i], &t0, &t1)) continue;
        if (!(ray.d[K] * float(p.s) > 0)) {
            Walk(0, ray, p.invD[i], t0, t1, q[i]);
            continue;
        }
        p.ray[i] = &ray;
        p.oK[i] = ray.o[K], p.oU[i] = ray.o[p.U], p.oV[i] = ray.o[p.V];
        p.dK[i] = ray.d[K], p.dU[i] = ray.d[p.U], p.dV[i] = ray.d[p.V];
        p.invK[i] = p.invD[i][K];
        p.t0[i] = t0, p.t1[i] = t1;
        p.cap[i] = q[i].Cap();
        p.capId[i] = q[i].CapId();
        p.live |= uint64_t(1) << i;
        originAbs = std::max({originAbs, std::abs(ray.o.x), std::abs(ray.o.y), std::abs(ray.o.z)});
        const detail::PreparedRay& pr = q[i].ray;
        if (!pr.valid) continue;
        if (!p.frameLanes) p.fkx = pr.kx, p.fky = pr.ky, p.fkz = pr.kz;
        if (pr.kx != p.fkx || pr.ky != p.fky || pr.kz != p.fkz) continue;
        p.frameLanes |= uint64_t(1) << i;
        p.fox[i] = pr.o[pr.kx], p.foy[i] = pr.o[pr.ky], p.foz[i] = pr.o[pr.kz];
        p.fsx[i] = pr.sx, p.fsy[i] = pr.sy, p.fsz[i] = pr.sz;
        p.ftMin[i] = pr.tMin, p.ftMax[i] = pr.tMax;
    }
    if (!p.live) return;
    const Node& top = nodes_[0];
    for (uint64_t m = p.live; m; m &= m - 1) {
        const int i = __builtin_ctzll(m);
        const float perSlice = std::abs(top.cellSize[K] * p.invK[i]);  // t across one slice
        p.slope = std::max({p.slope, std::abs(p.dU[i]) * perSlice * top.invCellSize[p.U],
                            std::abs(p.dV[i]) * perSlice * top.invCellSize[p.V]});
    }
    // A little more for rounding, so that the empty-space skip stays conservative.
    p.slope = p.slope * 1.001f + 1e-3f;
    // A ray that moves sideways only into the octant's side (or not at all) stays in the
    // cube of the octant at its cell (the skip's bound below is the centred box's).
    bool uPos = false, uNeg = false, vPos = false, vNeg = false;
    for (uint64_t m = p.live; m; m &= m - 1) {
        const int i = __builtin_ctzll(m);
        uPos |= p.dU[i] > 0, uNeg |= p.dU[i] < 0, vPos |= p.dV[i] > 0, vNeg |= p.dV[i] < 0;
    }
    if ((uPos && uNeg) || (vPos && vNeg))
        p.skipReach = emptyReach_.empty() ? nullptr : emptyReach_.data();
    else
        p.skipReach = jumpReach_ + size_t((p.s < 0) << K | int(uNeg) << p.U | int(vNeg) << p.V) * jumpReachStride_;
    // Rounding of o + d·t and of the planes' t is a few ulps of the coordinates
    // involved; the cells' growth (epsAbs_) covers the walk's own rounding.
    p.pad = RoundingReach(originAbs);
    PacketWalk(0, p, p.live, p.t0, p.t1, q);
}

namespace {

// Runs trace(rays, n, queries) over `count` rays in chunks of NestedGridAccel::kPacketSize,
// with a Query built for each ray in place, and hands each finished query to
// answer(index, query).
template <typename Query, typename Trace, typename Answer>
void InPackets(const Ray* rays, size_t count, Trace&& trace, Answer&& answer) {
    constexpr size_t kSize = NestedGridAccel::kPacketSize;
    for (size_t first = 0; first < count; first += kSize) {
        const size_t n = std::min(count - first, kSize);
        alignas(Query) unsigned char storage[kSize * sizeof(Query)];
        auto* q = reinterpret_cast<Query*>(storage);
        for (size_t i = 0; i < n; ++i) new (q + i) Query(rays[first + i]);
        trace(rays + first, n, q);
        for (size_t i = 0; i < n; ++i) answer(first + i, q[i]);
    }
}

}  // namespace

void NestedGridAccel::IntersectMany(const Ray* rays, size_t count, Hit* hits) const {
    // Cut-outs: ray by ray (the packet leaf test keeps one nearest hit per ray).
    if (mesh_.cutouts) return Accelerator::IntersectMany(rays, count, hits);
    InPackets<ClosestQuery>(
        rays, count, [&](const Ray* r, size_t n, ClosestQuery* q) { TraceMany(r, n, q); },
        [&](size_t i, const ClosestQuery& q) { hits[i] = q.found ? q.best : Hit{}; });
}

void NestedGridAccel::OccludedMany(const Ray* rays, size_t count, bool* occluded) const {
    if (mesh_.cutouts) return Accelerator::OccludedMany(rays, count, occluded);
    InPackets<AnyQuery>(
        rays, count, [&](const Ray* r, size_t n, AnyQuery* q) { TraceMany(r, n, q); },
        [&](size_t i, const AnyQuery& q) { occluded[i] = q.found; });
}

bool NestedGridAccel::Intersect(const Ray& ray, Hit* hit) const {
    ClosestQuery q(ray);
    Traverse(ray, q);
    if (q.found) *hit = q.best;
    return q.found;
}

bool NestedGridAccel::Occluded(const Ray& ray) const {
    AnyQuery q(ray);
    Traverse(ray, q);
    return q.found;
}

int NestedGridAccel::CountCrossings(const Ray& ray) const {
    CountQuery q(ray);
    Traverse(ray, q);
    return q.count;
}

}  // namespace lm
