#include "lightmesh/render/light_lists.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace lm {
namespace light_lists_test {
namespace {

// Against brute force: for random lights (some without a range) and random points in and
// around the box, Near(p) holds every light with a range that reaches p, in ascending
// order, and Everywhere() the lights without one.
TEST(LightLists, NearHoldsEveryLightWhoseRangeReachesThePoint) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    const Bounds3 box(Vec3(-10, 0, -20), Vec3(30, 5, 20));
    for (int trial = 0; trial < 4; ++trial) {
        std::vector<PointLight> lights(300);
        for (size_t i = 0; i < lights.size(); ++i) {
            lights[i].position = Vec3(10 + 25 * u(rng), 2.5f + 4 * u(rng), 25 * u(rng));
            if (i % 7 != 3) lights[i].range = (trial + 1) * (1.5f + u(rng));
        }
        const LightLists lists(lights, box);
        ASSERT_TRUE(lists.Active());
        std::vector<uint32_t> everywhere;
        for (uint32_t i = 0; i < lights.size(); ++i)
            if (!std::isfinite(lights[i].range)) everywhere.push_back(i);
        EXPECT_TRUE(std::equal(everywhere.begin(), everywhere.end(), lists.Everywhere().begin(), lists.Everywhere().end()));
        size_t reached = 0, listed = 0;
        for (int k = 0; k < 20000; ++k) {
            const Vec3 p(10 + 21 * u(rng), 2.5f + 2.7f * u(rng), 21 * u(rng));  // a little beyond the box too
            const auto near = lists.Near(p);
            ASSERT_TRUE(std::is_sorted(near.begin(), near.end()));
            if (box.Contains(p)) listed += near.size();
            for (uint32_t i = 0; i < lights.size(); ++i) {
                if (!std::isfinite(lights[i].range)) continue;
                if (LengthSquared(p - lights[i].position) > lights[i].range * lights[i].range) continue;
                reached += box.Contains(p);
                ASSERT_TRUE(std::binary_search(near.begin(), near.end(), i)) << "light " << i << ", trial " << trial;
            }
        }
        EXPECT_GT(reached, 1000u);
        // Inside the box the lists are short: a few times the lights that do reach (cells of
        // half the median range; outside the grid a point gets every light with a range).
        EXPECT_LT(listed, 12 * reached) << "trial " << trial;
    }
}

TEST(LightLists, InactiveWithoutRanges) {
    std::vector<PointLight> lights(5);
    EXPECT_FALSE(LightLists(lights, Bounds3(Vec3(0, 0, 0), Vec3(1, 1, 1))).Active());
    lights[2].range = 0.5f;
    const LightLists lists(lights, Bounds3(Vec3(0, 0, 0), Vec3(1, 1, 1)));
    EXPECT_TRUE(lists.Active());
    EXPECT_EQ(lists.Everywhere().size(), 4u);
    // A point outside the grid gets every light with a range.
    EXPECT_EQ(lists.Near(Vec3(100, 0, 0)).size(), 1u);
}

}  // namespace
}  // namespace light_lists_test
}  // namespace lm
