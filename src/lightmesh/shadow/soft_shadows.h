// soft_shadows.h -- "soft", the default shadow method: physically sized soft shadows from
// spherical lights, computed on the light mesh's lattice of cells (ours, beyond the paper).
//
// The paper's light mesh stores at each node whether it sees each light, and interpolates
// those bits around a shading point: the shadow is blurred by a kernel of radius kI·h that
// has nothing to do with the light's size, shadows narrower than a few cells dissolve, and
// nodes on the far side of a wall leak. This mode keeps the paper's structure -- a uniform
// lattice of cells over the scene, each evaluated lazily, once, published lock-free and
// shared by every point that falls in it -- but a cell stores, per light, the triangles
// that can stand between a point of the cell and a point of the light: those that meet the
// convex hull of the cell's bounding ball and the light's sphere (OccluderBvh, one query
// per cell and light). For each receiver (a triangle with a part in the cell), when a
// point on it first asks, the entries that can shadow that part: usually none (V = 1 for
// all its points), sometimes one triangle that covers the whole light from all of it (an
// umbra certificate, V = 0). A point with candidates left tests them against N directions
// stratified over its cone to the light (the area reference's distribution, turned per
// point), a quarter first: V = the fraction no triangle blocks. So V is the reference's
// estimate with N samples, exact for every triangle (thin occluders, gaps, closed walls and
// contact behave as they do for rays), without rays through the scene; only cells whose
// lists are too long (foliage) trace `denseSamples` rays per light through the back-end. A
// light of radius 0 gets the hard shadow: its segment tested against the same lists.
// docs/soft-shadows.md describes it with its measurements.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/accel/occluder_bvh.h"
#include "lightmesh/shadow/disc_pattern.h"
#include "lightmesh/shadow/shadow.h"

namespace lm {

/// Slots of RenderCounters::method this method fills.
enum SoftCount : size_t {
    kSoftLookups,     ///< (point, light) pairs answered
    kSoftFree,        ///< ... with no candidate triangle left: lit, no work
    kSoftSampled,     ///< ... sampled against their candidates
    kSoftCandidates,  ///< candidate triangles tested with samples
    kSoftDense,       ///< ... in dense cells, traced through the back-end
    kSoftOutside,     ///< ... outside the lattice (own query)
    kSoftFull,        ///< ... sampled with all directions (the first pass did not decide)
    kSoftBallPass,    ///< list entries whose plane separates the point from the light and
                      ///< whose bounding ball meets its cone
    kSoftReceiverFree,  ///< lookups whose receiver's list is empty
    kSoftWholeList,     ///< lookups that used the cell's whole list
    kSoftReceiverDark,  ///< lookups whose receiver is certified in the umbra
};

class SoftShadows final : public ShadowMethod {
  public:
    SoftShadows(const Scene& scene, const Accelerator& accel, SoftShadowOptions options);
    ~SoftShadows() override;
    std::string_view Name() const override { return "exact"; }
    void Visibility(const ShadingPoint& sp, LightIndices lights, float* vis, RenderCounters& counters) const override;
    ShadowFigures Figures() const override;
    StatsLines CounterLines(const RenderCounters& counters) const override;

    /// The visibility of light `light` from the shading point: in [0, 1], a multiple of
    /// 1/samples (or of 1/denseSamples in a dense cell).
    float LightVisibility(const ShadingPoint& sp, size_t light, RenderCounters& counters) const;
    /// The cell step h.
    float Step() const { return h_; }

    /// What the per-point tests read of a triangle, precomputed once: one cache line.
    struct alignas(64) Triangle {
        float v0[3], v1[3], v2[3];
        float n[3];  ///< (v1 − v0) × (v2 − v0)
        float c[3];  ///< bounding ball: centre ...
        float r;     ///< ... and radius
    };
    struct CellList;
    struct Receiver;

