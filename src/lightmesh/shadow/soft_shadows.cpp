#include "lightmesh/shadow/soft_shadows.h"

#include <immintrin.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>

#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/instances.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace {

constexpr int kBlockSide = 4;  // cells per block side
constexpr int kBlockCells = kBlockSide * kBlockSide * kBlockSide;
constexpr int kMaxSamples = 256;
constexpr int kMaxCandidates = 1024;  // a list holds at most denseEntries <= this
constexpr uint32_t kSideShift = 30;  // a receiver's entry: triangle id | side code << 30
constexpr uint32_t kPrimMask = (1u << kSideShift) - 1;
constexpr uint32_t kInFront = 1, kBehind = 2;  // side codes; 0: the light straddles the plane

/// The part of triangle (p0, p1, p2) inside `box` (Sutherland–Hodgman against its six
/// planes), into out[]; returns the vertex count, 0 if none (at most 9).
int ClipToBox(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Bounds3& box, Vec3 out[9]) {
    Vec3 a[9], b[9];
    int n = 3;
    a[0] = p0, a[1] = p1, a[2] = p2;
    Vec3* in = a;
    Vec3* res = b;
    for (int axis = 0; axis < 3; ++axis) {
        for (int sign = 0; sign < 2; ++sign) {
            const float bound = sign ? box.hi[axis] : box.lo[axis];
            auto inside = [&](const Vec3& v) { return sign ? v[axis] <= bound : v[axis] >= bound; };
            int m = 0;
            for (int i = 0; i < n; ++i) {
                const Vec3& u = in[i];
                const Vec3& v = in[(i + 1) % n];
                const bool iu = inside(u), iv = inside(v);
                if (iu) res[m++] = u;
                if (iu != iv && m < 9) {
                    const float t = (bound - u[axis]) / (v[axis] - u[axis]);
                    Vec3 x = u + (v - u) * t;
                    x[axis] = bound;
                    res[m++] = x;
                }
                if (m >= 9) break;
            }
            n = m;
            std::swap(in, res);
            if (n == 0) return 0;
        }
    }
    for (int i = 0; i < n; ++i) out[i] = in[i];
    return n;
}

inline Vec3 V3(const float* f) { return {f[0], f[1], f[2]}; }

/// Triangle t's plane m·x + w oriented by side code `code` (kInFront, kBehind) with the
/// light on its positive side: the receivers' stored planes and the whole list's test.
inline void OrientedPlane(const SoftShadows::Triangle& t, uint32_t code, Vec3* m, float* w) {
    *m = V3(t.n) * (code == kInFront ? 1.0f : -1.0f);
    *w = -Dot(*m, V3(t.v0));
}

}  // namespace

void SoftShadows::Directions(const ShadingPoint& sp, size_t light, const DiscPattern& pattern, int s0, int s1,
                             Directions4* out) const {
    const Vec3 oc = scene_.lights[light].position - sp.origin;
    const float R = options_.radii[light];
    const float d2 = LengthSquared(oc), r2 = R * R, d = std::sqrt(d2);
    const Vec3 u = oc / d;
    const float sin2 = r2 / d2, cosT = std::sqrt(std::max(0.0f, 1.0f - sin2));
    Vec3 e1, e2;
    CoordinateSystem(u, &e1, &e2);
    const uint64_t seed = AreaLightSeed(sp, static_cast<uint32_t>(light));
    const DiscTurns& turns = DiscTurns::Get();
    const float cs = turns.cs[seed >> 54], sn = turns.sn[seed >> 54];
    const Vec3 f1 = e1 * cs + e2 * sn, f2 = e2 * cs - e1 * sn;
    const float k1 = sin2 / (1.0f + cosT);  // 1 − cos θmax without cancellation
    const __m128 K = _mm_set1_ps(k1), two = _mm_set1_ps(2.0f), one = _mm_set1_ps(1.0f), zero = _mm_setzero_ps();
    const __m128 ocx = _mm_set1_ps(oc.x), ocy = _mm_set1_ps(oc.y), ocz = _mm_set1_ps(oc.z);
    const __m128 D2 = _mm_set1_ps(d2), R2 = _mm_set1_ps(r2), shorten = _mm_set1_ps(1.0f - 1e-5f);
    for (int s = s0; s < s1; s += 4) {
        const __m128 r2k = _mm_mul_ps(_mm_loadu_ps(&pattern.r2[s]), K);
        const __m128 cosTh = _mm_sub_ps(one, r2k);
        const __m128 sc = _mm_sqrt_ps(_mm_max_ps(zero, _mm_mul_ps(K, _mm_sub_ps(two, r2k))));
        const __m128 x = _mm_mul_ps(_mm_loadu_ps(&pattern.x[s]), sc), y = _mm_mul_ps(_mm_loadu_ps(&pattern.y[s]), sc);
        const __m128 Wx = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, _mm_set1_ps(f1.x)), _mm_mul_ps(y, _mm_set1_ps(f2.x))),
                                     _mm_mul_ps(cosTh, _mm_set1_ps(u.x)));
        const __m128 Wy = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, _mm_set1_ps(f1.y)), _mm_mul_ps(y, _mm_set1_ps(f2.y))),
                                     _mm_mul_ps(cosTh, _mm_set1_ps(u.y)));
        const __m128 Wz = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, _mm_set1_ps(f1.z)), _mm_mul_ps(y, _mm_set1_ps(f2.z))),
                                     _mm_mul_ps(cosTh, _mm_set1_ps(u.z)));
        // The near intersection with the sphere: b − sqrt(R² − (|oc|² − b²)), b = w·oc.
        const __m128 b = _mm_add_ps(_mm_add_ps(_mm_mul_ps(Wx, ocx), _mm_mul_ps(Wy, ocy)), _mm_mul_ps(Wz, ocz));
        const __m128 h2 = _mm_sub_ps(R2, _mm_sub_ps(D2, _mm_mul_ps(b, b)));
        const __m128 t = _mm_sub_ps(b, _mm_sqrt_ps(_mm_max_ps(zero, h2)));
        _mm_store_ps(&out->x[s], Wx), _mm_store_ps(&out->y[s], Wy), _mm_store_ps(&out->z[s], Wz);
        _mm_store_ps(&out->t[s], _mm_mul_ps(t, shorten));
    }
}

namespace {

}  // namespace

/// What the points of one receiver (a triangle with a part in the cell) need for one light:
/// the cell's entries that can shadow a point of that part, as triangle id | side code <<
/// 30 (largest triangles first), the side of the receiver's plane the light lies on (+1 /
/// −1; 0: the light straddles it), and whether the part is certified in the umbra.
struct SoftShadows::Receiver {
    float side = 0;
    bool dark = false;
    bool missed = false;  ///< the triangle has no part in the cell after all: use the cell's list
    std::vector<uint32_t> entries;
    /// For the per-point filter, 4 entries a group, each of the group's x, y, z, w in turn:
    /// the plane oriented with the light on its positive side (0·x − 1 where the light
    /// straddles it; padding 0·x + 1). The bounding balls are read from the triangles'
    /// table where a plane passes (a receiver is kept per cell, light and triangle: with many
    /// lights, receivers are most of the method's memory).
    std::vector<float> soa;
};

namespace {
// The receivers every cell shares: a triangle with no part in the cell after all, and one
// with no entry for the light on each side code (most receivers: the light reaches the
// whole part past every triangle of the list). Not freed, not counted in the bytes.
SoftShadows::Receiver MakeShared(float side, bool missed) {
    SoftShadows::Receiver r;
    r.side = side;
    r.missed = missed;
    return r;
}
const SoftShadows::Receiver kMissedReceiver = MakeShared(0.0f, true);
const SoftShadows::Receiver kOpenReceiver[3] = {MakeShared(-1.0f, false), MakeShared(0.0f, false), MakeShared(1.0f, false)};
bool IsShared(const SoftShadows::Receiver* r) {
    return r == &kMissedReceiver || (r >= kOpenReceiver && r < kOpenReceiver + 3);
}
}  // namespace

