#include "lightmesh/geometry/smooth_normals.h"

#include <gtest/gtest.h>

#include <cmath>

#include "lightmesh/scene/shapes.h"

namespace lm {
namespace smooth_normals_test {
namespace {

// A closed UV sphere of radius 1: `rings` bands, `segments` around, vertices shared.
TriangleMesh LowPolySphere(int rings, int segments) {
    TriangleMesh m;
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j < segments; ++j) {
            const float th = Pi * static_cast<float>(i) / static_cast<float>(rings);
            const float ph = 2 * Pi * static_cast<float>(j) / static_cast<float>(segments);
            m.positions.push_back(Vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)));
        }
    auto at = [&](int i, int j) { return static_cast<uint32_t>(i * segments + (j % segments)); };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            if (i > 0) m.triangles.push_back({at(i, j), at(i, j + 1), at(i + 1, j)});
            if (i + 1 < rings) m.triangles.push_back({at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)});
        }
    m.materialIds.assign(m.triangles.size(), 0);
    return m;
}

TEST(SmoothNormals, ASphereGetsItsRadialNormals) {
    TriangleMesh m = LowPolySphere(6, 8);
    SmoothNormals(&m, 60.0f);
    ASSERT_EQ(m.normals.size(), m.positions.size());
    // Away from the poles (whose ring of faces is a cone), each vertex's normal is close to
    // its radial direction, far closer than a face normal is.
    for (size_t v = 0; v < m.positions.size(); ++v) {
        const Vec3 radial = Normalize(m.positions[v]);
        if (std::abs(radial.y) > 0.99f) continue;
        EXPECT_GT(Dot(m.normals[v], radial), 0.99f) << v;
    }
}

TEST(SmoothNormals, ACubeStaysFlatUnderItsCreaseAngle) {
    TriangleMesh m;
    ShapeBuilder(&m).OrientedBox(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), 0);
    const size_t triangles = m.triangles.size();
    SmoothNormals(&m, 60.0f);
    ASSERT_EQ(m.triangles.size(), triangles);
    // 90° edges: every corner keeps its face's normal; the 8 corners become 24 vertices.
    EXPECT_EQ(m.positions.size(), 24u);
    for (const auto& t : m.triangles) {
        const Vec3 face = Normalize(Cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]));
        for (int k = 0; k < 3; ++k) EXPECT_GT(Dot(m.normals[t[k]], face), 0.9999f);
    }
    // Above 90°, everything is smoothed: a corner's normal is the diagonal.
    TriangleMesh s;
    ShapeBuilder(&s).OrientedBox(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), 0);
    SmoothNormals(&s, 180.0f);
    for (size_t v = 0; v < s.positions.size(); ++v)
        EXPECT_NEAR(std::abs(Dot(s.normals[v], Normalize(s.positions[v]))), 1.0f, 1e-5f);
}

TEST(SmoothNormals, SeparateVerticesAtOnePositionAreSmoothedTogether) {
    // Two triangles meeting at a 20° fold, each with its own vertices (as STL stores them).
    TriangleMesh m;
    const float a = 20.0f * Pi / 180.0f;
    m.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, -1), Vec3(0, 0, 0), Vec3(0, 0, -1),
                   Vec3(-std::cos(a), std::sin(a), 0)};
    m.triangles = {{0, 1, 2}, {3, 4, 5}};
    m.materialIds = {0, 0};
    SmoothNormals(&m, 30.0f);
    EXPECT_NEAR(Dot(m.normals[m.triangles[0][0]], m.normals[m.triangles[1][0]]), 1.0f, 1e-6f);
    TriangleMesh flat = m;
    flat.normals.clear();
    flat.positions = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, -1), Vec3(0, 0, 0), Vec3(0, 0, -1),
                      Vec3(-std::cos(a), std::sin(a), 0)};
    flat.triangles = {{0, 1, 2}, {3, 4, 5}};
    SmoothNormals(&flat, 10.0f);  // the fold is sharper than 10°: kept
    EXPECT_LT(Dot(flat.normals[flat.triangles[0][0]], flat.normals[flat.triangles[1][0]]), 0.95f);
}

}  // namespace
}  // namespace smooth_normals_test
}  // namespace lm
