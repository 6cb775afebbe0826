// grid_test.cpp -- the nested grid's own rules: resolution, nesting, figures, DDA limits.
#include "lightmesh/accel/grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "lightmesh/accel/grid_internal.h"

#include "lightmesh/accel/brute_force.h"
#include "lightmesh/geometry/triangle.h"
#include "support/accel_scenes.h"
#include "lightmesh/geometry/triangle.h"

namespace lm {
namespace grid_test {
namespace {

namespace ts = testing_scenes;

std::string FigureValue(const AccelFigures& figures, const std::string& key) {
    for (const auto& [k, v] : figures)
        if (k == key) return v;
    return "<missing " + key + ">";
}

TEST(GridResolution, AutoHeuristicBounds) {
    const Bounds3 cube(Vec3(0), Vec3(1));
    // A cube gets ≈ ∛(λN) cells per side.
    for (size_t n : {size_t(1), size_t(100), size_t(10000), size_t(1000000)}) {
        const auto r = NestedGridAccel::AutoResolution(n, cube);
        const double expected =
            std::min<double>(std::cbrt(NestedGridAccel::kCellsPerTriangle * double(n)),
                             NestedGridAccel::kMaxAutoResolution);
        for (int a = 0; a < 3; ++a) {
            EXPECT_GE(r[a], 1);
            EXPECT_LE(r[a], NestedGridAccel::kMaxResolution);
            EXPECT_NEAR(r[a], std::max(1.0, expected), 1.0) << n;
        }
    }
    // Cells stay cubic: an 8:2:1 box gets resolutions in about that ratio, and about λN cells.
    const Bounds3 slab(Vec3(0), Vec3(8, 2, 1));
    const auto r = NestedGridAccel::AutoResolution(1000, slab);
    EXPECT_NEAR(double(r[0]) / r[1], 4.0, 0.3);
    EXPECT_NEAR(double(r[0]) / r[2], 8.0, 0.8);
    const double cells = double(r[0]) * r[1] * r[2];
    EXPECT_GT(cells, 0.6 * NestedGridAccel::kCellsPerTriangle * 1000);
    EXPECT_LT(cells, 1.6 * NestedGridAccel::kCellsPerTriangle * 1000);
    // A nearly flat box: one cell across, a 2D grid of ≈ λN cells over the rest.
    const Bounds3 flat(Vec3(0), Vec3(10, 10, 1e-3f));
    const auto f = NestedGridAccel::AutoResolution(500, flat);
    EXPECT_EQ(f[2], 1);
    EXPECT_NEAR(double(f[0]) * f[1], NestedGridAccel::kCellsPerTriangle * 500, 0.1 * 1000);
    // Never beyond the caps, even for absurd counts or resolutions.
    const auto big = NestedGridAccel::AutoResolution(size_t(1) << 40, cube);
    EXPECT_EQ(big[0], NestedGridAccel::kMaxAutoResolution);
    EXPECT_EQ(NestedGridAccel::AutoResolution(10, cube, 100000)[0],
              NestedGridAccel::kMaxResolution);
    // The auto cap keeps the cells cubic: a 4:1:1 box with many triangles gets 48 x 12 x 12.
    const auto capped = NestedGridAccel::AutoResolution(10000000, Bounds3(Vec3(0), Vec3(4, 1, 1)));
    EXPECT_EQ(capped[0], NestedGridAccel::kMaxAutoResolution);
    EXPECT_EQ(capped[1], NestedGridAccel::kMaxAutoResolution / 4);
}

// The empty-space pass's outward search gives the minimum over the whole window, which the
// build computed before by scanning all 2k + 1 cells.
TEST(GridEmptySpace, OutwardSearchEqualsTheWholeWindow) {
    std::mt19937 rng(7);
    int checked = 0, belowK = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        const int n = 1 + static_cast<int>(rng() % 40), k = 1 + static_cast<int>(rng() % 10);
        std::vector<int> v(n);
        for (int& x : v) x = static_cast<int>(rng() % (k + 2));  // values up to k + 1
        for (int i = 0; i < n; ++i) {
            int whole = k;
            for (int j = std::max(0, i - k); j <= std::min(n - 1, i + k); ++j)
                whole = std::min(whole, std::max(std::abs(j - i), v[j]));
            const int outward = grid_detail::WindowMinOfMax([&](int j) { return v[j]; }, i, n, k);
            ASSERT_EQ(outward, whole) << "n " << n << " k " << k << " i " << i;
            ++checked;
            belowK += whole < k;
        }
    }
    EXPECT_GT(belowK, checked / 4);  // the cases where the search stops early are many
}

// The single walk's empty cubes (OctantEmptyCubes), against counting: in every octant, a
// cell's cube of side R has no non-empty cell inside the grid, and (unless R is the cap)
// the cube of side R + 1 has one, on grids with axes of one cell and at two densities.
TEST(GridEmptySpace, OctantCubesAreTheLargestEmptyOnes) {
    std::mt19937 rng(11);
    const int sizes[][3] = {{1, 1, 1}, {7, 1, 5}, {1, 9, 1}, {6, 4, 3}, {9, 9, 9}, {12, 3, 10}};
    int checked = 0, interior = 0;
    for (const auto& n : sizes)
        for (const int percent : {3, 30})
            for (const int cap : {2, 255}) {
                const size_t cells = size_t(n[0]) * n[1] * n[2];
                std::vector<uint8_t> full(cells);
                for (uint8_t& f : full) f = rng() % 100 < unsigned(percent);
                auto nonEmptyAt = [&](int x, int y, int z) {
                    return x >= 0 && y >= 0 && z >= 0 && x < n[0] && y < n[1] && z < n[2] &&
                           full[size_t(x) + size_t(n[0]) * (size_t(y) + size_t(n[1]) * size_t(z))];
                };
                for (int octant = 0; octant < 8; ++octant) {
                    std::vector<uint8_t> side(cells, 77);
                    grid_detail::OctantEmptyCubes(n, octant, cap, [&](size_t c) { return full[c] != 0; }, side.data());
                    const int gx = octant & 1 ? -1 : 1, gy = octant & 2 ? -1 : 1, gz = octant & 4 ? -1 : 1;
                    // Whether the cube of side r at (x, y, z) holds a non-empty cell in the grid.
                    auto holds = [&](int x, int y, int z, int r) {
                        for (int k = 0; k < r; ++k)
                            for (int j = 0; j < r; ++j)
                                for (int i = 0; i < r; ++i)
                                    if (nonEmptyAt(x + gx * i, y + gy * j, z + gz * k)) return true;
                        return false;
                    };
                    for (int z = 0; z < n[2]; ++z)
                        for (int y = 0; y < n[1]; ++y)
                            for (int x = 0; x < n[0]; ++x) {
                                const int r = side[size_t(x) + size_t(n[0]) * (size_t(y) + size_t(n[1]) * size_t(z))];
                                SCOPED_TRACE(::testing::Message() << n[0] << "x" << n[1] << "x" << n[2] << " octant "
                                                                << octant << " cap " << cap << " cell " << x << ","
                                                                << y << "," << z);
                                ASSERT_LE(r, cap);
                                ASSERT_EQ(r == 0, nonEmptyAt(x, y, z));
                                // Past the grid's extent every larger cube holds the same cells.
                                const int span = std::max({n[0], n[1], n[2]}) + 1;
                                ASSERT_FALSE(holds(x, y, z, std::min(r, span)));
                                if (r > 0 && r < cap) {
                                    ASSERT_TRUE(holds(x, y, z, r + 1));
                                }
                                ++checked;
                                interior += r > 1 && r < cap;
                            }
                }
            }
    EXPECT_GT(interior, checked / 20);  // cubes larger than one cell and below the cap
}

// A cell's content box (CellRef) holds every triangle's bounds clipped to the cell, rounded
// outwards by less than a step: a triangle on a face, one only in the cell's growth beyond
// a face, one across the whole cell, and random ones.
TEST(GridContentBox, HoldsTheClippedBoundsWithinAStep) {
    NestedGridAccel::Node node{};
    node.lo = Vec3(-3.0f, 0.5f, 10.0f);
    node.cellSize = Vec3(0.25f, 1.0f / 3.0f, 2.0f);
    for (int a = 0; a < 3; ++a) node.invCellSize[a] = 1.0f / node.cellSize[a];
    node.res[0] = node.res[1] = node.res[2] = 8;
    const int cell[3] = {2, 5, 1};
    double cellLo[3], cellHi[3];
    for (int a = 0; a < 3; ++a) {
        cellLo[a] = double(node.lo[a]) + cell[a] * double(node.cellSize[a]);
        cellHi[a] = cellLo[a] + node.cellSize[a];
    }
    auto at = [&](double fx, double fy, double fz) {  // a point by its fraction of the cell
        const double f[3] = {fx, fy, fz};
        Vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = float(cellLo[a] + f[a] * node.cellSize[a]);
        return p;
    };
    std::vector<NestedGridAccel::Tri> tris = {
        {at(0, 0.2, 0.3), at(0, 0.7, 0.3), at(0, 0.2, 0.9)},                 // on the low x face
        {at(1.00001, 0.4, 0.4), at(1.00001, 0.5, 0.4), at(1.00001, 0.4, 0.5)},  // in the growth above x
        {at(-2, -2, 0.5), at(3, -2, 0.5), at(-2, 3, 0.5)},                    // across the cell
    };
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-0.5, 1.5);
    for (int i = 0; i < 200; ++i) tris.push_back({at(u(rng), u(rng), u(rng)), at(u(rng), u(rng), u(rng)), at(u(rng), u(rng), u(rng))});
    // The build's call: the box of the triangles' vertices.
    auto SetBox = [&](const uint32_t* ids, uint32_t n, NestedGridAccel::CellRef* ref) {
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t i = 0; i < n; ++i)
            for (const Vec3& p : {tris[ids[i]].p0, tris[ids[i]].p1, tris[ids[i]].p2})
                for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
        grid_detail::SetContentBox(node, cell, lo, hi, ref);
    };
    constexpr double kSteps = NestedGridAccel::kBoxSteps;
    int tight = 0;
    for (uint32_t first = 0; first < tris.size(); ++first) {
        // A cell's triangles: one, or a run of a few.
        const uint32_t n = std::min<uint32_t>(first < 3 ? 1 : 1 + first % 4, uint32_t(tris.size()) - first);
        std::vector<uint32_t> ids(n);
        for (uint32_t i = 0; i < n; ++i) ids[i] = first + i;
        NestedGridAccel::CellRef ref{};
        SetBox(ids.data(), n, &ref);
        for (int a = 0; a < 3; ++a) {
            double lo = INFINITY, hi = -INFINITY;
            for (uint32_t id : ids)
                for (const Vec3& p : {tris[id].p0, tris[id].p1, tris[id].p2}) lo = std::min(lo, double(p[a])), hi = std::max(hi, double(p[a]));
            // The bounds clipped to the cell (a triangle beyond a face clips to that face).
            const double clo = std::clamp(lo, cellLo[a], cellHi[a]), chi = std::clamp(hi, cellLo[a], cellHi[a]);
            const double step = node.cellSize[a] / kSteps;
            const double boxLo = cellLo[a] + ref.box[a] * step, boxHi = cellLo[a] + ref.box[4 + a] * step;
            ASSERT_LE(ref.box[a], ref.box[4 + a]) << "triangles " << first << "+" << n << " axis " << a;
            ASSERT_LE(ref.box[4 + a], NestedGridAccel::kBoxSteps);
            EXPECT_LE(boxLo, clo) << "triangles " << first << "+" << n << " axis " << a;
            EXPECT_GE(boxHi, chi) << "triangles " << first << "+" << n << " axis " << a;
            EXPECT_LT(clo - boxLo, 1.01 * step) << "triangles " << first << "+" << n << " axis " << a;
            EXPECT_LT(boxHi - chi, 1.01 * step) << "triangles " << first << "+" << n << " axis " << a;
            tight += ref.box[4 + a] - ref.box[a] < kSteps / 2;
        }
        EXPECT_EQ(ref.box[3], 0);
        EXPECT_EQ(ref.box[7], 0);
    }
    // The first triangle is a sliver of box on the low x face, the second one on the high x face.
    NestedGridAccel::CellRef face{};
    const uint32_t one = 0, two = 1;
    SetBox(&one, 1, &face);
    EXPECT_EQ(face.box[0], 0);
    EXPECT_LE(face.box[4], 1);
    SetBox(&two, 1, &face);
    EXPECT_EQ(face.box[4], NestedGridAccel::kBoxSteps);
    EXPECT_GE(face.box[0], NestedGridAccel::kBoxSteps - 1);
    EXPECT_GT(tight, 20);  // the check saw boxes much smaller than the cell
}