/// A cell's triangles for one light, 4 bytes an entry: the triangle's id | its side code
/// << kSideShift. The code says which side of the triangle's plane the light's sphere lies
/// on (kInFront, kBehind; 0: the sphere straddles it), so a point can be shadowed by the
/// triangle only where the plane so oriented is negative there (Separates). Entries
/// come largest triangle first. `dense`: too many entries to pay for the per-point loop;
/// the cell's points trace rays. (A list is kept per cell and light, so with many lights
/// the lists are most of the method's memory: the planes are read from the triangles'
/// table when needed rather than copied into every list, and receivers with no entry share
/// one of three constant objects.)
struct SoftShadows::CellList {
    bool dense = false;
    uint32_t count = 0;
    Bounds3 box;                     ///< the cell
    std::vector<uint32_t> entries;   ///< id | code << kSideShift, `count` of them
    /// The triangles whose bounds meet the cell (ascending), and each one's Receiver, built
    /// when a point on it first asks (most are never seen) and published once.
    std::vector<uint32_t> receivers;
    std::unique_ptr<std::atomic<const Receiver*>[]> recv;
    ~CellList();
};

namespace {
const SoftShadows::CellList kEmptyList{};
}  // namespace

SoftShadows::CellList::~CellList() {
    for (size_t i = 0; recv && i < receivers.size(); ++i) {
        const Receiver* r = recv[i].load(std::memory_order_acquire);
        if (!IsShared(r)) delete r;
    }
}

SoftShadows::SoftShadows(const Scene& scene, const Accelerator& accel, SoftShadowOptions options)
    : scene_(scene),
      accel_(accel),
      options_(std::move(options)),
      bvh_(scene.mesh) {
    const size_t lights = scene.lights.size();
    if (options_.radii.size() != lights) options_.radii.resize(lights, 0.0f);
    for (float r : options_.radii)
        if (!(std::isfinite(r) && r >= 0)) throw Error(StringPrintf("soft shadows: light radius %g is not a finite number >= 0", static_cast<double>(r)));
    if (options_.cc < 1 || options_.cc > 4096) ThrowSettingError("cc", "soft shadows: CC %d: must be 1 to 4096", options_.cc);
    if (options_.samples == 0) options_.samples = kExactSoftSamples;
    if (options_.samples < 16 || options_.samples > kMaxSamples || options_.samples % 16)
        ThrowSettingError("soft_samples", "exact soft shadows: %d samples: must be a multiple of 16 from 16 to %d", options_.samples,
                          kMaxSamples);
    if (options_.denseSamples == 0) options_.denseSamples = std::max(8, options_.samples / 4);
    if (options_.denseSamples < 4 || options_.denseSamples > kMaxSamples || options_.denseSamples % 4)
        throw Error(StringPrintf("soft shadows: %d dense samples: must be a multiple of 4 from 4 to %d",
                                 options_.denseSamples, kMaxSamples));
    if (options_.denseEntries < 1 || options_.denseEntries > kMaxCandidates)
        throw Error(StringPrintf("soft shadows: dense threshold %d: must be 1 to %d", options_.denseEntries, kMaxCandidates));

    // What the per-point tests read of each triangle, in one cache line.
    const auto& mesh = scene.mesh;
    // A receiver's entry and a list's sort key keep a triangle id in 30 bits.
    if (mesh.PrimCount() > size_t{kPrimMask} + 1)
        throw Error(StringPrintf("soft shadows: %s triangles: at most %s; use --shadows rt",
                                 FormatCount(mesh.PrimCount()).c_str(), FormatCount(size_t{kPrimMask} + 1).c_str()));
    flatCount_ = static_cast<uint32_t>(mesh.TriangleCount());
    tris_.resize(mesh.TriangleCount());
    area_.resize(mesh.TriangleCount());
    for (uint32_t i = 0; i < tris_.size(); ++i)
        MakeTriangle(mesh.Vertex(i, 0), mesh.Vertex(i, 1), mesh.Vertex(i, 2), &tris_[i], &area_[i]);

    // The lattice: the scene's box grown by a cell on every side (shading origins sit a
    // hair off their surfaces), h = longest side / CC.
    const Bounds3 box = mesh.Bounds();
    const float longest = std::max(box.MaxExtent(), 1e-30f);
    h_ = longest / static_cast<float>(options_.cc);
    origin_ = box.lo - Vec3(h_, h_, h_);
    auto cells = [&](float extent) { return std::max(1, static_cast<int>(std::ceil(extent / h_)) + 2); };
    const Vec3 ext = box.Diagonal();
    nx_ = cells(ext.x), ny_ = cells(ext.y), nz_ = cells(ext.z);
    bx_ = (nx_ + kBlockSide - 1) / kBlockSide, by_ = (ny_ + kBlockSide - 1) / kBlockSide,
    bz_ = (nz_ + kBlockSide - 1) / kBlockSide;
    blockCount_ = static_cast<size_t>(bx_) * by_ * bz_;
    // The block index is allocated up front (8 bytes per 4³ cells); the blocks and lists only
    // where points fall. Refused, before allocating, past a sixteenth of the memory budget.
    const uint64_t budget = PhysicalMemoryBytes();
    const double indexBytes = static_cast<double>(blockCount_) * sizeof(std::atomic<Slot*>);
    if (budget && indexBytes > static_cast<double>(budget) / 16)
        ThrowSettingError("cc", "soft shadows: CC %d needs %.1f GB for the cell index alone (%d x %d x %d cells), more "
                          "than a sixteenth of the %.1f GB this process may use; lower --cc",
                          options_.cc, indexBytes / 1e9, nx_, ny_, nz_, static_cast<double>(budget) / 1e9);
    blocks_.reset(new std::atomic<Slot*>[blockCount_]);
    for (size_t b = 0; b < blockCount_; ++b) blocks_[b].store(nullptr, std::memory_order_relaxed);
    byteLimit_ = budget / 2;
    bytesBuilt_.store(static_cast<uint64_t>(indexBytes), std::memory_order_relaxed);

    // The stratified disc pattern: point k of the golden-ratio lattice ((k + ½)/N,
    // frac(k·(φ − 1))), mapped to the unit disc (area_light.cpp's pattern, unshifted; each
    // point turns it by an angle of its own instead).
    // The lattice on the disc in 4 passes (disc_pattern.h; each point turns it by an angle
    // of its own): each pass alone spreads over the whole disc, so the first can decide
    // alone where it sees the light wholly or not at all.
    pattern_ = DiscPattern::Golden(options_.samples, 4);
    densePattern_ = DiscPattern::Golden(options_.denseSamples, 4);
}

void SoftShadows::MakeTriangle(const Vec3& p0, const Vec3& p1, const Vec3& p2, Triangle* t, float* area) {
    const Vec3 n = TriangleNormal(p0, p1, p2);
    const Vec3 c = (p0 + p1 + p2) * (1.0f / 3.0f);
    const float r = std::sqrt(std::max({LengthSquared(p0 - c), LengthSquared(p1 - c), LengthSquared(p2 - c)}));
    for (int k = 0; k < 3; ++k) {
        t->v0[k] = p0[k], t->v1[k] = p1[k], t->v2[k] = p2[k];
        t->n[k] = n[k], t->c[k] = c[k];
    }
    t->r = r * (1.0f + 1e-5f) + 1e-6f * MaxComponent(Abs(c));
    *area = LengthSquared(n);
}

const SoftShadows::Triangle& SoftShadows::InstancedTri(uint32_t id, Triangle* scratch) const {
    Vec3 p[3];
    scene_.mesh.Corners(id, p);
    float area;
    MakeTriangle(p[0], p[1], p[2], scratch, &area);
    return *scratch;
}

SoftShadows::~SoftShadows() {
    const size_t lights = scene_.lights.size();
    for (size_t b = 0; b < blockCount_; ++b) {
        Slot* slots = blocks_[b].load(std::memory_order_acquire);
        if (!slots) continue;
        for (size_t s = 0; s < kBlockCells * lights; ++s) {
            const CellList* list = slots[s].load(std::memory_order_acquire);
            if (list && list != &kEmptyList) delete list;
        }
        delete[] slots;
    }
}

