// light_mesh_impl.h -- the class behind CreateLightMeshShadows: LightMesh<Word>, its data and
// its small members. The larger members are defined by concept in light_mesh_cells.h (cell
// summaries), light_mesh_patches.h (front lists, cell patches, blockers), light_mesh_walks.h
// (the sphere walks and the variants' local-visibility rules), light_mesh_penumbra.h
// (contact-hardening penumbrae) and light_mesh.cpp (construction, node evaluation, figures).
// Private to the light mesh: included once, by light_mesh.cpp (an anonymous namespace, as
// when it was one file, so the compiler sees one translation unit's functions). Over 500
// lines as one concept: the class's data with the comments that say what each part keeps.
#pragma once

#include "lightmesh/shadow/light_mesh.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cassert>
#include <cstddef>
#include <cstdlib>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <span>
#include <tuple>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

#include <immintrin.h>

#include "lightmesh/geometry/triangle.h"
#include "lightmesh/math/simd.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/shadow/light_mesh_kernels.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/huge_pages.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/parallel.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

using namespace kernels;

/// Zero-filled storage whose pages the kernel hands out on first touch (AllocateZeroed: on
/// huge pages from 256 KiB to 64 MiB), so a large lattice costs nothing until its nodes
/// are used (lazy, like the nodes themselves). std::atomic of an integer is a
/// standard-layout type whose zero bytes are the value 0.
template <typename T>
using ZeroedPtr = std::unique_ptr<T[], ZeroedDeleter>;
template <typename T>
ZeroedPtr<std::atomic<T>> ZeroedArray(uint64_t count, bool huge = true) {
    static_assert(std::atomic<T>::is_always_lock_free && sizeof(std::atomic<T>) == sizeof(T));
    if (count > std::numeric_limits<size_t>::max() / sizeof(T)) throw std::bad_alloc();
    ZeroedDeleter deleter;
    void* p = AllocateZeroed(std::max<uint64_t>(count, 1) * sizeof(T), &deleter, huge);
    return ZeroedPtr<std::atomic<T>>(static_cast<std::atomic<T>*>(p), deleter);
}

/// Per-point scratch of n elements: on the stack up to N (the usual template or reach),
/// on the heap beyond (a template of a large kI). Not initialised.
template <typename T, size_t N>
class Scratch {
  public:
    explicit Scratch(size_t n) {
        if (n > N) {
            heap_.resize(n);
            data_ = heap_.data();
        }
    }
    Scratch(const Scratch&) = delete;
    Scratch& operator=(const Scratch&) = delete;
    T* data() { return data_; }

  private:
    T local_[N];
    std::vector<T> heap_;
    T* data_ = local_;
};

// The most triangles a cell's reach list keeps (more: every segment of its points goes to
// the back-end). Measured: 1024 instead made the castle no faster and the playground 17 %
// slower (its thin bars fill the reach lists; building a point's front list scans them),
// also with a point's blockers capped at 32 or 64. Again with the cells' own tolerances
// (1024×768, Embree, medians of 2 alternated bench runs): at kI 3, 1024 took the castle's
// segments to Embree from 2.14M to 83k and still made every scene 3–16 % slower (a short
// segment costs Embree less than the front lists, patches and culling over long lists);
// at kI 2, 128 made the garden 7 % faster but the castle 2.5 % slower.
constexpr uint32_t kMaxReach = 256;
// Cell patches keep a bit per node of a cell's neighbourhood cube: up to 64 words (kI up
// to about 7; larger spheres test every segment point by point).
constexpr uint32_t kCubeWords = 64;

/// The light mesh with node words of type Word (uint8_t for up to 6 lights).
///
/// Node word layout: bits 0 … nL-1 are V(L_i, x) (paper §4: S = ⟨f, v_1…v_nL, i⟩), the top
/// bit is f ("initialised"), the bit below it i ("inside a solid", СТ only).
/// A node is evaluated the first time a sphere needs it. Several threads may evaluate the
/// same node at once: each computes the same value (it depends only on the node), and a
/// compare-and-swap from 0 lets exactly one of them store it and count it, so no lock is
/// taken and the result never depends on the thread that won.
template <typename Word>
class LightMesh final : public LightMeshShadows {
    static constexpr Word kInit = Word(1) << (sizeof(Word) * 8 - 1);
    static constexpr Word kInside = kInit >> 1;
    static constexpr Word kVisMask = kInside - 1;

  public:
    // `lights`: the lights this mesh's words hold (the scene's, or one group of them:
    // LightMeshGroups); light l of the mesh is lights[l].
    // `sharedTables`: another group's SharedTables() (same scene, lattice and options), or null.
    LightMesh(const Scene& scene, const Accelerator& accel, const LightMeshLattice& lattice,
              const LightMeshVariant& variant, TemplateLoad templates, const LightMeshOptions& options,
              std::vector<PointLight> lights, const std::shared_ptr<void>& sharedTables = nullptr);

    // The most (triangle, brick) pairs the binning may store: far more than any scene of
    // ordinary triangles needs (the garden: about 8 per triangle), far less than a file of
    // huge overlapping triangles would ask for.
    uint64_t BinBudget() const { return 64 * static_cast<uint64_t>(planes_.size()) + (uint64_t(1) << 22); }

    // Cell summaries (light_mesh_cells.h): the triangles binned by brick of cells.
    bool BinTrianglesByBrick(uint64_t bricksZ);