// The build's rasterization lists a triangle in exactly the cells whose grown box the
// separating-axis test accepts, whichever path it takes (one cell, a run along one axis, the
// 2D test inside one slab, the full test per cell), and never fewer when the triangle
// reaches beyond the node (a sub-grid's).
TEST(GridRasterize, ListsTheCellsTheOverlapTestAccepts) {
    std::mt19937 rng(23);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::uniform_int_distribution<int> resolution(1, 9);
    int runs = 0, planar = 0, solid = 0, beyond = 0;
    for (int trial = 0; trial < 8000; ++trial) {
        NestedGridAccel::Node node{};
        node.lo = Vec3(float(-2 + 4 * u(rng)), float(-2 + 4 * u(rng)), float(-2 + 4 * u(rng)));
        for (int a = 0; a < 3; ++a) {
            node.res[a] = resolution(rng);
            // As the build's nodes get them: the extent over the cells and back.
            const float extent = float((0.1 + u(rng)) * node.res[a]);
            node.cellSize[a] = extent / float(node.res[a]);
            node.invCellSize[a] = float(node.res[a]) / extent;
        }
        // A point of the node (a little beyond it now and then), and a triangle around it:
        // a speck, a sliver along one axis, or a large one.
        Vec3 centre, reach;
        for (int a = 0; a < 3; ++a) centre[a] = float(node.lo[a] + (-0.1 + 1.2 * u(rng)) * node.res[a] * node.cellSize[a]);
        const int kind = trial % 3, along = trial / 3 % 3;
        for (int a = 0; a < 3; ++a) {
            const double size = kind == 0 ? 0.3 : kind == 2 || a == along ? 3.0 : 0.2;
            reach[a] = float(size * node.cellSize[a]);
        }
        auto vertex = [&] {
            Vec3 p;
            for (int a = 0; a < 3; ++a) p[a] = centre[a] + float(-1 + 2 * u(rng)) * reach[a];
            return p;
        };
        const NestedGridAccel::Tri t{vertex(), vertex(), vertex()};
        const double epsAbs = 1e-6;
        std::vector<std::pair<uint32_t, uint32_t>> listed;
        grid_detail::RasterizeTriangle(node, t, epsAbs, 7, &listed);
        // The test on every cell of the node.
        std::vector<uint32_t> accepted;
        double h[3];
        for (int a = 0; a < 3; ++a) h[a] = 0.5 * node.cellSize[a] + std::max(1e-4 * node.cellSize[a], epsAbs);
        const TriangleBoxOverlap overlap(t.p0, t.p1, t.p2, h);
        uint32_t index = 0;
        int k[3];
        for (k[2] = 0; k[2] < node.res[2]; ++k[2])
            for (k[1] = 0; k[1] < node.res[1]; ++k[1])
                for (k[0] = 0; k[0] < node.res[0]; ++k[0], ++index) {
                    double c[3];
                    for (int a = 0; a < 3; ++a) c[a] = node.lo[a] + (k[a] + 0.5) * double(node.cellSize[a]);
                    if (overlap.Overlaps(c)) accepted.push_back(index);
                }
        std::vector<uint32_t> cells;
        for (const auto& [cell, id] : listed) {
            ASSERT_EQ(id, 7u);
            cells.push_back(cell);
        }
        ASSERT_TRUE(std::is_sorted(cells.begin(), cells.end())) << "trial " << trial;
        ASSERT_EQ(std::adjacent_find(cells.begin(), cells.end()), cells.end()) << "trial " << trial;
        bool inside = true;  // the triangle's grown bounds within the node
        for (int a = 0; a < 3; ++a) {
            const float lo = std::min({t.p0[a], t.p1[a], t.p2[a]}), hi = std::max({t.p0[a], t.p1[a], t.p2[a]});
            const double grow = 2 * (h[a] - 0.5 * node.cellSize[a]);
            inside &= lo - grow > node.lo[a] && hi + grow < node.lo[a] + node.res[a] * node.cellSize[a];
        }
        if (inside) {
            ASSERT_EQ(cells, accepted) << "trial " << trial;
        } else {
            ++beyond;
            ASSERT_TRUE(std::includes(cells.begin(), cells.end(), accepted.begin(), accepted.end())) << "trial " << trial;
        }
        // The path: along how many axes the grown bounds span more than one cell (as the
        // build counts them).
        int spanning = 0;
        for (int a = 0; a < 3; ++a) {
            const double eps = h[a] - 0.5 * node.cellSize[a];
            const double lo = std::min({t.p0[a], t.p1[a], t.p2[a]}) - eps, hi = std::max({t.p0[a], t.p1[a], t.p2[a]}) + eps;
            spanning += std::floor((hi - node.lo[a]) * node.invCellSize[a]) > std::floor((lo - node.lo[a]) * node.invCellSize[a]);
        }
        runs += inside && spanning == 1;
        planar += inside && spanning == 2;
        solid += inside && spanning == 3;
    }
    // Every path was taken.
    EXPECT_GT(runs, 200);
    EXPECT_GT(planar, 200);
    EXPECT_GT(solid, 50);
    EXPECT_GT(beyond, 200);
}

