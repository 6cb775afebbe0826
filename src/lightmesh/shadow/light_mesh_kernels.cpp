#include "lightmesh/shadow/light_mesh_kernels.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <immintrin.h>

#include "lightmesh/math/simd.h"
#include "lightmesh/util/parallel.h"  // LIGHTMESH_TSAN

namespace lm::kernels {
namespace {

/// One front triangle's blocker entry (LightMesh::FindBlockers): plane and the side o is on,
/// the edge planes through o with their rounding margins. The scalar oracle of the AVX2
/// pass, which performs these very operations in this order.
inline void BlockerEntry(const FrontArrays& f, uint32_t i, const BlockerQuery& q, float so, Blockers* b, uint32_t n) {
    b->reaches[n] = (f.hix[i] >= q.o.x - q.margin ? 1 : 0) | (f.lox[i] <= q.o.x + q.margin ? 2 : 0) |
                    (f.hiy[i] >= q.o.y - q.margin ? 4 : 0) | (f.loy[i] <= q.o.y + q.margin ? 8 : 0) |
                    (f.hiz[i] >= q.o.z - q.margin ? 16 : 0) | (f.loz[i] <= q.o.z + q.margin ? 32 : 0);
    b->nx[n] = f.nx[i];
    b->ny[n] = f.ny[i];
    b->nz[n] = f.nz[i];
    b->d[n] = f.d[i];
    b->side[n] = so > q.margin ? 1.0f : (so < -q.margin ? -1.0f : 0.0f);
    // The edge planes through P's origin. Their error: a_k is exact to about planeDelta_
    // (an ulp or two of the coordinates), so c_k to a few planeDelta_·|a| plus its own
    // rounding; a node's d = x - origin is at most pointReach_ long.
    const Vec3 a[3] = {Vec3(f.v0x[i], f.v0y[i], f.v0z[i]) - q.o, Vec3(f.v1x[i], f.v1y[i], f.v1z[i]) - q.o,
                       Vec3(f.v2x[i], f.v2y[i], f.v2z[i]) - q.o};
    float* cx[3] = {b->c0x, b->c1x, b->c2x};
    float* cy[3] = {b->c0y, b->c1y, b->c2y};
    float* cz[3] = {b->c0z, b->c1z, b->c2z};
    float* mk[3] = {b->m0, b->m1, b->m2};
    // Lengths bounded by L1 norms (no square roots; larger margins are safe).
    auto l1 = [](const Vec3& v) { return std::abs(v.x) + std::abs(v.y) + std::abs(v.z); };
    const float la[3] = {l1(a[0]), l1(a[1]), l1(a[2])};
    for (int k = 0; k < 3; ++k) {
        const int k1 = k == 2 ? 0 : k + 1;
        const Vec3 ck = Cross(a[k], a[k1]);
        cx[k][n] = ck.x;
        cy[k][n] = ck.y;
        cz[k][n] = ck.z;
        mk[k][n] = q.reach * (q.delta8 * (la[k] + la[k1]) + 1e-5f * la[k] * la[k1]) + q.delta8 * l1(ck);
    }
}
/// The octants of a segment's direction from which a blocker with direction code c may be
/// met: those whose needs (OctantNeeds) c has.
struct OctantTable {
    uint8_t octants[64];
};
constexpr OctantTable MakeOctantTable() {
    OctantTable t{};
    for (int c = 0; c < 64; ++c)
        for (int k = 0; k < 8; ++k)
            if ((c & OctantNeeds(k)) == OctantNeeds(k)) t.octants[c] |= static_cast<uint8_t>(1 << k);
    return t;
}
constexpr OctantTable kOctants = MakeOctantTable();

/// FindBlockers' pass over the front triangles, one at a time: those whose box meets the
/// segments' box and whose plane passes within `far` of o become blockers. False if more
/// than kMaxBlockers do (then the back-end decides every segment).
bool FindBlockersScalar(const FrontArrays& f, const BlockerQuery& q, Blockers* b) {
    uint32_t n = 0;
    for (uint32_t i = 0; i < f.count; ++i) {
        if (f.hix[i] < q.lo.x || f.lox[i] > q.hi.x || f.hiy[i] < q.lo.y || f.loy[i] > q.hi.y || f.hiz[i] < q.lo.z ||
            f.loz[i] > q.hi.z)
            continue;
        // A plane farther from P's origin than any node: every segment is on one side.
        const float so = Dot(Vec3(f.nx[i], f.ny[i], f.nz[i]), q.o) - f.d[i];
        if (std::abs(so) > q.far) continue;
        if (n == kMaxBlockers) return false;
        BlockerEntry(f, i, q, so, b, n++);
    }
    b->count = n;
    return true;
}
/// The same eight front triangles at a time with AVX2: the tests and BlockerEntry's
/// arithmetic lane by lane (-ffp-contract=off, so bit for bit the scalar pass's), then the
/// kept lanes packed to the front of each array by a permutation from a table.
struct CompactTable {
    alignas(32) int32_t index[256][8];
};
constexpr CompactTable MakeCompactTable() {
    CompactTable t{};
    for (int m = 0; m < 256; ++m) {
        int n = 0;
        for (int k = 0; k < 8; ++k)
            if (m >> k & 1) t.index[m][n++] = k;
        for (; n < 8; ++n) t.index[m][n] = 0;
    }
    return t;
}
constexpr CompactTable kCompact = MakeCompactTable();
__attribute__((target("avx2,popcnt"))) bool FindBlockersAvx2(const FrontArrays& f, const BlockerQuery& q, Blockers* b) {
    const __m256 lox = _mm256_set1_ps(q.lo.x), loy = _mm256_set1_ps(q.lo.y), loz = _mm256_set1_ps(q.lo.z);
    const __m256 hix = _mm256_set1_ps(q.hi.x), hiy = _mm256_set1_ps(q.hi.y), hiz = _mm256_set1_ps(q.hi.z);
    const __m256 ox = _mm256_set1_ps(q.o.x), oy = _mm256_set1_ps(q.o.y), oz = _mm256_set1_ps(q.o.z);
    const __m256 far = _mm256_set1_ps(q.far), margin = _mm256_set1_ps(q.margin), negMargin = _mm256_set1_ps(-q.margin);
    const __m256 reach = _mm256_set1_ps(q.reach), delta8 = _mm256_set1_ps(q.delta8), tiny = _mm256_set1_ps(1e-5f);
    const __m256 one = _mm256_set1_ps(1.0f), minusOne = _mm256_set1_ps(-1.0f), zero = _mm256_setzero_ps();
    const __m256 signBit = _mm256_set1_ps(-0.0f);
#define LM_ABS(v) _mm256_andnot_ps(signBit, (v))
#define LM_L1(x, y, z) _mm256_add_ps(_mm256_add_ps(LM_ABS(x), LM_ABS(y)), LM_ABS(z))
    uint32_t n = 0;
    for (uint32_t i = 0; i < f.count; i += 8) {
#define LM_LD(a) _mm256_load_ps(f.a + i)
        __m256 skip = _mm256_or_ps(_mm256_cmp_ps(LM_LD(hix), lox, _CMP_LT_OQ), _mm256_cmp_ps(LM_LD(lox), hix, _CMP_GT_OQ));
        skip = _mm256_or_ps(skip, _mm256_or_ps(_mm256_cmp_ps(LM_LD(hiy), loy, _CMP_LT_OQ), _mm256_cmp_ps(LM_LD(loy), hiy, _CMP_GT_OQ)));
        skip = _mm256_or_ps(skip, _mm256_or_ps(_mm256_cmp_ps(LM_LD(hiz), loz, _CMP_LT_OQ), _mm256_cmp_ps(LM_LD(loz), hiz, _CMP_GT_OQ)));
        const __m256 nx = LM_LD(nx), ny = LM_LD(ny), nz = LM_LD(nz), d = LM_LD(d);
        const __m256 so = _mm256_sub_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, ox), _mm256_mul_ps(ny, oy)), _mm256_mul_ps(nz, oz)), d);
        skip = _mm256_or_ps(skip, _mm256_cmp_ps(LM_ABS(so), far, _CMP_GT_OQ));
        const int keep = ~_mm256_movemask_ps(skip) & 0xFF;
        if (!keep) continue;
        const int kept = __builtin_popcount(static_cast<unsigned>(keep));
        if (n + kept > kMaxBlockers) return false;
        const __m256 side = _mm256_blendv_ps(_mm256_blendv_ps(zero, minusOne, _mm256_cmp_ps(so, negMargin, _CMP_LT_OQ)), one,
                                             _mm256_cmp_ps(so, margin, _CMP_GT_OQ));
        const __m256 ax[3] = {_mm256_sub_ps(LM_LD(v0x), ox), _mm256_sub_ps(LM_LD(v1x), ox), _mm256_sub_ps(LM_LD(v2x), ox)};
        const __m256 ay[3] = {_mm256_sub_ps(LM_LD(v0y), oy), _mm256_sub_ps(LM_LD(v1y), oy), _mm256_sub_ps(LM_LD(v2y), oy)};
        const __m256 az[3] = {_mm256_sub_ps(LM_LD(v0z), oz), _mm256_sub_ps(LM_LD(v1z), oz), _mm256_sub_ps(LM_LD(v2z), oz)};