    const LightMeshLattice& Lattice() const override { return lattice_; }
    const LightMeshVariant& Variant() const override { return variant_; }
    const TemplateLoad& Templates() const override { return templates_; }
    int BytesPerNode() const override { return LightMeshStorageBytesPerNode(lights_.size(), lightRadius_); }
    uint64_t NodesEvaluated() const override { return evaluated_.load(); }
    bool IsEvaluated(uint64_t index) const override {
        return (nodes_[index].load(std::memory_order_acquire) & kInit) != 0;
    }
    uint64_t NodeVisibility(uint64_t index) const override { return NodeWord(index) & kVisMask; }
    bool NodeInside(uint64_t index) const override { return (NodeWord(index) & kInside) != 0; }
    float NodeBlockerParameter(uint64_t index, size_t light) const override {
        if (light >= lights_.size()) return 0.0f;
        const Word w = NodeWord(index);
        if (lightRadius_ == 0 || ((w >> light) & 1)) return 0.0f;
        return BlockerParameter(index, light);
    }
    // The stored blocker parameter of an evaluated node whose light is blocked.
    float BlockerParameter(uint64_t index, size_t light) const {
        return static_cast<float>(blockerT_[index * lights_.size() + light].load(std::memory_order_relaxed)) *
               (1.0f / 65535.0f);
    }

    // Formula (2) at P for every light needed (light_mesh.cpp), then, with a light radius,
    // the thin-occluder check (CheckThin).
    // Inside, the lights needed are a mask of this mesh's lights (at most 62) and the values
    // go to an array indexed by light (LightValues) before they are handed out in the list's order.
    void Visibility(const ShadingPoint& sp, LightIndices lights, float* vis, RenderCounters& counters) const override;
    // With a light radius, a block of points in stages: every point's walk, its narrow
    // penumbrae's discs queued (DiscQueue); the discs, light by light (TraceDiscs); the
    // thin check's rays light by light, as hard shadows trace theirs (LightsVisibleMany);
    // each point gets what Visibility gives it. Without one, point by point.
    void VisibilityMany(const ShadingPoint* sps, const LightIndices* lights, float* const* vis, size_t count,
                        RenderCounters& counters) const override;
    // The work of both, by mask and light (VisibilityMany gathers the lists' values from it).
    void VisibilityOfMasks(const ShadingPoint* sps, const uint64_t* needed, LightValues* vis, size_t count,
                           RenderCounters& counters) const override;

    ShadowFigures Figures() const override;

  private:
    // A run of FrontBlocks with their front masks: visits the entries in front in the
    // template's order.
    struct FrontRun {
        const FrontBlock* blocks;
        const uint8_t* masks;
        uint32_t count;
        template <typename F>
        void ForEach(F&& f) const {
            for (uint32_t b = 0; b < count; ++b)
                for (unsigned m = masks[b]; m; m &= m - 1) f(blocks[b], __builtin_ctz(m));
        }
        /// Whether f holds for some entry in front, stopping at the first.
        template <typename F>
        bool Any(F&& f) const {
            for (uint32_t b = 0; b < count; ++b)
                for (unsigned m = masks[b]; m; m &= m - 1)
                    if (f(blocks[b], __builtin_ctz(m))) return true;
            return false;
        }
    };

    // ---- Cell summaries (ours, not in the paper; exact) ------------------------------
    //
    // A summary belongs to a mesh cell (the cell whose lower corner is node (ci, cj, ck))
    // and to its main plane Π: the plane of the largest triangle meeting the cell (ties:
    // the lower id, so it does not depend on the lists' order). It is used by the points of
    // the cell that lie on Π (within planeDelta_, normal within kPlaneEps; the planar
    // argument below within the cell's own tolerance delta), which is most points of
    // floors, walls and other flat faces. For each side s of Π:
    //  - uniform_s: every node a point of the cell on Π may use (cellNodes_ within
    //    pointReach_ of Π) that lies on side s of Π has the same visibility bits bits_s.
    //    A point on Π seen from side s uses only such nodes (its front test keeps nodes
    //    more than frontEps_ steps in front of its own plane, which is within the
    //    tolerances of Π), so any non-empty subset averages to exactly bits_s: formula (2)
    //    needs neither the walk nor the node words.
    //  - clear_s (consensus): no triangle meeting the cell grown by the sphere's reach has
    //    a vertex more than delta / 2 on side s. A local-visibility segment runs from a
    //    node to P's origin, both clearly on side s, inside that box, so nothing can block
    //    it: no segment is traced.
    // Summaries are computed on first use and published like the nodes: the values depend
    // on the cell only, and the thread that claims a record is the only one to write it.
    struct CellSummary {
        float n[3] = {0, 0, 0};  // Π: unit normal and offset, (n, x) = d on Π
        double d = 0;
        uint8_t flags = 0;
        // The cell's tolerance: planeDelta_'s rule at the largest coordinate the cell's
        // computations meet (its reach box and its reach's vertices), at most planeDelta_.
        // Every margin of the summaries, patches and culling of this cell scales with it, so
        // a small object near the coordinates' origin in a large scene keeps them.
        float delta = 0;
        // Consensus: the triangles whose bounding box meets the reach box (kTooMany: more
        // than kMaxReach; the back-end tests every segment), in an arena of the mesh.
        const uint32_t* reach = nullptr;
        uint32_t reachCount = 0;
    };
    static constexpr uint32_t kTooMany = UINT32_MAX;

