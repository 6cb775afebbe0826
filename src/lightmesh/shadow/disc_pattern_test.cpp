#include "lightmesh/shadow/disc_pattern.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <utility>

namespace lm {
namespace disc_pattern_test {
namespace {

// The lattice mapped to the disc is area-preserving: equal shares of the points fall in
// rings of equal area, and each pass alone spreads over all four quadrants.
TEST(DiscPattern, EqualAreasHoldEqualSharesAndEveryPassSpreads) {
    const DiscPattern d = DiscPattern::Golden(256, 4);
    ASSERT_EQ(d.Size(), 256);
    int inner = 0;
    for (int k = 0; k < d.Size(); ++k) {
        EXPECT_LE(d.r2[k], 1.0f + 1e-6f);
        EXPECT_NEAR(d.r2[k], d.x[k] * d.x[k] + d.y[k] * d.y[k], 1e-6f);
        inner += d.r2[k] < 0.5f;  // the inner disc of half the area
    }
    EXPECT_NEAR(inner, 128, 6);
    for (int p = 0; p < 4; ++p) {
        int quadrant[4] = {};
        for (int k = p * 64; k < (p + 1) * 64; ++k) ++quadrant[(d.x[k] < 0) + 2 * (d.y[k] < 0)];
        for (int q : quadrant) EXPECT_GE(q, 10) << "pass " << p;
    }
    // The same points as the unpermuted lattice, each once.
    const DiscPattern one = DiscPattern::Golden(256, 1);
    std::set<std::pair<float, float>> a, b;
    for (int k = 0; k < 256; ++k) a.insert({d.x[k], d.y[k]}), b.insert({one.x[k], one.y[k]});
    EXPECT_EQ(a, b);
    EXPECT_EQ(a.size(), 256u);
}

// The cone's rays end on the near side of the sphere (just short of it), inside the cone,
// and fill it: the disc's rim maps to the cone's rim, its centre to the axis.
TEST(SphereCone, RaysEndOnTheSphereInsideTheCone) {
    const Vec3 origin(1, 2, 3), center(4, 10, -2);
    const float R = 0.7f;
    SphereCone cone(origin, center, R);
    ASSERT_FALSE(cone.Inside());
    const DiscPattern d = DiscPattern::Golden(64, 4);
    float widest = 0;
    for (int turn : {0, 1, 517}) {
        cone.Turn(turn);
        for (int k = 0; k < d.Size(); ++k) {
            const Ray r = cone.RayTo(d.x[k], d.y[k], d.r2[k]);
            const Vec3 end = r.At(1.0f);
            EXPECT_NEAR(Length(end - center), R, 2e-3f) << k;  // on the sphere
            const float sinAngle = Length(Cross(Normalize(r.d), cone.Axis()));
            EXPECT_LE(sinAngle, R / cone.Distance() + 1e-5f);
            widest = std::max(widest, sinAngle);
            EXPECT_LT(r.tMax, 1.0f);
        }
    }
    EXPECT_GT(widest, 0.9f * R / cone.Distance());
    const Ray axis = cone.RayTo(0, 0, 0);
    EXPECT_NEAR(Length(axis.d), cone.Distance() - R, 1e-4f);
    EXPECT_NEAR(cone.TanHalfAngle(), R / std::sqrt(cone.Distance() * cone.Distance() - R * R), 1e-6f);
    EXPECT_TRUE(SphereCone(center + Vec3(0.1f, 0, 0), center, R).Inside());
}

// The turns are a full circle of unit vectors.
TEST(DiscTurns, AreUnitAndEven) {
    const DiscTurns& t = DiscTurns::Get();
    for (int k = 0; k < kDiscTurns; k += 37) EXPECT_NEAR(t.cs[k] * t.cs[k] + t.sn[k] * t.sn[k], 1.0f, 1e-6f);
    EXPECT_NEAR(t.cs[0], 1.0f, 1e-5f);
    EXPECT_GT(t.sn[0], 0.0f);  // half a step past 0
    EXPECT_NEAR(t.cs[kDiscTurns / 2], -1.0f, 1e-5f);
}

}  // namespace
}  // namespace disc_pattern_test
}  // namespace lm
