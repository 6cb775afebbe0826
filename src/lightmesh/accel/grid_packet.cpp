// grid_packet.cpp -- the nested grid's coherent rays: IntersectMany and OccludedMany trace
// packets of up to kPacketSize rays through the levels together (the walk itself is
// grid_packet_walk.h), and rays that do not share a direction one by one (grid.cpp's walk).
#include "lightmesh/accel/grid.h"
#include "lightmesh/accel/grid_packet_walk.h"
#include "lightmesh/accel/grid_queries.h"

#include <algorithm>
#include <cmath>
#include <new>

namespace lm {

using grid_detail::AnyQuery;
using grid_detail::ClosestQuery;

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

// The entry points of the packet's walk of one level (grid_packet_walk.h): 4 lanes at a time
// (SSE, the x86-64 baseline) and 8 (AVX2, compiled for it with a target attribute, which GCC
// and clang both honour, and chosen at run time).
template <typename Query>
void NestedGridAccel::PacketWalkLanes4(uint32_t nodeIndex, PacketLanes& p, uint64_t lanes, const float* tLo,
                                       const float* tHi, Query* q) const {
    PacketWalkLanes<4>(nodeIndex, p, lanes, tLo, tHi, q);
}
#if defined(__x86_64__) || defined(__i386__)
template <typename Query>
__attribute__((target("avx2"))) void NestedGridAccel::PacketWalkLanes8(uint32_t nodeIndex, PacketLanes& p, uint64_t lanes,
                                                                       const float* tLo, const float* tHi,
                                                                       Query* q) const {
    PacketWalkLanes<8>(nodeIndex, p, lanes, tLo, tHi, q);
}
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
        if (!grid_detail::ClipToBox(ray, box_, &p.invD[i], &t0, &t1)) continue;
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

}  // namespace lm
