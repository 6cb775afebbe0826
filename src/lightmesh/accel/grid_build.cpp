// grid_build.cpp -- the nested uniform grid of the paper's section 2: its build (the top
// level's resolution, the sub-grids, the flat arrays, the empty-space reach) and its figures.
// The queries are grid.cpp (single rays), grid_packet.cpp (packets) and grid_filter.cpp (the
// leaf cells' SIMD triangle filter).
#include "lightmesh/accel/grid.h"
#include "lightmesh/accel/grid_internal.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <utility>

#include "lightmesh/geometry/triangle.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"

namespace lm {
namespace {

static_assert(sizeof(NestedGridAccel::Tri) == 9 * sizeof(float), "Tri must be 9 packed floats");
inline const float* Floats(const NestedGridAccel::Tri& t) { return &t.p0.x; }

bool IsFiniteTri(const NestedGridAccel::Tri& t) {
    return IsFinite(t.p0) && IsFinite(t.p1) && IsFinite(t.p2);
}

// The mesh's triangles by primitive id, for the build only.
std::vector<NestedGridAccel::Tri> CopyTriangles(const TriangleMesh& mesh) {
    std::vector<NestedGridAccel::Tri> tris(mesh.triangles.size());
    for (size_t i = 0; i < tris.size(); ++i)
        tris[i] = NestedGridAccel::Tri{mesh.Vertex(uint32_t(i), 0), mesh.Vertex(uint32_t(i), 1),
                                       mesh.Vertex(uint32_t(i), 2)};
    return tris;
}

// floor(x) and ceil(x) of a finite x clamped to [lo, hi] (integers), in int arithmetic:
// the baseline x86-64 has no rounding instruction, so std::floor is a libm call, and the
// build rounds every triangle's bounds six times per level.
inline int FloorWithin(double x, int lo, int hi) {
    x = std::clamp(x, double(lo), double(hi));
    const int i = int(x);  // toward zero
    return i - int(double(i) > x);
}
inline int CeilWithin(double x, int lo, int hi) {
    x = std::clamp(x, double(lo), double(hi));
    const int i = int(x);
    return i + int(double(i) < x);
}

// body(i) for i in [0, n): in parallel when there is enough work for the threads' start-up
// to pay (a small scene's build is a fraction of a millisecond).
template <typename Body>
void ForEachIndex(size_t n, size_t minParallel, const Body& body) {
    if (n < minParallel) {
        for (size_t i = 0; i < n; ++i) body(i);
        return;
    }
    ParallelFor(size_t(0), n, body);
}

}  // namespace

namespace grid_detail {

namespace {
// A content box given in (fractional) steps from the cell's low corner, rounded outwards and
// clamped to the cell, into ref->box.
void StoreBoxSteps(const double lo[3], const double hi[3], NestedGridAccel::CellRef* ref) {
    constexpr double kSteps = NestedGridAccel::kBoxSteps;
    for (int a = 0; a < 3; ++a) {
        const int from = FloorWithin(lo[a], 0, int(kSteps));
        ref->box[a] = uint16_t(from);
        ref->box[4 + a] = uint16_t(CeilWithin(hi[a], from, int(kSteps)));
    }
}
}  // namespace

void SetContentBox(const NestedGridAccel::Node& node, const int cell[3], const float lo[3], const float hi[3],
                   NestedGridAccel::CellRef* ref) {
    // [lo, hi] in steps from the cell's low face (the cell's triangles are finite, and so is
    // every value here).
    double from[3], to[3];
    for (int a = 0; a < 3; ++a) {
        const double cellLo = double(node.lo[a]) + cell[a] * double(node.cellSize[a]);
        const double scale = NestedGridAccel::kBoxSteps / double(node.cellSize[a]);
        from[a] = (double(lo[a]) - cellLo) * scale;
        to[a] = (double(hi[a]) - cellLo) * scale;
    }
    StoreBoxSteps(from, to, ref);
}

void SetBoxFromSubGrid(const NestedGridAccel::Node& child, const NestedGridAccel::CellRef* cells,
                       NestedGridAccel::CellRef* ref) {
    constexpr double kSteps = NestedGridAccel::kBoxSteps;
    double lo[3] = {kSteps, kSteps, kSteps}, hi[3] = {0, 0, 0};
    int k[3];
    uint32_t c = child.firstCell;
    for (k[2] = 0; k[2] < child.res[2]; ++k[2])
        for (k[1] = 0; k[1] < child.res[1]; ++k[1])
            for (k[0] = 0; k[0] < child.res[0]; ++k[0], ++c) {
                const NestedGridAccel::CellRef& sub = cells[c];
                if (sub.count == 0) continue;
                // The sub-cell's box as a fraction of the parent cell, in steps.
                for (int a = 0; a < 3; ++a) {
                    lo[a] = std::min(lo[a], (k[a] + sub.box[a] / kSteps) / child.res[a] * kSteps);
                    hi[a] = std::max(hi[a], (k[a] + sub.box[4 + a] / kSteps) / child.res[a] * kSteps);
                }
            }
    StoreBoxSteps(lo, hi, ref);
}

void RasterizeTriangle(const NestedGridAccel::Node& node, const NestedGridAccel::Tri& t, double epsAbs, uint32_t id,
                       std::vector<std::pair<uint32_t, uint32_t>>* out) {
    double eps[3];
    int lo[3], hi[3];
    int spanning = 0, spanAxis = 0;  // the axes along which the triangle meets > 1 cell
    bool clamped = false;            // the grown bounds reach beyond the node
    for (int a = 0; a < 3; ++a) {
        // Grow cells by a little: the DDA's plane crossings are computed in float, and
        // a hit point rounded into the neighbouring cell must still find its triangle
        // there. 1e-4 of a cell is far above float error at the scene's own scale.
        eps[a] = std::max(1e-4 * node.cellSize[a], epsAbs);
        const double bmin = std::min({t.p0[a], t.p1[a], t.p2[a]}) - eps[a];
        const double bmax = std::max({t.p0[a], t.p1[a], t.p2[a]}) + eps[a];
        const double inv = node.invCellSize[a];
        const int top = node.res[a] - 1;
        const int first = FloorWithin((bmin - node.lo[a]) * inv, -1, top + 1);
        const int last = FloorWithin((bmax - node.lo[a]) * inv, -1, top + 1);
        clamped |= first < 0 || last > top;
        lo[a] = std::clamp(first, 0, top);
        hi[a] = std::clamp(last, 0, top);
        if (hi[a] > lo[a]) ++spanning, spanAxis = a;
    }
    const int nx = node.res[0], ny = node.res[1];
    auto emit = [&](int x, int y, int z) { out->emplace_back(uint32_t((z * ny + y) * nx + x), id); };
    if (spanning == 0) {
        emit(lo[0], lo[1], lo[2]);
        return;
    }
    if (spanning == 1 && !clamped) {
        // A run of cells along one axis, the triangle's grown bounds inside one cell along
        // the other two: the triangle is connected, so it has a point at every coordinate
        // of the run's axis between its extremes, and that point lies in the run's grown
        // cell there (the overlap test would accept each one, but for rounding).
        int k[3] = {lo[0], lo[1], lo[2]};
        for (k[spanAxis] = lo[spanAxis]; k[spanAxis] <= hi[spanAxis]; ++k[spanAxis])
            emit(k[0], k[1], k[2]);
        return;
    }
    double h[3];
    for (int a = 0; a < 3; ++a) h[a] = 0.5 * node.cellSize[a] + eps[a];
    // Every cell of the bounds' range whose centre meets(c) accepts, x fastest.
    auto emitWhere = [&](auto&& meets) {
        double c[3];
        for (int z = lo[2]; z <= hi[2]; ++z) {
            c[2] = node.lo[2] + (z + 0.5) * double(node.cellSize[2]);
            for (int y = lo[1]; y <= hi[1]; ++y) {
                c[1] = node.lo[1] + (y + 0.5) * double(node.cellSize[1]);
                for (int x = lo[0]; x <= hi[0]; ++x) {
                    c[0] = node.lo[0] + (x + 0.5) * double(node.cellSize[0]);
                    if (meets(c)) emit(x, y, z);
                }
            }
        }
    };
    if (spanning == 2 && !clamped) {
        // The grown bounds inside one cell along the third axis w: the triangle lies in that
        // slab, so a cell meets it exactly when the cell's rectangle across the other two
        // axes meets the triangle's projection there. That 2D test's axes are the full
        // test's three edge × w products, computed by the same operations (the w terms are
        // zeros; the build does not contract multiply-adds, -ffp-contract=off). The box
        // normals across u and v are the cells' range; the triangle's normal and the other
        // six edge products cannot separate what the 2D test accepts, so the cells are the
        // full test's up to its rounding on those axes.
        const int w = hi[0] == lo[0] ? 0 : (hi[1] == lo[1] ? 1 : 2);
        const int u = w == 0 ? 1 : 0, v = w == 2 ? 1 : 2;
        const double pu[3] = {t.p0[u], t.p1[u], t.p2[u]}, pv[3] = {t.p0[v], t.p1[v], t.p2[v]};
        double nu[3], nv[3], plo[3], phi[3], r[3];
        for (int i = 0; i < 3; ++i) {
            const int j = (i + 1) % 3;  // edge i runs from vertex i to vertex j
            // e × w: (-e_v, e_u) in the (u, v) plane, up to the sign the full test's
            // right-handed order gives it, which does not change a separation.
            nu[i] = -(pv[j] - pv[i]);
            nv[i] = pu[j] - pu[i];
            const double q0 = nu[i] * pu[0] + nv[i] * pv[0], q1 = nu[i] * pu[1] + nv[i] * pv[1],
                         q2 = nu[i] * pu[2] + nv[i] * pv[2];
            plo[i] = std::min(std::min(q0, q1), q2);
            phi[i] = std::max(std::max(q0, q1), q2);
            r[i] = h[u] * std::abs(nu[i]) + h[v] * std::abs(nv[i]);
        }
        emitWhere([&](const double c[3]) {
            bool meets = true;
            for (int i = 0; i < 3; ++i) {
                const double pc = nu[i] * c[u] + nv[i] * c[v];
                meets &= !(plo[i] - pc > r[i] || phi[i] - pc < -r[i]);
            }
            return meets;
        });
        return;
    }
    const TriangleBoxOverlap overlap(t.p0, t.p1, t.p2, h);
    emitWhere([&](const double c[3]) { return overlap.Overlaps(c); });
}

}  // namespace grid_detail

// The queries' triangle filters (grid_filter.cpp), of which the build picks one for this machine.
using grid_detail::FilterBlocks4;
using grid_detail::FilterBlocks8;
using grid_detail::HasAvx2;

// ---------------------------------------------------------------------------------------
// Build

std::array<int, 3> NestedGridAccel::AutoResolution(size_t triangles, const Bounds3& box,
                                                   int resolution) {
    const Vec3 e = box.Diagonal();
    const float longest = MaxComponent(e);
    std::array<int, 3> res{1, 1, 1};
    if (!(longest > 0)) return res;
    double side;  // target cell side
    if (resolution > 0) {
        side = double(longest) / resolution;
    } else {
        // s = (Π e_a over the free axes / λN)^(1/k); an axis thinner than s gets one cell
        // and leaves the product, which can only shrink s for the others (≤ 3 rounds).
        const double target =
            std::max(1.0, kCellsPerTriangle * double(std::max<size_t>(triangles, 1)));
        bool free[3] = {true, true, true};
        side = longest;
        for (int round = 0; round < 3; ++round) {
            double prod = 1;
            int k = 0;
            for (int a = 0; a < 3; ++a)
                if (free[a]) prod *= e[a], ++k;
            side = std::pow(prod / target, 1.0 / k);
            bool changed = false;
            for (int a = 0; a < 3; ++a)
                if (free[a] && e[a] < side) free[a] = false, changed = true;
            if (!changed) break;
        }
    }
    // Auto: at most kMaxAutoResolution cells along the longest side (coarser cells keep
    // their shape).
    if (resolution <= 0) side = std::max(side, double(longest) / kMaxAutoResolution);
    for (int a = 0; a < 3; ++a) {
        double n = double(e[a]) / side;
        res[a] = static_cast<int>(std::clamp(std::lround(n), 1L, long(kMaxResolution)));
    }
    if (resolution > 0) res[MaxDimension(e)] = std::min(resolution, kMaxResolution);
    return res;
}

// One level under construction: its cells as CSR, and the sub-grids of its crowded cells.
struct NestedGridAccel::BuildLevel {
    Node node{};
    int depth = 1;
    std::vector<uint32_t> start;  // CSR over this level's cells
    std::vector<uint32_t> prims;
    std::vector<std::pair<uint32_t, std::unique_ptr<BuildLevel>>> children;  // by local cell
};

// Fills the levels with their triangles, top-down.
struct NestedGridAccel::Builder {
    using Level = BuildLevel;