    // Consensus with cell summaries: the triangles that could block a segment from a node
    // to this P. Every such segment lies in the cell's reach box, so only the reach list's
    // triangles can block it; of those, one whose vertices all lie on or behind P's plane
    // cannot (the segment runs clearly in front of it, like the planar argument). So:
    // the reach triangles with a vertex in front of P's triangle's plane (by more than
    // the cell's delta / 2, measured with the triangle's own plane so the list depends on the
    // cell, the triangle and the side only): points of one triangle in one cell, which a
    // tile shades one after another, share it, so each thread keeps the last few.
    struct FrontList {
        uint64_t owner = 0;  // serial_ of the light mesh it belongs to
        int64_t base = -1;
        uint32_t prim = UINT32_MAX;
        float sign = 0;
        FrontArrays arrays;
        // The cell patch (Patch): computed on first use; usable when `patch` is true.
        bool patchTried = false, patch = false;
        float delta = 0;   // the cell's tolerance (CellSummary::delta)
        Vec3 normal;       // the points' normal the patch was built with
        Vec3 qlo, qhi;     // the box of the patch's origins, grown by reachMargin_
        uint64_t known[kCubeWords], sees[kCubeWords];  // node states, by CubeBit
    };
    // Lists per thread, kept in sets of two by a hash of (cell, triangle, side), the older
    // of a set replaced: a tile's row of pixels crosses cells and triangles back and forth,
    // and its next rows come back to them. (Eight lists replaced in turn rebuilt each one
    // 1.8 times on the castle at 1024×768: 17.2k builds for 9.5k lists.)
    static constexpr int kFrontSets = 32, kFrontWays = 2;
    // A thread's front lists with their arrays at their largest (kMaxReach triangles), in
    // one block made on the thread's first list: 1.4 MiB, on a huge page where the kernel
    // gives them (AllocateLarge). Grown one list at a time from malloc, the lists' pages
    // were ~840 first touches per process on the gazebo (about 11 µs each on the virtual
    // machines measured: 9 ms of CPU in a 70 ms render on 2 threads); one block is one.
    struct FrontCache {
        FrontList lists[kFrontSets][kFrontWays];
        uint8_t older[kFrontSets] = {};
        static constexpr uint32_t kRoom = FrontArrays::Room(kMaxReach);
        struct Deleter {
            void operator()(FrontCache* c) const {
                c->~FrontCache();
                std::free(c);
            }
        };
        static std::unique_ptr<FrontCache, Deleter> Make() {
            const size_t arrays = sizeof(float) * FrontArrays::kArrays * kRoom;
            const size_t arraysOffset = (sizeof(FrontCache) + 63) & ~size_t(63);  // the lists, then their arrays
            void* block = AllocateLarge(arraysOffset + arrays * kFrontSets * kFrontWays, 64);
            std::unique_ptr<FrontCache, Deleter> cache(new (block) FrontCache());
            char* storage = static_cast<char*>(block) + arraysOffset;
            for (int set = 0; set < kFrontSets; ++set)
                for (int way = 0; way < kFrontWays; ++way, storage += arrays)
                    cache->lists[set][way].arrays.Attach(reinterpret_cast<float*>(storage), kRoom);
            return cache;
        }
    };
    // Local-visibility segments handed to the back-end at once (SegmentBatch): Embree's
    // widest packet where it has AVX-512 (the garden at kI 3 6 % faster than with 8).
    static constexpr size_t kSegmentBatch = 16;
    // Segments decided without rays (light_mesh_patches.h): a point's front triangles, its
    // cell patch and the node that sees all of it, its blockers, the segment culling.
    FrontList& FrontTriangles(const CellSummary& c, int64_t base, const ShadingPoint& sp) const;

    FrontList* Patch(const CellSummary& c, int64_t base, int ci, int cj, int ck, const ShadingPoint& sp,
                     RenderCounters& counters) const;
    void BuildPatch(FrontList& list, int ci, int cj, int ck, const ShadingPoint& sp, float offset) const;
    bool PatchSees(FrontList& list, const FrontBlock& b, int k, const Vec3& x) const;
    // What the patch already knows of entry k's node: 1 it sees the whole patch, 0 not
    // certain (its segments need deciding), -1 not tested yet (PatchSees will).
    int PatchKnown(const FrontList& list, const FrontBlock& b, int k) const {
        const uint32_t bit = CubeBit(b, k), word = bit >> 6;
        const uint64_t mask = uint64_t(1) << (bit & 63);
        if (!(list.known[word] & mask)) return -1;
        return (list.sees[word] & mask) != 0 ? 1 : 0;
    }
    const FrontBlock* PatchWitness(const CellSummary& c, int64_t base, int ci, int cj, int ck, const ShadingPoint& sp,
                                   const FrontRun& all, RenderCounters& counters, int* lane = nullptr) const;
    void FindBlockers(const CellSummary& c, int64_t base, const ShadingPoint& sp, Blockers* b) const;
    bool SeesPointCulled(const Vec3& x, const ShadingPoint& sp, const Blockers& b, RenderCounters& counters) const;
    // The segment from node x to P's origin against P's blockers: 1 it sees P, 0 blocked,
    // -1 undecided (for the back-end).
    int CullSegment(const Vec3& x, const ShadingPoint& sp, const Blockers& b, RenderCounters& counters) const;
    static constexpr uint8_t kHasPlane = 1, kClear0 = 8, kClear1 = 16;
    static constexpr int kBrick = 4;  // summaries are stored by bricks of 4³ cells
    struct SideSummary {
        Word bits = 0, uniform = 0;
    };
    struct SummaryBrick {
        std::atomic<uint8_t> state[kBrick * kBrick * kBrick];  // 0 empty, 1 being written, 2 ready
        CellSummary cell[kBrick * kBrick * kBrick];
        // The brick's list from BinTrianglesByBrick: every triangle whose box meets the
        // reach of one of its cells; kTooMany if more than kMaxBrickNear.
        const uint32_t* near = nullptr;
        uint32_t nearCount = 0;
        // Per near triangle, which of the brick's cells its box meets, axis by axis (the
        // same float comparisons ComputeSummary's box tests make, see NearCodes): bits
        // 4a + p, the cells at position p along axis a whose reach box it meets; bits
        // 12 + 4a + p, those whose own box (grown by reachMargin_) it meets.
        const uint32_t* nearCodes = nullptr;
        std::atomic<uint8_t> sideState[kBrick * kBrick * kBrick][2];  // like state, per side of Π
        SideSummary side[kBrick * kBrick * kBrick][2];
    };
    static_assert(std::is_trivially_destructible_v<SummaryBrick>);  // freed with its chunk
    static constexpr uint32_t kMaxBrickNear = 16384;

    // A cell's summary, stored or computed (light_mesh_cells.h), with what it is made of.
    const CellSummary& Summary(int ci, int cj, int ck, CellSummary* scratch, SummaryBrick** brickOut,
                               int* slotOut) const;