#undef LM_LD
        const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompact.index[keep]));
#define LM_PUT(out, v) _mm256_storeu_ps((out) + n, _mm256_permutevar8x32_ps((v), perm))
        {
            const __m256 mo = _mm256_set1_ps(q.margin);
#define LM_BIT(mask, value) _mm256_and_si256(_mm256_castps_si256(mask), _mm256_set1_epi32(value))
            const __m256 oxm = _mm256_sub_ps(ox, mo), oxp = _mm256_add_ps(ox, mo), oym = _mm256_sub_ps(oy, mo),
                         oyp = _mm256_add_ps(oy, mo), ozm = _mm256_sub_ps(oz, mo), ozp = _mm256_add_ps(oz, mo);
            __m256i code = _mm256_or_si256(LM_BIT(_mm256_cmp_ps(_mm256_load_ps(f.hix + i), oxm, _CMP_GE_OQ), 1),
                                           LM_BIT(_mm256_cmp_ps(_mm256_load_ps(f.lox + i), oxp, _CMP_LE_OQ), 2));
            code = _mm256_or_si256(code, _mm256_or_si256(LM_BIT(_mm256_cmp_ps(_mm256_load_ps(f.hiy + i), oym, _CMP_GE_OQ), 4),
                                                         LM_BIT(_mm256_cmp_ps(_mm256_load_ps(f.loy + i), oyp, _CMP_LE_OQ), 8)));
            code = _mm256_or_si256(code, _mm256_or_si256(LM_BIT(_mm256_cmp_ps(_mm256_load_ps(f.hiz + i), ozm, _CMP_GE_OQ), 16),
                                                         LM_BIT(_mm256_cmp_ps(_mm256_load_ps(f.loz + i), ozp, _CMP_LE_OQ), 32)));
#undef LM_BIT
            _mm256_storeu_si256(reinterpret_cast<__m256i*>(b->reaches + n), _mm256_permutevar8x32_epi32(code, perm));
        }
        LM_PUT(b->nx, nx);
        LM_PUT(b->ny, ny);
        LM_PUT(b->nz, nz);
        LM_PUT(b->d, d);
        LM_PUT(b->side, side);
        float* cx[3] = {b->c0x, b->c1x, b->c2x};
        float* cy[3] = {b->c0y, b->c1y, b->c2y};
        float* cz[3] = {b->c0z, b->c1z, b->c2z};
        float* mk[3] = {b->m0, b->m1, b->m2};
        const __m256 la[3] = {LM_L1(ax[0], ay[0], az[0]), LM_L1(ax[1], ay[1], az[1]), LM_L1(ax[2], ay[2], az[2])};
        for (int k = 0; k < 3; ++k) {
            const int k1 = k == 2 ? 0 : k + 1;
            const __m256 cxk = _mm256_sub_ps(_mm256_mul_ps(ay[k], az[k1]), _mm256_mul_ps(az[k], ay[k1]));
            const __m256 cyk = _mm256_sub_ps(_mm256_mul_ps(az[k], ax[k1]), _mm256_mul_ps(ax[k], az[k1]));
            const __m256 czk = _mm256_sub_ps(_mm256_mul_ps(ax[k], ay[k1]), _mm256_mul_ps(ay[k], ax[k1]));
            LM_PUT(cx[k], cxk);
            LM_PUT(cy[k], cyk);
            LM_PUT(cz[k], czk);
            const __m256 inner = _mm256_add_ps(_mm256_mul_ps(delta8, _mm256_add_ps(la[k], la[k1])),
                                               _mm256_mul_ps(_mm256_mul_ps(tiny, la[k]), la[k1]));
            LM_PUT(mk[k], _mm256_add_ps(_mm256_mul_ps(reach, inner), _mm256_mul_ps(delta8, LM_L1(cxk, cyk, czk))));
        }
        n += static_cast<uint32_t>(kept);
    }