    const std::vector<Tri>& tris;
    const AccelOptions& options;
    double epsAbs;  // the least a cell is grown by when assigning triangles

    static Node MakeNode(const Vec3& lo, const Vec3& hi, const std::array<int, 3>& res) {
        Node n{};
        n.lo = lo;
        for (int a = 0; a < 3; ++a) {
            n.res[a] = res[a];
            n.cellSize[a] = (hi[a] - lo[a]) / float(res[a]);
            n.invCellSize[a] = float(res[a]) / (hi[a] - lo[a]);
        }
        return n;
    }

    // Fills level.start/prims with the given triangles, then builds sub-grids (paper §2:
    // a cell with more than the threshold gets ⌈∛n⌉ cells per side, recursively).
    void Fill(Level& level, const uint32_t* ids, size_t n, bool parallel) const {
        const Node& node = level.node;
        const size_t cells = size_t(node.res[0]) * node.res[1] * node.res[2];
        // (cell, triangle) pairs gathered per block of triangles; concatenating the blocks in
        // order and counting-sorting by cell keeps each cell's triangles in id order, so the
        // structure does not depend on the thread schedule.
        constexpr size_t kBlock = 4096;
        const size_t blocks = (n + kBlock - 1) / kBlock;
        std::vector<std::vector<std::pair<uint32_t, uint32_t>>> pairs(blocks);
        auto gather = [&](size_t b) {
            auto& out = pairs[b];
            const size_t end = std::min(n, (b + 1) * kBlock);
            for (size_t i = b * kBlock; i < end; ++i) {
                const uint32_t id = ids[i];
                grid_detail::RasterizeTriangle(node, tris[id], epsAbs, id, &out);
            }
        };
        if (parallel && blocks > 1)
            ParallelFor(size_t(0), blocks, gather);
        else
            for (size_t b = 0; b < blocks; ++b) gather(b);

        level.start.assign(cells + 1, 0);
        size_t total = 0;
        for (const auto& block : pairs) {
            total += block.size();
            for (const auto& [cell, id] : block) ++level.start[cell + 1];
        }
        for (size_t c = 0; c < cells; ++c) level.start[c + 1] += level.start[c];
        level.prims.resize(total);
        {
            std::vector<uint32_t> cursor(level.start.begin(), level.start.end() - 1);
            for (const auto& block : pairs)
                for (const auto& [cell, id] : block) level.prims[cursor[cell]++] = id;
        }
        pairs.clear();

        if (level.depth >= options.gridMaxDepth) return;
        const size_t threshold = size_t(std::max(1, options.gridMaxTrianglesPerCell));
        std::vector<uint32_t> crowded;
        size_t crowdedRefs = 0;  // the sub-grids' work, for the choice of threads
        for (uint32_t c = 0; c < cells; ++c)
            if (const size_t count = level.start[c + 1] - level.start[c]; count > threshold) {
                crowded.push_back(c);
                crowdedRefs += count;
            }
        level.children.resize(crowded.size());
        auto sub = [&](size_t k) {
            const uint32_t c = crowded[k];
            const int x = int(c % node.res[0]), y = int(c / node.res[0] % node.res[1]),
                      z = int(c / (size_t(node.res[0]) * node.res[1]));
            const Vec3 lo(node.lo.x + x * node.cellSize.x, node.lo.y + y * node.cellSize.y,
                          node.lo.z + z * node.cellSize.z);
            const Vec3 hi = lo + node.cellSize;
            const size_t count = level.start[c + 1] - level.start[c];
            const int r = std::max(2, int(std::ceil(std::cbrt(double(count)) - 1e-9)));
            auto child = std::make_unique<Level>();
            child->node = MakeNode(lo, hi, {r, r, r});
            child->depth = level.depth + 1;
            Fill(*child, level.prims.data() + level.start[c], count, false);
            level.children[k] = {c, std::move(child)};
        };
        // Threads only for enough triangles (a block's worth) that waking them pays: a small
        // scene's sub-grids take a few microseconds each.
        if (parallel && crowded.size() > 1 && crowdedRefs >= kBlock)
            ParallelFor(size_t(0), crowded.size(), sub);
        else
            for (size_t k = 0; k < crowded.size(); ++k) sub(k);
    }
};

NestedGridAccel::NestedGridAccel(const TriangleMesh& mesh, const AccelOptions& options)
    : mesh_(mesh), options_(options) {
    const auto startTime = std::chrono::steady_clock::now();
    if (mesh.triangles.size() >= kChildBit)
        ThrowError("the grid holds at most %u triangles, the scene has %zu", kChildBit - 1,
                   mesh.triangles.size());
    const std::vector<Tri> tris = CopyTriangles(mesh);
    std::vector<uint32_t> ids;  // the triangles the grid holds
    SetBounds(tris, &ids);

    // The levels, top-down, then in the flat arrays.
    Builder builder{tris, options_, double(epsAbs_)};
    BuildLevel top;
    top.node = Builder::MakeNode(box_.lo, box_.hi, AutoResolution(ids.size(), box_, options_.gridResolution));
    builder.Fill(top, ids.data(), ids.size(), true);
    std::vector<BuildLevel*> queue;  // the levels in the order of nodes_
    const uint64_t laneCount = Flatten(top, &queue);

    ComputeEmptyReach();
    ComputeOctantReach();
    if (!octantReach_.empty())
        jumpReach_ = octantReach_.data(), jumpReachStride_ = octantReach_.size() / 8;
    else if (!emptyReach_.empty())
        jumpReach_ = emptyReach_.data(), jumpReachStride_ = 0;

    FillBlocks(queue, tris, laneCount);
    SetSubGridBoxes();
    ChooseFilters();

    // The arrays in huge pages count as whole pages (resident where transparent huge pages
    // are on).
    stats_.bytes = nodes_.size() * sizeof(Node) + LargeAllocationBytes(cells_.capacity() * sizeof(CellRef), kHugeArraysFrom) +
                   occupied_.size() * sizeof(uint64_t) + LargeAllocationBytes(blockCount_ * sizeof(TriBlock), kHugeArraysFrom) +
                   emptyReach_.size() + octantReach_.size();
    stats_.buildMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - startTime)
            .count();
}