std::unique_ptr<SoftShadows::Receiver> SoftShadows::BuildReceiver(const CellList& list, uint32_t id, const Vec3& L,
                                                                  float R) const {
    return scene_.mesh.instances ? BuildReceiverOf<true>(list, id, L, R) : BuildReceiverOf<false>(list, id, L, R);
}

template <bool kInstanced>
std::unique_ptr<SoftShadows::Receiver> SoftShadows::BuildReceiverOf(const CellList& list, uint32_t id, const Vec3& L,
                                                                    float R) const {
    // The box grown a little: a point on a face of the cell belongs to the triangles that
    // touch it, and shading origins sit a hair off their surfaces.
    const Bounds3& box = list.box;
    const float grow = 1e-4f * h_ + 1e-5f * MaxComponent(Max(Abs(box.lo), Abs(box.hi)));
    const Bounds3 grown(box.lo - Vec3(grow, grow, grow), box.hi + Vec3(grow, grow, grow));
    auto rec = std::make_unique<Receiver>();
    Vec3 poly[9];
    Triangle rtScratch;
    const Triangle& rt = TriOf<kInstanced>(id, &rtScratch);
    const Vec3 r0 = V3(rt.v0), r1 = V3(rt.v1), r2 = V3(rt.v2);
    const Vec3 rlo = Min(Min(r0, r1), r2), rhi = Max(Max(r0, r1), r2);
    const int nv = ClipToBox(r0, r1, r2, grown, poly);
    if (nv == 0) {
        rec->missed = true;
        return rec;
    }
    // The part's bounding ball, grown by the shading origins' offset.
    Vec3 c(0, 0, 0);
    for (int i = 0; i < nv; ++i) c += poly[i];
    c = c * (1.0f / static_cast<float>(nv));
    float rr = 0;
    for (int i = 0; i < nv; ++i) rr = std::max(rr, LengthSquared(poly[i] - c));
    const float offset = 1e-5f * MaxComponent(Max(Abs(rlo), Abs(rhi))) + 1e-30f;
    const HullPieces hull(BallHull{c, std::sqrt(rr) + 2 * offset + grow, L, R});
    // The light's side of the receiver's plane: points of the receiver lit by the light
    // have their origins on that side (PrepareShading needs the light in front of them),
    // and a triangle wholly on the other side of the plane cannot stand between such a
    // point and the light.
    const Vec3 nr = V3(rt.n);
    const float lenR = Length(nr);
    const float sL = Dot(nr, L - r0), margin = 1e-5f * lenR * (Length(L - r0) + R);
    const float side = sL > R * lenR + margin ? 1.0f : sL < -(R * lenR + margin) ? -1.0f : 0.0f;
    rec->side = side;
    thread_local std::vector<uint32_t> kept;
    kept.clear();
    for (size_t e = 0; e < list.count; ++e) {
        const uint32_t prim = list.entries[e] & kPrimMask;
        Triangle tScratch;
        const Triangle& t = TriOf<kInstanced>(prim, &tScratch);
        const Vec3 v0 = V3(t.v0), v1 = V3(t.v1), v2 = V3(t.v2);
        if (side != 0) {
            const float tol = 1e-5f * lenR * (MaxComponent(Abs(r0)) + MaxComponent(Max(Abs(v0), Max(Abs(v1), Abs(v2)))));
            const float s0 = Dot(nr, v0 - r0) * side, s1 = Dot(nr, v1 - r0) * side, s2 = Dot(nr, v2 - r0) * side;
            if (s0 <= tol && s1 <= tol && s2 <= tol) continue;  // behind (or on) the receiver's plane
        }
        const Vec3 lo = Min(Min(v0, v1), v2), hi = Max(Max(v0, v1), v2);
        if (!hull.MeetsBox(Bounds3(lo, hi))) continue;
        const uint32_t code = list.entries[e] >> kSideShift;
        if (code) {
            // The receiver's part wholly on the light's side of the triangle's plane.
            const Vec3 n = V3(t.n) * (code == kInFront ? 1.0f : -1.0f);
            const float lenT = Length(n);
            bool allLit = true;
            for (int i = 0; i < nv && allLit; ++i)
                allLit = Dot(n, poly[i] - v0) > 4 * offset * lenT + 1e-5f * lenT * Length(poly[i] - v0);
            if (allLit) continue;
        }
        kept.push_back(prim | code << kSideShift);
    }
    rec->entries.assign(kept.begin(), kept.end());  // its size exactly: a receiver per cell, light and triangle
    // The umbra certified: one triangle that every segment from the part to the light
    // crosses. The crossing points of the segments from a point X form the light's
    // projection from X on the triangle's plane; from a point between the part's
    // vertices they lie between the vertices' (a central projection from each point of
    // the light keeps segments), so the vertices decide: for each, the triangle's
    // plane must lie between it and the whole light, and the light's cone from it
    // inside the triangle's three edge planes. Points sit up to `slide` off the part
    // (its grown box, the origins' offset), which moves a crossing point by at most as
    // much: the cones are widened to cover it.
    const float slide = 2 * offset + 2 * grow;
    const CutoutMask* cut = scene_.mesh.cutouts.get();
    for (size_t e = 0; e < rec->entries.size() && e < 8 && side != 0 && !rec->dark; ++e) {
        const uint32_t code = rec->entries[e] >> kSideShift;
        if (!code) continue;
        if (cut && cut->IsCutout(rec->entries[e] & kPrimMask)) continue;  // holes let light through
        Triangle tScratch;
        const Triangle& t = TriOf<kInstanced>(rec->entries[e] & kPrimMask, &tScratch);
        const Vec3 n = V3(t.n) * (code == kInFront ? 1.0f : -1.0f), v0 = V3(t.v0), v1 = V3(t.v1), v2 = V3(t.v2);
        const float lenT = Length(n);
        bool covers = true;
        for (int i = 0; i < nv && covers; ++i) {
            const Vec3 X = poly[i];
            const float dist = -Dot(n, X - v0) / lenT;  // X's distance behind the plane
            const Vec3 xl = L - X;
            const float dl = Length(xl);
            if (!(dist > 4 * slide) || !(dl > R)) {
                covers = false;
                break;
            }
            const Vec3 u = xl / dl;
            const float sinT = std::min(1.0f, (R / dl + slide / dist) * 1.001f + 1e-5f);
            const Vec3 a = v0 - X, b = v1 - X, c = v2 - X;
            Vec3 m0 = Cross(a, b), m1 = Cross(b, c), m2 = Cross(c, a);
            if (Dot(m0, c) < 0) m0 = -m0, m1 = -m1, m2 = -m2;
            for (const Vec3& m : {m0, m1, m2}) covers = covers && Dot(m, u) >= sinT * Length(m);
        }
        rec->dark = covers;
    }
    const size_t groups = (rec->entries.size() + 3) / 4;
    rec->soa.assign(groups * 16, 0.0f);
    for (size_t e = 0; e < groups * 4; ++e) {
        float* g = &rec->soa[(e / 4) * 16 + e % 4];
        if (e >= rec->entries.size()) {
            g[12] = 1.0f;  // never negative
            continue;
        }
        const uint32_t code = rec->entries[e] >> kSideShift;
        Triangle tScratch;
        const Triangle& t = TriOf<kInstanced>(rec->entries[e] & kPrimMask, &tScratch);
        if (code) {
            Vec3 m;
            OrientedPlane(t, code, &m, &g[12]);
            g[0] = m.x, g[4] = m.y, g[8] = m.z;
        } else {
            g[12] = -1.0f;
        }
    }
    return rec;
}

std::unique_ptr<SoftShadows::CellList> SoftShadows::BuildList(const BallHull& hull, const Bounds3& box,
                                                              size_t light) const {
    return scene_.mesh.instances ? BuildListOf<true>(hull, box, light) : BuildListOf<false>(hull, box, light);
}