#undef LM_PUT
#undef LM_L1
#undef LM_ABS
    b->count = n;
    return true;
}

/// Whether no front triangle can block a segment from x to any origin of the patch: each
/// has x and every origin clearly on one side of its plane, or a box apart from theirs.
bool PatchSeesScalar(const FrontArrays& f, const PatchQuery& q) {
    for (uint32_t i = 0; i < f.count; ++i) {
        const float sx = Dot(Vec3(f.nx[i], f.ny[i], f.nz[i]), q.x) - f.d[i];
        if ((sx > q.m && f.sMin[i] > q.mQ) || (sx < -q.m && f.sMax[i] < -q.mQ)) continue;
        if (f.hix[i] < q.lo.x || f.lox[i] > q.hi.x || f.hiy[i] < q.lo.y || f.loy[i] > q.hi.y || f.hiz[i] < q.lo.z ||
            f.loz[i] > q.hi.z)
            continue;
        return false;
    }
    return true;
}
// The same eight triangles at a time (the padding lanes' empty boxes are apart from all).
__attribute__((target("avx2"))) bool PatchSeesAvx2(const FrontArrays& f, const PatchQuery& q) {
    const __m256 xx = _mm256_set1_ps(q.x.x), xy = _mm256_set1_ps(q.x.y), xz = _mm256_set1_ps(q.x.z);
    const __m256 m = _mm256_set1_ps(q.m), negM = _mm256_set1_ps(-q.m), mQ = _mm256_set1_ps(q.mQ),
                 negMQ = _mm256_set1_ps(-q.mQ);
    const __m256 lox = _mm256_set1_ps(q.lo.x), loy = _mm256_set1_ps(q.lo.y), loz = _mm256_set1_ps(q.lo.z);
    const __m256 hix = _mm256_set1_ps(q.hi.x), hiy = _mm256_set1_ps(q.hi.y), hiz = _mm256_set1_ps(q.hi.z);
    for (uint32_t i = 0; i < f.count; i += 8) {
#define LM_LD(a) _mm256_load_ps(f.a + i)
        const __m256 sx = _mm256_sub_ps(
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(LM_LD(nx), xx), _mm256_mul_ps(LM_LD(ny), xy)), _mm256_mul_ps(LM_LD(nz), xz)),
            LM_LD(d));
        const __m256 above = _mm256_and_ps(_mm256_cmp_ps(sx, m, _CMP_GT_OQ), _mm256_cmp_ps(LM_LD(sMin), mQ, _CMP_GT_OQ));
        const __m256 below = _mm256_and_ps(_mm256_cmp_ps(sx, negM, _CMP_LT_OQ), _mm256_cmp_ps(LM_LD(sMax), negMQ, _CMP_LT_OQ));
        __m256 apart = _mm256_or_ps(_mm256_cmp_ps(LM_LD(hix), lox, _CMP_LT_OQ), _mm256_cmp_ps(LM_LD(lox), hix, _CMP_GT_OQ));
        apart = _mm256_or_ps(apart, _mm256_or_ps(_mm256_cmp_ps(LM_LD(hiy), loy, _CMP_LT_OQ), _mm256_cmp_ps(LM_LD(loy), hiy, _CMP_GT_OQ)));
        apart = _mm256_or_ps(apart, _mm256_or_ps(_mm256_cmp_ps(LM_LD(hiz), loz, _CMP_LT_OQ), _mm256_cmp_ps(LM_LD(loz), hiz, _CMP_GT_OQ)));
#undef LM_LD
        if (_mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(above, below), apart)) != 0xFF) return false;
    }
    return true;
}