    const uint32_t* StoreReach(std::span<const uint32_t> ids) const;

    // Cell (ci, cj, ck)'s box grown by reachMargin_ (the triangles that may choose its Π).
    Bounds3 CellBox(int ci, int cj, int ck) const {
        const LightMeshLattice& L = lattice_;
        return Bounds3(L.Node(ci, cj, ck) - Vec3(reachMargin_), L.Node(ci + 1, cj + 1, ck + 1) + Vec3(reachMargin_));
    }
    // The box of everything cell (ci, cj, ck)'s summary looks at: every node any of its
    // points may use, so every segment of theirs.
    Bounds3 ReachBox(int ci, int cj, int ck) const {
        const LightMeshLattice& L = lattice_;
        return Bounds3(L.Node(ci + minOffset_, cj + minOffset_, ck + minOffset_) - Vec3(reachMargin_),
                       L.Node(ci + maxOffset_, cj + maxOffset_, ck + maxOffset_) + Vec3(reachMargin_));
    }

    SummaryBrick* AllocateBrick(uint64_t brick) const;
    void NearCodes(uint64_t brick, const uint32_t* near, uint32_t count, uint32_t* codes) const;
    uint32_t* ReachSlots(size_t n) const;  // from reachArena_; brickMutex_ held

    CellSummary ComputeSummary(int ci, int cj, int ck, const SummaryBrick& brick) const;

    SideSummary Side(const CellSummary& c, SummaryBrick* brick, int slot, int side, int ci, int cj, int ck) const;

    static double UnitNormal(const TriangleMesh& mesh, uint32_t t, double n[3]);

    uint64_t SummaryBytes() const;

    // The sums of formula (2): m and, per light, the visible nodes. The bits of a node
    // word are counted eight at a time, one byte lane per light (kSpread of each byte of
    // the word that holds lights), and the lanes are moved to `visible` before they can
    // overflow, and at the end (Flush). With more than 6 lights (2-, 4- or 8-byte words)
    // that is one table lookup per eight lights instead of a shift, mask and add per light.
    struct Accumulator {
        uint32_t m = 0;
        uint32_t pending = 0;
        int bytes;  // the word's bytes that hold light bits
        uint64_t lanes[sizeof(Word)] = {};
        uint32_t visible[64];
        // Contact-hardening penumbrae: the visibilities themselves, for every light needed,
        // and the lights whose value already came from P's own rays (to the light's centre
        // or its disc), which the thin-occluder check need not trace again.
        bool weighted = false;
        float vis[64];
        uint64_t ownRays = 0;
        explicit Accumulator(size_t lights) : bytes(static_cast<int>(std::max<size_t>((lights + 7) / 8, 1))) {
            // Flush adds all eight lanes of each byte, so those are always zeroed.
            for (int l = 0; l < 8 * Bytes(); ++l) visible[l] = 0;
        }
        int Bytes() const {
            if constexpr (sizeof(Word) == 1) return 1;
            return bytes;
        }
        void Add(Word w) {
            ++m;
            for (int b = 0; b < Bytes(); ++b) lanes[b] += kSpread[(w >> (8 * b)) & 0xFF];
            if (++pending == 255) Flush();
        }
        void Flush() {
            if (pending == 0) return;  // the lanes are all 0 (the gathered sums add to visible directly)
            for (int b = 0; b < Bytes(); ++b) {
                for (int k = 0; k < 8; ++k) visible[8 * b + k] += static_cast<uint32_t>((lanes[b] >> (8 * k)) & 0xFF);
                lanes[b] = 0;
            }
            pending = 0;
        }
    };
    static constexpr std::array<uint64_t, 256> MakeSpread() {
        std::array<uint64_t, 256> t{};
        for (int w = 0; w < 256; ++w)
            for (int b = 0; b < 8; ++b) t[w] |= static_cast<uint64_t>((w >> b) & 1) << (8 * b);
        return t;
    }
    static constexpr std::array<uint64_t, 256> kSpread = MakeSpread();

    // Segments traced when a node is evaluated: one per light, plus, for СТ, the extra
    // segments that complete its vote of three (see EvaluateNode).
    size_t SegmentsPerNode() const {
        const size_t n = lights_.size();
        return variant_.local == LocalVisibility::Inside && n < 3 ? 3 : n;
    }

    Word NodeWord(uint64_t index) const { return Evaluate(index); }

    // Adds node x to the interpolation set.
    void Use(Accumulator& acc, Word w) const {
        acc.Add(w);
    }

    // The local-visibility segment from a node to P (paper §1.4): it must be unblocked.
    bool SeesPoint(const Vec3& x, const ShadingPoint& sp, RenderCounters& counters) const {
        ++Count(counters, LightMeshCount::kLocalSegments);
        return !accel_.Occluded(Segment(x, sp.origin));
    }

    // Local-visibility segments from nodes to one point that are all to be decided (ОТ, У,
    // consensus where a minority node sees P), handed to the back-end kSegmentBatch at a
    // time: Accelerator::OccludedMany, as Embree's packets, whose lanes compute each
    // segment with the single-ray test's operations, so every answer is the one the
    // segment gets alone (AccelBatch.SegmentsInPacketsGetTheAnswersTheyGetAlone); the
    // nodes that see P are used (and evaluated, if need be) as the answers come.
    struct SegmentBatch {
        // Written before read (Queue), so not initialised: a walk makes a batch per point,
        // and most never queue a segment.
        SegmentBatch() {}
        union {
            Ray rays[kSegmentBatch];
        };
        uint64_t nodes[kSegmentBatch];
        bool blocked[kSegmentBatch];
        size_t pending = 0;
        size_t seen = 0;  // nodes used so far
    };
    void Queue(SegmentBatch& batch, const Vec3& x, uint64_t index, const ShadingPoint& sp, Accumulator& acc,
               RenderCounters& counters) const {
        batch.rays[batch.pending] = Segment(x, sp.origin);
        batch.nodes[batch.pending] = index;
        if (++batch.pending == kSegmentBatch) Flush(batch, acc, counters);
    }
    void Flush(SegmentBatch& batch, Accumulator& acc, RenderCounters& counters) const {
        if (batch.pending == 0) return;
        Count(counters, LightMeshCount::kLocalSegments) += batch.pending;
        accel_.OccludedMany(batch.rays, batch.pending, batch.blocked);
        for (size_t q = 0; q < batch.pending; ++q)
            if (!batch.blocked[q]) {
                Use(acc, Evaluate(batch.nodes[q]));
                ++batch.seen;
            }
        batch.pending = 0;
    }

