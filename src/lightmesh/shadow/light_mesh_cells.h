// light_mesh_cells.h -- cell summaries (ours, not in the paper; exact): the triangles binned by
// brick of cells, each cell's main plane, tolerance and reach list, and the per-side uniform
// bits.
// Part of LightMesh<Word>'s definition (light_mesh_impl.h): included once, by light_mesh.cpp,
// whose anonymous namespace it shares.
#pragma once

#include "lightmesh/shadow/light_mesh_impl.h"

namespace lm {
namespace {

// Every brick's candidate list: the triangles whose bounding box meets the box of all
// that its cells' summaries look at (their reach), in triangle order. Built once, in
// parallel, in two passes (count, fill).
// False, having stored nothing, when the lists would exceed BinBudget().
template <typename Word>
inline bool LightMesh<Word>::BinTrianglesByBrick(uint64_t bricksZ) {
    const LightMeshLattice& L = lattice_;
    const uint64_t nb[3] = {bricksX_, bricksY_, bricksZ};
    const float lo[3] = {static_cast<float>(minOffset_), static_cast<float>(minOffset_), static_cast<float>(minOffset_)};
    const float span = static_cast<float>(kBrick - 1 + maxOffset_);
    const float slack = reachMargin_ / L.h + 0.01f;
    // The bricks [b0, b1] per axis whose reach meets the triangle's box (none if b0 > b1).
    auto range = [&](const TrianglePlane& pl, int axis, int64_t* b0, int64_t* b1) {
        const float tlo = (pl.lo[axis] - L.origin[axis]) / L.h, thi = (pl.hi[axis] - L.origin[axis]) / L.h;
        // brick B covers nodes [kBrick·B + minOffset, kBrick·B + span] (± slack)
        const float f0 = std::ceil((tlo - span - slack) / kBrick), f1 = std::floor((thi - lo[axis] + slack) / kBrick);
        const float maxB = static_cast<float>(nb[axis] - 1);
        *b0 = static_cast<int64_t>(std::clamp(f0, 0.0f, maxB + 1));
        *b1 = static_cast<int64_t>(std::clamp(f1, -1.0f, maxB));
    };
    const uint64_t bricks = bricksX_ * bricksY_ * bricksZ;
    // The pairs first, without visiting them: a hostile file must not make this a hang.
    std::atomic<uint64_t> pairs{0};
    ParallelFor(size_t(0), planes_.size(), [&](size_t t) {
        uint64_t product = 1;
        for (int a = 0; a < 3; ++a) {
            int64_t b0, b1;
            range(planes_[t], a, &b0, &b1);
            product *= static_cast<uint64_t>(std::max<int64_t>(b1 - b0 + 1, 0));
        }
        pairs.fetch_add(product, std::memory_order_relaxed);
    });
    binPairs_ = pairs.load();
    if (binPairs_ > BinBudget()) return false;
    // Count and fill by contiguous runs of triangles, each with its own counts per brick:
    // no atomics (two threads incrementing one array's counters spend most of their
    // time trading its cache lines), and every list comes out in triangle order. Runs
    // are fewer for a lattice with many bricks, so their counts stay within about
    // 16 M entries.
    const uint64_t runs = std::clamp<uint64_t>((uint64_t(1) << 24) / std::max<uint64_t>(bricks, 1), 1,
                                               std::min<uint64_t>(16, std::max<size_t>(planes_.size() / 4096, 1)));
    const uint64_t perRun = (planes_.size() + runs - 1) / runs;
    // Run r's count in brick b, then its next slot there: at[r·bricks + b].
    std::vector<uint64_t, HugePageAllocator<uint64_t>> at(runs * bricks, 0);
    auto each = [&](size_t t, auto&& visit) {
        int64_t b0[3], b1[3];
        for (int a = 0; a < 3; ++a) range(planes_[t], a, &b0[a], &b1[a]);
        for (int64_t z = b0[2]; z <= b1[2]; ++z)
            for (int64_t y = b0[1]; y <= b1[1]; ++y)
                for (int64_t x = b0[0]; x <= b1[0]; ++x) visit((static_cast<uint64_t>(z) * bricksY_ + y) * bricksX_ + x);
    };
    auto forRuns = [&](auto&& body) {
        ParallelFor(uint64_t(0), runs, [&](uint64_t r) {
            uint64_t* mine = at.data() + r * bricks;
            const size_t end = std::min<size_t>(planes_.size(), (r + 1) * perRun);
            for (size_t t = r * perRun; t < end; ++t) body(t, mine);
        });
    };
    forRuns([&](size_t t, uint64_t* mine) { each(t, [&](uint64_t b) { ++mine[b]; }); });
    // Brick b's list holds run 0's triangles, then run 1's, …: each run's slots start
    // where the previous run's end.
    brickStart_.assign(bricks + 1, 0);
    uint64_t total = 0;
    for (uint64_t b = 0; b < bricks; ++b) {
        brickStart_[b] = total;
        for (uint64_t r = 0; r < runs; ++r) {
            const uint64_t n = at[r * bricks + b];
            at[r * bricks + b] = total;
            total += n;
        }
    }
    brickStart_[bricks] = total;
    brickTris_.resize(total);
    forRuns([&](size_t t, uint64_t* mine) {
        each(t, [&](uint64_t b) { brickTris_[mine[b]++] = static_cast<uint32_t>(t); });
    });
    return true;
}

// The summary of cell (ci, cj, ck): the stored one, or one computed into `scratch`.
template <typename Word>
inline auto LightMesh<Word>::Summary(int ci, int cj, int ck, CellSummary* scratch, SummaryBrick** brickOut,
                                     int* slotOut) const -> const CellSummary& {
    // Cells of the lattice have non-negative indices: unsigned, the divisions and
    // remainders by kBrick are shifts and masks (signed ones need sign fix-ups, about 1 %
    // of a render's instructions on the gazebo).
    const uint32_t ui = static_cast<uint32_t>(ci), uj = static_cast<uint32_t>(cj), uk = static_cast<uint32_t>(ck);
    const uint64_t brick = (static_cast<uint64_t>(uk / kBrick) * bricksY_ + uj / kBrick) * bricksX_ + ui / kBrick;
    SummaryBrick* b = bricks_[brick].load(std::memory_order_acquire);
    if (!b) b = AllocateBrick(brick);
    const int slot = static_cast<int>(((uk % kBrick) * kBrick + (uj % kBrick)) * kBrick + (ui % kBrick));
    *brickOut = b;
    *slotOut = slot;
    uint8_t state = b->state[slot].load(std::memory_order_acquire);
    if (state == 2) return b->cell[slot];
    *scratch = ComputeSummary(ci, cj, ck, *b);
    if (state == 0 && b->state[slot].compare_exchange_strong(state, 1, std::memory_order_acquire)) {
        b->cell[slot] = *scratch;
        b->state[slot].store(2, std::memory_order_release);
        summarized_.fetch_add(1, std::memory_order_relaxed);
        if (scratch->flags & (kClear0 | kClear1)) planarCells_.fetch_add(1, std::memory_order_relaxed);
    }
    return *scratch;
}

// Copies a reach list into the arena (chunks never move, so the pointer stays valid).
template <typename Word>
inline const uint32_t* LightMesh<Word>::StoreReach(std::span<const uint32_t> ids) const {
    if (ids.empty()) return nullptr;
    std::lock_guard<std::mutex> lock(brickMutex_);
    uint32_t* out = ReachSlots(ids.size());
    std::copy(ids.begin(), ids.end(), out);
    return out;
}

// n slots (at most kReachChunk) of the reach arena, for reach lists and bricks' near codes.
template <typename Word>
inline uint32_t* LightMesh<Word>::ReachSlots(size_t n) const {
    if (reachArena_.empty() || reachUsed_ + n > kReachChunk) {
        // Pages as used, huge ones (see AllocateBrick).
        reachArena_.emplace_back(static_cast<uint32_t*>(AllocateLarge(kReachChunk * sizeof(uint32_t))));
        reachUsed_ = 0;
    }
    uint32_t* out = reachArena_.back().get() + reachUsed_;
    reachUsed_ += n;
    reachBytes_ += n * sizeof(uint32_t);
    return out;
}

// The near codes of a brick's triangles (SummaryBrick::nearCodes): each of the 64 cells
// used to test every triangle of its brick's list (up to 16,384) against its reach box
// and its own box, loading each triangle's bounds: 5.7 % of a castle render's samples
// (perf, one thread, 1024×768), 2.8 % with the codes. The boxes' bounds along an axis
// depend on the cell's index along that axis only (Node, Bounds3 and ReachBox work
// coordinate by coordinate), so the same comparisons, made once per triangle and position
// (kernels::BrickAxisBits), decide every cell: a cell then tests three bits of a word.
template <typename Word>
inline void LightMesh<Word>::NearCodes(uint64_t brick, const uint32_t* near, uint32_t count, uint32_t* codes) const {
    const int64_t first[3] = {static_cast<int64_t>(brick % bricksX_) * kBrick,
                              static_cast<int64_t>((brick / bricksX_) % bricksY_) * kBrick,
                              static_cast<int64_t>(brick / (bricksX_ * bricksY_)) * kBrick};
    // The bounds along each axis of the cells at positions 0 … 3: those of cells (p, p, p).
    BrickAxes reach, cell;
    for (int p = 0; p < kBrick; ++p) {
        const int ci = static_cast<int>(first[0] + p), cj = static_cast<int>(first[1] + p),
                  ck = static_cast<int>(first[2] + p);
        const Bounds3 reachBox = ReachBox(ci, cj, ck), cellBox = CellBox(ci, cj, ck);
        for (int a = 0; a < 3; ++a) {
            reach.lo[a][p] = reachBox.lo[a], reach.hi[a][p] = reachBox.hi[a];
            cell.lo[a][p] = cellBox.lo[a], cell.hi[a][p] = cellBox.hi[a];
        }
    }
    static_assert(offsetof(TrianglePlane, hi) == offsetof(TrianglePlane, lo) + sizeof(Vec3) &&
                      sizeof(TrianglePlane) % sizeof(float) == 0,
                  "NearCodesFunction reads a plane's box as six floats");
    nearCodes_(reach, cell, &planes_[0].lo.x, sizeof(TrianglePlane) / sizeof(float), near, count, codes);
}

template <typename Word>
inline auto LightMesh<Word>::AllocateBrick(uint64_t brick) const -> SummaryBrick* {
    SummaryBrick* fresh = nullptr;
    {
        // From chunks of kBricksPerChunk (on huge pages: a brick is 3.5 KiB, and a first
        // touch of each fresh 4 KiB page would cost a page fault). A brick that loses the
        // race below stays unused in its chunk.
        std::lock_guard<std::mutex> lock(brickMutex_);
        if (brickChunks_.empty() || brickChunkUsed_ == kBricksPerChunk) {
            brickChunks_.emplace_back(static_cast<SummaryBrick*>(AllocateLarge(kBricksPerChunk * sizeof(SummaryBrick))));
            brickChunkUsed_ = 0;
        }
        fresh = new (brickChunks_.back().get() + brickChunkUsed_++) SummaryBrick();
    }
    for (auto& st : fresh->state) st.store(0, std::memory_order_relaxed);
    for (auto& st : fresh->sideState) st[0].store(0, std::memory_order_relaxed), st[1].store(0, std::memory_order_relaxed);
    const uint64_t begin = brickStart_[brick], end = brickStart_[brick + 1];
    fresh->nearCount = end - begin > kMaxBrickNear ? kTooMany : static_cast<uint32_t>(end - begin);
    fresh->near = brickTris_.data() + begin;
    if (fresh->nearCount != kTooMany && fresh->nearCount > 0) {
        uint32_t* codes;
        {
            std::lock_guard<std::mutex> lock(brickMutex_);
            codes = ReachSlots(fresh->nearCount);
        }
        NearCodes(brick, fresh->near, fresh->nearCount, codes);
        fresh->nearCodes = codes;
    }
    SummaryBrick* expected = nullptr;
    if (bricks_[brick].compare_exchange_strong(expected, fresh, std::memory_order_acq_rel)) {
        bricksUsed_.fetch_add(1, std::memory_order_relaxed);
        return fresh;
    }
    return expected;  // another thread's brick
}

template <typename Word>
inline auto LightMesh<Word>::ComputeSummary(int ci, int cj, int ck, const SummaryBrick& brick) const -> CellSummary {
    CellSummary c;
    c.delta = planeDelta_;
    const TriangleMesh& mesh = scene_.mesh;
    const Bounds3 reachBox = ReachBox(ci, cj, ck);
    // Too crowded a brick (dense foliage): no summary; such points walk and trace.
    if (brick.nearCount == kTooMany) {
        c.reachCount = kTooMany;
        return c;
    }
    // From the brick's candidates: the reach (bounding boxes meeting the reach box) and
    // the triangles meeting the cell (CellBox; bounding boxes too: they only choose Π),
    // by the near codes' bits of the cell's position in its brick.
    const uint32_t inReach = CellBits(ci % kBrick, cj % kBrick, ck % kBrick);
    const uint32_t inCell = inReach << 12;
    // The cell's tolerance: every coordinate its tests compute with lies in the reach box
    // (nodes, points, origins) or is a vertex of a reach triangle (planes, patches).
    float magnitude = std::max(MaxComponent(Abs(reachBox.lo)), MaxComponent(Abs(reachBox.hi)));
    // The reach and the cell's own triangles (those in reach that meet the cell) from the
    // near codes (kernels::FilterNear), into buffers kept per thread and never cleared:
    // zero-filling vectors of a foliage brick's list length (up to kMaxBrickNear) cost as
    // much as the filter itself.
    thread_local std::unique_ptr<uint32_t[]> reachBuffer, trisBuffer;
    thread_local uint32_t bufferRoom = 0;
    if (bufferRoom < brick.nearCount + kFilterSlack) {
        bufferRoom = std::max(brick.nearCount + kFilterSlack, 2 * bufferRoom);
        reachBuffer.reset(new uint32_t[bufferRoom]);
        trisBuffer.reset(new uint32_t[bufferRoom]);
    }
    const uint64_t counts =
        filterNear_(brick.near, brick.nearCodes, brick.nearCount, inReach, inCell, reachBuffer.get(), trisBuffer.get());
    const std::span<const uint32_t> reach(reachBuffer.get(), counts & 0xffffffffu);
    const std::span<const uint32_t> tris(trisBuffer.get(), counts >> 32);
    for (const uint32_t t : reach) magnitude = std::max(magnitude, magnitudes_[t]);
    c.delta = std::min(planeDelta_, PlaneDelta(magnitude));
    if (variant_.local == LocalVisibility::Consensus) {
        if (reach.size() > kMaxReach) {
            c.reachCount = kTooMany;
        } else {
            c.reachCount = static_cast<uint32_t>(reach.size());
            c.reach = StoreReach(reach);
        }
    }
    // Π: the largest triangle meeting the cell (grown by the reach margin); a tie goes to
    // the lower id, so the choice does not depend on the lists' order.
    double best = 0, n[3] = {0, 0, 0};
    uint32_t plane = UINT32_MAX;
    for (const uint32_t t : tris) {
        double m[3];
        const double area = UnitNormal(mesh, t, m);
        if (area > best || (area == best && area > 0 && t < plane)) {
            best = area;
            plane = t;
            for (int a = 0; a < 3; ++a) n[a] = m[a];
        }
    }
    if (plane == UINT32_MAX) return c;
    const Vec3& v0 = mesh.Vertex(plane, 0);
    c.n[0] = static_cast<float>(n[0]);
    c.n[1] = static_cast<float>(n[1]);
    c.n[2] = static_cast<float>(n[2]);
    // Heights are measured with the stored (float) normal, as the points are tested.
    const double nf[3] = {c.n[0], c.n[1], c.n[2]};
    c.d = nf[0] * v0.x + nf[1] * v0.y + nf[2] * v0.z;
    c.flags = kHasPlane;

    if (variant_.local == LocalVisibility::Consensus) {
        // clear_s: the extreme heights of the vertices of the triangles in reach (of all
        // whose bounding box is in reach: more triangles can only make it stricter).
        // In float from a vertex of Π: v - v0 is short and exact to half an ulp of the
        // coordinates, so the error stays below the delta / 2 compared with.
        // A triangle wholly beyond the slab that the segments of points on Π stay in
        // (planeSlab_, as in Side) cannot block one of them, so it does not make its side
        // unclear (a table top above a floor cell, a ceiling).
        const Vec3 np(c.n[0], c.n[1], c.n[2]);
        const float limit = 0.5f * c.delta;
        const float slab = planeSlab_;
        bool up = false, down = false;  // a vertex above Π (side 0), below (side 1)
        for (size_t i = 0; i < reach.size() && !(up && down); ++i) {
            float hv[3];
            for (int k = 0; k < 3; ++k) hv[k] = Dot(np, mesh.Vertex(reach[i], k) - v0);
            const bool aboveSlab = hv[0] > slab && hv[1] > slab && hv[2] > slab;
            const bool belowSlab = hv[0] < -slab && hv[1] < -slab && hv[2] < -slab;
            for (int k = 0; k < 3; ++k) {
                up |= hv[k] > limit && !aboveSlab;
                down |= hv[k] < -limit && !belowSlab;
            }
        }
        if (!up) c.flags |= kClear0;
        if (!down) c.flags |= kClear1;
    }
    return c;
}

// uniform_s of the cell's plane, for one side, light by light: computed the first time
// a point on that side asks (so only the nodes on the side that is seen are evaluated,
// as a walk would), and stored in the brick like the summary itself.
template <typename Word>
inline auto LightMesh<Word>::Side(const CellSummary& c, SummaryBrick* brick, int slot, int side, int ci, int cj,
                                  int ck) const -> SideSummary {
    if (brick) {
        if (brick->sideState[slot][side].load(std::memory_order_acquire) == 2) return brick->side[slot][side];
    }
    const LightMeshLattice& L = lattice_;
    const int64_t base = static_cast<int64_t>(L.Index(ci, cj, ck));
    // The nodes on the side, off Π (hx of its node position, LightMeshLattice::Node, in
    // double), and only in the slab of Π that points on Π can reach (planeSlab_: a point
    // uses nodes within r of its snapped sub-position, so within pointReach_ of itself,
    // and it lies within 2·planeDelta_ of Π, TemplateWalk's test); hx's rounding is far
    // below the rest of the margin. The nodes of the cell's cube beyond it (a third of a
    // side's nodes over a floor at kI 2) are neither evaluated nor compared.
    const SideQuery q{{ci, cj, ck}, {L.origin.x, L.origin.y, L.origin.z}, L.h, {c.n[0], c.n[1], c.n[2]}, c.d,
                      planeSlab_, side};
    Scratch<uint32_t, 1024> keptScratch(cellNodes_.size());
    uint32_t* kept = keptScratch.data();
    const uint32_t count =
        sideNodes_(cellOx_.data(), cellOy_.data(), cellOz_.data(), static_cast<uint32_t>(cellNodes_.size()), q, kept);
    Word all = kVisMask, any = 0;
    for (uint32_t i = 0; i < count; ++i) {
        const Word w = Evaluate(static_cast<uint64_t>(base + cellNodes_[kept[i]])) & kVisMask;
        all &= w;
        any |= w;
    }
    SideSummary r{all, static_cast<Word>(~(all ^ any) & kVisMask)};
    if (brick) {
        uint8_t expected = 0;
        if (brick->sideState[slot][side].compare_exchange_strong(expected, 1, std::memory_order_acquire)) {
            brick->side[slot][side] = r;
            brick->sideState[slot][side].store(2, std::memory_order_release);
            if (r.uniform == kVisMask) uniformCells_.fetch_add(1, std::memory_order_relaxed);
        }
    }
    return r;
}

// Unit normal of triangle t in double into n; returns twice its area (0 if degenerate).
template <typename Word>
inline double LightMesh<Word>::UnitNormal(const TriangleMesh& mesh, uint32_t t, double n[3]) {
    const Vec3 &a = mesh.Vertex(t, 0), &b = mesh.Vertex(t, 1), &c = mesh.Vertex(t, 2);
    const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
    const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0) || !std::isfinite(len)) return 0;
    for (int k = 0; k < 3; ++k) n[k] /= len;
    return len;
}

template <typename Word>
inline uint64_t LightMesh<Word>::SummaryBytes() const {
    std::lock_guard<std::mutex> lock(brickMutex_);
    return bricksUsed_.load() * sizeof(SummaryBrick) + reachBytes_ + planes_.size() * sizeof(TrianglePlane) +
           magnitudes_.size() * sizeof(float) +
           brickTris_.size() * sizeof(uint32_t) + brickStart_.size() * sizeof(uint64_t) +
           bricksX_ * bricksY_ * sizeof(void*) * ((lattice_.nz + kBrick - 1) / kBrick);
}

}  // namespace
}  // namespace lm