// box_, boxAbs_ and epsAbs_ from the triangles; into *ids those with finite vertices.
void NestedGridAccel::SetBounds(const std::vector<Tri>& tris, std::vector<uint32_t>* ids) {
    // The box of the triangles (not of stray vertices). Triangles with a non-finite vertex
    // are left out: they would make the box infinite, and IntersectTriangle never reports
    // them (every comparison with NaN fails).
    ids->reserve(tris.size());
    Bounds3 b;
    for (uint32_t i = 0; i < tris.size(); ++i) {
        if (!IsFiniteTri(tris[i])) continue;
        ids->push_back(i);
        b.Extend(tris[i].p0);
        b.Extend(tris[i].p1);
        b.Extend(tris[i].p2);
    }
    if (b.IsEmpty()) b = Bounds3(Vec3(-1), Vec3(1));
    // A flat scene (a single plane) has a zero-thickness box: give every axis at least 1e-3
    // of the longest side (or 1e-3 if the box is a point), then pad by a little so triangles
    // on the boundary are strictly inside and the DDA's clamping never matters.
    const float maxAbs = std::max(MaxComponent(Abs(b.lo)), MaxComponent(Abs(b.hi)));
    float extent = b.MaxExtent();
    if (!(extent > 1e-6f * maxAbs)) extent = std::max(1e-3f, 1e-3f * maxAbs);
    const float minThick = 1e-3f * extent;
    const float pad = 1e-5f * extent + 4e-7f * maxAbs;
    for (int a = 0; a < 3; ++a) {
        float lo = b.lo[a], hi = b.hi[a];
        if (hi - lo < minThick) {
            const float mid = 0.5f * (lo + hi);
            lo = mid - 0.5f * minThick;
            hi = mid + 0.5f * minThick;
        }
        b.lo[a] = lo - pad;
        b.hi[a] = hi + pad;
    }
    box_ = b;
    boxAbs_ = std::max(MaxComponent(Abs(b.lo)), MaxComponent(Abs(b.hi)));

    epsAbs_ = 2e-7f * extent + 2.5e-7f * maxAbs;
}

