#include "lightmesh/geometry/triangle.h"

#include <gtest/gtest.h>

#include <random>

#include "lightmesh/scene/shapes.h"

namespace lm {
namespace triangle_test {
namespace {

const Vec3 A(0, 0, 0), B(1, 0, 0), C(0, 1, 0);

Ray Down(float x, float y) { return Ray{Vec3(x, y, 1), Vec3(0, 0, -1), 0, Infinity}; }

TEST(Triangle, InteriorHitGivesDistanceAndBarycentrics) {
    TriangleHit h;
    ASSERT_TRUE(IntersectTriangle(Down(0.25f, 0.5f), A, B, C, &h));
    EXPECT_FLOAT_EQ(h.t, 1.0f);
    EXPECT_FLOAT_EQ(h.b1, 0.25f);
    EXPECT_FLOAT_EQ(h.b2, 0.5f);
    EXPECT_FLOAT_EQ(h.b0, 0.25f);
    // Both windings are hit.
    ASSERT_TRUE(IntersectTriangle(Down(0.25f, 0.5f), A, C, B, &h));
    EXPECT_FLOAT_EQ(h.t, 1.0f);
}

TEST(Triangle, MissesOutsideBehindAndBeyondTmax) {
    TriangleHit h;
    EXPECT_FALSE(IntersectTriangle(Down(0.6f, 0.6f), A, B, C, &h));
    EXPECT_FALSE(IntersectTriangle(Down(-0.1f, 0.5f), A, B, C, &h));
    // Triangle behind the origin.
    EXPECT_FALSE(IntersectTriangle(Ray{Vec3(0.2f, 0.2f, -1), Vec3(0, 0, -1), 0, Infinity}, A, B, C, &h));
    // tMax stops before the plane, tMin starts after it.
    EXPECT_FALSE(IntersectTriangle(Ray{Vec3(0.2f, 0.2f, 1), Vec3(0, 0, -1), 0, 0.99f}, A, B, C, &h));
    EXPECT_FALSE(IntersectTriangle(Ray{Vec3(0.2f, 0.2f, 1), Vec3(0, 0, -1), 1.01f, Infinity}, A, B, C, &h));
}

TEST(Triangle, DegenerateTrianglesAndParallelRaysNeverHit) {
    TriangleHit h;
    EXPECT_FALSE(IntersectTriangle(Down(0.5f, 0), A, B, Vec3(2, 0, 0), &h));  // collinear
    EXPECT_FALSE(IntersectTriangle(Down(0, 0), A, A, A, &h));                 // a point
    // A ray in the triangle's plane.
    EXPECT_FALSE(IntersectTriangle(Ray{Vec3(-1, 0.2f, 0), Vec3(1, 0, 0), 0, Infinity}, A, B, C, &h));
    // A zero direction.
    EXPECT_FALSE(IntersectTriangle(Ray{Vec3(0.2f, 0.2f, 1), Vec3(0, 0, 0), 0, Infinity}, A, B, C, &h));
}

// Two triangles sharing the edge B-C of a unit square: a ray through the shared edge hits
// exactly one of them, whichever way each is wound and whichever way the ray goes.
TEST(Triangle, SharedEdgeIsHitExactlyOnce) {
    const Vec3 D(1, 1, 0);
    for (float s : {0.5f, 0.25f, 0.125f, 0.75f}) {
        const Vec3 onEdge = B + (C - B) * s;  // exactly representable
        for (float dir : {-1.0f, 1.0f}) {
            const Ray r{Vec3(onEdge.x, onEdge.y, -dir), Vec3(0, 0, dir), 0, Infinity};
            for (bool flip1 : {false, true}) {
                for (bool flip2 : {false, true}) {
                    TriangleHit h;
                    int hits = (flip1 ? IntersectTriangle(r, A, C, B, &h) : IntersectTriangle(r, A, B, C, &h)) +
                               (flip2 ? IntersectTriangle(r, B, C, D, &h) : IntersectTriangle(r, C, B, D, &h));
                    EXPECT_EQ(hits, 1) << "s=" << s << " dir=" << dir << " flips " << flip1 << flip2;
                }
            }
        }
    }
}

// A vertex shared by a fan of triangles covering its neighbourhood: a ray through the
// vertex hits exactly one triangle of the fan.
TEST(Triangle, SharedVertexIsHitExactlyOnce) {
    const Vec3 centre(0, 0, 0);
    const Vec3 ring[6] = {{1, 0, 0}, {0.5f, 1, 0}, {-0.5f, 1, 0}, {-1, 0, 0}, {-0.5f, -1, 0}, {0.5f, -1, 0}};
    for (Vec3 d : {Vec3(0, 0, -1), Vec3(0, 0, 1), Vec3(0.3f, 0.1f, -1), Vec3(-0.2f, 0.7f, 1)}) {
        const Ray r{centre - d, d, 0, Infinity};
        int hits = 0;
        TriangleHit h;
        for (int i = 0; i < 6; ++i) hits += IntersectTriangle(r, centre, ring[i], ring[(i + 1) % 6], &h);
        EXPECT_EQ(hits, 1) << "d=" << d.x << "," << d.y << "," << d.z;
    }
}

// Rays from a point inside a closed sphere mesh cross its surface an odd number of times
// (once), rays between two outside points an even number, also when aimed exactly at the
// mesh's vertices, which are shared by many triangles.
TEST(Triangle, ClosedMeshParityThroughVertices) {
    TriangleMesh mesh;
    ShapeBuilder(&mesh).Sphere(Vec3(0, 0, 0), 1.0f, 8, 12, 0);
    auto crossings = [&](const Ray& r) {
        int n = 0;
        TriangleHit h;
        for (uint32_t i = 0; i < mesh.TriangleCount(); ++i)
            n += IntersectTriangle(r, mesh.Vertex(i, 0), mesh.Vertex(i, 1), mesh.Vertex(i, 2), &h);
        return n;
    };
    const Vec3 inside(0, 0, 0);
    for (const Vec3& v : mesh.positions) {
        // From the centre through the vertex to twice as far: one crossing.
        EXPECT_EQ(crossings(Segment(inside, v * 2.0f)), 1) << v.x << " " << v.y << " " << v.z;
        // From far outside on one side, through the vertex, to the other side: parity even.
        EXPECT_EQ(crossings(Segment(v * 3.0f, -v * 3.0f)) % 2, 0);
    }
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-3, 3);
    for (int i = 0; i < 2000; ++i) {
        const Vec3 out(u(rng), u(rng), 3.5f);
        EXPECT_EQ(crossings(Segment(inside, out)) % 2, 1);
    }
}

// Exact-float regressions: each fixed bug in the intersection test adds a case here.
TEST(Triangle, BadCases) {
    TriangleHit h;
    // Grazing a vertex with a ray along an edge direction.
    EXPECT_FALSE(IntersectTriangle(Ray{Vec3(-1, 0, 0), Vec3(1, 0, 0), 0, Infinity}, A, B, C, &h));
}

// Normals at the triangle's own scale. At 1e-17 the plain cross product's square underflows
// (judged by it, such a model would be "zero area"); the scaled one does not, and stays
// exactly zero for a flat triangle; the unit normal is Normalize(TriangleNormal) bit for bit
// at everyday scales.
TEST(Triangle, NormalsAtTheTrianglesOwnScale) {
    for (const float scale : {1e-17f, 1e-30f, 1.0f, 1e15f}) {
        SCOPED_TRACE(scale);
        const Vec3 a(0, 0, 0), b(scale, 0, 0), c(0, scale, 0);
        EXPECT_GT(LengthSquared(ScaledTriangleNormal(a, b, c)), 0.0f);
        const Vec3 n = UnitTriangleNormal(a, b, c);
        EXPECT_NEAR(n.z, 1.0f, 1e-6f);
        EXPECT_EQ(ScaledTriangleNormal(a, b, Vec3(2 * scale, 0, 0)), Vec3(0.0f));  // collinear
        EXPECT_EQ(ScaledTriangleNormal(a, a, c), Vec3(0.0f));                     // repeated vertex
    }
    EXPECT_EQ(LengthSquared(TriangleNormal(Vec3(0, 0, 0), Vec3(1e-17f, 0, 0), Vec3(0, 1e-17f, 0))), 0.0f);
    const Vec3 p0(0.3f, 1.7f, -2.1f), p1(4.1f, 0.2f, 0.9f), p2(-1.3f, 2.2f, 3.3f);
    EXPECT_EQ(UnitTriangleNormal(p0, p1, p2), Normalize(TriangleNormal(p0, p1, p2)));
    // Exactly scaled (a power of two): the same zero/non-zero verdict as the plain product
    // wherever that does not underflow, e.g. collinear lattice points.
    EXPECT_EQ(ScaledTriangleNormal(Vec3(3, 6, 0.5f), Vec3(10, 20, 0.5f), Vec3(1, 2, 0.5f)), Vec3(0.0f));
}

}  // namespace
}  // namespace triangle_test
}  // namespace lm