    // The sphere walks and the variants' local visibility (light_mesh_walks.h).
    void Candidate(const Vec3& x, uint64_t index, const ShadingPoint& sp, Accumulator& acc, SegmentBatch& batch,
                   RenderCounters& counters) const;

    // A candidate node for the penumbra mode (PenumbraInterpolate).
    struct PenumbraNode {
        Vec3 x;
        float d2;  // |x − P|²
        uint64_t index;
        Word w;
    };

    void CubeWalk(const ShadingPoint& sp, Word neededMask, Accumulator& acc, RenderCounters& counters) const;

    void CubePenumbra(const ShadingPoint& sp, Word neededMask, std::vector<PenumbraNode>& nodes, Accumulator& acc,
                      RenderCounters& counters) const;

    bool TemplateWalk(const ShadingPoint& sp, Word neededMask, Accumulator& acc, RenderCounters& counters,
                      Word* uniform) const;

    // The position of lane k of block b for a point of cell (ci, cj, ck).
    Vec3 EntryNode(int ci, int cj, int ck, const FrontBlock& b, int k) const {
        return lattice_.Node(ci + static_cast<int>(b.ox[k]), cj + static_cast<int>(b.oy[k]), ck + static_cast<int>(b.oz[k]));
    }

    // Use() for every entry of the run in front of P: Нет's whole walk, and consensus's in
    // a planar cell. The counts live in registers (one byte per light, flushed before 255)
    // instead of in *acc, which the lazy evaluation's call might change for all the
    // compiler knows.
    void UseAll(const FrontRun& run, int64_t base, Accumulator& acc) const {
        auto word = [&](int32_t linear) { return Evaluate(static_cast<uint64_t>(base + linear)); };
        if (sumFront_ && sumFront_(run.blocks, run.masks, run.count, static_cast<const void*>(nodes_.get() + base),
                                   static_cast<int>(lights_.size()), acc.visible, &acc.m))
            return;
        if constexpr (sizeof(Word) == 1) {
            uint64_t lanes = 0;
            uint32_t m = 0, pending = 0;
            auto flush = [&] {
                for (int l = 0; l < 8; ++l) acc.visible[l] += static_cast<uint32_t>((lanes >> (8 * l)) & 0xFF);
                lanes = 0;
                pending = 0;
            };
            for (uint32_t b = 0; b < run.count; ++b)
                for (unsigned mask = run.masks[b]; mask; mask &= mask - 1) {
                    lanes += kSpread[word(run.blocks[b].linear[__builtin_ctz(mask)])];
                    ++m;
                    if (++pending == 255) flush();
                }
            flush();
            acc.m += m;
        } else {
            run.ForEach([&](const FrontBlock& b, int k) { Use(acc, word(b.linear[k])); });
        }
    }

    void ConsensusWalk(const ShadingPoint& sp, Word neededMask, const FrontRun& all, int64_t base, int ci, int cj,
                       int ck, bool planar, const CellSummary* summary, Blockers& blockers,
                       Accumulator& acc, RenderCounters& counters) const;

    void MinorityFirst(const ShadingPoint& sp, Word neededMask, Word majority, const FrontRun& all, int64_t base,
                       int ci, int cj, int ck, const CellSummary* summary, Blockers& blockers, Accumulator& acc,
                       RenderCounters& counters) const;

