// grid.cpp -- the nested uniform grid of the paper's section 2: build and 3D-DDA traversal.
#include "lightmesh/accel/grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <utility>

#include "lightmesh/geometry/triangle.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"

namespace lm {
namespace {

constexpr uint32_t kChild = 0x80000000u;  // an item that names a sub-grid node, not a triangle

static_assert(sizeof(NestedGridAccel::Tri) == 9 * sizeof(float), "Tri must be 9 packed floats");
inline const float* Floats(const NestedGridAccel::Tri& t) { return &t.p0.x; }

bool IsFiniteTri(const NestedGridAccel::Tri& t) {
    return IsFinite(t.p0) && IsFinite(t.p1) && IsFinite(t.p2);
}

// A direct-mapped cache of the triangles this query already tested (mailboxing, Amanatides
// & Woo §4): a triangle spanning several cells is tested once, usually. It lives on the
// query's stack, so concurrent queries share nothing. An evicted id is merely tested again;
// correctness never depends on it (CountCrossings dedupes its hits exactly).
struct Mailbox {
    static constexpr uint32_t kSize = 16;
    uint32_t ids[kSize];
    Mailbox() { std::fill(ids, ids + kSize, UINT32_MAX); }
    bool Seen(uint32_t id) const { return ids[id & (kSize - 1)] == id; }
    void Mark(uint32_t id) { ids[id & (kSize - 1)] = id; }
};

// One leaf cell as the walk hands it to a query: its triangle ids, and where the part of
// the ray inside the cell, [tCell, tCellExit], lies along the ray's dominant axis kz,
// padded for rounding.
struct CellSpan {
    const uint32_t* begin;
    const uint32_t* end;
    const NestedGridAccel::Tri* tris;  // by id
    float lo, hi;                      // along kz
    float tCellExit;
};

// Whether triangle v may be hit within the span: a cheap rejection before the exact test.
// IntersectTriangle's t is a convex combination of the vertices' depths along the ray's
// dominant axis kz (its weights u, v, w are >= 0), so a hit point lies within the
// triangle's kz range, up to a few ulps the padding covers. (Sideways there is no such
// tight bound: a ray grazing a triangle can round its hit point away from the triangle's
// box.) A triangle that fails is not hit in this cell; if it is hit elsewhere it is tested
// in that cell, since a skipped triangle is not marked in the mailbox. It halves the tests
// of short segments and shadow rays, which pass by most triangles of the cells they cross.
inline bool MayHit(const float* v, int kz, float lo, float hi) {
    const float a = v[kz], b = v[3 + kz], c = v[6 + kz];
    return !(std::min(a, std::min(b, c)) > hi || std::max(a, std::max(b, c)) < lo);
}

// The three kinds of query the one traversal serves. Cell() tests a leaf cell's triangles
// and returns true to stop the walk.
struct ClosestQuery {
    explicit ClosestQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    Hit best;
    bool found = false;
    Mailbox mailbox;

    bool Cell(const CellSpan& c) {
        for (const uint32_t* p = c.begin; p != c.end; ++p) {
            const uint32_t id = *p;
            const float* v = Floats(c.tris[id]);
            if (mailbox.Seen(id) || !MayHit(v, ray.kz, c.lo, c.hi)) continue;
            mailbox.Mark(id);
            TriangleHit th;
            if (!detail::IntersectPrepared(ray, v, &th)) continue;
            // ray.tMax is just above the best t, so equal-t hits arrive here too: brute
            // force keeps the lowest primitive id among them, and so do we.
            if (found && th.t == best.t && id > best.prim) continue;
            best = Hit{th.t, id, th.b1, th.b2};
            found = true;
            ray.tMax = std::nextafter(th.t, Infinity);
        }
        // Every triangle that could be hit before the ray leaves this cell overlaps this
        // cell (or an earlier one), so a hit within the cell is final.
        return found && best.t <= c.tCellExit;
    }
};

struct AnyQuery {
    explicit AnyQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    bool found = false;
    Mailbox mailbox;

