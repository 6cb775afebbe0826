// light_mesh_patches.h -- consensus's segment tests without rays (ours, exact): front lists,
// cell patches, a point's blockers and the segment culling.
// Part of LightMesh<Word>'s definition (light_mesh_impl.h): included once, by light_mesh.cpp,
// whose anonymous namespace it shares.
#pragma once

#include "lightmesh/shadow/light_mesh_impl.h"

namespace lm {
namespace {

template <typename Word>
inline auto LightMesh<Word>::FrontTriangles(const CellSummary& c, int64_t base, const ShadingPoint& sp) const
    -> FrontList& {
    thread_local std::unique_ptr<FrontCache, typename FrontCache::Deleter> cache;
    if (!cache) cache = FrontCache::Make();
    auto& lists = cache->lists;
    auto& older = cache->older;
    const TrianglePlane& own = planes_[sp.prim];
    const float sign = Dot(own.n, sp.n) >= 0 ? 1.0f : -1.0f;
    const uint64_t key = (static_cast<uint64_t>(base) * 0x9E3779B97F4A7C15ull) ^
                         (static_cast<uint64_t>(sp.prim) * 0xC2B2AE3D27D4EB4Full) ^ (sign > 0 ? 1u : 0u);
    const int set = static_cast<int>((key >> 40) % kFrontSets);
    for (int way = 0; way < kFrontWays; ++way) {
        FrontList& list = lists[set][way];
        if (list.owner == serial_ && list.base == base && list.prim == sp.prim && list.sign == sign) {
            older[set] = static_cast<uint8_t>(1 - way);
            return list;
        }
    }
    FrontList& list = lists[set][older[set]];
    older[set] = static_cast<uint8_t>(1 - older[set]);
    const TriangleMesh& mesh = scene_.mesh;
    const Vec3 n = own.n * sign;
    const float d = own.d * sign;
    FrontArrays& f = list.arrays;
    list.owner = 0;  // invalid until filled (Reserve may throw)
    f.Reserve(c.reachCount);
    // First the triangles in front, compacted without a branch on each one's answer (about
    // half of a reach is in front, in no order a predictor learns), then their data.
    const float limit = 0.5f * c.delta;
    Scratch<uint32_t, kMaxReach> pickedScratch(c.reachCount);
    uint32_t* picked = pickedScratch.data();
    uint32_t count = 0;
    for (uint32_t i = 0; i < c.reachCount; ++i) {
        const uint32_t t = c.reach[i];
        // (| on ints, not ||: no branch per vertex.)
        const int front = int(Dot(n, mesh.Vertex(t, 0)) - d > limit) | int(Dot(n, mesh.Vertex(t, 1)) - d > limit) |
                          int(Dot(n, mesh.Vertex(t, 2)) - d > limit);
        picked[count] = t;
        count += static_cast<uint32_t>(front);
    }
    for (uint32_t i = 0; i < count; ++i) {
        const uint32_t t = picked[i];
        const TrianglePlane& pl = planes_[t];
        const Vec3 &v0 = mesh.Vertex(t, 0), &v1 = mesh.Vertex(t, 1), &v2 = mesh.Vertex(t, 2);
        f.nx[i] = pl.n.x, f.ny[i] = pl.n.y, f.nz[i] = pl.n.z, f.d[i] = pl.d;
        f.lox[i] = pl.lo.x, f.loy[i] = pl.lo.y, f.loz[i] = pl.lo.z;
        f.hix[i] = pl.hi.x, f.hiy[i] = pl.hi.y, f.hiz[i] = pl.hi.z;
        f.v0x[i] = v0.x, f.v0y[i] = v0.y, f.v0z[i] = v0.z;
        f.v1x[i] = v1.x, f.v1y[i] = v1.y, f.v1z[i] = v1.z;
        f.v2x[i] = v2.x, f.v2y[i] = v2.y, f.v2z[i] = v2.z;
    }
    f.count = count;
    for (uint32_t i = count; i % 8 != 0; ++i) {  // padding: an empty box
        f.nx[i] = f.ny[i] = f.nz[i] = f.d[i] = f.sMin[i] = f.sMax[i] = 0;
        f.lox[i] = f.loy[i] = f.loz[i] = Infinity;
        f.hix[i] = f.hiy[i] = f.hiz[i] = -Infinity;
        f.v0x[i] = f.v0y[i] = f.v0z[i] = f.v1x[i] = f.v1y[i] = f.v1z[i] = f.v2x[i] = f.v2y[i] = f.v2z[i] = 0;
    }
    list.owner = serial_;
    list.delta = c.delta;
    list.base = base;
    list.prim = sp.prim;
    list.sign = sign;
    list.patchTried = list.patch = false;
    return list;
}

// ---- Cell patches (ours, exact) -------------------------------------------------
//
// The points of one triangle in one cell, seen from one side, have their origins on a
// small convex patch Q: the triangle clipped to the cell's box, pushed off the surface
// by the renderer's offset. Points of a patch ask for the same nodes again and again
// (4 times each on the castle at 1024×768, 11 at 2048×1536). A node x that sees every
// origin of Q needs no segment from any of them: no front triangle (the only ones that
// can block, FrontTriangles) meets the hull of x and Q when x and all of Q lie clearly
// on one side of its plane, or their box is apart from its box. Those are the tests the
// segment culling already trusts (SeesPointCulled), with margins for Q's rounding, so
// any exact test agrees: the image is ОТ's. Each node's answer is kept per patch (per
// thread, with the front list); nodes that may be blocked from some of Q (inside walls,
// behind edges) are tested point by point as before.
//
// The patch of `sp` (with its front list), or null where it cannot be used: no front
// list (crowded cell), a degenerate triangle, or a point not made as the renderer makes
// it — its origin SurfaceOffset() off P (within 2·delta, the cell's), P on its triangle's
// plane, the normal the patch was built with. So whether a segment is decided by the
// patch depends on the point and node only, never on which points a thread shaded
// before: --stats are the same for any thread count.
template <typename Word>
inline auto LightMesh<Word>::Patch(const CellSummary& c, int64_t base, int ci, int cj, int ck,
                                   const ShadingPoint& sp, RenderCounters& counters) const -> FrontList* {
    if (!patches_ || c.reachCount == kTooMany || planes_[sp.prim].n == Vec3(0.0f)) return nullptr;
    const Vec3 &v0 = scene_.mesh.Vertex(sp.prim, 0), &v1 = scene_.mesh.Vertex(sp.prim, 1),
               &v2 = scene_.mesh.Vertex(sp.prim, 2);
    const float offset = SurfaceOffset(v0, v1, v2);
    const float measured = Dot(sp.origin - sp.p, sp.n);
    if (!(measured > 4 * c.delta) || !(std::abs(measured - offset) <= 2 * c.delta)) return nullptr;
    // P on its triangle's plane, and the normal the patch was built with (the renderer
    // makes it from the triangle alone; a caller's other normal gets no patch).
    const TrianglePlane& own = planes_[sp.prim];
    if (!(std::abs(Dot(own.n, sp.p) - own.d) <= 2 * c.delta)) return nullptr;
    FrontList& list = FrontTriangles(c, base, sp);
    if (!PatchPays(sp, v0, v1, v2, list.arrays.count)) {
        ++Count(counters, LightMeshCount::kPatchesNotPaying);
        return nullptr;
    }
    if (!list.patchTried) BuildPatch(list, ci, cj, ck, sp, offset);
    if (!list.patch || list.normal != sp.n) return nullptr;
    return &list;
}

template <typename Word>
inline void LightMesh<Word>::BuildPatch(FrontList& list, int ci, int cj, int ck, const ShadingPoint& sp,
                                        float offset) const {
    list.patchTried = true;
    list.patch = false;
    list.normal = sp.n;
    const TriangleMesh& mesh = scene_.mesh;
    // The triangle clipped to the cell's box grown by reachMargin_ (a point's cell comes
    // from rounded coordinates), in double.
    const Vec3 c0 = lattice_.Node(ci, cj, ck), c1 = lattice_.Node(ci + 1, cj + 1, ck + 1);
    // Six clips of a triangle leave at most 9 vertices; rounding could add crossings, so
    // a polygon that would outgrow the buffer gets no patch (its points test as before).
    constexpr int kMaxPoly = 16;
    double poly[2][kMaxPoly][3];
    int n = 3;
    for (int k = 0; k < 3; ++k) {
        const Vec3& v = mesh.Vertex(sp.prim, k);
        poly[0][k][0] = v.x, poly[0][k][1] = v.y, poly[0][k][2] = v.z;
    }
    int cur = 0;
    for (int axis = 0; axis < 3 && n > 0; ++axis)
        for (int end = 0; end < 2 && n > 0; ++end) {
            // Keep (sign)·(v[axis] - bound) <= 0.
            const double bound = end == 0 ? double(c0[axis]) - reachMargin_ : double(c1[axis]) + reachMargin_;
            const double sign = end == 0 ? -1.0 : 1.0;
            int m = 0;
            for (int k = 0; k < n; ++k) {
                if (m + 2 > kMaxPoly) return;  // list.patch stays false
                const double* a = poly[cur][k];
                const double* b = poly[cur][(k + 1) % n];
                const double da = sign * (a[axis] - bound), db = sign * (b[axis] - bound);
                if (da <= 0) std::copy(a, a + 3, poly[1 - cur][m++]);
                if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
                    const double t = da / (da - db);
                    double* out = poly[1 - cur][m++];
                    for (int j = 0; j < 3; ++j) out[j] = a[j] + t * (b[j] - a[j]);
                    out[axis] = bound;
                }
            }
            n = m;
            cur = 1 - cur;
        }
    if (n == 0) return;
    // The origins: the polygon pushed along n by the offset, give or take 8·delta
    // along n: Patch lets in points whose origin lies within 2·delta of that offset
    // from P and whose P lies within 2·delta of the triangle's plane; the rest covers
    // the rounding of P and of the origin. The slack moves a plane's value by at most as
    // much (unit normals).
    const double slack = 8.08 * list.delta;
    double qx[kMaxPoly], qy[kMaxPoly], qz[kMaxPoly];
    for (int k = 0; k < n; ++k) {
        qx[k] = poly[cur][k][0] + double(sp.n.x) * offset;
        qy[k] = poly[cur][k][1] + double(sp.n.y) * offset;
        qz[k] = poly[cur][k][2] + double(sp.n.z) * offset;
    }
    double lo[3] = {qx[0], qy[0], qz[0]}, hi[3] = {qx[0], qy[0], qz[0]};
    for (int k = 1; k < n; ++k) {
        lo[0] = std::min(lo[0], qx[k]), hi[0] = std::max(hi[0], qx[k]);
        lo[1] = std::min(lo[1], qy[k]), hi[1] = std::max(hi[1], qy[k]);
        lo[2] = std::min(lo[2], qz[k]), hi[2] = std::max(hi[2], qz[k]);
    }
    list.qlo = Vec3(NextFloatDown(float(lo[0] - slack)), NextFloatDown(float(lo[1] - slack)),
                    NextFloatDown(float(lo[2] - slack))) - Vec3(reachMargin_);
    list.qhi = Vec3(NextFloatUp(float(hi[0] + slack)), NextFloatUp(float(hi[1] + slack)),
                    NextFloatUp(float(hi[2] + slack))) + Vec3(reachMargin_);
    FrontArrays& f = list.arrays;
    for (uint32_t i = 0; i < f.count; ++i) {
        const double nx = f.nx[i], ny = f.ny[i], nz = f.nz[i], d = f.d[i];
        double smin = Infinity, smax = -Infinity;
        for (int k = 0; k < n; ++k) {
            const double v = nx * qx[k] + ny * qy[k] + nz * qz[k] - d;
            smin = std::min(smin, v);
            smax = std::max(smax, v);
        }
        f.sMin[i] = NextFloatDown(float(smin - slack));
        f.sMax[i] = NextFloatUp(float(smax + slack));
    }
    std::fill(list.known, list.known + cubeWords_, 0);
    list.patch = true;
}

// Whether node x (lane k of template block b) sees every origin of the patch; false
// when not certain (the caller tests the segment).
template <typename Word>
inline bool LightMesh<Word>::PatchSees(FrontList& list, const FrontBlock& b, int k, const Vec3& x) const {
    if (const int known = PatchKnown(list, b, k); known >= 0) return known == 1;
    const uint32_t bit = CubeBit(b, k), word = bit >> 6;
    const uint64_t mask = uint64_t(1) << (bit & 63);
    PatchQuery q;
    q.x = x;
    q.lo = Min(x, list.qlo);
    q.hi = Max(x, list.qhi);
    q.m = CullMargin(list.delta);
    q.mQ = q.m + 4 * list.delta;
    const bool sees = patchSees_(list.arrays, q);
    list.known[word] |= mask;
    list.sees[word] = sees ? list.sees[word] | mask : list.sees[word] & ~mask;
    return sees;
}

// The first candidate (in the template's order) that sees the whole patch of `sp`, with
// its lane in *lane; null if none does or there is no patch. Where the candidates
// agree, such a node settles the point without a segment.
template <typename Word>
inline const FrontBlock* LightMesh<Word>::PatchWitness(const CellSummary& c, int64_t base, int ci, int cj, int ck,
                                                       const ShadingPoint& sp, const FrontRun& all,
                                                       RenderCounters& counters, int* lane) const {
    FrontList* patch = Patch(c, base, ci, cj, ck, sp, counters);
    if (!patch) return nullptr;
    const FrontBlock* found = nullptr;
    all.Any([&](const FrontBlock& b, int k) {
        if (!PatchSees(*patch, b, k, EntryNode(ci, cj, ck, b, k))) return false;
        found = &b;
        if (lane) *lane = k;
        return true;
    });
    if (found) ++Count(counters, LightMeshCount::kPatchSegments);
    return found;
}

template <typename Word>
inline void LightMesh<Word>::FindBlockers(const CellSummary& c, int64_t base, const ShadingPoint& sp,
                                          Blockers* b) const {
    b->tried = true;
    b->known = false;
    // (A degenerate own triangle has no plane to put the others in front of: no blockers.)
    if (c.reachCount == kTooMany || !(Dot(sp.origin - sp.p, sp.n) > 4 * c.delta) ||
        planes_[sp.prim].n == Vec3(0.0f))
        return;
    const FrontArrays& front = FrontTriangles(c, base, sp).arrays;
    BlockerQuery q;
    // The segments of this P lie within pointReach_ of it.
    q.lo = sp.p - Vec3(pointReach_);
    q.hi = sp.p + Vec3(pointReach_);
    q.o = sp.origin;
    q.margin = CullMargin(c.delta);
    q.far = pointReach_ + 2 * q.margin;
    q.reach = pointReach_;
    q.delta8 = 8 * c.delta;
    b->margin = q.margin;
    if (!findBlockers_(front, q, b)) return;  // too many: the back-end decides
    FinishBlockers(b);
    b->known = true;
}

// Whether the segment from node x to P's origin o is unblocked, decided without a ray
// where the answer is certain: it misses a blocker if its two ends lie clearly on one
// side of the blocker's plane, or the line passes clearly outside one of its edges
// (the triple products d·c_k, d = x - o, have both signs); it hits one if the ends lie
// clearly on both sides of its plane and d·c_k have one sign clearly (it crosses the
// inside). Any exact test agrees on such segments,
// so when every blocker is missed the answer is "sees", when one is hit "blocked", and
// otherwise the back-end decides, as for ОТ. The image is ОТ's either way.
template <typename Word>
inline int LightMesh<Word>::CullSegment(const Vec3& x, const ShadingPoint& sp, const Blockers& b,
                                        RenderCounters& counters) const {
    if (!b.known) return -1;
    const int blocked = cull_(b, x, sp.origin, b.margin);
    if (blocked < 0) return -1;
    ++Count(counters, LightMeshCount::kCulledSegments);
    return blocked == 0 ? 1 : 0;
}

template <typename Word>
inline bool LightMesh<Word>::SeesPointCulled(const Vec3& x, const ShadingPoint& sp, const Blockers& b,
                                             RenderCounters& counters) const {
    const int sees = CullSegment(x, sp, b, counters);
    return sees >= 0 ? sees == 1 : SeesPoint(x, sp, counters);
}

}  // namespace
}  // namespace lm