    // ---- Contact-hardening penumbrae (ours, beyond the paper) -------------------------
    //
    // A sphere light of radius R seen past an occluder edge gives a penumbra whose
    // half-width, measured across the shadow's boundary, is w = R·(d_P − d_b)/d_b (d_P,
    // d_b: the distances from the light to P and to the blocker; similar triangles). The
    // visible fraction across it is the share of the light's disc left uncovered. The
    // paper's formula (2) averages the nodes' hard visibility over a ball of fixed radius
    // r: a penumbra of half-width r everywhere. Here, at a point whose candidates disagree
    // on light l (the only points that can be in a penumbra of that light within r):
    //  1. d_b is the mean of the blocked candidates' blocker distances, which their
    //     evaluation stored (no new rays), and w follows;
    //  2. the nodes are weighted by an Epanechnikov kernel k = 1 − |x − P|²/ρ² of support
    //     ρ = kSupportPerWidth·w (at most r): its profile across a plane, the share of the
    //     kernel on one side, rises from 25 % to 75 % over 0.562·ρ, and the disc's over
    //     0.808·w, so the blur spans the true penumbra;
    //  3. P's own shadow ray (the hard answer, the centre of the penumbra) joins with
    //     weight 1;
    //  4. where ρ is below what the lattice resolves (contact, thin gaps: ρ < 1.5·h) the
    //     nodes only say whether a shadow edge is near; if it is, a few rays to the light's
    //     disc decide, else P's own ray (NarrowPenumbra).
    // Local visibility stays ОТ's: every node that gets a weight passes its segment test
    // (leak-free as the default); only nodes within the largest ρ are tested. Lights the
    // candidates agree on keep consensus's answer. The blocker estimate reads every
    // candidate, also ones a segment test would drop: it only sets the width.
    static constexpr float kSupportPerWidth = 1.438f;  // 0.808 / 0.562
    // Narrow penumbrae (ρ < kNarrow·h: a kernel on so few nodes would be the lattice's
    // shape, not the penumbra's): the light itself is sampled, 2·kNarrowPerRing rays to its
    // disc on two rings (DiscLightVisibility: the outer ring first, the inner one only if
    // those disagree). These points lie where the candidates disagree only, a band of
    // about 2r along each shadow edge. Chosen by measurement (gazebo and castle, 1024×768,
    // against the 256-sample reference): the two rings gave 45.4 and 53.8 dB where a
    // Vogel spiral of 8 traced 4 + 4 gave 43.8 and 51.0 and traced whole 45.3 and 53.4
    // for 15 % more time; a first round of 2 lost 3-4 dB more.
    static constexpr float kNarrow = 1.5f;
    static constexpr int kNarrowPerRing = 4;
    // Before sampling, the lattice's own answer where it is likely right: if every
    // candidate within ρ + kDetect·h of P has the same bit for the light and P's own shadow
    // ray agrees, no shadow edge of that light is taken to pass within the penumbra's reach
    // of P, so V is that bit. (A ball of radius √3/2·h always holds a node; 1.5·h leaves
    // room for the half of it behind the surface.) Measured: the castle 18 % and the garden
    // 13 % less time for −0.04 dB; kDetect = 1 lost 0.5 dB, and trusting the nodes without
    // P's ray 2-4.5 dB.
    static constexpr float kDetect = 1.5f;
    // The thin-occluder check (penumbra mode; ours). The nodes sample visibility every h, so
    // an occluder thinner than the mesh step (a rail, a wire, a bar of a climbing frame)
    // can fall between them: all the candidates see the light and the point gets no
    // shadow, although P's own shadow ray is blocked. Where the nodes' answer for a light
    // is exactly 1 ("lit", and with "all" also where it is exactly 0: gaps thinner than h
    // in a shadowing surface) and P's own ray was not traced yet, the ray checks it; where
    // the ray disagrees, an edge the lattice cannot see passes near P and the light's disc
    // decides, as for a narrow penumbra (DiscLightVisibility, 4 + 4 rays). The check only
    // replaces the nodes' 1 or 0 by what rays to the light see, so it cannot make a leak.
    // Measured (1024×768, R = 1.5 % of the diagonal, against the 256-ray reference):
    // "lit" gave the playground +6.4 dB (its rails and bars are thinner than h) and the
    // garden +3.0 dB (leaves), for one shadow ray per lit (point, light).
    enum class ThinCheck { kOff, kLit, kAll };
    // With "all" P's own ray checks every light the candidates agree on, so the agreement
    // needs no local-visibility segment: consensus traces them only to know that some
    // candidate sees P (else m = 0 and P's rays decide), and P's ray now decides there
    // anyway, sending the point to the light's disc where it contradicts the nodes. The
    // answer is P's own rays' either way, so this is leak-free too; only the kernel's
    // nodes (weights) still need their segments.
    bool OwnRayChecksAgreement() const { return thinCheck_ == ThinCheck::kAll; }
    static Word NeededMask(LightIndices lights) {
        Word mask = 0;
        for (const uint32_t l : lights) mask |= Word(1) << l;
        return mask;
    }
    void CheckThin(const ShadingPoint& sp, Word needed, uint64_t ownRays, float* vis, RenderCounters& counters) const;
    // The lights whose nodes' answer P's own ray checks (CheckThin), and what to do with
    // the rays' answers (bit l of `visible`: light l seen from P).
    uint64_t ThinChecked(Word needed, uint64_t ownRays, const float* vis) const;
    void ApplyThinCheck(const ShadingPoint& sp, uint64_t checked, uint64_t visible, float* vis,
                        RenderCounters& counters) const;
    // Formula (2) itself (or the penumbra mode's answer); returns Accumulator::ownRays.
    // vis is indexed by light; only the lights of `needed` are written.
    uint64_t Interpolate(const ShadingPoint& sp, Word needed, float* vis, RenderCounters& counters) const;
    // Whether light sampling (not the nodes' kernel) answers a penumbra of support ρ.
    bool Sampled(float rho2) const { return !(rho2 >= kNarrow * kNarrow * lattice_.h * lattice_.h); }
    // The batched penumbra mode (VisibilityMany): the (point, light) pairs whose light's
    // disc is sampled, queued by NarrowPenumbra while a thread walks a block's points and
    // traced after the walks, the rings of several points to one light together (coherent
    // rays, wider packets). Null outside VisibilityMany: the disc is sampled at once.
    struct DiscQueue {
        struct Entry {
            size_t point;
            size_t light;
            DiscRings rings;
        };
        size_t point = 0;  // the point being walked
        std::vector<Entry> entries;
    };
    static DiscQueue*& ThreadDiscQueue() {
        thread_local DiscQueue* queue = nullptr;
        return queue;
    }
    // The queued discs' values into vis (`lights` per point, the block's first point at 0).
    void TraceDiscs(const DiscQueue& queue, LightValues* vis, RenderCounters& counters) const;
    // The penumbra mode's answers (light_mesh_penumbra.h).
    float NarrowPenumbra(const ShadingPoint& sp, size_t l, float rho, const std::vector<PenumbraNode>& nodes,
                         RenderCounters& counters) const;
    void PenumbraInterpolate(const ShadingPoint& sp, Word neededMask, const std::vector<PenumbraNode>& nodes,
                             int64_t base, bool planar, const CellSummary* summary, Blockers& blockers,
                             Accumulator& acc, RenderCounters& counters) const;

    // Construction and node evaluation (light_mesh.cpp): the templates as FrontBlocks, a
    // node's shadow segments (and, for СТ, its inside vote).
    void ConvertTemplates();

