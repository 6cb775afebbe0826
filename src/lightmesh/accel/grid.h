// grid.h -- the paper's nested uniform grid (Debelov & Novikov, section 2): the ray-query
// back-end whose segment cost grows with the segment's length.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/math/bounds.h"
#include "lightmesh/util/huge_pages.h"

namespace lm {

/// A uniform grid over the scene's box whose crowded cells hold sub-grids (paper §2).
///
/// The top level has `res` cells along each axis (see AutoResolution); a cell with more than
/// AccelOptions::gridMaxTrianglesPerCell triangles gets a sub-grid of ⌈∛n⌉ cells per side
/// over the cell, and so on down to AccelOptions::gridMaxDepth levels in all. Everything is
/// built eagerly into flat arrays. Queries walk the cells with a 3D-DDA (Amanatides & Woo
/// 1987) from the ray's entry into the box to min(tMax, exit), so a short segment visits few
/// cells; a closest-hit query stops in the cell that holds its hit. Triangles are tested with
/// IntersectTriangle's arithmetic (set up once per ray, geometry/triangle.h), so every answer
/// (hit triangle, t to the bit, crossing count) is brute force's, ties included (the lowest
/// id among equal t). Cells are grown by a small epsilon when triangles are assigned, which
/// covers the DDA's rounding at the scene's own scale; for rays starting very far away
/// (thousands of scene sizes) a hit within rounding of a cell boundary could in principle be
/// missed by the early stop.
class NestedGridAccel final : public Accelerator {
  public:
    /// Builds the grid over `mesh`, which must outlive it. Throws Error if the mesh has
    /// 2^31 triangles or more.
    NestedGridAccel(const TriangleMesh& mesh, const AccelOptions& options = {});
    ~NestedGridAccel() override;
    // Not copied: jumpReach_ points into the grid's own arrays.
    NestedGridAccel(const NestedGridAccel&) = delete;
    NestedGridAccel& operator=(const NestedGridAccel&) = delete;

    std::string_view Name() const override { return "grid"; }
    bool Intersect(const Ray& ray, Hit* hit) const override;
    bool Occluded(const Ray& ray) const override;
    /// Coherent rays (a tile's camera rays, a tile's shadow rays to one light) traverse as
    /// packets of up to kPacketSize: slice by slice of the top level along the axis they
    /// share a direction on, visiting each cell the packet's footprint covers once for all
    /// its rays (coherent grid traversal, Wald et al. 2006). Rays that do not share it, and
    /// packets that spread over too many cells, take the single-ray walk. Every ray gets the
    /// answer Intersect / Occluded gives it alone, bit for bit.
    void IntersectMany(const Ray* rays, size_t count, Hit* hits) const override;
    void OccludedMany(const Ray* rays, size_t count, bool* occluded) const override;
    int CountCrossings(const Ray& ray) const override;
    AccelFigures Figures() const override;

    /// Most rays one packet traverses at once (one bit each in a 64-bit mask).
    static constexpr int kPacketSize = 64;
    /// A packet whose footprint in one slice of the top level covers more cells than this
    /// goes on ray by ray from there: a divergent packet visits cells most of its rays miss.
    static constexpr int kMaxFootprintCells = 48;
    /// A leaf cell met by at least this many of a packet's rays tests each triangle against
    /// several rays at once; fewer rays test 8 triangles at once each, as single rays do.
    static constexpr int kMinLeafGroup = 4;
    /// A sub-grid met by at least this many of a packet's rays is walked as a packet; fewer
    /// rays walk it one by one.
    static constexpr int kMinChildPacket = 8;

    /// Cells per axis of the top level for `triangles` triangles in `box` (the box after
    /// GridBounds' padding). `resolution` > 0 forces that many cells along the longest side.
    ///
    /// Auto heuristic: cubic cells whose total count is about λN (λ = kCellsPerTriangle),
    /// i.e. a cell side s = ∛(V / (λN)), giving ≈ ∛(λN) · (longest side / ∛V) cells along the
    /// longest side. Axes thinner than one cell get a single cell and s is recomputed over the
    /// other axes (a flat scene gets a 2D grid of ≈ λN cells). The longest side gets at most
    /// kMaxAutoResolution cells (pbrt-v2's uniform grid clamps at 64): in a large, mostly
    /// empty box (a garden on a wide ground) finer top cells cost more steps through empty
    /// space than they save, while the sub-grids refine the crowded cells where the triangles
    /// are. With the override each axis is clamped to [1, kMaxResolution] (the paper used 81
    /// and 100 cells).
    static std::array<int, 3> AutoResolution(size_t triangles, const Bounds3& box,
                                             int resolution = 0);
    /// λ of the heuristic: top-level cells per triangle. bench_accel, on builtin:gazebo
    /// (2.6k triangles, res 25): 1 to 4 within noise, 0.25 and 8 slower.
    static constexpr double kCellsPerTriangle = 2.0;
    /// Cap of the auto resolution (garden, 386k triangles: 24-48 cells best, 64 about 10%
    /// slower, the uncapped 167 40-60% slower on camera and shadow rays).
    static constexpr int kMaxAutoResolution = 48;
    static constexpr int kMaxResolution = 512;