template <bool kInstanced>
std::unique_ptr<SoftShadows::CellList> SoftShadows::BuildListOf(const BallHull& hull, const Bounds3& box,
                                                              size_t light) const {
    thread_local std::vector<uint32_t> ids;
    ids.clear();
    auto list = std::make_unique<CellList>();
    list->box = box;
    // A hull that meets far more triangles than a list may hold (foliage) is dense
    // without looking at them one by one.
    if (!bvh_.Query(hull, &ids, 4 * static_cast<size_t>(options_.denseEntries))) {
        list->dense = true;
        return list;
    }
    const Vec3 L = hull.b;
    const float R = options_.radii[light];
    const Vec3 boxCenter = box.Center(), half = box.Diagonal() * 0.5f;
    // The kept entries, one 64-bit key each: the bits of the triangle's |n|² inverted (they
    // order as the values do, |n|² being > 0), then its id, then its side code (2 bits;
    // ids are below 2^30). Sorted ascending, the keys come largest triangle first, ties by
    // id: in an umbra the first of them usually covers the point's whole first pass, and it
    // never looks at the rest (SampleLight).
    thread_local std::vector<uint64_t> keys;
    keys.clear();
    for (uint32_t id : ids) {
        Triangle tScratch;
        const Triangle& t = TriOf<kInstanced>(id, &tScratch);
        const Vec3 n = V3(t.n), v0 = V3(t.v0);
        const float len = Length(n);
        if (!(len > 0)) continue;
        // Which side of the triangle's plane the light's sphere is on, with a margin for
        // rounding; a segment between two points on one side never crosses the plane.
        const float sL = Dot(n, L - v0), margin = 1e-5f * len * (Length(L - v0) + R);
        const float side = sL > R * len + margin ? 1.0f : sL < -(R * len + margin) ? -1.0f : 0.0f;
        if (side != 0) {
            // The cell's box wholly on the light's side too: no point of it can be shadowed
            // by this triangle.
            const float sC = Dot(n, boxCenter - v0) * side;
            const float extent = std::abs(n.x) * half.x + std::abs(n.y) * half.y + std::abs(n.z) * half.z;
            if (sC > extent * 1.0001f + 1e-5f * len * Length(boxCenter - v0)) continue;
        }
        const uint32_t code = side > 0 ? kInFront : side < 0 ? kBehind : 0;
        const float area = !kInstanced || id < flatCount_ ? area_[id] : LengthSquared(n);  // the same value
        keys.push_back(static_cast<uint64_t>(~std::bit_cast<uint32_t>(area)) << 32 | uint64_t{id} << 2 | code);
    }
    list->count = static_cast<uint32_t>(keys.size());
    if (list->count > static_cast<uint32_t>(options_.denseEntries)) {
        list->dense = true;
        list->count = 0;
        return list;
    }
    std::sort(keys.begin(), keys.end());
    list->entries.resize(list->count);
    for (size_t e = 0; e < list->count; ++e) {
        const uint32_t id = static_cast<uint32_t>(keys[e] >> 2) & kPrimMask, code = static_cast<uint32_t>(keys[e]) & 3;
        list->entries[e] = id | code << kSideShift;
    }
    // The receivers: the triangles whose bounds meet the cell (grown a little, as in
    // BuildReceiver), ascending.
    thread_local std::vector<uint32_t> receivers;
    receivers.clear();
    const float grow = 1e-4f * h_ + 1e-5f * MaxComponent(Max(Abs(box.lo), Abs(box.hi)));
    for (uint32_t id : ids) {
        Triangle tScratch;
        const Triangle& t = TriOf<kInstanced>(id, &tScratch);
        const Vec3 lo = Min(Min(V3(t.v0), V3(t.v1)), V3(t.v2)), hi = Max(Max(V3(t.v0), V3(t.v1)), V3(t.v2));
        if (lo.x <= box.hi.x + grow && lo.y <= box.hi.y + grow && lo.z <= box.hi.z + grow && hi.x >= box.lo.x - grow &&
            hi.y >= box.lo.y - grow && hi.z >= box.lo.z - grow)
            receivers.push_back(id);
    }
    std::sort(receivers.begin(), receivers.end());
    list->receivers.assign(receivers.begin(), receivers.end());
    list->recv.reset(new std::atomic<const Receiver*>[list->receivers.size()]);
    for (size_t i = 0; i < list->receivers.size(); ++i) list->recv[i].store(nullptr, std::memory_order_relaxed);
    return list;
}

SoftShadows::Place SoftShadows::Locate(const Vec3& o) const {
    Place place;
    const Vec3 rel = (o - origin_) * (1.0f / h_);
    const int i = FloorToInt(rel.x), j = FloorToInt(rel.y), k = FloorToInt(rel.z);
    if (!(rel.x >= 0 && rel.y >= 0 && rel.z >= 0) || i >= nx_ || j >= ny_ || k >= nz_) return place;  // outside
    const size_t block = (static_cast<size_t>(k / kBlockSide) * by_ + static_cast<size_t>(j / kBlockSide)) * bx_ +
                         static_cast<size_t>(i / kBlockSide);
    Slot* slots = blocks_[block].load(std::memory_order_acquire);
    const size_t lights = scene_.lights.size();
    if (!slots) {
        Slot* fresh = new Slot[kBlockCells * lights];
        for (size_t s = 0; s < kBlockCells * lights; ++s) fresh[s].store(nullptr, std::memory_order_relaxed);
        if (blocks_[block].compare_exchange_strong(slots, fresh, std::memory_order_acq_rel, std::memory_order_acquire)) {
            slots = fresh;
            Account(kBlockCells * lights * sizeof(Slot));
        } else {
            delete[] fresh;
        }
    }
    const size_t cell = (static_cast<size_t>(k % kBlockSide) * kBlockSide + static_cast<size_t>(j % kBlockSide)) *
                            kBlockSide + static_cast<size_t>(i % kBlockSide);
    place.slots = slots + cell * lights;
    place.i = i, place.j = j, place.k = k;
    return place;
}

const SoftShadows::CellList* SoftShadows::List(const Vec3& o, const Place& place, size_t light,
                                               std::unique_ptr<CellList>* own, RenderCounters& counters) const {
    if (!place.slots) {
        // Outside the lattice (a point far off the scene's box): a list of its own.
        ++counters.method[kSoftOutside];
        const float eps = 1e-5f * MaxComponent(Abs(o)) + 1e-30f;
        *own = BuildList(BallHull{o, eps, scene_.lights[light].position, options_.radii[light]},
                         Bounds3(o - Vec3(eps, eps, eps), o + Vec3(eps, eps, eps)), light);
        return own->get();
    }
    Slot& slot = place.slots[light];
    const CellList* list = slot.load(std::memory_order_acquire);
    if (!list) {
        // Build it: the hull of the cell's bounding ball and the light's sphere holds every
        // segment from a point of the cell to a point of the light.
        const Vec3 lo = origin_ + Vec3(static_cast<float>(place.i), static_cast<float>(place.j), static_cast<float>(place.k)) * h_;
        list = Publish(&slot, BuildCell(Bounds3(lo, lo + Vec3(h_, h_, h_)), light));
    }
    return list;
}

std::unique_ptr<SoftShadows::CellList> SoftShadows::BuildCell(const Bounds3& box, size_t light) const {
    const float ra = 0.8660254f * MaxComponent(box.Diagonal()) * 1.001f + 1e-6f * MaxComponent(Abs(box.Center()));
    return BuildList(BallHull{box.Center(), ra, scene_.lights[light].position, options_.radii[light]}, box, light);
}

void SoftShadows::Account(size_t bytes) const {
    const uint64_t total = bytesBuilt_.fetch_add(bytes, std::memory_order_relaxed) + bytes;
    if (byteLimit_ && total > byteLimit_ && total - bytes <= byteLimit_) {
        const size_t lights = scene_.lights.size();
        throw Error(StringPrintf("soft shadows: the cells' occluder lists for %s light%s have grown past %s, half of "
                                 "the %s this process may use; give the lights a \"range\", lower --cc, or use "
                                 "--shadows lmm or rt",
                                 FormatCount(lights).c_str(), lights == 1 ? "" : "s", FormatBytes(byteLimit_).c_str(),
                                 FormatBytes(2 * byteLimit_).c_str()));
    }
}

