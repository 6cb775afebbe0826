// grid_internal.h -- what the nested grid's build (grid_build.cpp) and its triangle filter
// (grid_filter.cpp) share; not part of the grid's interface.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "lightmesh/accel/grid.h"

namespace lm::grid_detail {

/// The leaf cells' triangle filters (NestedGridAccel::BlockFilter), 4 and 8 lanes at a time,
/// defined in grid_filter.cpp; the build picks one for the machine.
uint64_t FilterBlocks4(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                       float* t, uint64_t* ties, float* bary);
/// Without AVX2 (not x86) the 4-lane filter.
uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                       float* t, uint64_t* ties, float* bary);
/// The same writing the hits' barycentrics too (closest-hit queries).
uint64_t FilterBlocks4Bary(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                           float* t, uint64_t* ties, float* bary);
uint64_t FilterBlocks8Bary(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                           float* t, uint64_t* ties, float* bary);
/// The same stopping at the first block that holds a hit (occlusion queries).
uint64_t FilterBlocks4Any(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                          float* t, uint64_t* ties, float* bary);
uint64_t FilterBlocks8Any(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                          float* t, uint64_t* ties, float* bary);
/// Whether this CPU runs FilterBlocks8's AVX2 code.
bool HasAvx2();

/// The cells of `node` that triangle `t` overlaps, each grown by max(1e-4 of a cell, epsAbs)
/// on every side, appended to `out` as (cell index, id) pairs in x-fastest order: the cells
/// of the triangle's grown bounds that the separating-axis test accepts (up to its rounding:
/// the paths that skip some of its axes may list a cell more). Inside the node, a
/// single cell or a run along one axis needs no test, and a triangle within one cell's slab
/// gets the 2D test across the other two axes. A triangle reaching beyond the node (a
/// sub-grid's) is clamped to its border cells.
void RasterizeTriangle(const NestedGridAccel::Node& node, const NestedGridAccel::Tri& t, double epsAbs, uint32_t id,
                       std::vector<std::pair<uint32_t, uint32_t>>* out);

/// CellRef's content box of `cell` (x, y, z) of `node`, whose triangles' vertices span
/// [lo, hi], into ref->box: that box clipped to the cell, in kBoxSteps-ths of the cell rounded
/// outwards (computed in double; the queries grow the box by rounding's reach, which covers
/// the cell's corners computed in float there). A triangle that only touches the cell's
/// growth clips to the face it lies beyond, where a point of it a rounding error inside the
/// cell is.
void SetContentBox(const NestedGridAccel::Node& node, const int cell[3], const float lo[3], const float hi[3],
                   NestedGridAccel::CellRef* ref);

/// The content box of a cell holding the sub-grid `child`, whose cells (cells[child.firstCell
/// …]) have theirs: the union of the sub-cells' boxes, in the cell's steps rounded outwards.
/// (A sub-grid's cells tile the cell exactly but for the float rounding of its node, which
/// the queries' growth by rounding's reach covers. A sub-grid with no non-empty cell gets a
/// sliver on the high faces: its walk finds nothing anyway.)
void SetBoxFromSubGrid(const NestedGridAccel::Node& child, const NestedGridAccel::CellRef* cells,
                       NestedGridAccel::CellRef* ref);

/// The empty-space pass along one axis (NestedGridAccel::ComputeEmptyReach): the minimum over
/// 0 <= j < n with |j − i| <= k of max(|j − i|, value(j)), and at most k, for value(j) >= 0.
/// Searched outward from i: a cell at distance d gives at least d, so the search stops once
/// d reaches the best found, which is the whole window's minimum in a few steps near
/// geometry instead of 2k + 1.
template <typename Value>
int WindowMinOfMax(Value&& value, int i, int n, int k) {
    int best = std::min(k, value(i));
    for (int d = 1; d < best; ++d) {
        if (i - d >= 0) best = std::min(best, std::max(d, value(i - d)));
        if (i + d < n) best = std::min(best, std::max(d, value(i + d)));
    }
    return best;
}

/// The single walk's empty cubes for one octant (NestedGridAccel::ComputeOctantReach): for
/// every cell c of an n[0] × n[1] × n[2] grid (x fastest), into out[c], the side of the
/// largest cube of cells with c at its corner, reaching into `octant` (bit a set: towards
/// lower indices along axis a), whose cells inside the grid are all empty (nonEmpty(c)
/// false), at most `cap`; 0 for a non-empty cell. With g the octant's step along each axis,
/// R(c) = 1 + the least R of the seven cells c + g·(i, j, k), (i, j, k) in {0, 1}³ but
/// (0, 0, 0): their cubes of that side cover the cube of side R(c) at c but c itself (the
/// largest-square recurrence in 3D). A neighbour outside the grid counts as `cap`: the cube
/// may reach past the grid, where a ray has left it.
template <typename NonEmpty>
void OctantEmptyCubes(const int n[3], int octant, int cap, NonEmpty&& nonEmpty, uint8_t* out) {
    int g[3];
    for (int a = 0; a < 3; ++a) g[a] = (octant >> a) & 1 ? -1 : 1;
    const size_t nx = size_t(n[0]), ny = size_t(n[1]);
    const std::vector<uint8_t> outside(nx, uint8_t(cap));  // a row of neighbours outside the grid
    std::vector<uint8_t> across(nx), ahead(nx);
    auto first = [&](int a) { return g[a] > 0 ? n[a] - 1 : 0; };
    // Row by row in the order that has each cell's seven neighbours done first: the rows one
    // step along y, along z and along both (at x and x + g), then the cell's own row (x + g).
    for (int z = first(2), zi = 0; zi < n[2]; ++zi, z -= g[2])
        for (int y = first(1), yi = 0; yi < n[1]; ++yi, y -= g[1]) {
            const bool inY = unsigned(y + g[1]) < unsigned(n[1]), inZ = unsigned(z + g[2]) < unsigned(n[2]);
            const size_t start = nx * (size_t(y) + ny * size_t(z));
            uint8_t* row = out + start;
            const uint8_t* rowY = inY ? out + nx * (size_t(y + g[1]) + ny * size_t(z)) : outside.data();
            const uint8_t* rowZ = inZ ? out + nx * (size_t(y) + ny * size_t(z + g[2])) : outside.data();
            const uint8_t* rowYZ = inY && inZ ? out + nx * (size_t(y + g[1]) + ny * size_t(z + g[2])) : outside.data();
            // The other rows' six neighbours first (loops the compiler vectorises), then the
            // row's own chain along x.
            for (size_t x = 0; x < nx; ++x) across[x] = std::min({rowY[x], rowZ[x], rowYZ[x]});
            if (g[0] > 0) {
                for (size_t x = 0; x + 1 < nx; ++x) ahead[x] = std::min(across[x], across[x + 1]);
                ahead[nx - 1] = across[nx - 1];  // x + 1 is outside
            } else {
                for (size_t x = 1; x < nx; ++x) ahead[x] = std::min(across[x], across[x - 1]);
                ahead[0] = across[0];
            }
            int next = cap;  // the row's value at x + g (outside the grid: cap)
            for (int x = first(0), xi = 0; xi < n[0]; ++xi, x -= g[0]) {
                next = nonEmpty(start + size_t(x)) ? 0 : std::min(cap, 1 + std::min(next, int(ahead[x])));
                row[x] = uint8_t(next);
            }
        }
}

}  // namespace lm::grid_detail