    bool Cell(const CellSpan& c) {
        for (const uint32_t* p = c.begin; p != c.end; ++p) {
            const uint32_t id = *p;
            const float* v = Floats(c.tris[id]);
            if (mailbox.Seen(id) || !MayHit(v, ray.kz, c.lo, c.hi)) continue;
            mailbox.Mark(id);
            TriangleHit th;
            if (detail::IntersectPrepared(ray, v, &th)) {
                found = true;
                return true;
            }
        }
        return false;
    }
};

struct CountQuery {
    explicit CountQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    Mailbox mailbox;
    // The triangles hit so far: a triangle spanning cells must count once even when the
    // mailbox has forgotten it. Hits are few (crossings along one ray), so a linear search
    // of a small array is the cheapest exact set.
    static constexpr int kLocal = 64;
    uint32_t local[kLocal];
    int count = 0;
    std::vector<uint32_t> overflow;

    bool Counted(uint32_t id) const {
        const int n = std::min(count, kLocal);
        for (int i = 0; i < n; ++i)
            if (local[i] == id) return true;
        return std::find(overflow.begin(), overflow.end(), id) != overflow.end();
    }
    bool Cell(const CellSpan& c) {
        for (const uint32_t* p = c.begin; p != c.end; ++p) {
            const uint32_t id = *p;
            const float* v = Floats(c.tris[id]);
            if (mailbox.Seen(id) || !MayHit(v, ray.kz, c.lo, c.hi)) continue;
            mailbox.Mark(id);
            TriangleHit th;
            if (!detail::IntersectPrepared(ray, v, &th) || Counted(id)) continue;
            if (count < kLocal)
                local[count] = id;
            else
                overflow.push_back(id);
            ++count;
        }
        return false;
    }
};

}  // namespace

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
struct NestedGridAccel::Builder {
    struct Level {
        Node node{};
        int depth = 1;
        std::vector<uint32_t> start;  // CSR over this level's cells
        std::vector<uint32_t> prims;
        std::vector<std::pair<uint32_t, std::unique_ptr<Level>>> children;  // by local cell
    };

    const std::vector<Tri>& tris;
    const AccelOptions& options;
    double epsAbs;  // the least a cell is grown by when assigning triangles

    // Which cells of `node` the triangle overlaps, each reported once through emit(cell).
    template <typename Emit>
    void Rasterize(const Node& node, const Tri& t, Emit&& emit) const {
        double eps[3];
        int lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            // Grow cells by a little: the DDA's plane crossings are computed in float, and
            // a hit point rounded into the neighbouring cell must still find its triangle
            // there. 1e-4 of a cell is far above float error at the scene's own scale.
            eps[a] = std::max(1e-4 * node.cellSize[a], epsAbs);
            const double bmin = std::min({t.p0[a], t.p1[a], t.p2[a]}) - eps[a];
            const double bmax = std::max({t.p0[a], t.p1[a], t.p2[a]}) + eps[a];
            const double inv = node.invCellSize[a];
            lo[a] = static_cast<int>(
                std::clamp(std::floor((bmin - node.lo[a]) * inv), 0.0, double(node.res[a] - 1)));
            hi[a] = static_cast<int>(
                std::clamp(std::floor((bmax - node.lo[a]) * inv), 0.0, double(node.res[a] - 1)));
        }
        const int nx = node.res[0], ny = node.res[1];
        if (lo[0] == hi[0] && lo[1] == hi[1] && lo[2] == hi[2]) {
            emit(uint32_t((lo[2] * ny + lo[1]) * nx + lo[0]));
            return;
        }
        double h[3], c[3];
        for (int a = 0; a < 3; ++a) h[a] = 0.5 * node.cellSize[a] + eps[a];
        for (int z = lo[2]; z <= hi[2]; ++z) {
            c[2] = node.lo[2] + (z + 0.5) * double(node.cellSize[2]);
            for (int y = lo[1]; y <= hi[1]; ++y) {
                c[1] = node.lo[1] + (y + 0.5) * double(node.cellSize[1]);
                for (int x = lo[0]; x <= hi[0]; ++x) {
                    c[0] = node.lo[0] + (x + 0.5) * double(node.cellSize[0]);
                    if (TriangleOverlapsBox(t.p0, t.p1, t.p2, c, h)) emit(uint32_t((z * ny + y) * nx + x));
                }
            }
        }
    }

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
                Rasterize(node, tris[id], [&](uint32_t cell) { out.emplace_back(cell, id); });
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
        for (uint32_t c = 0; c < cells; ++c)
            if (level.start[c + 1] - level.start[c] > threshold) crowded.push_back(c);
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
        if (parallel && crowded.size() > 1)
            ParallelFor(size_t(0), crowded.size(), sub);
        else
            for (size_t k = 0; k < crowded.size(); ++k) sub(k);
    }
};

