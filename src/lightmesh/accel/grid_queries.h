// grid_queries.h -- the nested grid's three kinds of query (closest hit, any hit, crossing
// count) and what they do with a leaf cell the walk hands them (private to the grid): shared
// by the single-ray walk (grid.cpp) and the packets' walk (grid_packet.cpp).
#pragma once

#include <algorithm>
#include <climits>
#include <cstdint>
#include <utility>
#include <vector>

#include "lightmesh/accel/grid.h"
#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/triangle.h"

namespace lm::grid_detail {

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

}  // namespace lm::grid_detail