TEST(GridResolution, OptionOverridesLongestSide) {
    const TriangleMesh mesh = ts::Transformed(ts::Soup(2000, 5), 1.0f, Vec3(0));
    AccelOptions options;
    options.gridResolution = 81;  // the paper's "Child park" grid
    const NestedGridAccel grid(mesh, options);
    const auto& res = grid.GetStats().resolution;
    EXPECT_EQ(std::max({res[0], res[1], res[2]}), 81);
    EXPECT_NE(FigureValue(grid.Figures(), "grid resolution").find("81"), std::string::npos);
}

TEST(GridNesting, SubGridsOnlyWhereCrowdedAndNotBeyondMaxDepth) {
    // 3000 tiny triangles in one spot of a large box: the top cell holding them is crowded.
    const TriangleMesh mesh = ts::OneCell(3000, 7);
    AccelOptions options;
    options.gridMaxDepth = 1;
    const NestedGridAccel flat(mesh, options);
    EXPECT_EQ(flat.GetStats().subGrids, 0u);
    EXPECT_EQ(flat.GetStats().depth, 1);
    EXPECT_GT(flat.GetStats().maxPerCell, 63u);

    options.gridMaxDepth = 2;  // the paper's two levels
    const NestedGridAccel two(mesh, options);
    EXPECT_GT(two.GetStats().subGrids, 0u);
    EXPECT_EQ(two.GetStats().depth, 2);
    EXPECT_LT(two.GetStats().maxPerCell, flat.GetStats().maxPerCell);

    options.gridMaxDepth = 4;
    const NestedGridAccel deep(mesh, options);
    EXPECT_GE(deep.GetStats().depth, 3);
    EXPECT_LE(deep.GetStats().depth, 4);
    EXPECT_LE(deep.GetStats().maxPerCell, two.GetStats().maxPerCell);

    // With a high threshold nothing is subdivided.
    options.gridMaxTrianglesPerCell = 100000;
    const NestedGridAccel none(mesh, options);
    EXPECT_EQ(none.GetStats().subGrids, 0u);

    // A uniform soup with the auto resolution has no crowded cell.
    const NestedGridAccel soup(ts::Soup(5000, 3), AccelOptions{});
    EXPECT_LE(soup.GetStats().maxPerCell, 63u);
}