// The levels into nodes_ and cells_ (*queue: the levels in the order of nodes_), with
// occupied_ and the cell counts of stats_; returns how many lanes the leaf cells take.
// Breadth-first: a node's index is its order in the queue, known when its parent's cells are
// written. A leaf's triangles get their lanes in the blocks at once.
uint64_t NestedGridAccel::Flatten(BuildLevel& top, std::vector<BuildLevel*>* queue) {
    queue->assign(1, &top);
    {
        // cells_ at its final size at once: growing it by doubling copied and faulted in
        // memory a process's first build pays for (the garden: 473k cells of 24 bytes).
        size_t cellCount = 0;
        std::vector<const BuildLevel*> pending{&top};
        while (!pending.empty()) {
            const BuildLevel* level = pending.back();
            pending.pop_back();
            cellCount += level->start.size() - 1;
            for (const auto& child : level->children) pending.push_back(child.second.get());
        }
        cells_.reserve(cellCount);
    }
    stats_ = Stats{};
    const int* res = top.node.res;
    stats_.resolution = {res[0], res[1], res[2]};
    stats_.topCells = size_t(res[0]) * res[1] * res[2];
    uint64_t laneCount = 0;  // the leaf cells' triangles one after another, 8 lanes per block
    for (size_t q = 0; q < queue->size(); ++q) {
        BuildLevel& level = *(*queue)[q];
        Node node = level.node;
        node.firstCell = uint32_t(cells_.size());
        nodes_.push_back(node);
        stats_.depth = std::max(stats_.depth, level.depth);
        const size_t cells = level.start.size() - 1;
        size_t k = 0;  // next child, children are sorted by cell
        for (size_t c = 0; c < cells; ++c) {
            CellRef ref{0, 0, {}};
            if (k < level.children.size() && level.children[k].first == c) {
                if (queue->size() >= kChildBit) ThrowError("the grid is too large (%zu sub-grids)", queue->size());
                ref.count = kChildBit | uint32_t(queue->size());
                queue->push_back(level.children[k].second.get());
                ++k;
            } else if (const uint32_t n = level.start[c + 1] - level.start[c]; n > 0) {
                ref = {uint32_t(laneCount), n, {}};
                laneCount += n;
                if (laneCount >= UINT32_MAX) ThrowError("the grid is too large (%llu triangle references)",
                                                        static_cast<unsigned long long>(laneCount));
                ++stats_.leafCells;
                stats_.references += n;
                stats_.maxPerCell = std::max<size_t>(stats_.maxPerCell, n);
            } else {
                ++stats_.emptyCells;
            }
            cells_.push_back(ref);
        }
    }
    stats_.totalCells = cells_.size();
    occupied_.assign((stats_.totalCells + 63) / 64, 0);
    for (size_t c = 0; c < stats_.totalCells; ++c)
        if (cells_[c].count != 0) occupied_[c >> 6] |= uint64_t(1) << (c & 63);
    stats_.subGrids = nodes_.size() - 1;
    nodes_.shrink_to_fit();
    cells_.shrink_to_fit();
    return laneCount;
}

