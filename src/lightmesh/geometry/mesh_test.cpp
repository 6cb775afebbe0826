#include "lightmesh/geometry/mesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <set>

#include "lightmesh/scene/shapes.h"

namespace lm {
namespace mesh_test {
namespace {

TEST(Mesh, CleanDropsDegenerateAndDuplicateTriangles) {
    TriangleMesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {1, 0, 0}, {NAN, 0, 0}};
    m.triangles = {{0, 1, 2}, {2, 1, 0}, {0, 1, 3}, {0, 0, 2}, {0, 4, 2}, {5, 1, 2}, {1, 2, 3}};
    m.materialIds = {0, 1, 2, 3, 4, 5, 6};
    const CleanReport r = CleanMesh(&m);
    // {2,1,0} and {0,4,2} repeat {0,1,2} (4 has 1's position); {0,1,3} is collinear,
    // {0,0,2} has a repeated vertex, {5,1,2} a NaN.
    EXPECT_EQ(r.duplicate, 2u);
    EXPECT_EQ(r.degenerate, 3u);
    ASSERT_EQ(m.TriangleCount(), 2u);
    EXPECT_EQ(m.materialIds, (std::vector<uint32_t>{0, 6}));
}

// +0 and -0 are one position; and on a mesh large enough for the open-addressing tables
// to collide often, the triangles kept are exactly those a plain set of sorted position
// triples keeps (first occurrence wins).
TEST(Mesh, CleanWeldsSignedZerosAndMatchesASetOnALargeMesh) {
    TriangleMesh z;
    z.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-0.0f, 0, -0.0f}};
    z.triangles = {{0, 1, 2}, {3, 1, 2}};
    EXPECT_EQ(CleanMesh(&z).duplicate, 1u);

    TriangleMesh m;
    uint32_t seed = 12345;
    auto next = [&] { return seed = seed * 1664525u + 1013904223u; };
    for (int i = 0; i < 60000; ++i)  // a 40×40 lattice of positions, many repeated
        m.positions.push_back({static_cast<float>(next() % 40), static_cast<float>(next() % 40), 0.5f});
    for (int i = 0; i < 50000; ++i) {
        m.triangles.push_back({next() % 60000, next() % 60000, next() % 60000});
        m.materialIds.push_back(static_cast<uint32_t>(i));
    }
    std::vector<uint32_t> expected;
    std::set<std::array<std::array<float, 3>, 3>> seen;
    for (uint32_t i = 0; i < m.triangles.size(); ++i) {
        std::array<std::array<float, 3>, 3> key;
        for (int k = 0; k < 3; ++k) {
            const Vec3& p = m.positions[m.triangles[i][k]];
            key[k] = {p.x, p.y, p.z};
        }
        const Vec3 e1 = m.positions[m.triangles[i][1]] - m.positions[m.triangles[i][0]];
        const Vec3 e2 = m.positions[m.triangles[i][2]] - m.positions[m.triangles[i][0]];
        if (!(LengthSquared(Cross(e1, e2)) > 0)) continue;  // degenerate
        std::sort(key.begin(), key.end());
        if (seen.insert(key).second) expected.push_back(i);
    }
    CleanMesh(&m);
    EXPECT_EQ(m.materialIds, expected);
    EXPECT_GT(m.materialIds.size(), 1000u);
    EXPECT_LT(m.materialIds.size(), 50000u);
}

TEST(Mesh, EdgeReportSeesClosedOpenAndNonManifold) {
    TriangleMesh box;
    ShapeBuilder(&box).Box({0, 0, 0}, {1, 1, 1}, 0);
    EXPECT_TRUE(AnalyzeEdges(box).Closed());
    EXPECT_EQ(AnalyzeEdges(box).edges, 18u);

    TriangleMesh open = box;
    open.triangles.pop_back();
    EXPECT_EQ(AnalyzeEdges(open).open, 3u);

    TriangleMesh fin = box;  // a third triangle on an edge of the box
    fin.positions.push_back({0.5f, -1, 0.5f});
    fin.triangles.push_back({0, 1, static_cast<uint32_t>(fin.positions.size() - 1)});
    const EdgeReport r = AnalyzeEdges(fin);
    EXPECT_GE(r.nonManifold, 1u);
    EXPECT_FALSE(r.Closed());
}

// Signed volume of a closed mesh: positive when every face points outwards.
double SignedVolume(const TriangleMesh& m) {
    double v = 0;
    for (uint32_t i = 0; i < m.TriangleCount(); ++i)
        v += Dot(m.Vertex(i, 0), Cross(m.Vertex(i, 1), m.Vertex(i, 2))) / 6.0;
    return v;
}

TEST(Shapes, SolidsAreClosedAndOutwardWithTheRightVolume) {
    struct Case {
        const char* name;
        std::function<void(ShapeBuilder&)> make;
        double volume, tolerance;
    };
    const Case cases[] = {
        {"box", [](ShapeBuilder& b) { b.Box({0, 0, 0}, {1, 2, 3}, 0); }, 6.0, 1e-5},
        {"beam", [](ShapeBuilder& b) { b.Beam({0, 0, 0}, {3, 4, 0}, 0.5f, 0); }, 5 * 0.25, 1e-4},
        {"cylinder", [](ShapeBuilder& b) { b.Cylinder({1, 1, 1}, 1, 2, 64, 0); }, 2 * M_PI * 0.998, 0.01},
        {"cone", [](ShapeBuilder& b) { b.Cone({0, 0, 0}, 1, 3, 64, 0); }, M_PI * 0.998, 0.01},
        {"sphere", [](ShapeBuilder& b) { b.Sphere({0, 0, 0}, 1, 32, 64, 0); }, 4.0 / 3.0 * M_PI, 0.04},
    };
    for (const Case& c : cases) {
        TriangleMesh m;
        ShapeBuilder b(&m);
        c.make(b);
        EXPECT_TRUE(AnalyzeEdges(m).Closed()) << c.name;
        EXPECT_NEAR(SignedVolume(m), c.volume, c.tolerance) << c.name;
    }
}

}  // namespace
}  // namespace mesh_test
}  // namespace lm
