// grid.cpp -- the nested uniform grid of the paper's section 2: the single-ray queries, by a
// 3D-DDA walk of the levels. The build is grid_build.cpp, the leaf cells' SIMD triangle filter
// grid_filter.cpp, the packets of coherent rays grid_packet.cpp.
#include "lightmesh/accel/grid.h"
#include "lightmesh/accel/grid_queries.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "lightmesh/math/simd.h"

namespace lm {

using grid_detail::AnyQuery;
using grid_detail::CellSpan;
using grid_detail::ClosestQuery;
using grid_detail::CountQuery;

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

template <typename Query>
void NestedGridAccel::Traverse(const Ray& ray, Query& query) const {
    Vec3 invD;
    float t0, t1;
    if (grid_detail::ClipToBox(ray, box_, &invD, &t0, &t1)) Walk(0, ray, invD, t0, t1, query);
}

// The packets' walk (grid_packet.cpp) hands rays to these too.
template bool NestedGridAccel::Walk<ClosestQuery>(uint32_t, const Ray&, const Vec3&, float, float, ClosestQuery&) const;
template bool NestedGridAccel::Walk<AnyQuery>(uint32_t, const Ray&, const Vec3&, float, float, AnyQuery&) const;
template void NestedGridAccel::Traverse<ClosestQuery>(const Ray&, ClosestQuery&) const;
template void NestedGridAccel::Traverse<AnyQuery>(const Ray&, AnyQuery&) const;

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