// blocks_: the leaf cells' triangles, 8 lanes per block, and the leaf cells' content boxes.
void NestedGridAccel::FillBlocks(const std::vector<BuildLevel*>& queue, const std::vector<Tri>& tris,
                                 uint64_t laneCount) {
    // The blocks, node by node in parallel (each leaf cell writes its own lanes; the storage
    // is not cleared first, a pass over memory the size of the grid, so the last block's
    // unused lanes are cleared here).
    const uint64_t blockCount = (laneCount + 7) / 8;
    blockCount_ = blockCount;
    if (blockCount) {
        blocks_.reset(static_cast<TriBlock*>(AllocateLarge(blockCount * sizeof(TriBlock), alignof(TriBlock), kHugeArraysFrom)));
        TriBlock& last = blocks_[blockCount - 1];
        for (uint64_t lane = laneCount % 8; lane != 0 && lane < 8; ++lane) {
            for (int row = 0; row < 9; ++row) last.v[row][lane] = 0.0f;
            last.id[lane] = 0;
        }
    }
    // Each leaf cell's content box (CellRef) with it, from the vertices it copies.
    ForEachIndex(queue.size(), blockCount > 4096 ? 2 : SIZE_MAX, [&](size_t q) {
        const BuildLevel& level = *queue[q];
        const Node& node = nodes_[q];
        const size_t cells = level.start.size() - 1;
        int cell[3] = {0, 0, 0};  // c's x, y, z
        for (size_t c = 0; c < cells; ++c) {
            if (c) {
                if (++cell[0] == node.res[0]) {
                    cell[0] = 0;
                    if (++cell[1] == node.res[1]) cell[1] = 0, ++cell[2];
                }
            }
            CellRef& ref = cells_[node.firstCell + c];
            if (ref.count == 0 || (ref.count & kChildBit)) continue;
            float lo[3] = {Infinity, Infinity, Infinity}, hi[3] = {-Infinity, -Infinity, -Infinity};
            for (uint32_t i = 0; i < ref.count; ++i) {
                const uint32_t id = level.prims[level.start[c] + i];
                const float* v = Floats(tris[id]);
                const uint64_t lane = uint64_t(ref.first) + i;
                TriBlock& block = blocks_[lane / 8];
                for (int row = 0; row < 9; ++row) block.v[row][lane % 8] = v[row];
                block.id[lane % 8] = id;
                for (int a = 0; a < 3; ++a) {
                    lo[a] = std::min({lo[a], v[a], v[3 + a], v[6 + a]});
                    hi[a] = std::max({hi[a], v[a], v[3 + a], v[6 + a]});
                }
            }
            grid_detail::SetContentBox(node, cell, lo, hi, &ref);
        }
    });
}