TEST(GridFigures, ReportsTheBuild) {
    const TriangleMesh mesh = ts::OneCell(2000, 8);
    const NestedGridAccel grid(mesh, AccelOptions{});
    const AccelFigures f = grid.Figures();
    for (const char* key :
         {"grid resolution", "grid cells", "empty cells", "triangles per non-empty cell",
          "references per triangle", "sub-grids", "grid bytes", "grid build ms"})
        EXPECT_EQ(FigureValue(f, key).find("<missing"), std::string::npos) << key;
    EXPECT_NE(FigureValue(f, "empty cells").find('%'), std::string::npos);
    EXPECT_NE(FigureValue(f, "sub-grids").find("depth reached 2 of 2"), std::string::npos)
        << FigureValue(f, "sub-grids");
    const auto& s = grid.GetStats();
    EXPECT_GT(s.bytes, mesh.TriangleCount() * sizeof(NestedGridAccel::Tri));
    EXPECT_GE(s.buildMs, 0.0);
    EXPECT_EQ(s.leafCells + s.emptyCells + s.subGrids, s.totalCells);
    EXPECT_GE(s.references, mesh.TriangleCount());
}

// Two parallel squares at z = 0 and z = 1 over [0, 1]², as four triangles (ids 0-1 and 2-3).
TriangleMesh TwoPlanes() {
    TriangleMesh m;
    for (float z : {0.0f, 1.0f}) {
        ts::AddTriangle(&m, {0, 0, z}, {1, 0, z}, {1, 1, z});
        ts::AddTriangle(&m, {0, 0, z}, {1, 1, z}, {0, 1, z});
    }
    return m;
}