const SoftShadows::CellList* SoftShadows::Publish(std::atomic<const CellList*>* slot, std::unique_ptr<CellList> built) const {
    const CellList* fresh = built->count == 0 && !built->dense ? &kEmptyList : built.get();
    const CellList* expected = nullptr;
    if (slot->compare_exchange_strong(expected, fresh, std::memory_order_acq_rel, std::memory_order_acquire)) {
        cellsBuilt_.fetch_add(1, std::memory_order_relaxed);
        entriesBuilt_.fetch_add(built->count, std::memory_order_relaxed);
        if (built->dense) denseBuilt_.fetch_add(1, std::memory_order_relaxed);
        if (fresh != &kEmptyList) {
            const CellList* list = built.release();
            Account(sizeof(CellList) + 4 * (list->entries.capacity() + list->receivers.capacity()) +
                    sizeof(std::atomic<const Receiver*>) * list->receivers.size());
        }
        return fresh;
    }
    return expected;  // another thread published the same list first
}

/// Whether the plane of triangle t, oriented by side code `code` with the light on its
/// positive side, is negative at o: the triangle may separate o from the light (a light
/// that straddles the plane, code 0: always). The operations of the receivers' vectorised
/// filter, in its order.
inline bool Separates(const SoftShadows::Triangle& t, uint32_t code, const Vec3& o) {
    if (!code) return true;
    Vec3 m;
    float w;
    OrientedPlane(t, code, &m, &w);
    return (m.x * o.x + m.y * o.y) + (m.z * o.z + w) < 0.0f;
}

namespace {

/// A point's cone to a light, for the per-point filter: apex O, unit axis u, length d to
/// the light's centre, tan and 1/cos of the half-angle (0 and 1 for a point light).
struct PointCone {
    Vec3 O, u;
    float d, tanT, invCos;
};

/// Whether the ball (c, r) may meet the cone: a point at axial distance a and radial
/// distance q is at least (q − a·tan θ)·cos θ from it.
inline bool BallMeetsCone(const PointCone& k, const float c[3], float r) {
    const Vec3 cv = V3(c) - k.O;
    const float a = Dot(cv, k.u);
    if (a + r < 0 || a - r > k.d) return false;
    const float q2 = std::max(0.0f, LengthSquared(cv) - a * a);
    const float rho = std::max(a, 0.0f) * k.tanT + r * k.invCos;
    return q2 <= rho * rho * 1.0001f;
}

/// The receiver's entries whose plane is negative at O and whose ball meets the cone, four
/// at a time (BallMeetsCone's test, the same operations in each lane); calls f(prim).
/// ball(e) gives entry e's bounding ball as 4 floats (centre, radius), 16-byte aligned.
static_assert(offsetof(SoftShadows::Triangle, c) % 16 == 0 &&
                  offsetof(SoftShadows::Triangle, r) == offsetof(SoftShadows::Triangle, c) + 3 * sizeof(float),
              "a triangle's ball is one aligned 16-byte load");
template <typename Ball, typename F>
inline void ForCandidates(const uint32_t* entries, const float* soa, size_t count, const PointCone& k, Ball&& ball,
                          F&& f) {
    const __m128 ox = _mm_set1_ps(k.O.x), oy = _mm_set1_ps(k.O.y), oz = _mm_set1_ps(k.O.z), zero = _mm_setzero_ps();
    const __m128 ux = _mm_set1_ps(k.u.x), uy = _mm_set1_ps(k.u.y), uz = _mm_set1_ps(k.u.z), d = _mm_set1_ps(k.d);
    const __m128 tanT = _mm_set1_ps(k.tanT), invCos = _mm_set1_ps(k.invCos), slack = _mm_set1_ps(1.0001f);
    alignas(16) static constexpr float kNoBall[4] = {0, 0, 0, 0};  // a padding lane's (its plane never passes)
    const size_t groups = (count + 3) / 4;
    for (size_t i = 0; i < groups; ++i, soa += 16) {
        const __m128 s = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_load_ps(soa), ox), _mm_mul_ps(_mm_load_ps(soa + 4), oy)),
                                    _mm_add_ps(_mm_mul_ps(_mm_load_ps(soa + 8), oz), _mm_load_ps(soa + 12)));
        const __m128 separating = _mm_cmplt_ps(s, zero);
        if (!_mm_movemask_ps(separating)) continue;
        // The four balls, one load each, turned into x, y, z and r across the lanes.
        const size_t e = i * 4;
        __m128 bx = _mm_load_ps(ball(e)), by = _mm_load_ps(e + 1 < count ? ball(e + 1) : kNoBall),
               bz = _mm_load_ps(e + 2 < count ? ball(e + 2) : kNoBall), br = _mm_load_ps(e + 3 < count ? ball(e + 3) : kNoBall);
        _MM_TRANSPOSE4_PS(bx, by, bz, br);
        const __m128 cx = _mm_sub_ps(bx, ox), cy = _mm_sub_ps(by, oy), cz = _mm_sub_ps(bz, oz), r = br;
        const __m128 a = _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, ux), _mm_mul_ps(cy, uy)), _mm_mul_ps(cz, uz));
        const __m128 len2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, cx), _mm_mul_ps(cy, cy)), _mm_mul_ps(cz, cz));
        const __m128 q2 = _mm_max_ps(zero, _mm_sub_ps(len2, _mm_mul_ps(a, a)));
        const __m128 rho = _mm_add_ps(_mm_mul_ps(_mm_max_ps(a, zero), tanT), _mm_mul_ps(r, invCos));
        const __m128 ahead = _mm_and_ps(_mm_cmpge_ps(_mm_add_ps(a, r), zero), _mm_cmple_ps(_mm_sub_ps(a, r), d));
        const __m128 near = _mm_cmple_ps(q2, _mm_mul_ps(_mm_mul_ps(rho, rho), slack));
        for (int m = _mm_movemask_ps(_mm_and_ps(separating, _mm_and_ps(ahead, near))); m; m &= m - 1)
            if (!f(entries[i * 4 + static_cast<size_t>(__builtin_ctz(m))] & kPrimMask)) return;
    }
}

}  // namespace

float SoftShadows::DenseLight(const ShadingPoint& sp, size_t light, RenderCounters& counters) const {
    // Rays through the back-end along the dense pattern's directions (the area reference's
    // distribution), all of them: among leaves a quarter of them decides too often wrongly
    // (measured on the garden: 48.2 dB against 52.9 with all 16).
    const Vec3 L = scene_.lights[light].position, O = sp.origin;
    const float R = options_.radii[light];
    if (LengthSquared(L - O) <= R * R) return 1.0f;  // inside the light
    const int N = options_.denseSamples;
    Directions4 dirs;
    Directions(sp, light, densePattern_, 0, N, &dirs);
    Ray rays[kMaxSamples];
    bool blocked[kMaxSamples];
    for (int s = 0; s < N; ++s) rays[s] = Ray{O, Vec3(dirs.x[s], dirs.y[s], dirs.z[s]) * dirs.t[s], 0.0f, 1.0f};
    // In packets of 8 (Embree's rtcOccluded8 for coherent rays from one point).
    for (int s = 0; s < N; s += 8) accel_.OccludedMany(rays + s, static_cast<size_t>(std::min(8, N - s)), blocked + s);
    counters.shadowRays += static_cast<uint64_t>(N);
    int n = 0;
    for (int s = 0; s < N; ++s) n += blocked[s];
    return 1.0f - static_cast<float>(n) / static_cast<float>(N);
}