  private:
    using Slot = std::atomic<const CellList*>;
    /// Where a point's lists are, found once for all the lights it needs: its cell's slots
    /// (one per light; null outside the lattice) and, once known, its triangle's place
    /// among the cell's receivers (the same in every light's list of the cell).
    struct Place {
        Slot* slots = nullptr;
        int i = 0, j = 0, k = 0;
        size_t receiver = SIZE_MAX;
    };
    Place Locate(const Vec3& o) const;
    float LightVisibilityAt(const ShadingPoint& sp, Place& place, size_t light, RenderCounters& counters) const;
    const CellList* List(const Vec3& o, const Place& place, size_t light, std::unique_ptr<CellList>* own,
                         RenderCounters& counters) const;
    std::unique_ptr<CellList> BuildList(const BallHull& hull, const Bounds3& box, size_t light) const;
    /// BuildList and BuildReceiver for a scene with instances or without (kInstanced false:
    /// every triangle read from tris_, no test per entry).
    template <bool kInstanced>
    std::unique_ptr<CellList> BuildListOf(const BallHull& hull, const Bounds3& box, size_t light) const;
    template <bool kInstanced>
    std::unique_ptr<Receiver> BuildReceiverOf(const CellList& list, uint32_t prim, const Vec3& L, float R) const;
    /// The list of cell `box` for `light`: the hull of the cell's bounding ball and the
    /// light's sphere holds every segment from a point of the cell to a point of the light.
    std::unique_ptr<CellList> BuildCell(const Bounds3& box, size_t light) const;
    /// Publishes `built` in *slot once (compare-and-swap; a list depends on its cell and
    /// light only, so a loser's copy is identical and is freed); returns the slot's list.
    const CellList* Publish(std::atomic<const CellList*>* slot, std::unique_ptr<CellList> built) const;
    std::unique_ptr<Receiver> BuildReceiver(const CellList& list, uint32_t prim, const Vec3& L, float R) const;
    /// V from the triangles `each` yields (each(f) calls f(id) for every triangle whose plane
    /// may separate the point from the light, until f returns false).
    template <typename Each>
    float SampleLight(const ShadingPoint& sp, size_t light, Each&& each, RenderCounters& counters) const;
    template <typename Each>
    float HardLight(const ShadingPoint& sp, size_t light, Each&& each) const;

    const Scene& scene_;
    const Accelerator& accel_;
    SoftShadowOptions options_;
    OccluderBvh bvh_;
    /// What the per-point tests read of each flat triangle (TriangleMesh::triangles), and its
    /// |n|² (the order of a cell's entries). An instanced triangle's are computed when read,
    /// from its world-space corners (the same values as over the mesh flattened).
    std::vector<Triangle> tris_;
    std::vector<float> area_;
    uint32_t flatCount_ = 0;
    static void MakeTriangle(const Vec3& p0, const Vec3& p1, const Vec3& p2, Triangle* t, float* area);
    const Triangle& Tri(uint32_t id, Triangle* scratch) const {
        if (id < flatCount_) [[likely]]
            return tris_[id];
        return InstancedTri(id, scratch);
    }
    [[gnu::noinline]] const Triangle& InstancedTri(uint32_t id, Triangle* scratch) const;
    template <bool kInstanced>
    const Triangle& TriOf(uint32_t id, Triangle* scratch) const {
        if constexpr (kInstanced) return Tri(id, scratch);
        else return tris_[id];
    }
    // The lattice of cells: cell (i, j, k) is origin_ + [i, i+1)·h × ... Cells are grouped
    // in blocks of 4³, allocated on first use; a block holds an atomic pointer per cell and
    // light, published once (compare-and-swap; the loser frees its own copy, which is
    // identical: a list depends on its cell and light only).
    Vec3 origin_;
    float h_ = 0;
    int nx_ = 0, ny_ = 0, nz_ = 0, bx_ = 0, by_ = 0, bz_ = 0;
    std::unique_ptr<std::atomic<Slot*>[]> blocks_;
    size_t blockCount_ = 0;
    /// Directions s0 .. s1 − 1 of `pattern` from sp's origin to the light's sphere: the
    /// pattern turned by an angle from a hash of the point (the area reference's seed),
    /// mapped to the cone uniformly in solid angle (1 − cos θ = r²·(1 − cos θmax)), with each
    /// ray's length to the near side of the sphere (shortened like LightSegment's).
    struct alignas(16) Directions4 {
        float x[256], y[256], z[256], t[256];
    };
    void Directions(const ShadingPoint& sp, size_t light, const DiscPattern& pattern, int s0, int s1,
                    Directions4* out) const;
    float DenseLight(const ShadingPoint& sp, size_t light, RenderCounters& counters) const;
    DiscPattern pattern_, densePattern_;
    mutable std::atomic<uint64_t> cellsBuilt_{0}, entriesBuilt_{0}, denseBuilt_{0};
    /// The bytes of the blocks, lists and receivers published so far, and the most they may
    /// take: half the memory budget (PhysicalMemoryBytes; 0: no limit). Lists are built
    /// where points need them, so their size is only known as the render goes: past the
    /// limit the render stops with an Error instead of running the machine out of memory.
    /// Only published copies count, and the lists a render needs do not depend on the
    /// threads, so whether a render stops does not either.
    mutable std::atomic<uint64_t> bytesBuilt_{0};
    uint64_t byteLimit_ = 0;
    void Account(size_t bytes) const;
};

/// Builds "soft" (see above); throws Error for bad options.
std::unique_ptr<ShadowMethod> CreateSoftShadows(const Scene& scene, const Accelerator& accel,
                                                const SoftShadowOptions& options);

}  // namespace lm
