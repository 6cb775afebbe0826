// grid.cpp -- the nested uniform grid of the paper's section 2: build and 3D-DDA traversal.
#include "lightmesh/accel/grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <utility>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include "lightmesh/geometry/triangle.h"
#include "lightmesh/math/simd.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"

namespace lm {
namespace {

static_assert(sizeof(NestedGridAccel::Tri) == 9 * sizeof(float), "Tri must be 9 packed floats");
inline const float* Floats(const NestedGridAccel::Tri& t) { return &t.p0.x; }

bool IsFiniteTri(const NestedGridAccel::Tri& t) {
    return IsFinite(t.p0) && IsFinite(t.p1) && IsFinite(t.p2);
}

// ---- The leaf cells' triangle test, W triangles at a time ---------------------------
//
// A cell's triangles sit in blocks of 8 (TriBlock), coordinate by coordinate. The ray's
// watertight-frame edge functions (IntersectPrepared: translate by the origin, shear,
// three 2D cross products) are computed for a whole block with SIMD, with the very
// operations and order of the scalar test, so lane k holds exactly the scalar values. A
// lane is dropped only where the scalar test would return at its first rejection (signs
// both ways and none zero), which most tested triangles do; the few others, and every
// exact edge or vertex case, go through IntersectPrepared itself. So the answers, ties
// included, are brute force's bit for bit, and a triangle tested in several cells gets the
// same answer each time (no mailbox is needed: a repeat costs one SIMD lane).

// The ray's constants of the filter, broadcast to W lanes.
template <int W>
struct FilterRay {
    using VF = typename SimdVectors<W>::F;
    VF ox, oy, oz, sx, sy, sz, tMin, tMax;
    int kx, ky, kz;
    [[gnu::always_inline]] explicit FilterRay(const detail::PreparedRay& r) : kx(r.kx), ky(r.ky), kz(r.kz) {
        const VF zero = {};
        ox = zero + r.o[r.kx];
        oy = zero + r.o[r.ky];
        oz = zero + r.o[r.kz];
        sx = zero + r.sx;
        sy = zero + r.sy;
        sz = zero + r.sz;
        tMin = zero + r.tMin;
        tMax = zero + r.tMax;
    }
};

// Lanes h … h+W-1 of a block: all ones where IntersectPrepared may report a hit. A lane
// without an exactly zero edge function is decided here with the scalar test's own
// operations (edge signs, det, t and its range), so it is set exactly when that test hits;
// a lane with a zero edge function (the tie-breaks, in double) is always set.
template <int W>
[[gnu::always_inline]] inline void FilterLanes(const NestedGridAccel::TriBlock& block, int h, const FilterRay<W>& r,
                                               typename SimdVectors<W>::I* lanes) {
    using VF = typename SimdVectors<W>::F;
    using VI = typename SimdVectors<W>::I;
    const VF zero = {};
    auto at = [&](int row) -> const VF& { return *reinterpret_cast<const VF*>(&block.v[row][h]); };
    const int kx = r.kx, ky = r.ky, kz = r.kz;
    const VF aZ = at(kz) - r.oz, bZ = at(3 + kz) - r.oz, cZ = at(6 + kz) - r.oz;
    const VF ax = (at(kx) - r.ox) - r.sx * aZ, ay = (at(ky) - r.oy) - r.sy * aZ;
    const VF bx = (at(3 + kx) - r.ox) - r.sx * bZ, by = (at(3 + ky) - r.oy) - r.sy * bZ;
    const VF cx = (at(6 + kx) - r.ox) - r.sx * cZ, cy = (at(6 + ky) - r.oy) - r.sy * cZ;
    const VF cu = cx * by - cy * bx, cv = ax * cy - ay * cx, cw = bx * ay - by * ax;
    const VI neg = (cu < zero) | (cv < zero) | (cw < zero);
    const VI pos = (cu > zero) | (cv > zero) | (cw > zero);
    const VI zeroEdge = (cu == zero) | (cv == zero) | (cw == zero);
    // As IntersectPrepared without a zero edge: d0 = u + v + w, sign = d0 > 0 ? 1 : -1,
    // (u, v, w) ·= sign, det = u + v + w > 0, t = (u·az + v·bz + w·cz) / det in range.
    const VF d0 = cu + cv + cw;
    const VI positive = d0 > zero;
    const VF one = zero + 1.0f, minusOne = zero - 1.0f;
    const VF sign = reinterpret_cast<VF>((positive & reinterpret_cast<VI>(one)) | (~positive & reinterpret_cast<VI>(minusOne)));
    const VF u = cu * sign, v = cv * sign, w = cw * sign;
    const VF det = u + v + w;
    const VF az = r.sz * aZ, bz = r.sz * bZ, cz = r.sz * cZ;
    const VF t = (u * az + v * bz + w * cz) / det;
    const VI hit = ~(neg & pos) & (d0 != zero) & (det > zero) & (t > r.tMin) & (t < r.tMax);
    *lanes = zeroEdge | hit;
}

uint64_t FilterBlocks4(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray) {
    if (!ray.valid) return 0;
    const FilterRay<4> r(ray);
    uint64_t mask = 0;
    for (uint32_t b = 0; b < count; ++b)
        for (int h = 0; h < 8; h += 4) {
            SimdVectors<4>::I lanes;
            FilterLanes<4>(blocks[b], h, r, &lanes);
#if defined(__x86_64__) || defined(__i386__)
            const uint64_t bits = static_cast<uint32_t>(_mm_movemask_ps(reinterpret_cast<__m128>(lanes)));
#else
            uint64_t bits = 0;
            for (int k = 0; k < 4; ++k) bits |= uint64_t(lanes[k] != 0) << k;
#endif
            mask |= bits << (8 * b + h);
        }
    return mask;
}
#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("avx2"))) uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count,
                                                       const detail::PreparedRay& ray) {
    if (!ray.valid) return 0;
    const FilterRay<8> r(ray);
    uint64_t mask = 0;
    for (uint32_t b = 0; b < count; ++b) {
        SimdVectors<8>::I lanes;
        FilterLanes<8>(blocks[b], 0, r, &lanes);
        mask |= uint64_t(static_cast<uint32_t>(_mm256_movemask_ps(reinterpret_cast<__m256>(lanes)))) << (8 * b);
    }
    return mask;
}
bool HasAvx2() { return __builtin_cpu_supports("avx2"); }
#else
uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray) {
    return FilterBlocks4(blocks, count, ray);
}
bool HasAvx2() { return false; }
#endif