    // The node's word, computing it on first use: one shadow ray to each light; for СТ
    // also the inside flag.
    // The node's position is only computed when the node is, so a use costs one load.
    Word Evaluate(uint64_t index) const {
        const Word w = nodes_[index].load(std::memory_order_acquire);
        if (w & kInit) [[likely]] return w;
        return EvaluateSlow(index);
    }
    [[gnu::noinline]] Word EvaluateSlow(uint64_t index) const {
        const Vec3 x = lattice_.NodeAt(index);
        const Word value = variant_.local == LocalVisibility::Inside ? EvaluateWithInside(x) : EvaluateVisibility(x, index);
        Word expected = 0;
        if (nodes_[index].compare_exchange_strong(expected, value, std::memory_order_acq_rel))
            evaluated_.fetch_add(1, std::memory_order_relaxed);
        return value;
    }
    // The word of a node a pass before evaluated (ConsensusWalk's pass 1 evaluates every
    // candidate): no test of the "initialised" bit, no call.
    Word EvaluatedWord(uint64_t index) const {
        const Word w = nodes_[index].load(std::memory_order_acquire);
        assert(w & kInit);
        return w;
    }

    Word EvaluateVisibility(const Vec3& x, uint64_t index) const;

    Word EvaluateWithInside(const Vec3& x) const;

    static constexpr float kPlaneEps = 1e-5f;

    const Scene& scene_;
    const std::vector<PointLight> lights_;  // the lights of the node words (the constructor's)
    const Accelerator& accel_;
    const LightMeshLattice lattice_;
    const LightMeshVariant variant_;
    const TemplateLoad templates_;
    int minOffset_ = 0, maxOffset_ = 0;
    float invH_ = 0;
    Bounds3 sceneBox_;
    float planeDelta_ = 0, frontEps_ = 0, reachMargin_ = 0, cullMargin_ = 0, pointReach_ = 0;
    // How far off its main plane Π a cell's summary looks (Side, the clear flags): a point
    // on Π (within 2·planeDelta_ of it) uses nodes within pointReach_ of itself.
    float planeSlab_ = 0;
    // The plane margin of the segment culling and the patches' test for a tolerance delta:
    // cullMargin_ at the scene's (the triangles' grown boxes), a cell's at its own.
    static float CullMargin(float delta) { return 4 * delta; }
    // How far from a plane a point may lie and still count as on it, for coordinates up to
    // `magnitude`: a few float ulps (planeDelta_ at the lattice's, a cell's at its own).
    static float PlaneDelta(float magnitude) { return 2e-7f * magnitude; }
    // The templates again, as FrontBlocks: sub-position s's boundary entries are blocks
    // frontRuns_[s].begin … inner - 1, its inner entries inner … end - 1, each run in the
    // template's order. (One record per sub-position, read once per point: as two arrays
    // the three loads were 4 % of the demo's L1 read misses.)
    std::vector<FrontBlock, HugePageAllocator<FrontBlock>> frontBlocks_;  // ~0.24 MiB at kI 2
    struct FrontRuns {
        uint32_t begin, inner, end;
    };
    std::vector<FrontRuns> frontRuns_;
    FrontFunction frontMasks_ = nullptr;
    CullFunction cull_ = nullptr;
    FindBlockersFunction findBlockers_ = nullptr;
    PatchSeesFunction patchSees_ = nullptr;
    SideNodesFunction sideNodes_ = nullptr;
    FilterNearFunction filterNear_ = nullptr;
    NearCodesFunction nearCodes_ = nullptr;
    // Cell patches: on for consensus with summaries when the neighbourhood cube of a cell
    // (the nodes any of its points may use) has at most kCubeWords·64 nodes.
    bool patches_ = false, patchesFit_ = false;
    uint32_t cubeWords_ = 0;
    // Offsets within ±(ceil(kI) + 1), kI <= 16: ParseSphereTemplates refuses a template
    // file with others, and the built ones run from -floor(kI) to floor(kI) + 1.
    static constexpr int kMaxCubeSide = 2 * (16 + 1) + 1;
    int cubeSide_ = 0;  // nodes along a side of the neighbourhood cube (maxOffset_ - minOffset_ + 1)
    // An offset's place in the neighbourhood cube of all offsets, x fastest.
    uint32_t CubeIndex(int dx, int dy, int dz) const {
        return static_cast<uint32_t>((dx - minOffset_) + cubeSide_ * ((dy - minOffset_) + cubeSide_ * (dz - minOffset_)));
    }
    // Entry k's node's bit in the cube (the cell patches' node states).
    uint32_t CubeBit(const FrontBlock& b, int k) const { return CubeIndex(b.ox[k], b.oy[k], b.oz[k]); }
    SumFrontFunction sumFront_ = nullptr;  // for words of 1, 2 or 4 bytes
    MinorityFunction minority_ = nullptr;  // likewise
    static constexpr size_t kPacketLights = 16;  // a node's rays as one packet from this many lights (EvaluateVisibility)
    static constexpr uint64_t kNodePadding = 8;  // words after the last node, for SumFrontWordsAvx2's loads
    const uint64_t serial_ = NextSerial();  // tells this mesh's thread-local caches from others'
    static uint64_t NextSerial() {
        static std::atomic<uint64_t> next{1};
        return next.fetch_add(1, std::memory_order_relaxed);
    }
    bool summaries_ = false;
    bool summariesOff_ = false;  // asked for, but the binning was over its budget
    // "auto": a cell's summary is used only within this distance of the camera (squared;
    // infinite with "on" or an unknown ray angle), see SummaryPays.
    Vec3 camera_;
    float summaryReach2_ = Infinity;
    // Summaries pay where a cell holds enough points to amortise them (a summary and its
    // side summary cost about ten walks; measured break-even near 10 points per cell).
    // Camera rays are about rayAngle·d apart at distance d, so a cell there meets about
    // (h / (rayAngle·d))² of them per unit of its projected area: the summaries are used
    // for points nearer the camera than h / (rayAngle·√kMinRaysPerCell). The decision
    // depends on the point and the camera only, so images (exact either way), counts and
    // nodes evaluated stay the same for any thread count. Points reached by mirror rays
    // are further along their path than from the camera, so they may keep summaries that
    // do not pay: a matter of time only.
    static constexpr float kMinRaysPerCell = 8.0f;
    bool SummaryPays(const ShadingPoint& sp) const { return LengthSquared(sp.p - camera_) <= summaryReach2_; }
    // A cell patch (Patch, ours) serves the points of one triangle in one cell. Building it
    // scans the cell's front triangles, and each node's first test scans them again; a
    // point without one decides its segments with its blockers or the back-end, as exactly.
    // It pays where the triangle's part of the cell meets many camera rays for its number
    // of front triangles: about min(area, h²) / (rayAngle·d)² rays at a distance d. "auto"
    // builds one only where that is at least the number of front triangles (measured,
    // callgrind, one thread: the garden's light mesh 4,422M -> 4,060M instructions at
    // 1024×600, where a patch per leaf and cell, with ~100 front triangles, rarely decided
    // a segment; the gazebo's 517M -> 512M, the castle's within 0.2 %; at 512×300 the
    // garden -18 %, the parque -5 %, the castle -3 %). Like SummaryPays, a matter of the
    // point and the camera only: the counts stay the same for any thread count.
    float patchRayAngle2_ = 0;  // rayAngle² ("auto" with a known ray angle); 0: always
    bool PatchPays(const ShadingPoint& sp, const Vec3& v0, const Vec3& v1, const Vec3& v2, uint32_t front) const {
        if (patchRayAngle2_ == 0) return true;
        const float area = std::min(0.5f * Length(Cross(v1 - v0, v2 - v0)), lattice_.h * lattice_.h);
        return area >= static_cast<float>(front) * patchRayAngle2_ * LengthSquared(sp.p - camera_);
    }
    uint64_t binPairs_ = 0;      // (triangle, brick) pairs the binning counted
    std::vector<int64_t> cellNodes_;  // linear offsets of the union of the templates
    std::vector<int8_t> cellOx_, cellOy_, cellOz_;  // the same nodes' offsets, an array per axis
    ZeroedPtr<std::atomic<Word>> nodes_;
    // Penumbra mode (lightRadius_ > 0): per node and light, the nearest blocker's parameter
    // along the node's shadow segment, t·65535 (EvaluateVisibility); light l of node i at
    // i·lights + l.
    const float lightRadius_;
    bool ranged_ = false;  // some light has a finite range (EvaluateVisibility skips beyond it)
    ThinCheck thinCheck_ = ThinCheck::kOff;
    ZeroedPtr<std::atomic<uint16_t>> blockerT_;
    static constexpr size_t kReachChunk = 1 << 18;
    static_assert(kMaxBrickNear <= kReachChunk, "a brick's near codes must fit in one reach chunk (ReachSlots)");
    mutable std::vector<std::unique_ptr<uint32_t[], FreeDeleter>> reachArena_;
    mutable size_t reachUsed_ = 0, reachBytes_ = 0;
    // Cell summaries: each triangle's plane (unit normal, offset) and bounding box (grown
    // by cullMargin_), for the binning, the reach lists and the segment culling.
    struct TrianglePlane {
        Vec3 n;
        float d;
        Vec3 lo, hi;
    };
    // (These on huge pages: on the garden 18 and 15 MiB, filled at once.)
    // The triangles' planes and magnitudes and the bricks' lists depend on the geometry and
    // the lattice only: the groups of one LightMeshGroups share them (SharedTables, built
    // by the first group; on the garden 45 MiB a group), each group keeps its node words.
    struct Tables {
        std::vector<TrianglePlane, HugePageAllocator<TrianglePlane>> planes;
        std::vector<float, HugePageAllocator<float>> magnitudes;
        std::vector<uint64_t, HugePageAllocator<uint64_t>> brickStart;
        std::vector<uint32_t, HugePageAllocator<uint32_t>> brickTris;
        bool built = false;  // by the first mesh that had them
        bool binned = false;
        uint64_t binPairs = 0;
    };
    static std::shared_ptr<Tables> TakeTables(const std::shared_ptr<void>& shared) {
        return shared ? std::static_pointer_cast<Tables>(shared) : std::make_shared<Tables>();
    }
    std::shared_ptr<Tables> tables_;