// Whether any lane of a comparison's mask is set: the halves OR-ed down to one lane
// (shuffles the compiler keeps in registers), not a loop over lanes.
template <int W>
[[gnu::always_inline]] inline bool AnyLane(const typename SimdVectors<W>::I& v) {
    SimdVectors<4>::I low;
    if constexpr (W == 8)
        low = __builtin_shufflevector(v, v, 0, 1, 2, 3) | __builtin_shufflevector(v, v, 4, 5, 6, 7);
    else
        low = v;
    low |= __builtin_shufflevector(low, low, 2, 3, 0, 1);
    return (low[0] | low[1]) != 0;
}

/// The culling loop of LightMesh::SeesPointCulled over W blockers at a time (GCC/clang
/// vector extensions): 1 if a blocker is certainly hit, 0 if every blocker is certainly
/// missed, -1 if undecided.
template <int W>
[[gnu::always_inline]] inline int CullSegment(const Blockers& b, const Vec3& x, const Vec3& o, float m) {
    using VF = typename SimdVectors<W>::F;
    using VI = typename SimdVectors<W>::I;
    const VF zero = {};
    const VF xx = zero + x.x, xy = zero + x.y, xz = zero + x.z, mm = zero + m;
    const Vec3 dv = x - o;
    const VF dx = zero + dv.x, dy = zero + dv.y, dz = zero + dv.z;
    VI maybe = {};
    // Only the blockers that reach to the side d points to on every axis can be met.
    const int octant = DirectionOctant(dv);
    const VI needsV = VI{} + OctantNeeds(octant);
    for (uint32_t i = 0; i < b.count; i += W) {
        if (!((b.octants[i / kCullWidth] >> octant) & 1)) continue;  // none of these eight
#define LM_AT(a) (*reinterpret_cast<const VF*>((a) + i))
        const VI reached = (*reinterpret_cast<const VI*>(b.reaches + i) & needsV) == needsV;
        // Both ends clearly on one side of the plane (miss), or on both sides (a hit if
        // the line crosses the inside).
        const VF sideX = (LM_AT(b.nx) * xx + LM_AT(b.ny) * xy + LM_AT(b.nz) * xz - LM_AT(b.d)) * LM_AT(b.side);
        const VI sameSide = sideX > mm, across = sideX < -mm;
        // The line's side of each edge plane through the origin.
        const VF t0 = LM_AT(b.c0x) * dx + LM_AT(b.c0y) * dy + LM_AT(b.c0z) * dz;
        const VF t1 = LM_AT(b.c1x) * dx + LM_AT(b.c1y) * dy + LM_AT(b.c1z) * dz;
        const VF t2 = LM_AT(b.c2x) * dx + LM_AT(b.c2y) * dy + LM_AT(b.c2z) * dz;
        const VF m0 = LM_AT(b.m0), m1 = LM_AT(b.m1), m2 = LM_AT(b.m2);
        const VI pos0 = t0 > m0, pos1 = t1 > m1, pos2 = t2 > m2;
        const VI neg0 = t0 < -m0, neg1 = t1 < -m1, neg2 = t2 < -m2;
        const VI outside = (pos0 | pos1 | pos2) & (neg0 | neg1 | neg2);
        const VI inside = (pos0 & pos1 & pos2) | (neg0 & neg1 & neg2);
        maybe |= ~(sameSide | outside) & reached;
        // A blocker certainly hit decides the segment, whatever the others say: stop (a
        // blocked minority node, the common case where candidates disagree, often meets
        // its blocker in the first eight).
        if (AnyLane<W>(inside & across & reached)) return 1;
#undef LM_AT
    }
    return AnyLane<W>(maybe) ? -1 : 0;
}
int CullSegmentSse(const Blockers& b, const Vec3& x, const Vec3& o, float m) { return CullSegment<4>(b, x, o, m); }
// The same eight at a time where the processor has AVX2 (chosen once, at run time).
__attribute__((target("avx2"))) int CullSegmentAvx2(const Blockers& b, const Vec3& x, const Vec3& o, float m) {
    return CullSegment<8>(b, x, o, m);
}