    /// The box the top level covers: the mesh's bounds, thickened where flat and padded a
    /// little so triangles on the boundary are strictly inside.
    const Bounds3& GridBounds() const { return box_; }

    /// What the build produced (Figures() prints these).
    struct Stats {
        std::array<int, 3> resolution{};  ///< top-level cells per axis
        size_t topCells = 0;              ///< cells of the top level
        size_t totalCells = 0;            ///< cells of all levels
        size_t leafCells = 0;             ///< cells holding triangles (not sub-grids)
        size_t emptyCells = 0;            ///< cells of all levels holding nothing
        size_t references = 0;            ///< triangle references in leaf cells
        size_t maxPerCell = 0;            ///< most triangles in one leaf cell
        size_t subGrids = 0;              ///< grids below the top level
        int depth = 1;                    ///< levels reached, top included
        size_t bytes = 0;                 ///< memory of the structure, triangles included
        double buildMs = 0;               ///< wall-clock build time
    };
    const Stats& GetStats() const { return stats_; }

    /// One grid level: `res` cells of size `cellSize` from `lo`, whose cells are
    /// cells_[firstCell ...]. (Public only so the grid's helpers, in its private headers and
    /// .cpp files, can name it.)
    struct Node {
        Vec3 lo;
        Vec3 cellSize;
        Vec3 invCellSize;
        int res[3];
        uint32_t firstCell;
    };
    /// A triangle's vertices, copied in primitive order while the grid is built.
    struct Tri {
        Vec3 p0, p1, p2;
    };
    /// Eight triangles of one leaf cell, coordinate by coordinate (v[3·vertex + axis][lane]),
    /// so that one ray is tested against all eight with SIMD instructions (grid_filter.cpp), and
    /// their primitive ids: a cell's test reads its blocks and nothing else.
    struct alignas(32) TriBlock {
        float v[9][8];
        uint32_t id[8];
    };
    /// A cell of any level: a leaf's `count` triangles in lanes first … first + count - 1 of
    /// blocks_ (lane L is lane L % 8 of block L / 8: cells share blocks, so every block is
    /// full), or (count with kChildBit) the sub-grid node count & ~kChildBit; count 0 when
    /// empty.
    ///
    /// And the box of what a non-empty cell holds (ours, in the spirit of a BVH's leaf
    /// bounds): along axis a, from box[a] to box[4 + a] kBoxSteps-ths of the cell (rounded
    /// outwards), it holds the bounds of every triangle of the cell clipped to the cell. A
    /// ray whose stretch through the cell misses that box, grown by rounding's reach, hits
    /// nothing there: the walk skips the cell's triangles, or its sub-grid, and a packet the
    /// rays whose rectangle misses it. Half the non-empty cells a ray meets are skipped so
    /// (a surface across a corner of the cell, foliage, a floor under the ray, a triangle
    /// that only touches the cell's growth).
    struct CellRef {
        uint32_t first;
        uint32_t count;
        // boxLo x, y, z, 0, then boxHi x, y, z, 0: two 4-lane vectors for the queries' test
        uint16_t box[8];
    };
    /// Steps per cell side of CellRef's box (16 bits). With 255 steps a triangle on a cell's
    /// face left a whole step of box inside the cell, and far fewer cells were skipped
    /// (callgrind, bench_accel's gazebo shadow rays: 91.4M instructions against 81.9M).
    static constexpr int kBoxSteps = 65535;
    static constexpr uint32_t kChildBit = 0x80000000u;
    /// Tests `count` (≤ 8) blocks against a prepared ray with the watertight test's very
    /// arithmetic, lane by lane: returns the bits 8·b + lane of the triangles it hits, their
    /// t in t[8·b + lane]; *ties gets the bits of those with an edge function exactly zero
    /// (the tie-breaks, left to the scalar test). The closest-hit variant also writes their
    /// b0, b1, b2 to bary[64·k + 8·b + lane] (3 × 64 floats), as the scalar test computes
    /// them; the other ignores `bary`.
    using BlockFilter = uint64_t (*)(const TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                                     float* t, uint64_t* ties, float* bary);

