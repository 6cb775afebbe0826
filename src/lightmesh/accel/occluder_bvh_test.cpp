#include "lightmesh/accel/occluder_bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "lightmesh/geometry/triangle.h"
#include "support/sanitized.h"

namespace lm {
namespace occluder_bvh_test {
namespace {

TriangleMesh RandomSoup(std::mt19937& rng, int count, float extent, float size) {
    std::uniform_real_distribution<float> pos(-extent, extent), off(-size, size);
    TriangleMesh mesh;
    for (int i = 0; i < count; ++i) {
        const Vec3 c(pos(rng), pos(rng), pos(rng));
        const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
        for (int k = 0; k < 3; ++k) mesh.positions.push_back(c + Vec3(off(rng), off(rng), off(rng)));
        mesh.triangles.push_back({base, base + 1, base + 2});
        mesh.materialIds.push_back(0);
    }
    return mesh;
}

Vec3 InBall(std::mt19937& rng, const Vec3& c, float r) {
    std::uniform_real_distribution<float> u(-1, 1);
    for (;;) {
        const Vec3 v(u(rng), u(rng), u(rng));
        if (LengthSquared(v) <= 1) return c + v * r;
    }
}

// The query's promise, checked against brute force: every triangle that some segment
// from the first ball to the second crosses is listed (segments are what shadow rays
// are; a hull meets whatever they meet).
TEST(OccluderBvh, ListsEveryTriangleASegmentBetweenTheBallsCrosses) {
    std::mt19937 rng(7);
    const TriangleMesh mesh = RandomSoup(rng, 3000, 10.0f, 0.6f);
    const OccluderBvh bvh(mesh);
    std::uniform_real_distribution<float> pos(-12, 12), rad(0.0f, 2.0f);
    int checked = 0;
    for (int q = 0; q < testing::SweepCases(60, 3); ++q) {
        const BallHull hull{Vec3(pos(rng), pos(rng), pos(rng)), rad(rng), Vec3(pos(rng), pos(rng), pos(rng)), rad(rng)};
        std::vector<uint32_t> ids;
        ASSERT_TRUE(bvh.Query(hull, &ids));
        std::sort(ids.begin(), ids.end());
        EXPECT_TRUE(std::adjacent_find(ids.begin(), ids.end()) == ids.end()) << "an id listed twice";
        for (int s = 0; s < 400; ++s) {
            const Vec3 a = InBall(rng, hull.a, hull.ra), b = InBall(rng, hull.b, hull.rb);
            const Ray ray{a, b - a, 0.0f, 1.0f};
            for (uint32_t t = 0; t < mesh.TriangleCount(); ++t) {
                TriangleHit hit;
                if (!IntersectTriangle(ray, mesh.Vertex(t, 0), mesh.Vertex(t, 1), mesh.Vertex(t, 2), &hit)) continue;
                ++checked;
                EXPECT_TRUE(std::binary_search(ids.begin(), ids.end(), t)) << "query " << q << " misses triangle " << t;
            }
        }
    }
    EXPECT_GT(checked, 100);  // the test did test something
}

TEST(OccluderBvh, ListsFewTrianglesFarFromTheHull) {
    std::mt19937 rng(3);
    const TriangleMesh mesh = RandomSoup(rng, 5000, 10.0f, 0.2f);
    const OccluderBvh bvh(mesh);
    // A thin hull through the middle meets a small share of a soup spread over the cube.
    std::vector<uint32_t> ids;
    ASSERT_TRUE(bvh.Query(BallHull{Vec3(-10, 0, 0), 0.1f, Vec3(10, 0, 0), 0.1f}, &ids));
    EXPECT_LT(ids.size(), 60u);
    // The limit stops a query that would list more.
    std::vector<uint32_t> all;
    EXPECT_FALSE(bvh.Query(BallHull{Vec3(-10, 0, 0), 20.0f, Vec3(10, 0, 0), 20.0f}, &all, 100));
    all.clear();
    EXPECT_TRUE(bvh.Query(BallHull{Vec3(-10, 0, 0), 20.0f, Vec3(10, 0, 0), 20.0f}, &all));
    EXPECT_EQ(all.size(), mesh.TriangleCount());  // every triangle lies within 15 of the axis
}

// The query lists exactly the triangles whose own boxes pass the hull's capsule test (a
// node's box holds its triangles', and the test passes a bigger box whenever it passes a
// smaller one): checked against the test on every triangle.
TEST(OccluderBvh, ListsExactlyTheTrianglesWhoseBoxesMeetThePieces) {
    std::mt19937 rng(11);
    const TriangleMesh mesh = RandomSoup(rng, 4000, 10.0f, 0.8f);
    const OccluderBvh bvh(mesh);
    std::uniform_real_distribution<float> pos(-12, 12), rad(0.0f, 1.5f);
    size_t listed = 0;
    for (int q = 0; q < 80; ++q) {
        const BallHull hull{Vec3(pos(rng), pos(rng), pos(rng)), rad(rng), Vec3(pos(rng), pos(rng), pos(rng)), rad(rng)};
        std::vector<uint32_t> ids;
        ASSERT_TRUE(bvh.Query(hull, &ids));
        std::sort(ids.begin(), ids.end());
        const HullPieces pieces(hull);
        std::vector<uint32_t> brute;
        for (uint32_t t = 0; t < mesh.TriangleCount(); ++t) {
            const Vec3 &p0 = mesh.Vertex(t, 0), &p1 = mesh.Vertex(t, 1), &p2 = mesh.Vertex(t, 2);
            if (pieces.MeetsBox(Bounds3(Min(Min(p0, p1), p2), Max(Max(p0, p1), p2)))) brute.push_back(t);
        }
        EXPECT_EQ(ids, brute) << "query " << q;
        listed += ids.size();
    }
    EXPECT_GT(listed, 500u);
}

// MeetsBox tests the four capsules side by side in SSE lanes; it must answer as the slab
// test of one capsule at a time (the pieces built as HullPieces documents them), also for
// axis-parallel hulls (zero components) and boxes that touch a capsule.
TEST(OccluderBvh, PiecesSideBySideAnswerAsOneAtATime) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> pos(-5, 5), rad(0.0f, 1.0f), size(0.0f, 2.0f);
    std::uniform_int_distribution<int> flat(0, 3);
    int met = 0, missed = 0;
    for (int q = 0; q < 400; ++q) {
        BallHull hull{Vec3(pos(rng), pos(rng), pos(rng)), rad(rng), Vec3(pos(rng), pos(rng), pos(rng)), rad(rng)};
        if (const int k = flat(rng); k < 3) hull.b[k] = hull.a[k];  // a zero component
        const HullPieces pieces(hull);
        const Vec3 d = hull.b - hull.a;
        for (int b = 0; b < 200; ++b) {
            const Vec3 lo(pos(rng), pos(rng), pos(rng)), hi = lo + Vec3(size(rng), size(rng), size(rng));
            bool one = false;
            for (int j = 0; j < HullPieces::kPieces && !one; ++j) {
                const float s0 = static_cast<float>(j) / HullPieces::kPieces, s1 = static_cast<float>(j + 1) / HullPieces::kPieces;
                const Vec3 o = hull.a + d * s0, seg = d * (s1 - s0);
                const float r0 = std::max(hull.ra + (hull.rb - hull.ra) * s0, hull.ra + (hull.rb - hull.ra) * s1);
                const float r = r0 * (1.0f + 1e-5f) + 1e-6f * (MaxComponent(Abs(o)) + Length(seg));
                float t0 = 0.0f, t1 = 1.0f;
                for (int k = 0; k < 3; ++k) {
                    const float inv = std::abs(seg[k]) > 1e-30f ? 1.0f / seg[k] : (seg[k] < 0 ? -1e30f : 1e30f);
                    float a = (lo[k] - r - o[k]) * inv, c = (hi[k] + r - o[k]) * inv;
                    if (a > c) std::swap(a, c);
                    t0 = std::max(t0, a);
                    t1 = std::min(t1, c);
                }
                one = t0 <= t1;
            }
            ASSERT_EQ(pieces.MeetsBox(Bounds3(lo, hi)), one) << "hull " << q << " box " << b;
            (one ? met : missed)++;
        }
    }
    EXPECT_GT(met, 1000);
    EXPECT_GT(missed, 1000);
}

TEST(OccluderBvh, EmptyMesh) {
    TriangleMesh mesh;
    const OccluderBvh bvh(mesh);
    std::vector<uint32_t> ids;
    EXPECT_TRUE(bvh.Query(BallHull{Vec3(0, 0, 0), 1, Vec3(1, 1, 1), 1}, &ids));
    EXPECT_TRUE(ids.empty());
}

}  // namespace
}  // namespace occluder_bvh_test
}  // namespace lm