/// The templates' front test, (n(P), x - P) > eps·h with x - P = (offset - frac)·h, written
/// (n, offset) - nfrac > eps with nfrac = (n, frac) once per point, over `count` blocks:
/// bit k of masks[b] is set when lane k of block b is in front. Dot()'s operations in its
/// order, then the subtraction (the library is built with -ffp-contract=off), so SSE, AVX2
/// and a scalar Dot agree bit for bit; what it saves is a scalar loop's unpredictable
/// branch per entry.
// Four int8 offsets (from p) as floats, with SSE2 only: each byte spread over a 32-bit
// lane and shifted back down with its sign.
inline __m128 FourOffsets(const int8_t* p) {
    int32_t bytes;
    std::memcpy(&bytes, p, sizeof(bytes));
    __m128i v = _mm_cvtsi32_si128(bytes);
    v = _mm_unpacklo_epi8(v, v);
    v = _mm_unpacklo_epi16(v, v);
    return _mm_cvtepi32_ps(_mm_srai_epi32(v, 24));
}
void FrontMasksSse(const FrontBlock* blocks, uint32_t count, const Vec3& n, float nfrac, float eps, uint8_t* masks) {
    const __m128 nx = _mm_set1_ps(n.x), ny = _mm_set1_ps(n.y), nz = _mm_set1_ps(n.z);
    const __m128 nf = _mm_set1_ps(nfrac), e = _mm_set1_ps(eps);
    for (uint32_t b = 0; b < count; ++b) {
        int mask = 0;
        for (int half = 0; half < 2; ++half) {
            const int o = 4 * half;
            __m128 d = _mm_add_ps(_mm_mul_ps(nx, FourOffsets(blocks[b].ox + o)), _mm_mul_ps(ny, FourOffsets(blocks[b].oy + o)));
            d = _mm_sub_ps(_mm_add_ps(d, _mm_mul_ps(nz, FourOffsets(blocks[b].oz + o))), nf);
            mask |= _mm_movemask_ps(_mm_cmpgt_ps(d, e)) << o;
        }
        masks[b] = static_cast<uint8_t>(mask & blocks[b].lanes);
    }
}
// Eight int8 offsets (from p) as floats.
__attribute__((target("avx2"), always_inline)) inline __m256 EightOffsets(const int8_t* p) {
    int64_t bytes;
    std::memcpy(&bytes, p, sizeof(bytes));
    return _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(_mm_cvtsi64_si128(bytes)));
}
__attribute__((target("avx2"))) void FrontMasksAvx2(const FrontBlock* blocks, uint32_t count, const Vec3& n, float nfrac,
                                                    float eps, uint8_t* masks) {
    const __m256 nx = _mm256_set1_ps(n.x), ny = _mm256_set1_ps(n.y), nz = _mm256_set1_ps(n.z);
    const __m256 nf = _mm256_set1_ps(nfrac), e = _mm256_set1_ps(eps);
    for (uint32_t b = 0; b < count; ++b) {
        __m256 d = _mm256_add_ps(_mm256_mul_ps(nx, EightOffsets(blocks[b].ox)), _mm256_mul_ps(ny, EightOffsets(blocks[b].oy)));
        d = _mm256_sub_ps(_mm256_add_ps(d, _mm256_mul_ps(nz, EightOffsets(blocks[b].oz))), nf);
        masks[b] = static_cast<uint8_t>(_mm256_movemask_ps(_mm256_cmp_ps(d, e, _CMP_GT_OQ)) & blocks[b].lanes);
    }
}
// One lane at a time with Dot() itself: the oracle of the other two (tests).
void FrontMasksScalar(const FrontBlock* blocks, uint32_t count, const Vec3& n, float nfrac, float eps, uint8_t* masks) {
    for (uint32_t b = 0; b < count; ++b) {
        int mask = 0;
        for (int k = 0; k < 8; ++k) {
            const Vec3 offset(static_cast<float>(blocks[b].ox[k]), static_cast<float>(blocks[b].oy[k]),
                              static_cast<float>(blocks[b].oz[k]));
            if (((blocks[b].lanes >> k) & 1) && Dot(n, offset) - nfrac > eps) mask |= 1 << k;
        }
        masks[b] = static_cast<uint8_t>(mask);
    }
}

/// Нет's sum (LightMesh::UseAll) with AVX2 for node words of 2 or 4 bytes (1-byte words:
/// SumFrontBytesAvx2 below; GatherFrontWords serves all three): the words
/// of a block's eight entries gathered at once (32-bit loads at the words' addresses: the
/// node array has padding after its end, and the bytes above a narrower word are shifted
/// out), then per light the entries in front whose bit is set, by popcount of a movemask.
/// False, having added nothing, if an entry in front is not yet evaluated (the scalar path
/// evaluates it). The loads are relaxed: a node's word is all it publishes, and an aligned
/// word cannot tear.
// The words of block b's lanes in `mask` (in the low bytes of a lane; the other lanes 0);
// false if one of them is not yet evaluated (its top bit, "initialised", clear).
template <int Bytes>
__attribute__((target("avx2"), always_inline)) inline bool GatherFrontWords(const FrontBlock& block, int mask,
                                                                            const void* nodes, __m256i* words) {
    const __m256i laneBits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    const __m256i on = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(mask), laneBits), laneBits);
    const __m256i index = _mm256_load_si256(reinterpret_cast<const __m256i*>(block.linear));
    *words = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), static_cast<const int*>(nodes), index, on, Bytes);
    return (_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_slli_epi32(*words, 32 - 8 * Bytes))) & mask) == mask;
}
template <int Bytes>
__attribute__((target("avx2,popcnt"))) bool SumFrontWordsAvx2(const FrontBlock* blocks, const uint8_t* masks,
                                                              uint32_t count, const void* nodes, int lights,
                                                              uint32_t* visible, uint32_t* m) {
    uint32_t sums[8 * Bytes - 2] = {}, used = 0;
    for (uint32_t b = 0; b < count; ++b) {
        const int mask = masks[b];
        if (!mask) continue;
        __m256i w;
        if (!GatherFrontWords<Bytes>(blocks[b], mask, nodes, &w)) return false;
        for (int l = 0; l < lights; ++l)
            sums[l] += static_cast<uint32_t>(
                __builtin_popcount(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_slli_epi32(w, 31 - l))) & mask));
        used += static_cast<uint32_t>(__builtin_popcount(mask));
    }
    for (int l = 0; l < lights; ++l) visible[l] += sums[l];
    *m += used;
    return true;
}
/// The same sum for 1-byte words (up to 6 lights: the common case), without a pass per
/// light: a lane's light bits 0-3 are spread to the four bytes of its 32-bit lane by one
/// multiply, (w & 15)·0x00204081 & 0x01010101 (the four shifted copies, by 0, 7, 14 and 21
/// bits, do not overlap, so byte k holds bit k), and bits 4-5 likewise, and added to byte
/// counters per lane; every 255 blocks at most (a lane's byte gains at most 1 per block)
/// the counters are widened to 16 bits and summed over the lanes. The gathered lanes not
/// in front are 0 and add nothing. Measured (callgrind, one thread, the castle's Нет at
/// 1024×768, 4 lights): UseAll 541 → 496 instructions a point; with two lights (the
/// gazebo) the two are even.
__attribute__((target("avx2"), always_inline)) inline void AddByteCounters(__m256i counters, uint32_t* sums) {
    const __m256i zero = _mm256_setzero_si256();
    // Bytes 0-7 and 8-15 of each half as 16-bit lanes: byte i's light is i mod 4.
    const __m256i wide = _mm256_add_epi16(_mm256_unpacklo_epi8(counters, zero), _mm256_unpackhi_epi8(counters, zero));
    __m128i s = _mm_add_epi16(_mm256_castsi256_si128(wide), _mm256_extracti128_si256(wide, 1));
    s = _mm_add_epi16(s, _mm_srli_si128(s, 8));  // 16-bit lanes 0-3: lights 0-3, at most 8·255
    alignas(16) uint32_t out[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(out), _mm_cvtepu16_epi32(s));
    for (int k = 0; k < 4; ++k) sums[k] += out[k];
}
__attribute__((target("avx2,popcnt"))) bool SumFrontBytesAvx2(const FrontBlock* blocks, const uint8_t* masks,
                                                              uint32_t count, const void* nodes, int lights,
                                                              uint32_t* visible, uint32_t* m) {
    const __m256i low = _mm256_set1_epi32(0x0F), spread = _mm256_set1_epi32(0x00204081),
                  ones = _mm256_set1_epi32(0x01010101);
    __m256i lowCounters = _mm256_setzero_si256(), highCounters = _mm256_setzero_si256();
    uint32_t sums[8] = {}, used = 0, pending = 0;
    const bool high = lights > 4;
    for (uint32_t b = 0; b < count; ++b) {
        const int mask = masks[b];
        if (!mask) continue;
        __m256i w;
        if (!GatherFrontWords<1>(blocks[b], mask, nodes, &w)) return false;
        lowCounters = _mm256_add_epi32(
            lowCounters, _mm256_and_si256(_mm256_mullo_epi32(_mm256_and_si256(w, low), spread), ones));
        if (high)  // bits 4 and 5 (bit 6 is "inside", 7 "initialised")
            highCounters = _mm256_add_epi32(
                highCounters,
                _mm256_and_si256(_mm256_mullo_epi32(_mm256_and_si256(_mm256_srli_epi32(w, 4), _mm256_set1_epi32(3)), spread),
                                 ones));
        used += static_cast<uint32_t>(__builtin_popcount(static_cast<unsigned>(mask)));
        if (++pending == 255) {
            AddByteCounters(lowCounters, sums);
            if (high) AddByteCounters(highCounters, sums + 4);
            lowCounters = highCounters = _mm256_setzero_si256();
            pending = 0;
        }
    }
    AddByteCounters(lowCounters, sums);
    if (high) AddByteCounters(highCounters, sums + 4);
    for (int l = 0; l < lights; ++l) visible[l] += sums[l];
    *m += used;
    return true;
}