TEST(GridTraversal, RayStartingInsideFindsTheHitAhead) {
    const TriangleMesh mesh = TwoPlanes();
    const NestedGridAccel grid(mesh, AccelOptions{});
    Hit h;
    // From between the planes, upwards: the z = 1 plane at t = 0.5 (d has length 1).
    ASSERT_TRUE(grid.Intersect(Ray{{0.3f, 0.6f, 0.5f}, {0, 0, 1}}, &h));
    EXPECT_EQ(h.t, 0.5f);
    EXPECT_GE(h.prim, 2u);
    // Downwards, with |d| = 4: t = 0.5 / 4.
    ASSERT_TRUE(grid.Intersect(Ray{{0.3f, 0.6f, 0.5f}, {0, 0, -4}}, &h));
    EXPECT_EQ(h.t, 0.125f);
    EXPECT_LE(h.prim, 1u);
    EXPECT_EQ(grid.CountCrossings(Ray{{0.3f, 0.6f, 0.5f}, {0, 0, 1}}), 1);
    EXPECT_EQ(grid.CountCrossings(Ray{{0.3f, 0.6f, -0.5f}, {0, 0, 1}}), 2);
}

TEST(GridTraversal, TMaxStopsTheWalk) {
    const TriangleMesh mesh = TwoPlanes();
    const NestedGridAccel grid(mesh, AccelOptions{});
    const Ray up{{0.7f, 0.2f, -0.5f}, {0, 0, 1}, 0.0f, 1.2f};  // reaches z = 0.7 only
    Hit h;
    ASSERT_TRUE(grid.Intersect(up, &h));
    EXPECT_EQ(h.t, 0.5f);
    EXPECT_EQ(grid.CountCrossings(up), 1);  // the z = 1 plane is beyond tMax
    const Ray shortRay{{0.7f, 0.2f, 0.1f}, {0, 0, 1}, 0.0f, 0.8f};
    EXPECT_FALSE(grid.Occluded(shortRay));
    EXPECT_FALSE(grid.Intersect(shortRay, &h));
    EXPECT_EQ(grid.CountCrossings(shortRay), 0);
    // tMin skips the first plane.
    const Ray late{{0.7f, 0.2f, -0.5f}, {0, 0, 1}, 0.6f, Infinity};
    ASSERT_TRUE(grid.Intersect(late, &h));
    EXPECT_EQ(h.t, 1.5f);
}