template <typename Each>
float SoftShadows::HardLight(const ShadingPoint& sp, size_t light, Each&& each) const {
    const Vec3 L = scene_.lights[light].position;
    const Ray ray = LightSegment(sp.origin, L);
    const float d = Length(L - sp.origin);
    if (!(d > 0)) return 1.0f;
    const PointCone cone{sp.origin, (L - sp.origin) / d, d, 0.0f, 1.0f};
    bool blocked = false;
    const CutoutMask* cut = scene_.mesh.cutouts.get();
    each(cone, [&](uint32_t prim) {
        Triangle tScratch;
        const Triangle& t = Tri(prim, &tScratch);
        TriangleHit hit;
        blocked = IntersectTriangle(ray, V3(t.v0), V3(t.v1), V3(t.v2), &hit) &&
                  (!cut || cut->Solid(scene_.mesh, prim, hit.b1, hit.b2));
        return !blocked;
    });
    return blocked ? 0.0f : 1.0f;
}

namespace {

/// A candidate triangle relative to the point O: the edge planes through O, (a×b), (b×c),
/// (c×a), signed so that the triangle's cone from O is on their positive sides, and its
/// plane n·(x − O) = num, signed so that num > 0.
struct Candidate {
    float m0[3], m1[3], m2[3], n[3], num;
};

/// Marks in blocked[] (bit s of word s / 64) the directions s0 .. s1 − 1 whose ray from O
/// meets the candidate before its end t: w in the triangle's cone (edges count as inside,
/// so no ray slips between two triangles that share one) and n·w·t > num.
inline void MarkBlocked(const Candidate& c, const float* wx, const float* wy, const float* wz, const float* tk,
                        int s0, int s1, uint64_t* blocked) {
    const __m128 zero = _mm_setzero_ps(), num = _mm_set1_ps(c.num);
    const __m128 ax = _mm_set1_ps(c.m0[0]), ay = _mm_set1_ps(c.m0[1]), az = _mm_set1_ps(c.m0[2]);
    const __m128 bx = _mm_set1_ps(c.m1[0]), by = _mm_set1_ps(c.m1[1]), bz = _mm_set1_ps(c.m1[2]);
    const __m128 cx = _mm_set1_ps(c.m2[0]), cy = _mm_set1_ps(c.m2[1]), cz = _mm_set1_ps(c.m2[2]);
    const __m128 nx = _mm_set1_ps(c.n[0]), ny = _mm_set1_ps(c.n[1]), nz = _mm_set1_ps(c.n[2]);
    for (int s = s0; s < s1; s += 4) {
        const __m128 x = _mm_load_ps(wx + s), y = _mm_load_ps(wy + s), z = _mm_load_ps(wz + s);
        const __m128 d0 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, x), _mm_mul_ps(ay, y)), _mm_mul_ps(az, z));
        const __m128 d1 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(bx, x), _mm_mul_ps(by, y)), _mm_mul_ps(bz, z));
        const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, x), _mm_mul_ps(cy, y)), _mm_mul_ps(cz, z));
        const __m128 dn = _mm_add_ps(_mm_add_ps(_mm_mul_ps(nx, x), _mm_mul_ps(ny, y)), _mm_mul_ps(nz, z));
        const __m128 inside = _mm_and_ps(_mm_and_ps(_mm_cmpge_ps(d0, zero), _mm_cmpge_ps(d1, zero)), _mm_cmpge_ps(d2, zero));
        const __m128 before = _mm_cmplt_ps(num, _mm_mul_ps(dn, _mm_load_ps(tk + s)));
        blocked[s >> 6] |= static_cast<uint64_t>(_mm_movemask_ps(_mm_and_ps(inside, before))) << (s & 63);
    }
}

/// MarkBlocked for a cut-out triangle `prim`: a direction that meets it is blocked only
/// where the point it meets is solid (CutoutMask::Solid at that point's barycentrics: the
/// edge planes' values along w are proportional to them, d1 : d2 : d0 for vertices 0, 1, 2).
/// Returns whether some direction met a hole.
bool MarkBlockedCutout(const Candidate& c, const TriangleMesh& mesh, const CutoutMask& cut, uint32_t prim,
                       const float* wx, const float* wy, const float* wz, const float* tk, int s0, int s1,
                       uint64_t* blocked) {
    bool hole = false;
    uint64_t hit[kMaxSamples / 64] = {};
    MarkBlocked(c, wx, wy, wz, tk, s0, s1, hit);
    const CutoutMaterial* material = cut.MaterialOf(prim);
    TexCoord uv[3];  // flat ones in place, instanced ones out of line
    mesh.UvsOf(prim, uv);
    const TexCoord &t0 = uv[0], &t1 = uv[1], &t2 = uv[2];
    // The texture coordinates of four directions at a time, the scalar arithmetic of
    // CutoutMask::SolidAt lane by lane (the same operations in the same order: the same
    // bits), then the alpha test of each direction that meets the triangle.
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
    const __m128 ax = _mm_set1_ps(c.m0[0]), ay = _mm_set1_ps(c.m0[1]), az = _mm_set1_ps(c.m0[2]);
    const __m128 bx = _mm_set1_ps(c.m1[0]), by = _mm_set1_ps(c.m1[1]), bz = _mm_set1_ps(c.m1[2]);
    const __m128 cx = _mm_set1_ps(c.m2[0]), cy = _mm_set1_ps(c.m2[1]), cz = _mm_set1_ps(c.m2[2]);
    const __m128 u0 = _mm_set1_ps(t0.u), u1 = _mm_set1_ps(t1.u), u2 = _mm_set1_ps(t2.u);
    const __m128 v0 = _mm_set1_ps(t0.v), v1 = _mm_set1_ps(t1.v), v2 = _mm_set1_ps(t2.v);
    // The cell table's lookup four lanes at a time where the image repeats on sides of 2^k
    // texels (Texture::CellAt's mask path: the same texel position, the same cell); a lane
    // whose cell is mixed, or whose coordinates Tame would change, takes SolidUV.
    const int W = material->image->Width(), H = material->image->Height();
    const bool table = !material->cells.empty() && material->wrapU == TextureWrap::Repeat &&
                       material->wrapV == TextureWrap::Repeat && (W & (W - 1)) == 0 && (H & (H - 1)) == 0;
    const __m128 fw = _mm_set1_ps(static_cast<float>(W)), fh = _mm_set1_ps(static_cast<float>(H)),
                 half = _mm_set1_ps(0.5f), tame = _mm_set1_ps(1e5f),
                 absMask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    const __m128i maskW = _mm_set1_epi32(W - 1), maskH = _mm_set1_epi32(H - 1);
    for (int s = s0; s < s1; s += 4) {
        const unsigned lanes = static_cast<unsigned>(hit[s >> 6] >> (s & 63)) & 15u;
        if (!lanes) continue;
        const __m128 x = _mm_load_ps(wx + s), y = _mm_load_ps(wy + s), z = _mm_load_ps(wz + s);
        const __m128 d0 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, x), _mm_mul_ps(ay, y)), _mm_mul_ps(az, z));
        const __m128 d1 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(bx, x), _mm_mul_ps(by, y)), _mm_mul_ps(bz, z));
        const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, x), _mm_mul_ps(cy, y)), _mm_mul_ps(cz, z));
        const __m128 sum = _mm_add_ps(_mm_add_ps(d0, d1), d2);
        const __m128 positive = _mm_cmpgt_ps(sum, zero);
        // Lanes with sum ≤ 0 divide by 1 and are masked to 0, as the scalar test's 0.
        const __m128 safe = _mm_or_ps(_mm_and_ps(positive, sum), _mm_andnot_ps(positive, one));
        const __m128 b1 = _mm_and_ps(positive, _mm_div_ps(d2, safe)), b2 = _mm_and_ps(positive, _mm_div_ps(d0, safe));
        const __m128 b0 = _mm_sub_ps(_mm_sub_ps(one, b1), b2);
        alignas(16) float u[4], v[4];
        const __m128 U = _mm_add_ps(_mm_add_ps(_mm_mul_ps(u0, b0), _mm_mul_ps(u1, b1)), _mm_mul_ps(u2, b2));
        const __m128 V = _mm_add_ps(_mm_add_ps(_mm_mul_ps(v0, b0), _mm_mul_ps(v1, b1)), _mm_mul_ps(v2, b2));
        _mm_store_ps(u, U);
        _mm_store_ps(v, V);
        alignas(16) int32_t cell[4] = {-1, -1, -1, -1};
        if (table) {
            const __m128 X = _mm_sub_ps(_mm_mul_ps(U, fw), half);
            const __m128 Y = _mm_sub_ps(_mm_mul_ps(_mm_sub_ps(one, V), fh), half);
            __m128i x0 = _mm_cvttps_epi32(X), y0 = _mm_cvttps_epi32(Y);
            x0 = _mm_add_epi32(x0, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(x0), X)));  // floor
            y0 = _mm_add_epi32(y0, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(y0), Y)));
            alignas(16) int32_t xa[4], ya[4];
            _mm_store_si128(reinterpret_cast<__m128i*>(xa), _mm_and_si128(x0, maskW));
            _mm_store_si128(reinterpret_cast<__m128i*>(ya), _mm_and_si128(y0, maskH));
            const int tamed = _mm_movemask_ps(_mm_and_ps(_mm_cmplt_ps(_mm_and_ps(U, absMask), tame),
                                                         _mm_cmplt_ps(_mm_and_ps(V, absMask), tame)));
            for (int lane = 0; lane < 4; ++lane)
                if (tamed >> lane & 1) cell[lane] = ya[lane] * W + xa[lane];
        }
        for (unsigned m = lanes; m; m &= m - 1) {
            const int lane = __builtin_ctz(m), k = s + lane;
            const uint8_t known = cell[lane] >= 0 ? material->cells[static_cast<size_t>(cell[lane])] : 0;
            if (known ? known == CutoutMaterial::kCellSolid : CutoutMask::SolidUV(*material, u[lane], v[lane]))
                blocked[k >> 6] |= uint64_t(1) << (k & 63);
            else
                hole = true;
        }
    }
    return hole;
}