// A cell holding a sub-grid gets the union of its sub-cells' boxes (every point of a
// triangle in the cell is in a sub-cell that holds the triangle), children before their
// parents (a sub-grid's node comes after its parent's in nodes_): no second pass over
// the crowded cells' triangles, which are most of the references of a large scene.
void NestedGridAccel::SetSubGridBoxes() {
    for (size_t q = nodes_.size(); q-- > 0;) {
        const Node& node = nodes_[q];
        const size_t cells = size_t(node.res[0]) * node.res[1] * node.res[2];
        for (size_t c = 0; c < cells; ++c) {
            CellRef& ref = cells_[node.firstCell + c];
            if (ref.count & kChildBit) grid_detail::SetBoxFromSubGrid(nodes_[ref.count & ~kChildBit], cells_.data(), &ref);
        }
    }
}

// The triangle filters for this machine (grid_filter.cpp).
void NestedGridAccel::ChooseFilters() {
    simdWidth_ = options_.gridSimdWidth == 4 || !HasAvx2() ? 4 : 8;
    filter_ = simdWidth_ == 8 ? FilterBlocks8 : FilterBlocks4;
    nearestFilter_ = simdWidth_ == 8 ? grid_detail::FilterBlocks8Bary : grid_detail::FilterBlocks4Bary;
    anyFilter_ = simdWidth_ == 8 ? grid_detail::FilterBlocks8Any : grid_detail::FilterBlocks4Any;

}

