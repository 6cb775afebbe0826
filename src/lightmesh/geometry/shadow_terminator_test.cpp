#include "lightmesh/geometry/shadow_terminator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace lm {
namespace shadow_terminator_test {
namespace {

// A triangle of a sphere of radius 1 tessellated coarsely (about 30° between its corners),
// with the sphere's own normals at the corners.
struct SphereFacet {
    Vec3 corner[3], normal[3];
    SphereFacet() {
        const Vec3 dirs[3] = {Normalize(Vec3(1, 0.1f, 0)), Normalize(Vec3(0.87f, 0.5f, 0)), Normalize(Vec3(0.87f, 0.2f, 0.5f))};
        for (int k = 0; k < 3; ++k) corner[k] = dirs[k], normal[k] = dirs[k];
    }
};

TEST(ShadowTerminator, AFlatTriangleKeepsItsPoints) {
    // Every corner's normal is the triangle's: p lies on every plane and stays, bit for bit.
    const Vec3 corner[3] = {{0, 0, 0}, {2, 0, 0}, {0, 0, -3}}, up(0, 1, 0);
    const Vec3 normal[3] = {up, up, up};
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 100; ++i) {
        float b1 = u(rng), b2 = u(rng);
        if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
        const float b[3] = {1 - b1 - b2, b1, b2};
        const Vec3 p = corner[0] * b[0] + corner[1] * b[1] + corner[2] * b[2];
        EXPECT_EQ(LiftToShadingPlanes(p, b, corner, normal), p);
    }
}

TEST(ShadowTerminator, ASphereFacetsPointsRiseAboveTheFacet) {
    const SphereFacet f;
    const Vec3 facetNormal = Normalize(Cross(f.corner[1] - f.corner[0], f.corner[2] - f.corner[0]));
    ASSERT_GT(Dot(facetNormal, f.corner[0]), 0);  // outwards
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 1000; ++i) {
        float b1 = u(rng), b2 = u(rng);
        if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
        const float b[3] = {1 - b1 - b2, b1, b2};
        const Vec3 p = f.corner[0] * b[0] + f.corner[1] * b[1] + f.corner[2] * b[2];
        const Vec3 lifted = LiftToShadingPlanes(p, b, f.corner, f.normal);
        // Inside the facet, p lies below its corners' tangent planes: it rises off the
        // facet, outwards, about as far as the sphere bulges there (up to 4.5 % of the
        // radius), and moves by a fraction of the facet's size (its edges are 0.4-0.6).
        const float height = Dot(lifted - f.corner[0], facetNormal);
        EXPECT_GE(height, -1e-6f);
        if (std::min({b[0], b[1], b[2]}) > 0.1f) {
            EXPECT_GT(height, 0.01f);
            EXPECT_GT(Length(lifted), Length(p));
        }
        EXPECT_LE(height, 0.1f);
        EXPECT_LE(Length(lifted - p), 0.15f);
    }
}

TEST(ShadowTerminator, NormalsOfAnyLengthAndEitherSideLiftAlike) {
    // Meshes store normals as written (not unit), and a ray may hit the side they point
    // away from: `side` turns them.
    const SphereFacet f;
    const float b[3] = {0.2f, 0.5f, 0.3f};
    const Vec3 p = f.corner[0] * b[0] + f.corner[1] * b[1] + f.corner[2] * b[2];
    const Vec3 unit = LiftToShadingPlanes(p, b, f.corner, f.normal);
    const Vec3 scaled[3] = {f.normal[0] * 3.0f, f.normal[1] * 0.25f, f.normal[2] * 7.0f};
    const Vec3 flipped[3] = {-scaled[0], -scaled[1], -scaled[2]};
    const Vec3 zero[3] = {Vec3(0.0f), Vec3(0.0f), Vec3(0.0f)};
    EXPECT_NEAR(Length(LiftToShadingPlanes(p, b, f.corner, scaled) - unit), 0.0f, 1e-6f);
    EXPECT_NEAR(Length(LiftToShadingPlanes(p, b, f.corner, flipped, -1.0f) - unit), 0.0f, 1e-6f);
    EXPECT_GT(Length(unit - p), 0.01f);
    EXPECT_EQ(LiftToShadingPlanes(p, b, f.corner, zero), p);  // no normals: no lift
}

TEST(ShadowTerminator, APointAboveEveryPlaneStays) {
    // A concave patch: the normals lean inwards, so the facet lies above their planes.
    const SphereFacet f;
    const Vec3 inward[3] = {-f.normal[0], -f.normal[1], -f.normal[2]};
    const float b[3] = {0.3f, 0.3f, 0.4f};
    const Vec3 p = f.corner[0] * b[0] + f.corner[1] * b[1] + f.corner[2] * b[2];
    EXPECT_EQ(LiftToShadingPlanes(p, b, f.corner, inward), p);
}

TEST(ShadowTerminator, ACornerItselfStays) {
    const SphereFacet f;
    const float b[3] = {1, 0, 0};
    EXPECT_EQ(LiftToShadingPlanes(f.corner[0], b, f.corner, f.normal), f.corner[0]);
}

}  // namespace
}  // namespace shadow_terminator_test
}  // namespace lm
