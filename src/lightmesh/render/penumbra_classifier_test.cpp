#include "lightmesh/render/penumbra_classifier.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lm {
namespace penumbra_classifier_test {
namespace {

// A light of radius 1 at (0, 10, 0) over a receiver at the origin: its cone narrows from
// radius 1 at the light to 0 at the receiver (tan θ = 1/√99).
TEST(PenumbraClassifier, ConeHoldsWhatLiesBetweenThePointAndTheLight) {
    const Vec3 o(0, 0, 0), c(0, 10, 0);
    const float R = 1.0f, tan = 1.0f / std::sqrt(99.0f);
    EXPECT_TRUE(ConeHolds(o, c, R, Vec3(0, 5, 0), 0));                       // on the axis
    EXPECT_TRUE(ConeHolds(o, c, R, Vec3(0.99f * 5 * tan, 5, 0), 0));         // just inside
    EXPECT_FALSE(ConeHolds(o, c, R, Vec3(1.01f * 5 * tan, 5, 0), 0));        // just outside
    EXPECT_TRUE(ConeHolds(o, c, R, Vec3(1.01f * 5 * tan, 5, 0), 0.01f));     // within the slop
    EXPECT_FALSE(ConeHolds(o, c, R, Vec3(0, -1, 0), 1.0f));                  // behind the point
    EXPECT_FALSE(ConeHolds(o, c, R, Vec3(0, 10.5f, 0), 1.0f));               // beyond the light's centre
    EXPECT_FALSE(ConeHolds(Vec3(0, 9.5f, 0), c, R, Vec3(0, 9.7f, 0), 0));    // inside the light
    // A point light holds only its segment (with the slop around it).
    EXPECT_TRUE(ConeHolds(o, c, 0, Vec3(0, 3, 0), 0));
    EXPECT_FALSE(ConeHolds(o, c, 0, Vec3(0.1f, 3, 0), 0.05f));
}

// The penumbra's half width R·b/(d − b): a blocker halfway to the light casts a penumbra as
// wide as the light; stretched by 1/cos on a slanted receiver, at most 5×; in samples of
// the footprint, plus 2; capped.
TEST(PenumbraClassifier, ReachIsThePenumbrasHalfWidthInSamples) {
    const Vec3 o(0, 0, 0), c(0, 10, 0), up(0, 1, 0);
    EXPECT_NEAR(PenumbraReach(o, up, c, 1.0f, 5.0f, 0.1f, 1000), 10.0f + 2.0f, 1e-3f);
    EXPECT_NEAR(PenumbraReach(o, up, c, 1.0f, 1.0f, 0.1f, 1000), 1.0f / 9 / 0.1f + 2.0f, 1e-3f);
    const Vec3 slanted = Normalize(Vec3(1, 1, 0));  // cos 45°
    EXPECT_NEAR(PenumbraReach(o, slanted, c, 1.0f, 5.0f, 0.1f, 1000), 10.0f * std::sqrt(2.0f) + 2.0f, 1e-3f);
    const Vec3 grazing = Normalize(Vec3(1, 0.01f, 0));
    EXPECT_NEAR(PenumbraReach(o, grazing, c, 1.0f, 5.0f, 0.1f, 1000), 50.0f + 2.0f, 1e-3f);
    EXPECT_EQ(PenumbraReach(o, up, c, 1.0f, 5.0f, 0.1f, 8.0f), 8.0f);
    EXPECT_EQ(PenumbraReach(o, up, c, 1.0f, 5.0f, 0.0f, 8.0f), 8.0f);  // no footprint: the cap
}

}  // namespace
}  // namespace penumbra_classifier_test
}  // namespace lm