namespace lm {
namespace triangle_test {
namespace {

// TriangleBoxOverlap (the grid's rasterization) against what overlap means: a box that holds
// a point of the triangle overlaps it; a box beyond one of the triangle's supporting
// planes, or beyond its bounding box, does not.
TEST(TriangleBox, AgreesWithPointsInsideAndSeparatingPlanes) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    int hits = 0, misses = 0;
    for (int trial = 0; trial < 4000; ++trial) {
        const Vec3 p0(u(rng), u(rng), u(rng)), p1(u(rng), u(rng), u(rng)), p2(u(rng), u(rng), u(rng));
        const double h[3] = {0.05 + 0.2 * std::abs(u(rng)), 0.05 + 0.2 * std::abs(u(rng)), 0.05 + 0.2 * std::abs(u(rng))};
        const TriangleBoxOverlap overlap(p0, p1, p2, h);
        // A point of the triangle, and a box around it.
        const float a = std::abs(u(rng)), b = std::abs(u(rng)) * (1 - a);
        const Vec3 q = p0 + (p1 - p0) * a + (p2 - p0) * b;
        const double inside[3] = {q.x + 0.9 * h[0] * u(rng), q.y + 0.9 * h[1] * u(rng), q.z + 0.9 * h[2] * u(rng)};
        ASSERT_TRUE(overlap.Overlaps(inside)) << "trial " << trial;
        ASSERT_TRUE(TriangleOverlapsBox(p0, p1, p2, inside, h));
        ++hits;
        // A box entirely on the far side of the triangle's plane.
        const Vec3 n = Normalize(TriangleNormal(p0, p1, p2));
        if (!(Length(TriangleNormal(p0, p1, p2)) > 1e-3f)) continue;
        const double reach = std::abs(n.x) * h[0] + std::abs(n.y) * h[1] + std::abs(n.z) * h[2];
        const double off = reach * 1.01 + 1e-3;
        const double beyond[3] = {q.x + n.x * off, q.y + n.y * off, q.z + n.z * off};
        ASSERT_FALSE(overlap.Overlaps(beyond)) << "trial " << trial;
        // A box outside the bounding box along x.
        const double right[3] = {std::max({p0.x, p1.x, p2.x}) + h[0] * 1.01, q.y, q.z};
        ASSERT_FALSE(overlap.Overlaps(right));
        misses += 2;
    }
    EXPECT_GT(hits, 3000);
    EXPECT_GT(misses, 3000);
}

// A degenerate triangle (a segment) still overlaps the boxes it passes through and no others:
// its zero edge axes are left out, the others still separate.
TEST(TriangleBox, DegenerateTriangleIsASegment) {
    const Vec3 a(0, 0, 0), b(1, 1, 0);
    const double h[3] = {0.1, 0.1, 0.1};
    const TriangleBoxOverlap segment(a, b, b, h);
    const double onIt[3] = {0.5, 0.5, 0.0}, beside[3] = {0.5, 0.2, 0.0}, above[3] = {0.5, 0.5, 0.3};
    EXPECT_TRUE(segment.Overlaps(onIt));
    EXPECT_FALSE(segment.Overlaps(beside));
    EXPECT_FALSE(segment.Overlaps(above));
}

}  // namespace
}  // namespace triangle_test
}  // namespace lm