/// Consensus's minority and majority with AVX2: a block's words gathered as for the sums,
/// their needed bits compared with the majority's lane by lane (the bytes above a narrower
/// word are masked out with the bits not needed), instead of a load, a compare and a shift
/// per entry. Measured (callgrind, one thread, castle at 1024×768): the light mesh's
/// instructions 1,136M → 1,113M at kI 2 and 3,576M → 3,435M at kI 3.
template <int Bytes>
__attribute__((target("avx2"))) void MinorityMasksAvx2(const FrontBlock* blocks, const uint8_t* masks, uint32_t count,
                                                       const void* nodes, uint32_t needed, uint32_t majority,
                                                       uint8_t* minority, uint8_t* majorityMasks) {
    const __m256i need = _mm256_set1_epi32(static_cast<int>(needed)), major = _mm256_set1_epi32(static_cast<int>(majority));
    for (uint32_t b = 0; b < count; ++b) {
        const int mask = masks[b];
        minority[b] = majorityMasks[b] = 0;
        if (!mask) continue;
        __m256i w;
        GatherFrontWords<Bytes>(blocks[b], mask, nodes, &w);  // all evaluated (the caller's pass 1)
        const int same = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(w, need), major)));
        minority[b] = static_cast<uint8_t>(~same & mask);
        majorityMasks[b] = static_cast<uint8_t>(same & mask);
    }
}