NestedGridAccel::NestedGridAccel(const TriangleMesh& mesh, const AccelOptions& options)
    : mesh_(mesh), options_(options) {
    const auto startTime = std::chrono::steady_clock::now();
    if (mesh.triangles.size() >= kChild)
        ThrowError("the grid holds at most %u triangles, the scene has %zu", kChild - 1,
                   mesh.triangles.size());

    tris_.resize(mesh.triangles.size());
    for (size_t i = 0; i < tris_.size(); ++i)
        tris_[i] = Tri{mesh.Vertex(uint32_t(i), 0), mesh.Vertex(uint32_t(i), 1),
                       mesh.Vertex(uint32_t(i), 2)};

    // The box of the triangles (not of stray vertices). Triangles with a non-finite vertex
    // are left out: they would make the box infinite, and IntersectTriangle never reports
    // them (every comparison with NaN fails).
    std::vector<uint32_t> ids;
    ids.reserve(tris_.size());
    Bounds3 b;
    for (uint32_t i = 0; i < tris_.size(); ++i) {
        if (!IsFiniteTri(tris_[i])) continue;
        ids.push_back(i);
        b.Extend(tris_[i].p0);
        b.Extend(tris_[i].p1);
        b.Extend(tris_[i].p2);
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

    epsAbs_ = 2e-7f * extent + 2.5e-7f * maxAbs;
    boxMaxAbs_ = std::max(MaxComponent(Abs(box_.lo)), MaxComponent(Abs(box_.hi)));
    Builder builder{tris_, options_, double(epsAbs_)};
    Builder::Level top;
    const auto res = AutoResolution(ids.size(), box_, options_.gridResolution);
    top.node = Builder::MakeNode(box_.lo, box_.hi, res);
    builder.Fill(top, ids.data(), ids.size(), true);

    // Flatten breadth-first: a node's index is its order in the queue, known when its
    // parent's cells are written.
    std::vector<Builder::Level*> queue{&top};
    stats_ = Stats{};
    stats_.resolution = res;
    stats_.topCells = size_t(res[0]) * res[1] * res[2];
    cellStart_.push_back(0);
    for (size_t q = 0; q < queue.size(); ++q) {
        Builder::Level& level = *queue[q];
        Node node = level.node;
        node.firstCell = uint32_t(cellStart_.size() - 1);
        nodes_.push_back(node);
        stats_.depth = std::max(stats_.depth, level.depth);
        const size_t cells = level.start.size() - 1;
        size_t k = 0;  // next child, children are sorted by cell
        for (size_t c = 0; c < cells; ++c) {
            if (k < level.children.size() && level.children[k].first == c) {
                items_.push_back(kChild | uint32_t(queue.size()));
                queue.push_back(level.children[k].second.get());
                ++k;
            } else {
                const uint32_t n = level.start[c + 1] - level.start[c];
                items_.insert(items_.end(), level.prims.begin() + level.start[c],
                              level.prims.begin() + level.start[c + 1]);
                if (n == 0)
                    ++stats_.emptyCells;
                else {
                    ++stats_.leafCells;
                    stats_.references += n;
                    stats_.maxPerCell = std::max<size_t>(stats_.maxPerCell, n);
                }
            }
            cellStart_.push_back(uint32_t(items_.size()));
        }
        level.start = {};
        level.prims = {};
    }
    if (items_.size() >= kChild)
        ThrowError("the grid is too large (%zu references)", items_.size());
    stats_.totalCells = cellStart_.size() - 1;
    occupied_.assign((stats_.totalCells + 63) / 64, 0);
    for (size_t c = 0; c < stats_.totalCells; ++c)
        if (cellStart_[c + 1] != cellStart_[c]) occupied_[c >> 6] |= uint64_t(1) << (c & 63);
    stats_.subGrids = nodes_.size() - 1;
    nodes_.shrink_to_fit();
    cellStart_.shrink_to_fit();
    items_.shrink_to_fit();
    stats_.bytes = nodes_.size() * sizeof(Node) + cellStart_.size() * sizeof(uint32_t) +
                   items_.size() * sizeof(uint32_t) + tris_.size() * sizeof(Tri) +
                   occupied_.size() * sizeof(uint64_t);
    stats_.buildMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - startTime)
            .count();
}

