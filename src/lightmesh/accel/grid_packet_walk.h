// grid_packet_walk.h -- the nested grid's packets (private to the grid, grid_packet.cpp's):
// a packet's rays lane by lane, and its walk of one level with its leaf test, W rays per
// vector instruction.
//
// The walk and the leaf test are templates on W in generic vector code, always inlined into
// their entry points: PacketWalkLanes4 (SSE, the x86-64 baseline) and PacketWalkLanes8,
// compiled for AVX2 with a target attribute and chosen at run time, so that the one body
// becomes the code of both instruction sets. A target attribute cannot depend on W, and it
// does not reach into functions the body calls; so the body's helpers are always_inline too
// and take 32-byte vectors by reference and return them through pointers (by value, outside
// AVX code, they would change the ABI), and the one AVX2 helper, LaneBits<8>, is inlined
// once the body is in the AVX2 entry point (grid_lanes.h).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <tuple>
#include <utility>

#include "lightmesh/accel/grid.h"
#include "lightmesh/accel/grid_lanes.h"
#include "lightmesh/accel/grid_queries.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/math/simd.h"

namespace lm {

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
    // one triangle against W of them at once (PacketLeaf).
    int fkx = 0, fky = 1, fkz = 2;
    uint64_t frameLanes = 0;
    alignas(32) float fox[kMax], foy[kMax], foz[kMax], fsx[kMax], fsy[kMax], fsz[kMax], ftMin[kMax], ftMax[kMax];
    alignas(32) int capId[kMax];  // Query::CapId()

