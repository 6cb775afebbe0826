// grid.cpp -- the nested uniform grid of the paper's section 2: the queries, by 3D-DDA
// traversal, and their SIMD triangle filter. The build is grid_build.cpp.
#include "lightmesh/accel/grid.h"
#include "lightmesh/accel/grid_internal.h"

#include <algorithm>
#include <utility>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

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

// Lanes h … h+W-1 of a block: all ones where IntersectPrepared may report a hit. A lane
// without an exactly zero edge function is decided here with the scalar test's own
// operations (edge signs, det, t and its range), so it is set exactly when that test hits;
// a lane with a zero edge function (the tie-breaks, in double) is always set.
template <int W>
[[gnu::always_inline]] inline void FilterLanes(const NestedGridAccel::TriBlock& block, int h, const FilterRay<W>& r,
                                               typename SimdVectors<W>::I* lanes) {
    using VF = typename SimdVectors<W>::F;
    using VI = typename SimdVectors<W>::I;
    const VF zero = {};
    auto at = [&](int row) -> const VF& { return *reinterpret_cast<const VF*>(&block.v[row][h]); };
    const int kx = r.kx, ky = r.ky, kz = r.kz;
    const VF aZ = at(kz) - r.oz, bZ = at(3 + kz) - r.oz, cZ = at(6 + kz) - r.oz;
    const VF ax = (at(kx) - r.ox) - r.sx * aZ, ay = (at(ky) - r.oy) - r.sy * aZ;
    const VF bx = (at(3 + kx) - r.ox) - r.sx * bZ, by = (at(3 + ky) - r.oy) - r.sy * bZ;
    const VF cx = (at(6 + kx) - r.ox) - r.sx * cZ, cy = (at(6 + ky) - r.oy) - r.sy * cZ;
    const VF cu = cx * by - cy * bx, cv = ax * cy - ay * cx, cw = bx * ay - by * ax;
    const VI neg = (cu < zero) | (cv < zero) | (cw < zero);
    const VI pos = (cu > zero) | (cv > zero) | (cw > zero);
    const VI zeroEdge = (cu == zero) | (cv == zero) | (cw == zero);
    // As IntersectPrepared without a zero edge: d0 = u + v + w, sign = d0 > 0 ? 1 : -1,
    // (u, v, w) ·= sign, det = u + v + w > 0, t = (u·az + v·bz + w·cz) / det in range.
    const VF d0 = cu + cv + cw;
    const VI positive = d0 > zero;
    const VF one = zero + 1.0f, minusOne = zero - 1.0f;
    const VF sign = reinterpret_cast<VF>((positive & reinterpret_cast<VI>(one)) | (~positive & reinterpret_cast<VI>(minusOne)));
    const VF u = cu * sign, v = cv * sign, w = cw * sign;
    const VF det = u + v + w;
    const VF az = r.sz * aZ, bz = r.sz * bZ, cz = r.sz * cZ;
    const VF t = (u * az + v * bz + w * cz) / det;
    const VI hit = ~(neg & pos) & (d0 != zero) & (det > zero) & (t > r.tMin) & (t < r.tMax);
    *lanes = zeroEdge | hit;
}

}  // namespace

namespace grid_detail {

uint64_t FilterBlocks4(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray) {
    if (!ray.valid) return 0;
    const FilterRay<4> r(ray);
    uint64_t mask = 0;
    for (uint32_t b = 0; b < count; ++b)
        for (int h = 0; h < 8; h += 4) {
            SimdVectors<4>::I lanes;
            FilterLanes<4>(blocks[b], h, r, &lanes);
#if defined(__x86_64__) || defined(__i386__)
            const uint64_t bits = static_cast<uint32_t>(_mm_movemask_ps(reinterpret_cast<__m128>(lanes)));
#else
            uint64_t bits = 0;
            for (int k = 0; k < 4; ++k) bits |= uint64_t(lanes[k] != 0) << k;
#endif
            mask |= bits << (8 * b + h);
        }
    return mask;
}
#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("avx2"))) uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count,
                                                       const detail::PreparedRay& ray) {
    if (!ray.valid) return 0;
    const FilterRay<8> r(ray);
    uint64_t mask = 0;
    for (uint32_t b = 0; b < count; ++b) {
        SimdVectors<8>::I lanes;
        FilterLanes<8>(blocks[b], 0, r, &lanes);
        mask |= uint64_t(static_cast<uint32_t>(_mm256_movemask_ps(reinterpret_cast<__m256>(lanes)))) << (8 * b);
    }
    return mask;
}
bool HasAvx2() { return __builtin_cpu_supports("avx2"); }
#else
uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray) {
    return FilterBlocks4(blocks, count, ray);
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
    NestedGridAccel::BlockFilter filter;
    float tCellExit;
};

