#include "lightmesh/accel/occluder_bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "lightmesh/geometry/triangle.h"

namespace lm {
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
    for (int q = 0; q < 60; ++q) {
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

TEST(OccluderBvh, EmptyMesh) {
    TriangleMesh mesh;
    const OccluderBvh bvh(mesh);
    std::vector<uint32_t> ids;
    EXPECT_TRUE(bvh.Query(BallHull{Vec3(0, 0, 0), 1, Vec3(1, 1, 1), 1}, &ids));
    EXPECT_TRUE(ids.empty());
}

}  // namespace
}  // namespace lm
