// light_mesh_kernels.h -- the light mesh's inner loops, vectorised (AVX2 where the processor
// has it, chosen at run time; SSE or scalar otherwise) over the data they read: the
// templates' blocks of eight entries (front test, sums of node words), a cell's front
// triangles (a point's blockers, the cell patches' test) and a point's blockers (the
// segment culling). Each vectorised kernel performs its scalar oracle's operations in the
// same order (the library is built with -ffp-contract=off), so every width gives the same
// answers bit for bit; LightMeshOptions::simdWidth picks one for the tests. Internal to
// the light mesh (light_mesh_impl.h and its parts).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>

#include "lightmesh/math/vec.h"

namespace lm::kernels {

/// Eight entries of one sub-position's template in one cache line: their linear index
/// offsets, so that a node's word is one load away, and the nodes' offsets from the cell's
/// corner LM0 in lattice steps, coordinate by coordinate (small whole numbers: |offset| ≤
/// ⌈kI⌉ + 2, and kI ≤ 16), converted to floats exactly for the front test of eight entries
/// at once; `lanes` has a bit per real entry (padding lanes: offsets 0, bit clear). A
/// point's front test reads its sub-position's blocks, ~5 at kI 2 in no order a cache
/// predicts: with float offsets and a cell-patch index per entry a block took 160 bytes
/// and the test 40 % of the demo's L1 read misses (callgrind's cache model).
struct alignas(64) FrontBlock {
    int32_t linear[8];
    int8_t ox[8], oy[8], oz[8];
    uint8_t lanes;
};
static_assert(sizeof(FrontBlock) == 64, "a FrontBlock is one cache line");

/// Consensus with cell summaries: the triangles that could block a segment from a node to
/// one shading point P (LightMesh::FindBlockers), in arrays for the vectorised culling loop:
/// each one's plane, the side P's origin is on (+1, -1; 0 within the margin), and the
/// normals c_k = a_k × a_k+1 of the planes through P's origin and each edge (a_k: vertex k
/// minus the origin) with their rounding margins. Padded to a multiple of kCullWidth with
/// entries that never block.
///
/// Each blocker also has a direction code: bit 2a is set when its box reaches to the +
/// side of the origin along axis a (hi_a >= o_a - margin), bit 2a+1 when it reaches to the
/// - side (lo_a <= o_a + margin). A segment from the origin along d can only meet a
/// triangle that reaches to the side d_a points to on every axis (its points lie between
/// o_a and o_a + d_a), so the others are certainly missed (about 60 % of a point's
/// blockers for any one segment on the gazebo and the castle). Per eight blockers, the
/// octants of d (bit (d.x < 0) | (d.y < 0) << 1 | (d.z < 0) << 2) that any of them may be
/// met from, so that the culling skips the eights none of which can be.
constexpr uint32_t kMaxBlockers = 256;
constexpr uint32_t kCullWidth = 8;
struct Blockers {
    bool tried = false;  // FindBlockers ran for this point
    bool known = false;  // false: test every segment with the back-end
    uint32_t count = 0;
    float margin = 0;    // the plane margin of the culling (the cell's cullMargin_)
    static constexpr size_t N = kMaxBlockers + kCullWidth;
    alignas(32) float nx[N], ny[N], nz[N], d[N], side[N];
    alignas(32) float c0x[N], c0y[N], c0z[N], c1x[N], c1y[N], c1z[N], c2x[N], c2y[N], c2z[N];
    alignas(32) float m0[N], m1[N], m2[N];
    alignas(32) int32_t reaches[N];              // direction codes
    uint8_t octants[N / kCullWidth];             // per eight blockers
};
/// The octant of a segment's direction d (see Blockers): bit a set where d_a < 0.
inline int DirectionOctant(const Vec3& d) { return (d.x < 0 ? 1 : 0) | (d.y < 0 ? 2 : 0) | (d.z < 0 ? 4 : 0); }
/// The direction code bits a segment of octant k needs of a blocker: bit 2a (+) or 2a+1
/// (-) for each axis a, as k's bit a says.
constexpr int32_t OctantNeeds(int k) {
    return (1 << (0 + (k & 1))) | (1 << (2 + ((k >> 1) & 1))) | (1 << (4 + ((k >> 2) & 1)));
}
/// Blockers::octants from the direction codes of count blockers (padding: code 0).
void OctantsOfBlockers(Blockers* b);

/// The triangles of a cell's reach in front of one triangle's plane (LightMesh::FrontTriangles),
/// structure of arrays for the vectorised passes over them: plane, grown bounding box,
/// vertices and the cell patch's ranges, 21 arrays of `capacity` floats in one 32-byte
/// aligned block. Padded to a multiple of 8 with entries whose empty box (lo > hi) no
/// sphere meets.
struct FrontArrays {
    uint32_t count = 0, capacity = 0;
    float *nx = nullptr, *ny, *nz, *d, *lox, *loy, *loz, *hix, *hiy, *hiz;
    float *v0x, *v0y, *v0z, *v1x, *v1y, *v1z, *v2x, *v2y, *v2z;
    // The range of (n, q) - d over the cell patch's origins q (LightMesh::Patch), per triangle.
    float *sMin, *sMax;
    static constexpr int kArrays = 21;
    std::unique_ptr<float[], void (*)(float*)> block{nullptr, [](float* p) { std::free(p); }};
    // Entries that fit with their padding: (count + 8) rounded down to a multiple of 8.
    static constexpr uint32_t Room(uint32_t count) { return (count + 8) & ~7u; }
    // Room for `count` entries and their padding (the contents are not kept).
    void Reserve(uint32_t count) {
        const uint32_t need = Room(count);
        if (need <= capacity) return;
        const uint32_t grown = std::max(need, 2 * capacity);  // a multiple of 8: the size is of 32
        void* p = std::aligned_alloc(32, sizeof(float) * kArrays * grown);
        if (!p) throw std::bad_alloc();
        block.reset(static_cast<float*>(p));
        Point(block.get(), grown);
    }
    // The arrays in `storage`, owned by the caller: kArrays·room floats, 32-byte aligned,
    // room a multiple of 8 (Reserve up to room - 8 entries then allocates nothing).
    void Attach(float* storage, uint32_t room) {
        block.reset();
        Point(storage, room);
    }

private:
    void Point(float* storage, uint32_t room) {
        capacity = room;
        float** arrays[kArrays] = {&nx,  &ny,  &nz,  &d,   &lox, &loy, &loz, &hix, &hiy, &hiz, &v0x,
                                   &v0y, &v0z, &v1x, &v1y, &v1z, &v2x, &v2y, &v2z, &sMin, &sMax};
        for (int a = 0; a < kArrays; ++a) *arrays[a] = storage + static_cast<size_t>(a) * room;
    }
};
/// Which cells of a brick of 4×4×4 cells a box meets, coordinate by coordinate. Cells'
/// boxes along an axis depend on their position along that axis only (lattice nodes and
/// bounds are computed per coordinate), so `lo[a][p]`, `hi[a][p]` are the bounds along axis
/// a of the cells at position p, and a box meets cell (px, py, pz) exactly when it meets
/// the three bounds: BrickAxisBits sets bit 4a + p when the box's extent along a meets
/// [lo[a][p], hi[a][p]] (the comparisons of a box test, hi ≥ lo and lo ≤ hi); CellBits is
/// the mask a cell needs all of.
struct BrickAxes {
    float lo[3][4], hi[3][4];
};
inline uint32_t BrickAxisBits(const BrickAxes& cells, const Vec3& lo, const Vec3& hi) {
    const float l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    uint32_t bits = 0;
    for (int a = 0; a < 3; ++a)
        for (int p = 0; p < 4; ++p)
            bits |= static_cast<uint32_t>((h[a] >= cells.lo[a][p]) & (l[a] <= cells.hi[a][p])) << (4 * a + p);
    return bits;
}
constexpr uint32_t CellBits(int px, int py, int pz) { return (1u << px) | (1u << (4 + py)) | (1u << (8 + pz)); }

/// What FindBlockers needs of the point: its segments' box and origin, and the margins.
struct BlockerQuery {
    Vec3 lo, hi;        // P ± pointReach_: every node a segment of P's ends at lies inside
    Vec3 o;             // P's origin, where the segments end
    float far;          // a plane farther from o than this has every segment on one side
    float margin;       // cullMargin_
    float reach;        // pointReach_
    float delta8;       // 8·planeDelta_
};
/// Completes a FindBlockers pass's blockers for the culling: padding after the last
/// blocker (a plane x·0 - d with d = -1e30 puts every end at 1e30 on the + side, so no
/// segment can be undecided or blocked by it, and no direction reaches it), then each
/// eight's octants from the direction codes.
inline void FinishBlockers(Blockers* b) {
    for (uint32_t n = b->count; n % kCullWidth != 0; ++n) {
        b->nx[n] = b->ny[n] = b->nz[n] = 0;
        b->d[n] = -1e30f;
        b->side[n] = 1;
        b->c0x[n] = b->c0y[n] = b->c0z[n] = b->c1x[n] = b->c1y[n] = b->c1z[n] = 0;
        b->c2x[n] = b->c2y[n] = b->c2z[n] = b->m0[n] = b->m1[n] = b->m2[n] = 0;
        b->reaches[n] = 0;  // met from no direction
    }
    OctantsOfBlockers(b);
}
/// What LightMesh::PatchSees needs to decide whether node x sees every origin of a cell patch.
struct PatchQuery {
    Vec3 x;
    Vec3 lo, hi;  // the box of x and the patch's origins, grown
    float m;      // margin of x's side of a plane (cullMargin_)
    float mQ;     // margin of the origins' side (cullMargin_ and their rounding)
};
/// The kernels, chosen once for a SIMD width (0: the widest the processor has; 1 scalar,
/// 4 SSE, 8 AVX2).
///
/// The templates' front test over `count` blocks: bit k of masks[b] is set when lane k of
/// block b is in front, (n, offset) - nfrac > eps.
using FrontFunction = void (*)(const FrontBlock* blocks, uint32_t count, const Vec3& n, float nfrac, float eps,
                               uint8_t* masks);
FrontFunction ChooseFrontFunction(int width);
/// Нет's sum over the entries in front for node words of `wordBytes` bytes (1, 2 or 4): per
/// light the entries whose bit is set (added to visible[]) and their number (added to
/// *m); false, having added nothing, if an entry in front is not yet evaluated. Null where
/// the gathers are not used: without AVX2, for a narrower test width, for 8-byte words,
/// and under ThreadSanitizer (which does not see their loads as atomic).
using SumFrontFunction = bool (*)(const FrontBlock* blocks, const uint8_t* masks, uint32_t count, const void* nodes,
                                  int lights, uint32_t* visible, uint32_t* m);
SumFrontFunction ChooseSumFrontFunction(int width, int wordBytes);
/// Consensus's two groups (LightMesh::MinorityFirst) for node words of `wordBytes` bytes:
/// bit k of minority[b] is set when lane k of block b is in front (masks[b]) and its
/// word's `needed` bits are not `majority`, of majorityMasks[b] when they are. Every entry
/// in front must be evaluated. Null where the gathers are not used (as for
/// SumFrontFunction).
using MinorityFunction = void (*)(const FrontBlock* blocks, const uint8_t* masks, uint32_t count, const void* nodes,
                                  uint32_t needed, uint32_t majority, uint8_t* minority, uint8_t* majorityMasks);
MinorityFunction ChooseMinorityFunction(int width, int wordBytes);
/// The nodes of a cell's neighbourhood that its side summary compares (LightMesh::Side):
/// of the `count` nodes at cell + (ox[e], oy[e], oz[e]), whose position is
/// origin + (cell + offset)·h in float as LightMeshLattice::Node computes it, those with
/// hx = n0·x + n1·y + n2·z − d (in double, in that order) > 0 for side 0 or < 0 for side 1,
/// and |hx| <= slab. Writes their e to `kept` in increasing order and returns how many.
struct SideQuery {
    int cell[3];
    float origin[3];
    float h;
    double n[3], d, slab;
    int side;
};
using SideNodesFunction = uint32_t (*)(const int8_t* ox, const int8_t* oy, const int8_t* oz, uint32_t count,
                                       const SideQuery& q, uint32_t* kept);
SideNodesFunction ChooseSideNodesFunction(int width);
/// A point's blockers from its cell's front triangles; false if more than kMaxBlockers.
using FindBlockersFunction = bool (*)(const FrontArrays& f, const BlockerQuery& q, Blockers* b);
FindBlockersFunction ChooseFindBlockersFunction(int width);
/// Whether node q.x sees every origin of a cell patch (no front triangle can block).
using PatchSeesFunction = bool (*)(const FrontArrays& f, const PatchQuery& q);
PatchSeesFunction ChoosePatchSeesFunction(int width);
/// The segment from node x to origin o against a point's blockers: 1 certainly blocked, 0
/// certainly unblocked, -1 undecided (m: the plane margin).
using CullFunction = int (*)(const Blockers& b, const Vec3& x, const Vec3& o, float m);
CullFunction ChooseCullFunction(int width);
/// A brick's near codes (LightMesh::NearCodes): for each of the `count` triangles `ids`,
/// BrickAxisBits(reach, lo, hi) | BrickAxisBits(cell, lo, hi) << 12 of its box, whose lo
/// corner is the Vec3 at boxes + id·stride floats and hi the next one.
using NearCodesFunction = void (*)(const BrickAxes& reach, const BrickAxes& cell, const float* boxes, size_t stride,
                                   const uint32_t* ids, uint32_t count, uint32_t* codes);
NearCodesFunction ChooseNearCodesFunction(int width);
/// A cell's lists from its brick's near list (LightMesh::ComputeSummary): of the `count`
/// ids, in their order, those whose near code has every bit of `reachBits` go to `reach`,
/// and those with every bit of `reachBits | cellBits` to `cell`. Returns the two counts
/// packed as reach | cell << 32. Each output needs room for count + kFilterSlack ids (the
/// vector pass stores whole groups of eight and advances by the ones kept).
constexpr uint32_t kFilterSlack = 8;
using FilterNearFunction = uint64_t (*)(const uint32_t* ids, const uint32_t* codes, uint32_t count, uint32_t reachBits,
                                        uint32_t cellBits, uint32_t* reach, uint32_t* cell);
FilterNearFunction ChooseFilterNearFunction(int width);

}  // namespace lm::kernels