/// The side summary's nodes one at a time, with the very operations of LightMesh::Side
/// before it used this kernel: the AVX2 pass's oracle, and its tail.
uint32_t SideNodesScalar(const int8_t* ox, const int8_t* oy, const int8_t* oz, uint32_t count, const SideQuery& q,
                         uint32_t* kept) {
    uint32_t n = 0;
    for (uint32_t e = 0; e < count; ++e) {
        const float x = q.origin[0] + static_cast<float>(q.cell[0] + ox[e]) * q.h;
        const float y = q.origin[1] + static_cast<float>(q.cell[1] + oy[e]) * q.h;
        const float z = q.origin[2] + static_cast<float>(q.cell[2] + oz[e]) * q.h;
        const double hx = q.n[0] * x + q.n[1] * y + q.n[2] * z - q.d;
        if (q.side == 0 ? !(hx > 0) : !(hx < 0)) continue;  // the other side, or on Π
        if (std::abs(hx) > q.slab) continue;
        kept[n++] = e;
    }
    return n;
}
/// Four nodes at a time: the positions in float (SSE lanes), then hx in double (AVX lanes),
/// each operation the scalar one's, without contraction (no FMA in the target), so every
/// node is kept or not exactly as one at a time. Measured (callgrind, one thread, the
/// gazebo at 800×600): the side summaries' loop 20M of the light mesh's 500M instructions.
__attribute__((target("avx2"), always_inline)) inline __m128 FourCoordinates(const int8_t* o, int cell, float origin,
                                                                              float h) {
    int32_t bytes;
    std::memcpy(&bytes, o, sizeof(bytes));
    const __m128i index = _mm_add_epi32(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(bytes)), _mm_set1_epi32(cell));
    return _mm_add_ps(_mm_set1_ps(origin), _mm_mul_ps(_mm_cvtepi32_ps(index), _mm_set1_ps(h)));
}
__attribute__((target("avx2,popcnt"))) uint32_t SideNodesAvx2(const int8_t* ox, const int8_t* oy, const int8_t* oz,
                                                              uint32_t count, const SideQuery& q, uint32_t* kept) {
    const __m256d n0 = _mm256_set1_pd(q.n[0]), n1 = _mm256_set1_pd(q.n[1]), n2 = _mm256_set1_pd(q.n[2]);
    const __m256d d = _mm256_set1_pd(q.d), slab = _mm256_set1_pd(q.slab), zero = _mm256_setzero_pd();
    const __m256d sign = _mm256_set1_pd(-0.0);
    uint32_t n = 0, e = 0;
    for (; e + 4 <= count; e += 4) {
        const __m256d x = _mm256_cvtps_pd(FourCoordinates(ox + e, q.cell[0], q.origin[0], q.h));
        const __m256d y = _mm256_cvtps_pd(FourCoordinates(oy + e, q.cell[1], q.origin[1], q.h));
        const __m256d z = _mm256_cvtps_pd(FourCoordinates(oz + e, q.cell[2], q.origin[2], q.h));
        const __m256d hx =
            _mm256_sub_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(n0, x), _mm256_mul_pd(n1, y)), _mm256_mul_pd(n2, z)), d);
        const __m256d onSide = q.side == 0 ? _mm256_cmp_pd(hx, zero, _CMP_GT_OQ) : _mm256_cmp_pd(hx, zero, _CMP_LT_OQ);
        const __m256d inSlab = _mm256_cmp_pd(_mm256_andnot_pd(sign, hx), slab, _CMP_LE_OQ);
        for (unsigned m = static_cast<unsigned>(_mm256_movemask_pd(_mm256_and_pd(onSide, inSlab))); m; m &= m - 1)
            kept[n++] = e + static_cast<uint32_t>(__builtin_ctz(m));
    }
    const uint32_t tail = SideNodesScalar(ox + e, oy + e, oz + e, count - e, q, kept + n);
    for (uint32_t i = 0; i < tail; ++i) kept[n + i] += e;  // the tail's numbers, counted from e
    return n + tail;
}

/// The near-list filter one id at a time, without branches (a third of a list passes, at
/// random): each id is written and kept if it passes. The AVX2 pass's oracle.
uint64_t FilterNearScalar(const uint32_t* ids, const uint32_t* codes, uint32_t count, uint32_t reachBits,
                          uint32_t cellBits, uint32_t* reach, uint32_t* cell) {
    const uint32_t both = reachBits | cellBits;
    uint32_t nr = 0, nc = 0;
    for (uint32_t i = 0; i < count; ++i) {
        const uint32_t code = codes[i], t = ids[i];
        reach[nr] = t;
        nr += (code & reachBits) == reachBits;
        cell[nc] = t;
        nc += (code & both) == both;
    }
    return nr | static_cast<uint64_t>(nc) << 32;
}
/// Left-packing permutations: entry m lists, in order, the lanes of the bits set in m
/// (the rest 0), one byte each.
struct PackTable {
    uint64_t lanes[256];
};
constexpr PackTable MakePackTable() {
    PackTable t{};
    for (int m = 0; m < 256; ++m) {
        int n = 0;
        for (int k = 0; k < 8; ++k)
            if (m & (1 << k)) t.lanes[m] |= static_cast<uint64_t>(k) << (8 * n++);
    }
    return t;
}
constexpr PackTable kPack = MakePackTable();
// v's lanes of the bits set in mask, moved to the front in order.
__attribute__((target("avx2"), always_inline)) inline __m256i PackLanes(__m256i v, unsigned mask) {
    const __m256i lanes = _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(static_cast<long long>(kPack.lanes[mask])));
    return _mm256_permutevar8x32_epi32(v, lanes);
}
/// Eight ids at a time: the codes' tests as lane masks, the ids kept moved to the front
/// of the group by a permutation (kPack) and the whole group stored where the list ends;
/// the list then grows by the number kept. Same lists as the scalar pass (tests).
__attribute__((target("avx2,popcnt"))) uint64_t FilterNearAvx2(const uint32_t* ids, const uint32_t* codes,
                                                                uint32_t count, uint32_t reachBits, uint32_t cellBits,
                                                                uint32_t* reach, uint32_t* cell) {
    const __m256i rb = _mm256_set1_epi32(static_cast<int>(reachBits));
    const __m256i bb = _mm256_set1_epi32(static_cast<int>(reachBits | cellBits));
    uint32_t nr = 0, nc = 0, i = 0;
    for (; i + 8 <= count; i += 8) {
        const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(codes + i));
        const __m256i t = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ids + i));
        const unsigned mr = static_cast<unsigned>(
            _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(c, rb), rb))));
        const unsigned mc = static_cast<unsigned>(
            _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(c, bb), bb))));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(reach + nr), PackLanes(t, mr));
        nr += static_cast<uint32_t>(__builtin_popcount(mr));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(cell + nc), PackLanes(t, mc));
        nc += static_cast<uint32_t>(__builtin_popcount(mc));
    }
    const uint64_t tail = FilterNearScalar(ids + i, codes + i, count - i, reachBits, cellBits, reach + nr, cell + nc);
    return (nr + (tail & 0xffffffffu)) | static_cast<uint64_t>(nc + (tail >> 32)) << 32;
}