NestedGridAccel::~NestedGridAccel() = default;

AccelFigures NestedGridAccel::Figures() const {
    const Stats& s = stats_;
    const double nonEmpty = double(std::max<size_t>(s.leafCells, 1));
    const double tris = double(std::max<size_t>(tris_.size(), 1));
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
    };
}

// ---------------------------------------------------------------------------------------
// Traversal: one 3D-DDA (Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray
// Tracing", 1987) for all three query kinds.

template <typename Query>
bool NestedGridAccel::Walk(uint32_t nodeIndex, const Ray& ray, const Vec3& invD, float pad,
                           float tEnter, float tExit, Query& query) const {
    const Node& g = nodes_[nodeIndex];
    int cell[3], step[3], stop[3];
    float nextT[3];
    const int stride[3] = {1, g.res[0], g.res[0] * g.res[1]};
    // The plane crossings are recomputed from the plane's index at every step rather than
    // accumulated (nextT += deltaT), so their error does not grow along a long ray.
    auto planeT = [&](int a, int k) {
        return (g.lo[a] + float(k) * g.cellSize[a] - ray.o[a]) * invD[a];
    };
    for (int a = 0; a < 3; ++a) {
        // The entry cell, clamped: rounding may put the entry point a hair outside. (A
        // truncating conversion is floor for f >= 0; std::floor would be a libm call.)
        const float p = ray.o[a] + ray.d[a] * tEnter;
        const float f = (p - g.lo[a]) * g.invCellSize[a];
        cell[a] = !(f > 0) ? 0 : (f >= float(g.res[a]) ? g.res[a] - 1 : int(f));
        if (ray.d[a] > 0) {
            step[a] = 1;
            stop[a] = g.res[a];
            nextT[a] = planeT(a, cell[a] + 1);
        } else if (ray.d[a] < 0) {
            step[a] = -1;
            stop[a] = -1;
            nextT[a] = planeT(a, cell[a]);
        } else {
            step[a] = 0;
            stop[a] = -1;
            nextT[a] = Infinity;
        }
    }
    uint32_t idx = g.firstCell + uint32_t(cell[0] + cell[1] * stride[1] + cell[2] * stride[2]);
    float tCell = tEnter;
    // The loop state in scalars, so it stays in registers (indexing small arrays by the
    // axis of each step goes through memory and serialises the steps).
    float tx = nextT[0], ty = nextT[1], tz = nextT[2];
    int cx = cell[0], cy = cell[1], cz = cell[2];
    const int ox = step[0] > 0, oy = step[1] > 0, oz = step[2] > 0;  // far plane of a cell
    const uint32_t dx = uint32_t(step[0]), dy = uint32_t(step[1] * stride[1]),
                   dz = uint32_t(step[2] * stride[2]);
    const uint64_t* occupied = occupied_.data();
    for (;;) {
        const float tNext = std::min(tx, std::min(ty, tz));
        const float tCellExit = std::min(tNext, tExit);
        // Most cells are empty; their bit (a small array that stays in cache) spares the
        // load from the much larger cellStart_.
        if ((occupied[idx >> 6] >> (idx & 63)) & 1) {
            const uint32_t b = cellStart_[idx], e = cellStart_[idx + 1];
            const uint32_t first = items_[b];
            if (first & kChild) {
                if (Walk(first & ~kChild, ray, invD, pad, tCell, tCellExit, query)) return true;
            } else {
                const int kz = query.ray.kz;
                const float z0 = ray.o[kz] + ray.d[kz] * tCell,
                            z1 = ray.o[kz] + ray.d[kz] * tCellExit;
                const CellSpan span{items_.data() + b,      items_.data() + e,      tris_.data(),
                                    std::min(z0, z1) - pad, std::max(z0, z1) + pad, tCellExit};
                if (query.Cell(span)) return true;
            }
        }
        // Written so that a NaN (from a ray the caller built out of overflowed values)
        // ends the walk instead of stepping along an axis the ray does not move on.
        if (!(tNext < tExit)) return false;
        tCell = tNext;
        // Step across the nearest plane (at a tie, either: the other follows at once).
        if (tx == tNext) {
            cx += step[0];
            if (cx == stop[0]) return false;
            idx += dx;
            tx = planeT(0, cx + ox);
        } else if (ty == tNext) {
            cy += step[1];
            if (cy == stop[1]) return false;
            idx += dy;
            ty = planeT(1, cy + oy);
        } else {
            cz += step[2];
            if (cz == stop[2]) return false;
            idx += dz;
            tz = planeT(2, cz + oz);
        }
    }
}

