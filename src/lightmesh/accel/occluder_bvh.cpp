#include "lightmesh/accel/occluder_bvh.h"

#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "lightmesh/geometry/instances.h"
#include "lightmesh/util/error.h"

namespace lm {

OccluderBvh::OccluderBvh(const TriangleMesh& mesh) : mesh_(mesh) {
    const auto start = std::chrono::steady_clock::now();
    const size_t n = mesh.TriangleCount();
    if (mesh.PrimCount() >= UINT32_MAX / 2) throw Error("occluder hierarchy: too many triangles");
    std::vector<BuildItem> items(n);
    for (size_t i = 0; i < n; ++i) {
        const uint32_t id = static_cast<uint32_t>(i);
        Bounds3 b(mesh.Vertex(id, 0), mesh.Vertex(id, 1));
        b.Extend(mesh.Vertex(id, 2));
        items[i] = {b, b.Center(), id};
    }
    if (mesh.instances) {
        for (const TriangleMesh& p : mesh.instances->Prototypes()) protos_.push_back(std::make_unique<OccluderBvh>(p));
        const auto& inst = mesh.instances->Instances();
        for (size_t i = 0; i < inst.size(); ++i)
            items.push_back({inst[i].bounds, inst[i].bounds.Center(), static_cast<uint32_t>(i) | kInstanceBit});
    }
    BuildOver(std::move(items));
    buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

OccluderBvh::~OccluderBvh() = default;

void OccluderBvh::BuildOver(std::vector<BuildItem> items) {
    const size_t n = items.size();
    prims_.resize(n);
    nodes_.reserve(n ? 2 * ((n + kLeafSize - 1) / kLeafSize) : 1);
    if (n) Build(items.data(), n, 0, 0);
    boxes_.resize(n);
    for (size_t i = 0; i < n; ++i) {
        const uint32_t prim = prims_[i];
        Vec3 lo, hi;
        if (prim & kInstanceBit) {
            const Bounds3& b = mesh_.instances->Instances()[prim & ~kInstanceBit].bounds;
            lo = b.lo, hi = b.hi;
        } else {
            const Vec3 &p0 = mesh_.Vertex(prim, 0), &p1 = mesh_.Vertex(prim, 1), &p2 = mesh_.Vertex(prim, 2);
            lo = Min(Min(p0, p1), p2), hi = Max(Max(p0, p1), p2);
        }
        boxes_[i] = {{lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z}};
    }
}

size_t OccluderBvh::NodeCount() const {
    size_t n = nodes_.size();
    for (const auto& p : protos_) n += p->NodeCount();
    return n;
}

size_t OccluderBvh::Bytes() const {
    size_t b = nodes_.size() * sizeof(Node) + prims_.size() * sizeof(uint32_t) + boxes_.size() * sizeof(PrimBox);
    for (const auto& p : protos_) b += p->Bytes();
    return b;
}

uint32_t OccluderBvh::Build(BuildItem* items, size_t count, size_t first, int depth) {
    Bounds3 bounds, centroids;
    for (size_t i = 0; i < count; ++i) {
        bounds.Extend(items[i].bounds);
        centroids.Extend(items[i].centroid);
    }
    const uint32_t self = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(Node{{bounds.lo.x, bounds.lo.y, bounds.lo.z}, 0, {bounds.hi.x, bounds.hi.y, bounds.hi.z}, 0});
    const Vec3 extent = centroids.Diagonal();
    // A leaf for a few triangles, for coincident centroids, and past a depth that only a
    // degenerate split sequence reaches (the median split halves the count each level).
    if (count <= static_cast<size_t>(kLeafSize) || MaxComponent(extent) <= 0 || depth > 60) {
        for (size_t i = 0; i < count; ++i) prims_[first + i] = items[i].prim;
        nodes_[self].index = static_cast<uint32_t>(first);
        nodes_[self].count = static_cast<uint32_t>(count);
        return self;
    }
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
    const size_t mid = count / 2;
    // Ties broken by the id, so the tree does not depend on the sort's internals.
    std::nth_element(items, items + mid, items + count, [axis](const BuildItem& p, const BuildItem& q) {
        const float a = p.centroid[axis], b = q.centroid[axis];
        return a < b || (a == b && p.prim < q.prim);
    });
    Build(items, mid, first, depth + 1);
    const uint32_t right = Build(items + mid, count - mid, first + mid, depth + 1);
    nodes_[self].index = right;
    return self;
}

HullPieces::HullPieces(const BallHull& hull) {
    static_assert(kPieces == 4, "MeetsBox tests the pieces in the four lanes of an SSE register");
    const Vec3 d = hull.b - hull.a;
    for (int j = 0; j < kPieces; ++j) {
        const float s0 = static_cast<float>(j) / kPieces, s1 = static_cast<float>(j + 1) / kPieces;
        const Vec3 o = hull.a + d * s0;
        const Vec3 seg = d * (s1 - s0);
        for (int k = 0; k < 3; ++k) {
            o_[k][j] = o[k];
            // A zero component gets a huge finite inverse: (bound − o)·inv is then ±huge or
            // 0, never NaN, and the slab test stays exact.
            inv_[k][j] = std::abs(seg[k]) > 1e-30f ? 1.0f / seg[k] : (seg[k] < 0 ? -1e30f : 1e30f);
        }
        // The radius grows or shrinks linearly: its largest value on the stretch is at an
        // end; a relative margin covers the rounding of the grown boxes.
        const float r = std::max(hull.ra + (hull.rb - hull.ra) * s0, hull.ra + (hull.rb - hull.ra) * s1);
        r_[j] = r * (1.0f + 1e-5f) + 1e-6f * (MaxComponent(Abs(o)) + Length(seg));
    }
}

bool HullPieces::MeetsBox(const float lo[3], const float hi[3]) const {
    // Per piece (lane), the slab test of its axis against the box grown by its radius (a
    // box grown by r contains every point within r of the box). No value is NaN, so min and
    // max order each slab's ends as a swap would, and the comparisons decide as they would.
    const __m128 r = _mm_load_ps(r_);
    __m128 t0 = _mm_setzero_ps(), t1 = _mm_set1_ps(1.0f);
    for (int k = 0; k < 3; ++k) {
        const __m128 o = _mm_load_ps(o_[k]), inv = _mm_load_ps(inv_[k]);
        const __m128 a = _mm_mul_ps(_mm_sub_ps(_mm_sub_ps(_mm_set1_ps(lo[k]), r), o), inv);
        const __m128 b = _mm_mul_ps(_mm_sub_ps(_mm_add_ps(_mm_set1_ps(hi[k]), r), o), inv);
        t0 = _mm_max_ps(t0, _mm_min_ps(a, b));
        t1 = _mm_min_ps(t1, _mm_max_ps(a, b));
    }
    return _mm_movemask_ps(_mm_cmple_ps(t0, t1)) != 0;
}

namespace {

// The world box of a local box under `t` (the centre mapped, the half-extents through |A|),
// grown by a relative margin so that rounding never makes it smaller than the box of the
// transformed corners (which holds every transformed point of the local box).
void WorldBox(const Affine& t, const float lo[3], const float hi[3], float wlo[3], float whi[3]) {
    for (int r = 0; r < 3; ++r) {
        float c = t.m[r][3], e = 0, mag = std::abs(t.m[r][3]);
        for (int k = 0; k < 3; ++k) {
            const float ck = 0.5f * (lo[k] + hi[k]), hk = 0.5f * (hi[k] - lo[k]);
            c += t.m[r][k] * ck;
            e += std::abs(t.m[r][k]) * hk;
            mag += std::abs(t.m[r][k]) * std::max(std::abs(lo[k]), std::abs(hi[k]));
        }
        const float pad = 1e-5f * mag + 1e-30f;
        wlo[r] = c - e - pad;
        whi[r] = c + e + pad;
    }
}

}  // namespace

void OccluderBvh::QueryInstance(const HullPieces& pieces, uint32_t i, std::vector<uint32_t>* out) const {
    const MeshInstance& in = mesh_.instances->Instances()[i];
    const OccluderBvh& proto = *protos_[in.prototype];
    const TriangleMesh& pm = proto.mesh_;
    const uint32_t base = static_cast<uint32_t>(mesh_.TriangleCount()) + in.first;
    if (proto.nodes_.empty()) return;
    uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top) {
        const Node& node = proto.nodes_[stack[--top]];
        float lo[3], hi[3];
        WorldBox(in.toWorld, node.lo, node.hi, lo, hi);
        if (!pieces.MeetsBox(lo, hi)) continue;
        if (node.count) {
            // Each triangle's world box, from its corners as the flattened mesh has them.
            for (uint32_t k = 0; k < node.count; ++k) {
                const uint32_t local = proto.prims_[node.index + k];
                const auto& t = pm.triangles[local];
                const Vec3 p0 = in.toWorld.ApplyPoint(pm.positions[t[0]]), p1 = in.toWorld.ApplyPoint(pm.positions[t[1]]),
                           p2 = in.toWorld.ApplyPoint(pm.positions[t[2]]);
                const Vec3 l = Min(Min(p0, p1), p2), h = Max(Max(p0, p1), p2);
                const float bl[3] = {l.x, l.y, l.z}, bh[3] = {h.x, h.y, h.z};
                if (pieces.MeetsBox(bl, bh)) out->push_back(base + local);
            }
            continue;
        }
        const uint32_t self = static_cast<uint32_t>(&node - proto.nodes_.data());
        stack[top++] = node.index;
        stack[top++] = self + 1;
    }
}

bool OccluderBvh::Query(const BallHull& hull, std::vector<uint32_t>* out, size_t limit) const {
    if (nodes_.empty()) return true;
    const size_t start = out->size();
    const HullPieces pieces(hull);
    auto meets = [&](const float lo[3], const float hi[3]) { return pieces.MeetsBox(lo, hi); };
    uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top) {
        const Node& node = nodes_[stack[--top]];
        if (!meets(node.lo, node.hi)) continue;
        if (node.count) {
            for (uint32_t i = 0; i < node.count; ++i) {
                const PrimBox& b = boxes_[node.index + i];
                const uint32_t prim = prims_[node.index + i];
                if (prim & kInstanceBit) {
                    if (meets(b.lo, b.hi)) QueryInstance(pieces, prim & ~kInstanceBit, out);
                } else if (node.count == 1 || meets(b.lo, b.hi)) {
                    out->push_back(prim);
                }
            }
            if (out->size() - start > limit) return false;
            continue;
        }
        const uint32_t self = static_cast<uint32_t>(&node - nodes_.data());
        // Far child first on the stack, so the near (left) one is popped first: the order
        // only matters for determinism, which any fixed order gives.
        stack[top++] = node.index;
        stack[top++] = self + 1;
    }
    return true;
}

}  // namespace lm