    // After lane i's query changed, the packet's copies of what it bounds.
    template <typename Query>
    [[gnu::always_inline]] void Sync(int i, const Query& q) {
        cap[i] = q.Cap(), capId[i] = q.CapId(), ftMax[i] = q.ray.tMax;
    }
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

namespace grid_detail {

// The W floats (or ints) at x as one vector (x 32-byte aligned for W = 8).
template <typename V, typename T>
[[gnu::always_inline]] inline const V& Lanes(const T* x) {
    return *reinterpret_cast<const V*>(x);
}

// The cell indices, clamped to [0, maxCell], of the coordinates x along an axis whose cells
// start at lo, 1 / inv apart.
template <typename VF, typename VI>
[[gnu::always_inline]] inline void CellIndices(const VF& x, const VF& lo, const VF& inv, const VF& maxCell, VI* cell) {
    const VF zero = {};
    const VF f = (x - lo) * inv;
    const VF clampedLo = f > zero ? f : zero;
    *cell = __builtin_convertvector(clampedLo < maxCell ? clampedLo : maxCell, VI);
}

}  // namespace grid_detail

// A leaf cell's triangles against the rays of `group` (lanes in the packet's shared frame),
// one triangle against W rays per step, with the watertight test's very operations in each
// lane (FilterLanes' with the roles of triangle and ray swapped). First a triangle's box
// across U and V against each ray's rectangle in this slice (sl): a ray whose rectangle
// misses the box, grown by the padding once more, does not test it here. That loses no
// hit: a hit point lies in its triangle's box and on the ray's stretch in some slice,
// whose cell there holds the triangle (the cells' growth), and the ray tests it in that
// cell; a triangle met before its hit's slice only ends the ray sooner. Most of a cell's
// triangles pass beside most rays, and the box test is a fifth of the watertight one. A lane's hit without a
// zero edge function is decided here: a closest-hit ray keeps the nearest (the lowest id at
// equal t), whose b1 and b2 are then computed as IntersectPrepared computes them; a
// shadow ray is done at its first. The tie cases go through IntersectPrepared itself.
// Returns false if there were more tie cases than it keeps (nothing is lost: the caller
// then tests those rays one by one, and a query keeps the least hit whatever the order).
template <int W, typename Query>
inline bool NestedGridAccel::PacketLeaf(PacketLanes& p, const SliceLanes& sl, uint64_t group, const CellRef& ref,
                                        Query* q) const {
    using grid_detail::Lanes;
    using grid_detail::LaneBits;
    using grid_detail::WatertightLanes;
    using VF = typename SimdVectors<W>::F;
    using VI = typename SimdVectors<W>::I;
    const VF zero = {};
    const VI none = {};
    VI laneBit;
    for (int j = 0; j < W; ++j) laneBit[j] = 1 << j;
    const int gFirst = __builtin_ctzll(group) / W * W, gEnd = (64 - __builtin_clzll(group) + W - 1) / W * W;
    alignas(32) float bestT[kPacketSize], bestV[kPacketSize], bestW[kPacketSize], bestDet[kPacketSize];
    alignas(32) int bestId[kPacketSize];
    for (int i = gFirst; i < gEnd; ++i) bestT[i] = p.cap[i], bestId[i] = p.capId[i], bestV[i] = bestW[i] = bestDet[i] = 0;
    uint64_t active = group;  // lanes still testing (a shadow ray stops at its first hit)
    uint64_t won = 0;         // lanes with a hit in this cell that beats what they had
    constexpr int kMaxTies = 64;
    uint8_t tieLane[kMaxTies];
    uint32_t tieTri[kMaxTies];
    int ties = 0;
    bool overflow = false;
    const int kx = p.fkx, ky = p.fky, kz = p.fkz, U = p.U, V = p.V;
    const TriBlock* blocks = blocks_.get();
    for (uint32_t L = ref.first, end = ref.first + ref.count; L < end && active && !overflow; ++L) {
        const TriBlock& block = blocks[L / 8];
        const int j = int(L % 8);
        const VF Ax = zero + block.v[kx][j], Ay = zero + block.v[ky][j], Az = zero + block.v[kz][j];
        const VF Bx = zero + block.v[3 + kx][j], By = zero + block.v[3 + ky][j], Bz = zero + block.v[3 + kz][j];
        const VF Cx = zero + block.v[6 + kx][j], Cy = zero + block.v[6 + ky][j], Cz = zero + block.v[6 + kz][j];
        const VI idV = none + int(block.id[j]);
        const float* bu = block.v[U];
        const float* bv = block.v[V];
        const VF triULo = zero + (std::min({bu[j], bu[24 + j], bu[48 + j]}) - p.pad);
        const VF triUHi = zero + (std::max({bu[j], bu[24 + j], bu[48 + j]}) + p.pad);
        const VF triVLo = zero + (std::min({bv[j], bv[24 + j], bv[48 + j]}) - p.pad);
        const VF triVHi = zero + (std::max({bv[j], bv[24 + j], bv[48 + j]}) + p.pad);
        for (int i = gFirst; i < gEnd; i += W) {
            uint32_t lanes = uint32_t(active >> i) & ((1u << W) - 1);
            if (!lanes) continue;
            lanes &= LaneBits<W>((triULo <= Lanes<VF>(sl.uHi + i)) & (triUHi >= Lanes<VF>(sl.uLo + i)) &
                                 (triVLo <= Lanes<VF>(sl.vHi + i)) & (triVHi >= Lanes<VF>(sl.vLo + i)));
            if (!lanes) continue;
            const VF ox = Lanes<VF>(p.fox + i), oy = Lanes<VF>(p.foy + i), oz = Lanes<VF>(p.foz + i);
            const VF sx = Lanes<VF>(p.fsx + i), sy = Lanes<VF>(p.fsy + i), sz = Lanes<VF>(p.fsz + i);
            const WatertightLanes<VF, VI> tri(Ax, Ay, Az, Bx, By, Bz, Cx, Cy, Cz, ox, oy, oz, sx, sy);
            for (uint32_t tie = LaneBits<W>(tri.zeroEdge) & lanes; tie; tie &= tie - 1) {
                if (ties == kMaxTies) {
                    overflow = true;
                    break;
                }
                tieLane[ties] = uint8_t(i + __builtin_ctz(tie));
                tieTri[ties++] = L;
            }
            const uint32_t in = LaneBits<W>(tri.inside) & lanes;
            if (!in) continue;
            VF t, u, v, w, det;  // (u unused: b0 is not kept)
            VI hit;
            tri.Hits(sz, Lanes<VF>(p.ftMin + i), Lanes<VF>(p.ftMax + i), &hit, &t, &u, &v, &w, &det);
            hit &= ((none + int(in)) & laneBit) != none;
            if constexpr (Query::kClosest) {
                const VF bt = Lanes<VF>(bestT + i);
                const VI bid = *reinterpret_cast<const VI*>(bestId + i);
                const VI better = hit & ((t < bt) | ((t == bt) & (idV < bid)));
                const uint32_t betterBits = LaneBits<W>(better);
                if (!betterBits) continue;
                *reinterpret_cast<VF*>(bestT + i) = better ? t : bt;
                *reinterpret_cast<VI*>(bestId + i) = better ? idV : bid;
                *reinterpret_cast<VF*>(bestV + i) = better ? v : Lanes<VF>(bestV + i);
                *reinterpret_cast<VF*>(bestW + i) = better ? w : Lanes<VF>(bestW + i);
                *reinterpret_cast<VF*>(bestDet + i) = better ? det : Lanes<VF>(bestDet + i);
                won |= uint64_t(betterBits) << i;
            } else {
                const uint64_t hitBits = uint64_t(LaneBits<W>(hit)) << i;
                active &= ~hitBits;
                won |= hitBits;
            }
        }
    }
    for (uint64_t m = won; m; m &= m - 1) {
        const int i = __builtin_ctzll(m);
        if constexpr (Query::kClosest) {
            const float inv = 1.0f / bestDet[i];
            q[i].Offer(uint32_t(bestId[i]), bestT[i], bestV[i] * inv, bestW[i] * inv);
        } else {
            q[i].found = true;
        }
        p.Sync(i, q[i]);
    }
    if (overflow) return false;
    for (int k = 0; k < ties; ++k) {
        const int i = tieLane[k];
        if (q[i].Finished()) continue;
        const TriBlock& block = blocks[tieTri[k] / 8];
        const int j = int(tieTri[k] % 8);
        float v[9];
        for (int row = 0; row < 9; ++row) v[row] = block.v[row][j];
        TriangleHit th;
        if (!detail::IntersectPrepared(q[i].ray, v, &th)) continue;
        if constexpr (Query::kClosest)
            q[i].Offer(block.id[j], th.t, th.b1, th.b2);
        else
            q[i].found = true;
        p.Sync(i, q[i]);
    }
    return true;
}

template <int W, typename Query>
inline void NestedGridAccel::PacketWalkLanes(uint32_t nodeIndex, PacketLanes& p, uint64_t lanes, const float* tLo,
                                             const float* tHi, Query* q) const {
    using grid_detail::CellIndices;
    using grid_detail::CellSpan;
    using grid_detail::Lanes;
    using grid_detail::LaneBits;
    using VF = typename SimdVectors<W>::F;
    using VI = typename SimdVectors<W>::I;
    const Node& g = nodes_[nodeIndex];
    const bool top = nodeIndex == 0;
    const int K = p.K, U = p.U, V = p.V, s = p.s;
    const int resK = g.res[K], resU = g.res[U], resV = g.res[V];
    const uint32_t stride[3] = {1u, uint32_t(g.res[0]), uint32_t(g.res[0] * g.res[1])};
    const uint32_t strideK = stride[K], strideU = stride[U], strideV = stride[V];
    // The slices the rays' ranges reach, one more each way for rounding at their ends.
    auto sliceOf = [&](float x) {
        const float f = (x - g.lo[K]) * g.invCellSize[K];
        return !(f > 0) ? 0 : (f >= float(resK) ? resK - 1 : int(f));
    };
    int kFirst = s > 0 ? resK : -1, kLast = s > 0 ? -1 : resK;
    for (uint64_t m = lanes; m; m &= m - 1) {
        const int i = __builtin_ctzll(m);
        const int ke = sliceOf(p.oK[i] + p.dK[i] * tLo[i]), kx = sliceOf(p.oK[i] + p.dK[i] * tHi[i]);
        kFirst = s > 0 ? std::min(kFirst, ke) : std::max(kFirst, ke);
        kLast = s > 0 ? std::max(kLast, kx) : std::min(kLast, kx);
    }
    kFirst = std::clamp(kFirst - s, 0, resK - 1);
    kLast = std::clamp(kLast + s, 0, resK - 1);

    const VF zero = {};
    const VF padV = zero + p.pad;
    const VF loU = zero + g.lo[U], invU = zero + g.invCellSize[U], maxU = zero + float(resU - 1);
    // One step of the cells' content boxes (CellRef) across U and V.
    const float boxStepU = g.cellSize[U] * (1.0f / kBoxSteps), boxStepV = g.cellSize[V] * (1.0f / kBoxSteps);
    const VF loV = zero + g.lo[V], invV = zero + g.invCellSize[V], maxV = zero + float(resV - 1);
    const VI none = {}, emptyLo = none + (1 << 30), emptyHi = none - 1;
    VI laneBit;  // lane j's bit: a 64-bit lane mask's lanes i … i+W-1 as a vector mask
    for (int j = 0; j < W; ++j) laneBit[j] = 1 << j;
    const uint64_t* occupied = occupied_.data();
    const uint8_t* empty = top ? p.skipReach : nullptr;
    SliceLanes sl;
    // (kFirst is not past kLast: along K a ray's entry comes before its exit.)
    for (int k = kFirst; s > 0 ? k <= kLast : k >= kLast; k += s) {
        const float entry = g.lo[K] + float(s > 0 ? k : k + 1) * g.cellSize[K];
        const float exit = g.lo[K] + float(s > 0 ? k + 1 : k) * g.cellSize[K];
        const VF entryV = zero + entry, exitV = zero + exit, safeV = zero + (entry - float(s) * p.pad);
        uint64_t in = 0, finished = 0;
        VI ru0 = emptyLo, ru1 = emptyHi, rv0 = emptyLo, rv1 = emptyHi;
        // Only the lane groups that still hold rays of this walk.
        const int width = lanes ? std::min(p.width, (64 - __builtin_clzll(lanes) + W - 1) / W * W) : 0;
        for (int i = (lanes ? __builtin_ctzll(lanes) / W * W : 0); i < width; i += W) {
            const VF oK = Lanes<VF>(p.oK + i), invK = Lanes<VF>(p.invK + i);
            const VF lo = Lanes<VF>(tLo + i), hi = Lanes<VF>(tHi + i), cap = Lanes<VF>(p.cap + i);
            const VF ta = (entryV - oK) * invK, tb = (exitV - oK) * invK;
            const VF hiCap = hi < cap ? hi : cap;
            const VF a = ta > lo ? ta : lo, b = tb < hiCap ? tb : hiCap;
            const VI inSlice = (a <= b) & (((none + int((lanes >> i) & ((1u << W) - 1))) & laneBit) != none);
            const VF oU = Lanes<VF>(p.oU + i), dU = Lanes<VF>(p.dU + i), oV = Lanes<VF>(p.oV + i), dV = Lanes<VF>(p.dV + i);
            const VF ua = oU + dU * a, ub = oU + dU * b, va = oV + dV * a, vb = oV + dV * b;
            const VF uLo = (ua < ub ? ua : ub) - padV, uHi = (ua > ub ? ua : ub) + padV;
            const VF vLo = (va < vb ? va : vb) - padV, vHi = (va > vb ? va : vb) + padV;
            VI u0, u1, v0, v1;
            CellIndices(uLo, loU, invU, maxU, &u0);
            CellIndices(uHi, loU, invU, maxU, &u1);
            CellIndices(vLo, loV, invV, maxV, &v0);
            CellIndices(vHi, loV, invV, maxV, &v1);
            u0 = inSlice ? u0 : emptyLo, u1 = inSlice ? u1 : emptyHi;
            v0 = inSlice ? v0 : emptyLo, v1 = inSlice ? v1 : emptyHi;
            *reinterpret_cast<VF*>(sl.a + i) = a;
            *reinterpret_cast<VF*>(sl.b + i) = b;
            *reinterpret_cast<VF*>(sl.uLo + i) = uLo;
            *reinterpret_cast<VF*>(sl.uHi + i) = uHi;
            *reinterpret_cast<VF*>(sl.vLo + i) = vLo;
            *reinterpret_cast<VF*>(sl.vHi + i) = vHi;
            *reinterpret_cast<VI*>(sl.u0 + i) = u0;
            *reinterpret_cast<VI*>(sl.u1 + i) = u1;
            *reinterpret_cast<VI*>(sl.v0 + i) = v0;
            *reinterpret_cast<VI*>(sl.v1 + i) = v1;
            ru0 = ru0 < u0 ? ru0 : u0, ru1 = ru1 > u1 ? ru1 : u1, rv0 = rv0 < v0 ? rv0 : v0, rv1 = rv1 > v1 ? rv1 : v1;
            in |= uint64_t(LaneBits<W>(inSlice)) << i;
            // The top level ends a ray whose best hit lies before this slice (the padded
            // plane), or whose range ended before it.
            if (top) finished |= uint64_t(LaneBits<W>((cap < (safeV - oK) * invK) | (ta > hi))) << i;
        }
        if (top) {
            p.live &= ~finished;
            lanes = p.live;
            in &= lanes;
        }
        if (in) {
            int u0 = ru0[0], u1 = ru1[0], v0 = rv0[0], v1 = rv1[0];
            for (int j = 1; j < W; ++j)
                u0 = std::min(u0, int(ru0[j])), u1 = std::max(u1, int(ru1[j])), v0 = std::min(v0, int(rv0[j])),
                v1 = std::max(v1, int(rv1[j]));
            if (top && (u1 - u0 + 1) * (v1 - v0 + 1) > kMaxFootprintCells) {
                // Divergent: each ray walks on alone from its entry into this slice (the
                // slices before it are done for every ray, so its walk's early stop holds).
                for (uint64_t m = lanes; m; m &= m - 1) {
                    const int i = __builtin_ctzll(m);
                    if (sl.a[i] <= p.t1[i]) Walk(0, *p.ray[i], p.invD[i], sl.a[i], p.t1[i], q[i]);
                }
                p.live = 0;
                return;
            }
            const int selFirst = __builtin_ctzll(in) / W * W, selEnd = (64 - __builtin_clzll(in) + W - 1) / W * W;
            const uint32_t base = g.firstCell + uint32_t(k) * strideK;
            // Empty space (top level): the least reach of the footprint's empty cells.
            int reach = empty ? std::max(kMaxEmptyReach, kMaxOctantReach) + 1 : 0;
            for (int cv = v0; cv <= v1; ++cv)
                for (int cu = u0; cu <= u1; ++cu) {
                    const uint32_t idx = base + uint32_t(cu) * strideU + uint32_t(cv) * strideV;
                    if (!((occupied[idx >> 6] >> (idx & 63)) & 1)) {
                        if (empty) reach = std::min(reach, int(empty[idx]));
                        continue;
                    }
                    reach = 0;
                    const VI cuV = none + cu, cvV = none + cv;
                    uint64_t sel = 0;
                    for (int i = selFirst; i < selEnd; i += W) {
                        const VI hit = (*reinterpret_cast<const VI*>(sl.u0 + i) <= cuV) &
                                       (*reinterpret_cast<const VI*>(sl.u1 + i) >= cuV) &
                                       (*reinterpret_cast<const VI*>(sl.v0 + i) <= cvV) &
                                       (*reinterpret_cast<const VI*>(sl.v1 + i) >= cvV);
                        sel |= uint64_t(LaneBits<W>(hit)) << i;
                    }
                    sel &= in;
                    if (!sel) continue;
                    const CellRef& ref = cells_[idx];
                    // The rays whose rectangle meets the cell's content box across U and V
                    // (CellRef), grown by the padding once more: the others hit nothing the
                    // cell holds in this slice.
                    {
                        const float cellU = g.lo[U] + float(cu) * g.cellSize[U];
                        const float cellV = g.lo[V] + float(cv) * g.cellSize[V];
                        const VF boxULo = zero + (cellU + float(ref.box[U]) * boxStepU - p.pad);
                        const VF boxUHi = zero + (cellU + float(ref.box[4 + U]) * boxStepU + p.pad);
                        const VF boxVLo = zero + (cellV + float(ref.box[V]) * boxStepV - p.pad);
                        const VF boxVHi = zero + (cellV + float(ref.box[4 + V]) * boxStepV + p.pad);
                        uint64_t meets = 0;
                        for (int i = selFirst; i < selEnd; i += W)
                            meets |= uint64_t(LaneBits<W>((boxULo <= Lanes<VF>(sl.uHi + i)) & (boxUHi >= Lanes<VF>(sl.uLo + i)) &
                                                          (boxVLo <= Lanes<VF>(sl.vHi + i)) & (boxVHi >= Lanes<VF>(sl.vLo + i))))
                                     << i;
                        sel &= meets;
                        if (!sel) continue;
                    }
                    if (ref.count & kChildBit) {
                        const uint32_t child = ref.count & ~kChildBit;
                        if (__builtin_popcountll(sel) >= kMinChildPacket) {
                            PacketWalk(child, p, sel, sl.a, sl.b, q);
                            continue;
                        }
                        // Few rays: each walks the sub-grid alone over its stretch inside
                        // this cell, as its own walk would have (a ray the rectangle holds
                        // but the cell's box does not is not in it).
                        const float cellLoU = g.lo[U] + float(cu) * g.cellSize[U], cellHiU = cellLoU + g.cellSize[U];
                        const float cellLoV = g.lo[V] + float(cv) * g.cellSize[V], cellHiV = cellLoV + g.cellSize[V];
                        for (; sel; sel &= sel - 1) {
                            const int i = __builtin_ctzll(sel);
                            if (q[i].Finished()) continue;
                            const Vec3& invD = p.invD[i];
                            const Ray& ray = *p.ray[i];
                            float t0 = sl.a[i], t1 = sl.b[i];
                            for (const auto& [axis, lo, hi] : {std::tuple{U, cellLoU, cellHiU}, std::tuple{V, cellLoV, cellHiV}}) {
                                if (ray.d[axis] == 0) continue;  // inside the slab: the rectangle holds it
                                float tn = (lo - ray.o[axis]) * invD[axis], tf = (hi - ray.o[axis]) * invD[axis];
                                if (tn > tf) std::swap(tn, tf);
                                t0 = std::max(t0, tn);
                                t1 = std::min(t1, tf);
                            }
                            if (!(t0 <= t1)) continue;
                            Walk(child, ray, invD, t0, t1, q[i]);
                            p.Sync(i, q[i]);
                        }
                        continue;
                    }
                    // The cell's exit is not the ray's business here: the slice ends it.
                    const CellSpan span{blocks_.get(), ref.first,     ref.count, filter_, nearestFilter_, anyFilter_,
                                        Infinity,      mesh_.cutouts.get(), &mesh_};
                    // Several rays in the shared frame: each triangle against W of them at
                    // once. Few: each ray against 8 triangles at once (the single-ray test).
                    const uint64_t group = sel & p.frameLanes;
                    if (__builtin_popcountll(group) >= kMinLeafGroup && PacketLeaf<W>(p, sl, group, ref, q)) sel &= ~group;
                    for (; sel; sel &= sel - 1) {
                        const int i = __builtin_ctzll(sel);
                        if (q[i].Finished()) continue;
                        q[i].Cell(span);
                        p.Sync(i, q[i]);
                    }
                }
            // Every cell within reach - 1 steps of the footprint's is empty (towards the rays'
            // octant, or all round), and a ray moves at most p.slope cells sideways per
            // slice: the next `skip` slices hold nothing for any of the rays (as the single
            // walk's jumps) if every ray still walking is in this slice (none enters the box
            // further on).
            if (reach > 1 && in == lanes) {
                const int m = reach - 1;
                const int skip = std::min(m, int(float(m) / std::max(p.slope, 1e-6f)));
                if (skip > 0) {
                    if (s > 0 ? k + skip >= kLast : k - skip <= kLast) return;
                    k += s * skip;
                }
            }
        }
        if (top && !p.live) return;
    }
}

}  // namespace lm