NestedGridAccel::~NestedGridAccel() = default;

// Empty-space skipping over the top level (ours; proximity clouds, Cohen & Sheffer 1994):
// each top cell's Chebyshev distance in cells to the nearest non-empty top cell, capped at
// kMaxEmptyReach (0 for a non-empty cell). A capped or clipped value is never more than the
// true one, so the box it promises empty is. Separable: the distance along x per row, then
// min over y' of max(|y - y'|, that), then the same along z.
void NestedGridAccel::ComputeEmptyReach() {
    const Node& top = nodes_[0];
    const int nx = top.res[0], ny = top.res[1], nz = top.res[2];
    const size_t cells = size_t(nx) * ny * nz;
    if (cells > kMaxEmptyReachCells) return;
    constexpr int K = kMaxEmptyReach;
    std::vector<uint8_t> d(cells), e(cells);
    auto at = [&](int x, int y, int z) { return (size_t(z) * ny + y) * nx + x; };
    const size_t minParallel = 1 << 15;  // cells
    // Both passes go row by row, in parallel from minParallel cells.
    const size_t rowsMinParallel = cells < minParallel ? SIZE_MAX : 2;
    ForEachIndex(size_t(ny) * nz, rowsMinParallel, [&](size_t row) {
        const int y = int(row % ny), z = int(row / ny);
        int last = -K - 1;
        for (int x = 0; x < nx; ++x) {
            if (cells_[at(x, y, z)].count != 0) last = x;
            d[at(x, y, z)] = uint8_t(std::min(K, x - last));
        }
        last = nx + K;
        for (int x = nx - 1; x >= 0; --x) {
            if (cells_[at(x, y, z)].count != 0) last = x;
            d[at(x, y, z)] = uint8_t(std::min<int>(d[at(x, y, z)], std::min(K, last - x)));
        }
    });
    // min over |j| <= K of max(|j|, src(c + j·axis)), from src into dst along one axis.
    // Row by row (one division a row, not three a cell): a cell's neighbours along y are
    // nx apart, along z nx·ny.
    auto pass = [&](const std::vector<uint8_t>& src, std::vector<uint8_t>& dst, int axis) {
        const int n = axis == 1 ? ny : nz;
        const size_t stride = axis == 1 ? size_t(nx) : size_t(nx) * ny;
        ForEachIndex(size_t(ny) * nz, rowsMinParallel, [&](size_t row) {
            const int i = axis == 1 ? int(row % ny) : int(row / ny);
            const size_t rowStart = row * nx;
            for (int x = 0; x < nx; ++x) {
                const uint8_t* line = src.data() + (rowStart + x - size_t(i) * stride);
                auto value = [&](int j) { return int(line[size_t(j) * stride]); };
                dst[rowStart + x] = uint8_t(grid_detail::WindowMinOfMax(value, i, n, K));
            }
        });
    };
    pass(d, e, 1);
    pass(e, d, 2);
    emptyReach_ = std::move(d);
}