int CountBits(const uint64_t* words, int s0, int s1) {
    int count = 0;
    for (int s = s0; s < s1; s += 64) {
        const int n = std::min(64, s1 - s);
        const uint64_t mask = n == 64 ? ~uint64_t(0) : (uint64_t(1) << n) - 1;
        count += std::popcount(words[s >> 6] & mask);
    }
    return count;
}

}  // namespace

template <typename Each>
float SoftShadows::SampleLight(const ShadingPoint& sp, size_t light, Each&& each, RenderCounters& counters) const {
    const Vec3 O = sp.origin, L = scene_.lights[light].position;
    const float R = options_.radii[light];
    const Vec3 oc = L - O;
    const float d2 = LengthSquared(oc), r2 = R * R;
    if (d2 <= r2) return 1.0f;  // inside the light: all of it is visible
    const float d = std::sqrt(d2);
    const Vec3 u = oc / d;
    const float sin2 = r2 / d2, cosT = std::sqrt(std::max(0.0f, 1.0f - sin2));
    const float tanT = std::sqrt(sin2) / std::max(cosT, 1e-30f), invCos = 1.0f / std::max(cosT, 1e-30f);
    const float slack2 = sin2 * 1.0002f;

    // The directions (Directions): made for the first pass when the first candidate turns
    // up, for the rest if needed.
    const int N = options_.samples, first = N / 4;
    Directions4 dirs;
    float *wx = dirs.x, *wy = dirs.y, *wz = dirs.z, *tk = dirs.t;
    auto directions = [&](int s0, int s1) { Directions(sp, light, pattern_, s0, s1, &dirs); };

    // The candidates: triangles whose plane separates O from (part of) the light, whose
    // bounding ball meets O's cone to the light, and whose own cone from O is not cut off
    // from the light's by one of its edge planes. Each is tested at once against the first
    // pass (a quarter of the directions, spread over the whole disc): once the first pass is
    // wholly blocked the point is in the umbra, and the rest of the list is never looked at.
    Candidate cand[kMaxCandidates];
    uint32_t candPrim[kMaxCandidates];  // the triangle of a cut-out candidate, else UINT32_MAX
    const CutoutMask* cut = scene_.mesh.cutouts.get();
    bool holeSeen = false;  // a direction of the first pass met a cut-out candidate's hole
    int nc = 0;
    uint64_t blocked[kMaxSamples / 64] = {};
    bool umbra = false;
    const PointCone cone{O, u, d, tanT, invCos};
    each(cone, [&](uint32_t prim) {
        ++counters.method[kSoftBallPass];
        Triangle tScratch;
        const Triangle& t = Tri(prim, &tScratch);
        const Vec3 pa = V3(t.v0) - O, pb = V3(t.v1) - O, pc = V3(t.v2) - O;
        Vec3 m0 = Cross(pa, pb), m1 = Cross(pb, pc), m2 = Cross(pc, pa);
        const float det = Dot(m0, pc);
        if (det == 0) return true;  // O in the triangle's plane: no ray from O crosses it
        if (det < 0) m0 = -m0, m1 = -m1, m2 = -m2;
        // An edge plane with the light's whole cone on its outer side: m·u < −sin θ·|m|.
        auto cutOff = [&](const Vec3& m) {
            const float e = Dot(m, u);
            return e < 0 && e * e > slack2 * LengthSquared(m);
        };
        if (cutOff(m0) || cutOff(m1) || cutOff(m2)) return true;
        Vec3 n = V3(t.n);
        float num = Dot(n, pa);
        if (num < 0) n = -n, num = -num;
        if (nc == 0) directions(0, first);
        cand[nc] = Candidate{{m0.x, m0.y, m0.z}, {m1.x, m1.y, m1.z}, {m2.x, m2.y, m2.z}, {n.x, n.y, n.z}, num};
        candPrim[nc] = cut && cut->IsCutout(prim) ? prim : UINT32_MAX;
        if (candPrim[nc] != UINT32_MAX) {
            holeSeen |= MarkBlockedCutout(cand[nc], scene_.mesh, *cut, prim, wx, wy, wz, tk, 0, first, blocked);
        } else {
            MarkBlocked(cand[nc], wx, wy, wz, tk, 0, first, blocked);
        }
        ++nc;
        if (CountBits(blocked, 0, first) == first) {
            umbra = true;
            return false;
        }
        return nc < kMaxCandidates;
    });
    if (nc == 0) {
        ++counters.method[kSoftFree];
        return 1.0f;
    }
    ++counters.method[kSoftSampled];
    counters.method[kSoftCandidates] += static_cast<uint64_t>(nc);
    if (umbra) return 0.0f;
    // The first pass wholly clear: the candidates only graze the cone between its
    // directions (unless the pass went through a cut-out's holes: the other directions may
    // meet its solid parts); otherwise the other three passes decide with it.
    if (CountBits(blocked, 0, first) == 0 && !holeSeen) return 1.0f;
    ++counters.method[kSoftFull];
    directions(first, N);
    for (int ci = 0; ci < nc; ++ci) {
        if (candPrim[ci] != UINT32_MAX)
            MarkBlockedCutout(cand[ci], scene_.mesh, *cut, candPrim[ci], wx, wy, wz, tk, first, N, blocked);
        else
            MarkBlocked(cand[ci], wx, wy, wz, tk, first, N, blocked);
    }
    return 1.0f - static_cast<float>(CountBits(blocked, 0, N)) / static_cast<float>(N);
}

float SoftShadows::LightVisibility(const ShadingPoint& sp, size_t light, RenderCounters& counters) const {
    Place place = Locate(sp.origin);
    return LightVisibilityAt(sp, place, light, counters);
}