/// The near codes with BrickAxisBits itself: the oracle of the AVX pass.
void NearCodesScalar(const BrickAxes& reach, const BrickAxes& cell, const float* boxes, size_t stride,
                     const uint32_t* ids, uint32_t count, uint32_t* codes) {
    for (uint32_t i = 0; i < count; ++i) {
        const float* box = boxes + ids[i] * stride;
        const Vec3 lo(box[0], box[1], box[2]), hi(box[3], box[4], box[5]);
        codes[i] = BrickAxisBits(reach, lo, hi) | BrickAxisBits(cell, lo, hi) << 12;
    }
}
/// Per axis, one compare of eight lanes (the reach's four positions, then the cell's four)
/// for each bound: the same comparisons as BrickAxisBits (ordered, so false with a NaN).
__attribute__((target("avx2"))) void NearCodesAvx2(const BrickAxes& reach, const BrickAxes& cell, const float* boxes,
                                                   size_t stride, const uint32_t* ids, uint32_t count,
                                                   uint32_t* codes) {
    __m256 lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = _mm256_setr_m128(_mm_loadu_ps(reach.lo[a]), _mm_loadu_ps(cell.lo[a]));
        hi[a] = _mm256_setr_m128(_mm_loadu_ps(reach.hi[a]), _mm_loadu_ps(cell.hi[a]));
    }
    for (uint32_t i = 0; i < count; ++i) {
        const float* box = boxes + ids[i] * stride;
        uint32_t code = 0;
        for (int a = 0; a < 3; ++a) {
            const __m256 meets = _mm256_and_ps(_mm256_cmp_ps(_mm256_broadcast_ss(box + 3 + a), lo[a], _CMP_GE_OQ),
                                               _mm256_cmp_ps(_mm256_broadcast_ss(box + a), hi[a], _CMP_LE_OQ));
            const uint32_t m = static_cast<uint32_t>(_mm256_movemask_ps(meets));
            code |= (m & 15u) << (4 * a) | (m >> 4) << (12 + 4 * a);
        }
        codes[i] = code;
    }
}

}  // namespace

NearCodesFunction ChooseNearCodesFunction(int width) {
    return (width == 0 || width == 8) && __builtin_cpu_supports("avx2") ? NearCodesAvx2 : NearCodesScalar;
}

FilterNearFunction ChooseFilterNearFunction(int width) {
    return (width == 0 || width == 8) && __builtin_cpu_supports("avx2") ? FilterNearAvx2 : FilterNearScalar;
}

void OctantsOfBlockers(Blockers* b) {
    for (uint32_t g = 0; g * kCullWidth < b->count; ++g) {
        uint8_t octants = 0;
        for (uint32_t i = g * kCullWidth; i < (g + 1) * kCullWidth; ++i)
            octants |= kOctants.octants[b->reaches[i] & 63];
        b->octants[g] = octants;
    }
}

// LightMeshOptions::simdWidth: AVX2 for the widest (and 8) where the processor has it;
// the scalar pass otherwise (the 4-wide tests use it as their oracle).
FindBlockersFunction ChooseFindBlockersFunction(int width) {
    return (width == 0 || width == 8) && __builtin_cpu_supports("avx2") ? FindBlockersAvx2 : FindBlockersScalar;
}

PatchSeesFunction ChoosePatchSeesFunction(int width) {
    return (width == 0 || width == 8) && __builtin_cpu_supports("avx2") ? PatchSeesAvx2 : PatchSeesScalar;
}

CullFunction ChooseCullFunction(int width) {
    return (width == 0 || width == 8) && __builtin_cpu_supports("avx2") ? CullSegmentAvx2 : CullSegmentSse;
}

// LightMeshOptions::simdWidth: 0 the widest, 1 scalar, 4 SSE, 8 AVX2 if the processor has it.
FrontFunction ChooseFrontFunction(int width) {
    if (width == 1) return FrontMasksScalar;
    return width != 4 && __builtin_cpu_supports("avx2") ? FrontMasksAvx2 : FrontMasksSse;
}

SideNodesFunction ChooseSideNodesFunction(int width) {
    return (width == 0 || width == 8) && __builtin_cpu_supports("avx2") ? SideNodesAvx2 : SideNodesScalar;
}

// The kernels that gather node words (the sums, the minority): AVX2 only, and not under
// ThreadSanitizer, which does not see their loads as atomic.
static bool GathersUsable(int width) {
#ifdef LIGHTMESH_TSAN
    (void)width;
    return false;
#else
    return (width == 0 || width == 8) && __builtin_cpu_supports("avx2");
#endif
}

MinorityFunction ChooseMinorityFunction(int width, int wordBytes) {
    if (!GathersUsable(width)) return nullptr;
    switch (wordBytes) {
        case 1: return MinorityMasksAvx2<1>;
        case 2: return MinorityMasksAvx2<2>;
        case 4: return MinorityMasksAvx2<4>;
        default: return nullptr;
    }
}

SumFrontFunction ChooseSumFrontFunction(int width, int wordBytes) {
    if (!GathersUsable(width)) return nullptr;
    switch (wordBytes) {
        case 1: return SumFrontBytesAvx2;
        case 2: return SumFrontWordsAvx2<2>;
        case 4: return SumFrontWordsAvx2<4>;
        default: return nullptr;  // 8-byte words (31-62 lights): the scalar sums
    }
}

}  // namespace lm::kernels