TEST(GridTraversal, ZeroThicknessBox) {
    // One plane: the box has no thickness on z and gets some, so rays still walk it.
    TriangleMesh mesh = ts::HeightField(16, 1, 0.0f);  // flat at z = 0 (amplitude 0)
    for (Vec3& p : mesh.positions) p.z = 0.0f;
    const NestedGridAccel grid(mesh, AccelOptions{});
    EXPECT_GT(grid.GridBounds().Diagonal().z, 0.0f);
    EXPECT_EQ(grid.GetStats().resolution[2], 1);
    const BruteForceAccel brute(mesh);
    ts::Rng rng(3);
    for (int i = 0; i < 2000; ++i) {
        const Vec3 o(rng.Uniform(-0.2f, 1.2f), rng.Uniform(-0.2f, 1.2f), rng.Uniform(-1, 1));
        Vec3 d = rng.Direction();
        if (i % 3 == 0) d = Vec3(0, 0, o.z > 0 ? -1.0f : 1.0f);  // perpendicular
        if (i % 3 == 1) d.z = 0;                                 // in the plane: never hits
        Hit a, b;
        const bool ha = grid.Intersect(Ray{o, d}, &a), hb = brute.Intersect(Ray{o, d}, &b);
        ASSERT_EQ(ha, hb) << i;
        if (ha) {
            EXPECT_EQ(a.t, b.t);
            EXPECT_EQ(a.prim, b.prim);
        }
        EXPECT_EQ(grid.CountCrossings(Ray{o, d}), brute.CountCrossings(Ray{o, d}));
    }
    // A ray lying in the plane starting on the box's boundary.
    EXPECT_FALSE(grid.Occluded(Ray{{0, 0.5f, 0}, {1, 0, 0}}));
}