float SoftShadows::LightVisibilityAt(const ShadingPoint& sp, Place& place, size_t light, RenderCounters& counters) const {
    ++counters.method[kSoftLookups];
    std::unique_ptr<CellList> own;
    const CellList* list = List(sp.origin, place, light, &own, counters);
    if (list->count == 0 && !list->dense) {
        ++counters.method[kSoftFree];
        return 1.0f;
    }
    const float R = options_.radii[light];
    const Vec3 O = sp.origin;
    if (list->dense) {
        ++counters.method[kSoftDense];
        const Vec3& L = scene_.lights[light].position;
        if (R == 0) {
            ++counters.shadowRays;
            return LightVisible(accel_, O, L) ? 1.0f : 0.0f;
        }
        return DenseLight(sp, light, counters);
    }
    // The point's own triangle among the cell's receivers, with the origin on the light's
    // side of it: its short list applies. Otherwise (an origin on the far side) the cell's
    // whole list.
    const uint32_t* entries = nullptr;
    const float* soa = nullptr;
    size_t count = 0;
    bool receiver = false;
    // The triangle's place among the receivers: every light's list of a cell has the same
    // receivers, so after the point's first light it is checked, not searched.
    size_t r = place.receiver;
    if (!(r < list->receivers.size() && list->receivers[r] == sp.prim)) {
        const auto it = std::lower_bound(list->receivers.begin(), list->receivers.end(), sp.prim);
        r = it != list->receivers.end() && *it == sp.prim ? static_cast<size_t>(it - list->receivers.begin()) : SIZE_MAX;
        if (r != SIZE_MAX) place.receiver = r;
    }
    if (r != SIZE_MAX) {
        const Receiver* rec = list->recv[r].load(std::memory_order_acquire);
        if (!rec) {
            std::unique_ptr<Receiver> built = BuildReceiver(*list, sp.prim, scene_.lights[light].position, R);
            // A receiver without entries is one of the shared ones (its answers depend on
            // `missed` and `side` only).
            const Receiver* fresh = built->missed         ? &kMissedReceiver
                                    : built->entries.empty() ? &kOpenReceiver[built->side > 0 ? 2 : built->side < 0 ? 0 : 1]
                                                             : built.get();
            const Receiver* expected = nullptr;
            if (list->recv[r].compare_exchange_strong(expected, fresh, std::memory_order_acq_rel,
                                                      std::memory_order_acquire)) {
                rec = fresh;
                if (!IsShared(fresh)) {
                    built.release();
                    Account(sizeof(Receiver) + 4 * (rec->entries.capacity() + rec->soa.capacity()));
                }
            } else
                rec = expected;  // another thread published the same receiver first
        }
        Triangle tScratch;
        const Triangle& t = Tri(sp.prim, &tScratch);
        if (!rec->missed && (rec->side == 0 || Dot(V3(t.n), O - V3(t.v0)) * rec->side > 0)) {
            receiver = true;
            if (rec->dark) {
                ++counters.method[kSoftReceiverDark];
                return 0.0f;
            }
            entries = rec->entries.data();
            soa = rec->soa.data();
            count = rec->entries.size();
            if (count == 0) {
                ++counters.method[kSoftFree];
                ++counters.method[kSoftReceiverFree];
                return 1.0f;
            }
        }
    }
    if (!receiver) ++counters.method[kSoftWholeList];
    // The candidates: entries whose plane separates O from (part of) the light and whose
    // bounding ball meets O's cone to it.
    auto each = [&](const PointCone& cone, auto&& f) {
        if (receiver) {
            Triangle scratch[4];  // instanced triangles' (computed when read)
            ForCandidates(entries, soa, count, cone,
                          [&](size_t e) -> const float* {
                              const uint32_t id = entries[e] & kPrimMask;
                              if (id < flatCount_) [[likely]]
                                  return tris_[id].c;
                              return InstancedTri(id, &scratch[e % 4]).c;
                          },
                          f);
            return;
        }
        // The whole list (an origin on the far side of its own triangle, or a triangle the
        // cell does not list): rare, so the planes are read from the triangles' table.
        for (size_t e = 0; e < list->count; ++e) {
            const uint32_t prim = list->entries[e] & kPrimMask;
            Triangle tScratch;
            const Triangle& t = Tri(prim, &tScratch);
            if (Separates(t, list->entries[e] >> kSideShift, O) && BallMeetsCone(cone, t.c, t.r) && !f(prim)) return;
        }
    };
    if (R == 0) return HardLight(sp, light, each);
    return SampleLight(sp, light, each, counters);
}

void SoftShadows::Visibility(const ShadingPoint& sp, LightIndices lights, float* vis, RenderCounters& counters) const {
    Place place = Locate(sp.origin);
    for (size_t k = 0; k < lights.size(); ++k) vis[k] = LightVisibilityAt(sp, place, lights[k], counters);
}

ShadowFigures SoftShadows::Figures() const {
    std::string radii;
    const std::vector<float>& r = options_.radii;
    if (r.size() <= 8) {
        for (size_t i = 0; i < r.size(); ++i) radii += StringPrintf("%s%g", i ? ", " : "", static_cast<double>(r[i]));
    } else {  // many lights: their range
        const auto [lo, hi] = std::minmax_element(r.begin(), r.end());
        radii = StringPrintf("%g to %g (%s lights)", static_cast<double>(*lo), static_cast<double>(*hi),
                             FormatCount(r.size()).c_str());
    }
    const uint64_t cells = cellsBuilt_.load(), entries = entriesBuilt_.load();
    ShadowFigures lines = {{"light radii", radii.empty() ? "-" : radii},
            {"cells", StringPrintf("CC %d, h %g, %d x %d x %d", options_.cc, static_cast<double>(h_), nx_, ny_, nz_)},
            {"samples", StringPrintf("%d per light where a triangle is in the cone, %d rays in dense cells (lists > %d)",
                                     options_.samples, options_.denseSamples, options_.denseEntries)},
            {"occluder hierarchy", StringPrintf("%zu nodes, %.1f MB, %.1f ms", bvh_.NodeCount(), bvh_.Bytes() / 1e6,
                                                bvh_.BuildSeconds() * 1e3)},
            {"cell lists", StringPrintf("%llu built (cell x light), %.1f triangles each, %llu dense, %s with the "
                                        "index and receivers",
                                        static_cast<unsigned long long>(cells),
                                        cells ? static_cast<double>(entries) / static_cast<double>(cells) : 0.0,
                                        static_cast<unsigned long long>(denseBuilt_.load()),
                                        FormatBytes(bytesBuilt_.load()).c_str())}};
    if (scene_.mesh.instances)
        lines.push_back({"instances", StringPrintf("%zu prototype hierarchies under one over %s instances and %s flat triangles; "
                                                   "per-triangle tables %.1f MB (flat triangles only)",
                                                   bvh_.PrototypeCount(), FormatCount(scene_.mesh.instances->Instances().size()).c_str(),
                                                   FormatCount(flatCount_).c_str(),
                                                   static_cast<double>(tris_.size() * sizeof(Triangle) + area_.size() * 4) / 1e6)});
    return lines;
}

StatsLines SoftShadows::CounterLines(const RenderCounters& counters) const {
    const auto& m = counters.method;
    const double n = std::max<double>(1.0, static_cast<double>(m[kSoftLookups]));
    return {{"soft", StringPrintf("%llu point-light lookups: %.1f %% free, %.1f %% sampled (%.2f candidates each), "
                                  "%.1f %% with all directions, %.1f %% in dense cells, %llu outside the lattice; per lookup "
                                  "%.2f entries meeting the cone; %.1f %% free by their receiver's list, %.1f %% certified dark, %.1f %% on the whole list",
                                  static_cast<unsigned long long>(m[kSoftLookups]), 100.0 * m[kSoftFree] / n,
                                  100.0 * m[kSoftSampled] / n,
                                  m[kSoftSampled] ? static_cast<double>(m[kSoftCandidates]) / m[kSoftSampled] : 0.0,
                                  100.0 * m[kSoftFull] / n, 100.0 * m[kSoftDense] / n,
                                  static_cast<unsigned long long>(m[kSoftOutside]), m[kSoftBallPass] / n, 100.0 * m[kSoftReceiverFree] / n, 100.0 * m[kSoftReceiverDark] / n,
                                  100.0 * m[kSoftWholeList] / n)}};
}

std::unique_ptr<ShadowMethod> CreateSoftShadows(const Scene& scene, const Accelerator& accel,
                                                const SoftShadowOptions& options) {
    return std::make_unique<SoftShadows>(scene, accel, options);
}

}  // namespace lm