// The single walk's empty cubes, octant by octant (grid_detail::OctantEmptyCubes). The cap
// only shrinks a cube, so every in-grid cell of the cube of side octantReach_ is empty.
void NestedGridAccel::ComputeOctantReach() {
    const Node& top = nodes_[0];
    const size_t cells = size_t(top.res[0]) * top.res[1] * top.res[2];
    if (cells > kMaxOctantReachCells) return;
    octantReach_.resize(8 * cells);
    // On threads from a few thousand cells (the sub-grids of such a scene already woke them).
    ForEachIndex(8, cells < 4096 ? SIZE_MAX : 2, [&](size_t octant) {
        grid_detail::OctantEmptyCubes(
            top.res, int(octant), kMaxOctantReach, [&](size_t c) { c += top.firstCell; return (occupied_[c >> 6] >> (c & 63)) & 1; },
            octantReach_.data() + octant * cells);
    });
}

AccelFigures NestedGridAccel::Figures() const {
    const Stats& s = stats_;
    const double nonEmpty = double(std::max<size_t>(s.leafCells, 1));
    const double tris = double(std::max<size_t>(mesh_.triangles.size(), 1));
    return {
        {"grid resolution",
         StringPrintf("%d x %d x %d", s.resolution[0], s.resolution[1], s.resolution[2])},
        {"grid cells", StringPrintf("%zu top level, %zu in all", s.topCells, s.totalCells)},
        {"empty cells",
         StringPrintf("%zu (%.1f%%)", s.emptyCells,
                      100.0 * double(s.emptyCells) / double(std::max<size_t>(s.totalCells, 1)))},
        {"triangles per non-empty cell",
         StringPrintf("mean %.2f, max %zu", double(s.references) / nonEmpty, s.maxPerCell)},
        {"references per triangle", StringPrintf("%.2f", double(s.references) / tris)},
        {"sub-grids",
         StringPrintf("%zu, depth reached %d of %d", s.subGrids, s.depth, options_.gridMaxDepth)},
        {"grid bytes", StringPrintf("%zu (%.1f per triangle)", s.bytes, double(s.bytes) / tris)},
        {"grid build ms", StringPrintf("%.1f", s.buildMs)},
        {"grid triangle tests", StringPrintf("%d at a time (%s), %zu blocks of 8", simdWidth_, simdWidth_ == 8 ? "AVX2" : "SSE", blockCount_)},
    };
}

}  // namespace lm