// One leaf cell as the walk hands it to a query: its lanes in the blocks, and the cell's
// exit along the ray.
struct CellSpan {
    const NestedGridAccel::TriBlock* blocks;  // all of them
    uint32_t first, count;                    // the cell's lanes: first … first + count - 1
    NestedGridAccel::BlockFilter filter;
    float tCellExit;
};

// Calls test(id, hit) for each triangle of the cell the ray hits (IntersectPrepared's
// answer on the block's copy of its vertices), in the cell's order, until test returns
// true (then returns true).
template <typename Test>
[[gnu::always_inline]] inline bool ForEachHit(const CellSpan& c, const detail::PreparedRay& ray, Test&& test) {
    // The blocks that hold the cell's lanes, up to 8 (64 lanes) per filter call; lanes of
    // the neighbouring cells that share the first and last block are masked off.
    const uint64_t begin = c.first, end = begin + c.count;
    for (uint64_t b0 = begin / 8; b0 * 8 < end; b0 += 8) {
        const uint64_t base = b0 * 8, stop = std::min(end, base + 64);
        const NestedGridAccel::TriBlock* blocks = c.blocks + b0;
        uint64_t mask = c.filter(blocks, static_cast<uint32_t>((stop - base + 7) / 8), ray);
        const uint64_t lo = begin > base ? begin - base : 0, hi = stop - base;
        mask &= (hi == 64 ? ~uint64_t(0) : (uint64_t(1) << hi) - 1) & ~((uint64_t(1) << lo) - 1);
        while (mask) {
            const uint32_t k = static_cast<uint32_t>(__builtin_ctzll(mask));
            mask &= mask - 1;
            const NestedGridAccel::TriBlock& block = blocks[k / 8];
            float v[9];
            for (int row = 0; row < 9; ++row) v[row] = block.v[row][k % 8];
            TriangleHit th;
            if (detail::IntersectPrepared(ray, v, &th) && test(block.id[k % 8], th)) return true;
        }
    }
    return false;
}

// The three kinds of query the one traversal serves. Cell() tests a leaf cell's triangles
// and returns true to stop the walk.
struct ClosestQuery {
    explicit ClosestQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    Hit best;
    bool found = false;