TEST(GridTraversal, DegenerateInputs) {
    const TriangleMesh mesh = TwoPlanes();
    const NestedGridAccel grid(mesh, AccelOptions{});
    Hit h;
    EXPECT_FALSE(grid.Intersect(Ray{{0.5f, 0.5f, 0.5f}, {0, 0, 0}}, &h));         // no direction
    EXPECT_FALSE(grid.Occluded(Ray{{0.5f, 0.5f, 0.5f}, {0, 0, 1}, 2.0f, 1.0f}));  // empty range
    EXPECT_FALSE(grid.Occluded(Ray{{5, 5, 5}, {0, 0, 1}}));  // parallel, outside the box
    // A triangle with a NaN vertex is ignored, not poisoning the box.
    TriangleMesh bad = TwoPlanes();
    ts::AddTriangle(&bad, {0, 0, 0}, {std::nanf(""), 0, 0}, {0, 1, 0});
    const NestedGridAccel g2(bad, AccelOptions{});
    EXPECT_TRUE(std::isfinite(g2.GridBounds().MaxExtent()));
    ASSERT_TRUE(g2.Intersect(Ray{{0.3f, 0.6f, 0.5f}, {0, 0, 1}}, &h));
    EXPECT_EQ(h.t, 0.5f);
    // Rays built from overflowed values (a fuzzed scene once put light-mesh nodes at
    // infinity): the walk ends with no hit instead of stepping forever.
    const float inf = Infinity, nan = std::nanf("");
    for (const Ray& r : {Ray{{0.5f, inf, 0.5f}, {0, -inf, 0}}, Ray{{inf, 0.5f, 0.5f}, {-inf, 0.1f, 0}},
                         Ray{{0.3f, 0.6f, 0.5f}, {nan, nan, 1}}, Ray{{nan, 0.5f, 0.5f}, {1, 0, 0}},
                         Ray{{0.3f, 0.6f, -1}, {0, 0, 1}, 0.0f, nan}}) {
        EXPECT_FALSE(grid.Intersect(r, &h));
        EXPECT_FALSE(grid.Occluded(r));
        EXPECT_EQ(grid.CountCrossings(r), 0);
    }
}

TEST(GridTraversal, ShortSegmentsMatchBruteForce) {
    // The light-mesh workload: segments a few cells long starting inside the grid.
    const TriangleMesh mesh = ts::Soup(3000, 11);
    const NestedGridAccel grid(mesh, AccelOptions{});
    const BruteForceAccel brute(mesh);
    ts::Rng rng(5);
    for (int i = 0; i < 3000; ++i) {
        const Vec3 a = rng.InBox(Vec3(0), Vec3(1));
        const Vec3 b = a + rng.Direction() * rng.Uniform(0.0f, 0.03f);
        EXPECT_EQ(grid.Occluded(Segment(a, b)), brute.Occluded(Segment(a, b)));
        EXPECT_EQ(grid.CountCrossings(Segment(a, b)), brute.CountCrossings(Segment(a, b)));
    }
}

}  // namespace
}  // namespace grid_test
}  // namespace lm