  public:
    // The tables, for the next group to share (CreateLightMeshForLights).
    std::shared_ptr<void> SharedTables() const { return tables_; }

  private:
    std::vector<TrianglePlane, HugePageAllocator<TrianglePlane>>& planes_ = tables_->planes;
    // Per triangle, the largest |coordinate| of its vertices (a cell's tolerance), apart
    // from the planes: a summary takes the maximum over its reach, and as a field of the
    // 44-byte planes that gather was 8 % of the castle's L1 read misses (callgrind's model).
    std::vector<float, HugePageAllocator<float>>& magnitudes_ = tables_->magnitudes;
    std::vector<uint64_t, HugePageAllocator<uint64_t>>& brickStart_ = tables_->brickStart;  // CSR of the bricks' candidate triangles
    std::vector<uint32_t, HugePageAllocator<uint32_t>>& brickTris_ = tables_->brickTris;
    uint64_t bricksX_ = 0, bricksY_ = 0;
    ZeroedPtr<std::atomic<SummaryBrick*>> bricks_;  // per brick of cells, allocated on first use
    mutable std::mutex brickMutex_;
    static constexpr size_t kBricksPerChunk = 512;  // 1.8 MiB
    mutable std::vector<std::unique_ptr<SummaryBrick, FreeDeleter>> brickChunks_;
    mutable size_t brickChunkUsed_ = 0;
    mutable std::atomic<uint64_t> bricksUsed_{0};
    mutable std::atomic<uint64_t> evaluated_{0}, summarized_{0}, uniformCells_{0}, planarCells_{0};
};

}  // namespace
}  // namespace lm