  private:
    // The build (grid_build.cpp): the constructor's steps.
    struct Builder;
    struct BuildLevel;  // one level under construction
    void SetBounds(const std::vector<Tri>& tris, std::vector<uint32_t>* ids);
    uint64_t Flatten(BuildLevel& top, std::vector<BuildLevel*>* queue);
    void FillBlocks(const std::vector<BuildLevel*>& queue, const std::vector<Tri>& tris, uint64_t laneCount);
    void SetSubGridBoxes();
    void ChooseFilters();
    struct PacketLanes;  // a packet's rays, lane by lane (grid_packet_walk.h)
    struct SliceLanes;   // the rays' stretches across one slice of one level (grid_packet_walk.h)
    template <typename Query>
    bool Walk(uint32_t node, const Ray& ray, const Vec3& invD, float tEnter, float tExit, Query& query) const;
    template <typename Query>
    void Traverse(const Ray& ray, Query& query) const;
    template <typename Query>
    void TraceMany(const Ray* rays, size_t count, Query* queries) const;
    template <typename Query>
    void PacketWalk(uint32_t node, PacketLanes& p, uint64_t lanes, const float* tLo, const float* tHi,
                    Query* queries) const;
    // The packet's walk of one level and its leaf test, W rays per vector instruction
    // (grid_packet_walk.h): one body for both instruction sets, always inlined into the
    // entry points PacketWalkLanes4 and PacketWalkLanes8.
    template <int W, typename Query>
    [[gnu::always_inline]] void PacketWalkLanes(uint32_t node, PacketLanes& p, uint64_t lanes, const float* tLo,
                                                const float* tHi, Query* queries) const;
    template <int W, typename Query>
    [[gnu::always_inline]] bool PacketLeaf(PacketLanes& p, const SliceLanes& sl, uint64_t group, const CellRef& ref,
                                           Query* queries) const;
    template <typename Query>
    void PacketWalkLanes4(uint32_t node, PacketLanes& p, uint64_t lanes, const float* tLo, const float* tHi,
                          Query* queries) const;
#if defined(__x86_64__) || defined(__i386__)
    // Compiled for AVX2 (PacketWalk chooses it where the CPU has it).
    template <typename Query>
    __attribute__((target("avx2"))) void PacketWalkLanes8(uint32_t node, PacketLanes& p, uint64_t lanes,
                                                          const float* tLo, const float* tHi, Query* queries) const;
#endif

    const TriangleMesh& mesh_;
    AccelOptions options_;
    Bounds3 box_;
    float epsAbs_ = 0;         // least growth of a cell when assigning triangles (scene scale)
    float boxAbs_ = 0;         // the largest coordinate of box_, in magnitude
    std::vector<Node> nodes_;  // [0] is the top level
    // The two large arrays come in 2 MiB pages from kHugeArraysFrom up (util/huge_pages.h):
    // a build writes them once, and through 4 KiB pages the first touches' faults were half
    // of a large scene's build (perf, the trees: 56 MB of blocks). Below it, rounding up to
    // a whole 2 MiB page would cost more memory than the faults it spares cost time (the
    // gazebo's 0.4 MB of blocks: about 100 faults).
    static constexpr size_t kHugeArraysFrom = size_t(2) << 20;  // bytes
    std::vector<CellRef, HugePageAllocator<CellRef, kHugeArraysFrom>> cells_;  // all cells of all nodes, node by node
    std::vector<uint64_t> occupied_;   // one bit per cell: not empty
    // The leaf cells' triangles, each cell's in id order, cell after cell, 8 lanes per block.
    std::unique_ptr<TriBlock[], FreeDeleter> blocks_;  // AllocateLarge's
    size_t blockCount_ = 0;
    // Per top-level cell: how many cells around it are empty (ComputeEmptyReach).
    std::vector<uint8_t> emptyReach_;
    static constexpr int kMaxEmptyReach = 8;
    static constexpr size_t kMaxEmptyReachCells = size_t(1) << 24;
    void ComputeEmptyReach();
    // Per top-level cell and octant of directions (bit a set: the negative side along axis
    // a), the side in cells of the largest all-empty cube of top cells with this cell at its
    // corner, reaching into that octant (ComputeOctantReach): octant o's cells are
    // octantReach_[o · top cells ...]. A ray only moves into its own octant, so the single
    // walk jumps across this cube, not the centred one of emptyReach_, which a floor or wall
    // behind the ray or beside it keeps small (a packet skips by it when its rays share an
    // octant, else by emptyReach_). Eight bytes a top cell, so only up to
    // kMaxOctantReachCells of them.
    std::vector<uint8_t> octantReach_;
    static constexpr int kMaxOctantReach = 255;
    static constexpr size_t kMaxOctantReachCells = size_t(1) << 21;
    void ComputeOctantReach();
    // What the single walk jumps by: octant o's array at jumpReach_ + o · jumpReachStride_
    // (octantReach_, or emptyReach_ with stride 0, or nullptr without either).
    const uint8_t* jumpReach_ = nullptr;
    size_t jumpReachStride_ = 0;
    // How far rounding may put a point computed along a ray whose origin's largest coordinate
    // is `originAbs` (o + d·t, a plane's t) from where it belongs, in world units: the
    // packets' rectangles and the cells' content boxes (CellRef) are grown by it.
    float RoundingReach(float originAbs) const { return epsAbs_ + 1e-6f * (boxAbs_ + originAbs); }
    BlockFilter filter_ = nullptr;         // t only
    BlockFilter nearestFilter_ = nullptr;  // and the hits' barycentrics (closest-hit queries)
    BlockFilter anyFilter_ = nullptr;      // t only, up to the first block with a hit (occlusion)
    int simdWidth_ = 0;
    Stats stats_;
};

}  // namespace lm