template <typename Query>
void NestedGridAccel::Traverse(const Ray& ray, Query& query) const {
    // Clip [tMin, tMax] to the box; a zero direction component cannot cross that axis'
    // slabs, so it only has to start between them (and 0 · ∞ never happens).
    float t0 = ray.tMin, t1 = ray.tMax;
    Vec3 invD;
    bool moves = false;
    for (int a = 0; a < 3; ++a) {
        const float d = ray.d[a];
        if (d == 0) {
            if (!(ray.o[a] >= box_.lo[a] && ray.o[a] <= box_.hi[a])) return;
            invD[a] = Infinity;
            continue;
        }
        moves = true;
        invD[a] = 1.0f / d;
        float tn = (box_.lo[a] - ray.o[a]) * invD[a];
        float tf = (box_.hi[a] - ray.o[a]) * invD[a];
        if (tn > tf) std::swap(tn, tf);
        t0 = std::max(t0, tn);
        t1 = std::min(t1, tf);
    }
    if (!moves || !(t0 <= t1)) return;
    // Rounding allowance of the span test (see MayHit): a few ulps of the coordinates in play.
    const float pad = 4e-6f * (MaxComponent(Abs(ray.o)) + boxMaxAbs_) + epsAbs_;
    Walk(0, ray, invD, pad, t0, t1, query);
}

bool NestedGridAccel::Intersect(const Ray& ray, Hit* hit) const {
    ClosestQuery q(ray);
    Traverse(ray, q);
    if (q.found) *hit = q.best;
    return q.found;
}

bool NestedGridAccel::Occluded(const Ray& ray) const {
    AnyQuery q(ray);
    Traverse(ray, q);
    return q.found;
}

int NestedGridAccel::CountCrossings(const Ray& ray) const {
    CountQuery q(ray);
    Traverse(ray, q);
    return q.count;
}

}  // namespace lm