// Calls test(id, hit) for each triangle of the cell the ray hits (IntersectPrepared's
// answer on the block's copy of its vertices), in the cell's order, until test returns
// true (then returns true).
template <typename Test>
[[gnu::always_inline]] inline bool ForEachHit(const CellSpan& c, const detail::PreparedRay& ray, Test&& test) {
    // The blocks that hold the cell's lanes, up to 8 (64 lanes) per filter call; lanes of
    // the neighbouring cells that share the first and last block are masked off.
    const uint64_t begin = c.first, end = begin + c.count;
    for (uint64_t b0 = begin / 8; b0 * 8 < end; b0 += 8) {
        const uint64_t base = b0 * 8, stop = std::min(end, base + 64);
        const NestedGridAccel::TriBlock* blocks = c.blocks + b0;
        uint64_t mask = c.filter(blocks, static_cast<uint32_t>((stop - base + 7) / 8), ray);
        const uint64_t lo = begin > base ? begin - base : 0, hi = stop - base;
        mask &= (hi == 64 ? ~uint64_t(0) : (uint64_t(1) << hi) - 1) & ~((uint64_t(1) << lo) - 1);
        while (mask) {
            const uint32_t k = static_cast<uint32_t>(__builtin_ctzll(mask));
            mask &= mask - 1;
            const NestedGridAccel::TriBlock& block = blocks[k / 8];
            float v[9];
            for (int row = 0; row < 9; ++row) v[row] = block.v[row][k % 8];
            TriangleHit th;
            if (detail::IntersectPrepared(ray, v, &th) && test(block.id[k % 8], th)) return true;
        }
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

    bool Cell(const CellSpan& c) {
        ForEachHit(c, ray, [&](uint32_t id, const TriangleHit& th) {
            // ray.tMax is just above the best t, so equal-t hits arrive here too: brute
            // force keeps the lowest primitive id among them, and so do we.
            if (found && th.t == best.t && id > best.prim) return false;
            best = Hit{th.t, id, th.b1, th.b2};
            found = true;
            ray.tMax = NextFloatUp(th.t);
            return false;
        });
        // Every triangle that could be hit before the ray leaves this cell overlaps this
        // cell (or an earlier one), so a hit within the cell is final.
        return found && best.t <= c.tCellExit;
    }
};

struct AnyQuery {
    explicit AnyQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    bool found = false;

    bool Cell(const CellSpan& c) {
        found = ForEachHit(c, ray, [](uint32_t, const TriangleHit&) { return true; });
        return found;
    }
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
    bool Cell(const CellSpan& c) {
        ForEachHit(c, ray, [&](uint32_t id, const TriangleHit&) {
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
    const uint64_t* occupied = occupied_.data();
    // Empty space (top level): an empty cell knows how far the empty cells around it reach.
    const uint8_t* empty = nodeIndex == 0 && !emptyReach_.empty() ? emptyReach_.data() : nullptr;
    for (;;) {
        const float tNext = std::min(tx, std::min(ty, tz));
        const float tCellExit = std::min(tNext, tExit);
        // Most cells are empty; their bit (a small array that stays in cache) spares the
        // load from the much larger cells_.
        if ((occupied[idx >> 6] >> (idx & 63)) & 1) {
            const CellRef ref = cells_[idx];
            if (ref.count & kChildBit) {
                if (Walk(ref.count & ~kChildBit, ray, invD, tCell, tCellExit, query)) return true;
            } else {
                const CellSpan span{blocks_.get(), ref.first, ref.count, filter_, tCellExit};
                if (query.Cell(span)) return true;
            }
        } else if (empty && empty[idx] > 1) {
            // Every cell within empty[idx] - 1 steps of this one on each axis is empty: go
            // to where the ray leaves that box and start there as at the entry. The cell of
            // that point is rounded like the entry's, which the cells' growth covers; t
            // only increases, so the walk ends.
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

template <typename Query>
void NestedGridAccel::Traverse(const Ray& ray, Query& query) const {
    // Clip [tMin, tMax] to the box; a zero direction component cannot cross that axis'
    // slabs, so it only has to start between them (and 0 · ∞ never happens).
    float t0 = ray.tMin, t1 = ray.tMax;
    Vec3 invD;
    bool moves = false;
    for (int a = 0; a < 3; ++a) {
        const float d = ray.d[a];
        if (d == 0) {
            if (!(ray.o[a] >= box_.lo[a] && ray.o[a] <= box_.hi[a])) return;
            invD[a] = Infinity;
            continue;
        }
        moves = true;
        invD[a] = 1.0f / d;
        float tn = (box_.lo[a] - ray.o[a]) * invD[a];
        float tf = (box_.hi[a] - ray.o[a]) * invD[a];
        if (tn > tf) std::swap(tn, tf);
        t0 = std::max(t0, tn);
        t1 = std::min(t1, tf);
    }
    if (!moves || !(t0 <= t1)) return;
    Walk(0, ray, invD, t0, t1, query);
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