    bool Cell(const CellSpan& c) {
        ForEachHit(c, ray, [&](uint32_t id, const TriangleHit& th) {
            // ray.tMax is just above the best t, so equal-t hits arrive here too: brute
            // force keeps the lowest primitive id among them, and so do we.
            if (found && th.t == best.t && id > best.prim) return false;
            best = Hit{th.t, id, th.b1, th.b2};
            found = true;
            ray.tMax = NextFloatUp(th.t);
            return false;
        });
        // Every triangle that could be hit before the ray leaves this cell overlaps this
        // cell (or an earlier one), so a hit within the cell is final.
        return found && best.t <= c.tCellExit;
    }
};

struct AnyQuery {
    explicit AnyQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    bool found = false;

    bool Cell(const CellSpan& c) {
        found = ForEachHit(c, ray, [](uint32_t, const TriangleHit&) { return true; });
        return found;
    }
};

struct CountQuery {
    explicit CountQuery(const Ray& r) : ray(r) {}
    detail::PreparedRay ray;
    // The triangles hit so far: a triangle spanning cells is met in each of them and must
    // count once. Hits are few (crossings along one ray), so a linear search of a small
    // array is the cheapest exact set.
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
        ForEachHit(c, ray, [&](uint32_t id, const TriangleHit&) {
            if (Counted(id)) return false;
            if (count < kLocal)
                local[count] = id;
            else
                overflow.push_back(id);
            ++count;
            return false;
        });
        return false;
    }
};

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
        const TriangleBoxOverlap overlap(t.p0, t.p1, t.p2, h);
        for (int z = lo[2]; z <= hi[2]; ++z) {
            c[2] = node.lo[2] + (z + 0.5) * double(node.cellSize[2]);
            for (int y = lo[1]; y <= hi[1]; ++y) {
                c[1] = node.lo[1] + (y + 0.5) * double(node.cellSize[1]);
                for (int x = lo[0]; x <= hi[0]; ++x) {
                    c[0] = node.lo[0] + (x + 0.5) * double(node.cellSize[0]);
                    if (overlap.Overlaps(c)) emit(uint32_t((z * ny + y) * nx + x));
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
    if (mesh.triangles.size() >= kChildBit)
        ThrowError("the grid holds at most %u triangles, the scene has %zu", kChildBit - 1,
                   mesh.triangles.size());

    std::vector<Tri> tris(mesh.triangles.size());  // by primitive id, for the build only
    for (size_t i = 0; i < tris.size(); ++i)
        tris[i] = Tri{mesh.Vertex(uint32_t(i), 0), mesh.Vertex(uint32_t(i), 1),
                       mesh.Vertex(uint32_t(i), 2)};

    // The box of the triangles (not of stray vertices). Triangles with a non-finite vertex
    // are left out: they would make the box infinite, and IntersectTriangle never reports
    // them (every comparison with NaN fails).
    std::vector<uint32_t> ids;
    ids.reserve(tris.size());
    Bounds3 b;
    for (uint32_t i = 0; i < tris.size(); ++i) {
        if (!IsFiniteTri(tris[i])) continue;
        ids.push_back(i);
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

    epsAbs_ = 2e-7f * extent + 2.5e-7f * maxAbs;
    Builder builder{tris, options_, double(epsAbs_)};
    Builder::Level top;
    const auto res = AutoResolution(ids.size(), box_, options_.gridResolution);
    top.node = Builder::MakeNode(box_.lo, box_.hi, res);
    builder.Fill(top, ids.data(), ids.size(), true);

    // Flatten breadth-first: a node's index is its order in the queue, known when its
    // parent's cells are written. A leaf's triangles go into blocks of 8 at once.
    std::vector<Builder::Level*> queue{&top};
    stats_ = Stats{};
    stats_.resolution = res;
    stats_.topCells = size_t(res[0]) * res[1] * res[2];
    uint64_t laneCount = 0;  // the leaf cells' triangles one after another, 8 lanes per block
    for (size_t q = 0; q < queue.size(); ++q) {
        Builder::Level& level = *queue[q];
        Node node = level.node;
        node.firstCell = uint32_t(cells_.size());
        nodes_.push_back(node);
        stats_.depth = std::max(stats_.depth, level.depth);
        const size_t cells = level.start.size() - 1;
        size_t k = 0;  // next child, children are sorted by cell
        for (size_t c = 0; c < cells; ++c) {
            CellRef ref{0, 0};
            if (k < level.children.size() && level.children[k].first == c) {
                if (queue.size() >= kChildBit) ThrowError("the grid is too large (%zu sub-grids)", queue.size());
                ref.count = kChildBit | uint32_t(queue.size());
                queue.push_back(level.children[k].second.get());
                ++k;
            } else if (const uint32_t n = level.start[c + 1] - level.start[c]; n > 0) {
                ref = {uint32_t(laneCount), n};
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

    ComputeEmptyReach();

    // The blocks, node by node in parallel (each leaf cell writes its own lanes; the storage
    // is not cleared first, a pass over memory the size of the grid, so the last block's
    // unused lanes are cleared here).
    const uint64_t blockCount = (laneCount + 7) / 8;
    blockCount_ = blockCount;
    blocks_.reset(new TriBlock[blockCount]);
    if (blockCount) {
        TriBlock& last = blocks_[blockCount - 1];
        for (uint64_t lane = laneCount % 8; lane != 0 && lane < 8; ++lane) {
            for (int row = 0; row < 9; ++row) last.v[row][lane] = 0.0f;
            last.id[lane] = 0;
        }
    }
    ForEachIndex(queue.size(), blockCount > 4096 ? 2 : SIZE_MAX, [&](size_t q) {
        const Builder::Level& level = *queue[q];
        const size_t cells = level.start.size() - 1;
        for (size_t c = 0; c < cells; ++c) {
            const CellRef& ref = cells_[nodes_[q].firstCell + c];
            if (ref.count == 0 || (ref.count & kChildBit)) continue;
            for (uint32_t i = 0; i < ref.count; ++i) {
                const uint32_t id = level.prims[level.start[c] + i];
                const float* v = Floats(tris[id]);
                const uint64_t lane = uint64_t(ref.first) + i;
                TriBlock& block = blocks_[lane / 8];
                for (int row = 0; row < 9; ++row) block.v[row][lane % 8] = v[row];
                block.id[lane % 8] = id;
            }
        }
    });
    simdWidth_ = options_.gridSimdWidth == 4 || !HasAvx2() ? 4 : 8;
    filter_ = simdWidth_ == 8 ? FilterBlocks8 : FilterBlocks4;

    stats_.bytes = nodes_.size() * sizeof(Node) + cells_.size() * sizeof(CellRef) +
                   occupied_.size() * sizeof(uint64_t) + blockCount_ * sizeof(TriBlock) + emptyReach_.size();
    stats_.buildMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - startTime)
            .count();
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
    ForEachIndex(size_t(ny) * nz, cells < minParallel ? SIZE_MAX : 2, [&](size_t row) {
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
    auto pass = [&](const std::vector<uint8_t>& src, std::vector<uint8_t>& dst, int axis) {
        const int n = axis == 1 ? ny : nz;
        ForEachIndex(cells, minParallel, [&](size_t c) {
            const int x = int(c % nx), y = int(c / nx % ny), z = int(c / (size_t(nx) * ny));
            const int i = axis == 1 ? y : z;
            int best = K;
            for (int j = std::max(0, i - K); j <= std::min(n - 1, i + K) && best > 0; ++j) {
                const int v = src[axis == 1 ? at(x, j, z) : at(x, y, j)];
                best = std::min(best, std::max(std::abs(j - i), v));
            }
            dst[c] = uint8_t(best);
        });
    };
    pass(d, e, 1);
    pass(e, d, 2);
    emptyReach_ = std::move(d);
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

// ---------------------------------------------------------------------------------------
// Traversal: one 3D-DDA (Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray
// Tracing", 1987) for all three query kinds.

template <typename Query>
bool NestedGridAccel::Walk(uint32_t nodeIndex, const Ray& ray, const Vec3& invD, float tEnter, float tExit, Query& query) const {
    const Node& g = nodes_[nodeIndex];
    // The plane crossings are recomputed from the plane's index at every step rather than
    // accumulated (nextT += deltaT), so their error does not grow along a long ray.
    auto planeT = [&](int a, int k) { return (g.lo[a] + float(k) * g.cellSize[a] - ray.o[a]) * invD[a]; };
    // The cell of the ray's point at t along axis a, clamped: rounding may put the point a
    // hair outside. (A truncating conversion is floor for f >= 0; std::floor would be a
    // libm call.)
    auto cellAt = [&](int a, float t) {
        const float f = (ray.o[a] + ray.d[a] * t - g.lo[a]) * g.invCellSize[a];
        return !(f > 0) ? 0 : (f >= float(g.res[a]) ? g.res[a] - 1 : int(f));
    };
    const int sx = ray.d.x > 0 ? 1 : (ray.d.x < 0 ? -1 : 0), sy = ray.d.y > 0 ? 1 : (ray.d.y < 0 ? -1 : 0),
              sz = ray.d.z > 0 ? 1 : (ray.d.z < 0 ? -1 : 0);
    const int ox = sx > 0, oy = sy > 0, oz = sz > 0;  // the far plane of a cell
    const int stopX = sx > 0 ? g.res[0] : -1, stopY = sy > 0 ? g.res[1] : -1, stopZ = sz > 0 ? g.res[2] : -1;
    const uint32_t strideY = uint32_t(g.res[0]), strideZ = uint32_t(g.res[0] * g.res[1]);
    const uint32_t dx = uint32_t(sx), dy = uint32_t(sy) * strideY, dz = uint32_t(sz) * strideZ;
    // The loop state in scalars, so it stays in registers (indexing small arrays by the
    // axis of each step goes through memory and serialises the steps).
    int cx, cy, cz;
    float tx, ty, tz;
    uint32_t idx;
    auto enter = [&](float t) {
        cx = cellAt(0, t);
        cy = cellAt(1, t);
        cz = cellAt(2, t);
        tx = sx ? planeT(0, cx + ox) : Infinity;
        ty = sy ? planeT(1, cy + oy) : Infinity;
        tz = sz ? planeT(2, cz + oz) : Infinity;
        idx = g.firstCell + uint32_t(cx) + uint32_t(cy) * strideY + uint32_t(cz) * strideZ;
    };
    enter(tEnter);
    float tCell = tEnter;
    const uint64_t* occupied = occupied_.data();
    // Empty space (top level): an empty cell knows how far the empty cells around it reach.
    const uint8_t* empty = nodeIndex == 0 && !emptyReach_.empty() ? emptyReach_.data() : nullptr;
    for (;;) {
        const float tNext = std::min(tx, std::min(ty, tz));
        const float tCellExit = std::min(tNext, tExit);
        // Most cells are empty; their bit (a small array that stays in cache) spares the
        // load from the much larger cells_.
        if ((occupied[idx >> 6] >> (idx & 63)) & 1) {
            const CellRef ref = cells_[idx];
            if (ref.count & kChildBit) {
                if (Walk(ref.count & ~kChildBit, ray, invD, tCell, tCellExit, query)) return true;
            } else {
                const CellSpan span{blocks_.get(), ref.first, ref.count, filter_, tCellExit};
                if (query.Cell(span)) return true;
            }
        } else if (empty && empty[idx] > 1) {
            // Every cell within empty[idx] - 1 steps of this one on each axis is empty: go
            // to where the ray leaves that box and start there as at the entry. The cell of
            // that point is rounded like the entry's, which the cells' growth covers; t
            // only increases, so the walk ends.
            const int k = empty[idx] - 1;
            float tJump = tExit;
            if (sx) tJump = std::min(tJump, planeT(0, sx > 0 ? std::min(cx + k, g.res[0] - 1) + 1 : std::max(cx - k, 0)));
            if (sy) tJump = std::min(tJump, planeT(1, sy > 0 ? std::min(cy + k, g.res[1] - 1) + 1 : std::max(cy - k, 0)));
            if (sz) tJump = std::min(tJump, planeT(2, sz > 0 ? std::min(cz + k, g.res[2] - 1) + 1 : std::max(cz - k, 0)));
            if (tJump > tNext && tJump > tCell) {
                if (!(tJump < tExit)) return false;
                tCell = tJump;
                enter(tJump);
                continue;
            }
        }
        // Written so that a NaN (from a ray the caller built out of overflowed values)
        // ends the walk instead of stepping along an axis the ray does not move on.
        if (!(tNext < tExit)) return false;
        tCell = tNext;
        // Step across the nearest plane (at a tie, either: the other follows at once).
        if (tx == tNext) {
            cx += sx;
            if (cx == stopX) return false;
            idx += dx;
            tx = planeT(0, cx + ox);
        } else if (ty == tNext) {
            cy += sy;
            if (cy == stopY) return false;
            idx += dy;
            ty = planeT(1, cy + oy);
        } else {
            cz += sz;
            if (cz == stopZ) return false;
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
    Walk(0, ray, invD, t0, t1, query);
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
