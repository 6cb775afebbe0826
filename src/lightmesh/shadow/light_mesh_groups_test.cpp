// The light mesh past 62 lights (groups of lights, a light mesh each): the groups, the
// storage, and that every light gets the value it gets alone.
#include "lightmesh/shadow/light_mesh_groups.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "support/floor_scenes.h"
#include "support/light_mesh_probe.h"

namespace lm {
namespace light_mesh_groups_test {
namespace {

using testing::AddBox;
using testing::FloorScene;
using testing::RenderedFloorPoint;

TEST(LightMeshGroups, GroupsHoldEveryLightOnceAndNearbyLightsTogether) {
    std::vector<PointLight> lights(1000);
    for (size_t i = 0; i < lights.size(); ++i)
        lights[i].position = Vec3(static_cast<float>((i * 37) % 100), 3.0f, static_cast<float>((i * 91) % 97));
    const auto groups = LightGroups(lights, kMaxLightsPerWord);
    ASSERT_EQ(groups.size(), 17u);  // ceil(1000 / 62)
    std::set<uint32_t> seen;
    for (const auto& g : groups) {
        EXPECT_GE(g.size(), 58u);
        EXPECT_LE(g.size(), 59u);
        EXPECT_TRUE(std::is_sorted(g.begin(), g.end()));
        seen.insert(g.begin(), g.end());
        // Nearby together: a group's lights span far less than the 100 × 97 field.
        Bounds3 box;
        for (uint32_t id : g) box.Extend(lights[id].position);
        EXPECT_LT(box.Diagonal().x * box.Diagonal().z, 0.35f * 100 * 97);
    }
    EXPECT_EQ(seen.size(), lights.size());
    // Up to 62 lights: one group, in order.
    lights.resize(62);
    const auto one = LightGroups(lights, kMaxLightsPerWord);
    ASSERT_EQ(one.size(), 1u);
    for (uint32_t i = 0; i < 62; ++i) EXPECT_EQ(one[0][i], i);
}

TEST(LightMeshGroups, StorageIsAWordPerGroup) {
    EXPECT_EQ(LightMeshBytesPerNode(63), 16);     // 32 + 31 lights: 8 bytes each
    EXPECT_EQ(LightMeshBytesPerNode(124), 16);    // 2 × 62
    EXPECT_EQ(LightMeshBytesPerNode(125), 24);    // 3 groups
    EXPECT_EQ(LightMeshBytesPerNode(1024), 136);  // 17 groups of 60 or 61
    EXPECT_EQ(LightMeshBytesPerNode(4096), 67 * 8);
}

// A floor with two boxes under `n` lights in a grid 2.5 to 3.3 units up.
Scene ManyLightScene(int n) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0, -1}, {0.6f, 0.5f, 0.3f});
    AddBox(&s, {0.9f, 0.7f, -0.4f}, {1.6f, 0.8f, 0.9f});
    s.lights.clear();
    for (int i = 0; i < n; ++i) {
        const float x = -3.0f + 6.0f * static_cast<float>(i % 10) / 9.0f, z = -3.0f + 6.0f * static_cast<float>(i / 10 % 10) / 9.0f;
        s.lights.push_back({Vec3(x, 2.5f + 0.8f * static_cast<float>(i / 100) / 2.0f, z), Color(0.05f), Falloff::InverseSquare});
    }
    return s;
}

// VisibilityOfMasks (the groups hand each group's mesh its points' lights as masks) gives
// each needed light its Visibility value and leaves the other entries alone: a mesh of one
// word (its own override, with and without a light radius: the batched penumbra mode) and
// the groups' mesh of 130 lights (the default, through the lists; its first 64 lights).
TEST(LightMeshGroups, MasksGiveWhatTheListsGive) {
    for (const int lights : {40, 130})
        for (const float radius : {0.0f, 0.08f}) {
            const Scene s = ManyLightScene(lights);
            const testing::LightMeshProbe probe(s, testing::LightMeshSettings(40, 2.0f, "consensus", radius));
            std::vector<ShadingPoint> points;
            for (float x = -2.2f; x <= 2.6f; x += 0.31f)
                for (float z = -2.1f; z <= 2.2f; z += 0.37f) points.push_back(RenderedFloorPoint(x, z));
            const size_t n = std::min<size_t>(64, s.lights.size());
            std::vector<uint64_t> masks(points.size());
            for (size_t p = 0; p < points.size(); ++p)
                for (size_t l = 0; l < n; ++l)
                    if ((p * 7 + l * 3) % 5 != 0) masks[p] |= uint64_t(1) << l;  // some lights not needed
            const float kSentinel = -3.0f;
            std::vector<LightMeshShadows::LightValues> byMask(points.size());
            for (auto& v : byMask) std::fill(v, v + 64, kSentinel);
            RenderCounters c;
            probe.lmm->VisibilityOfMasks(points.data(), masks.data(), byMask.data(), points.size(), c);
            int partial = 0;
            for (size_t p = 0; p < points.size(); ++p) {
                std::vector<uint32_t> ids;
                for (size_t l = 0; l < n; ++l)
                    if ((masks[p] >> l) & 1) ids.push_back(static_cast<uint32_t>(l));
                std::vector<float> vis(ids.size(), -1.0f);
                probe.lmm->Visibility(points[p], ids, vis.data(), c);
                for (size_t l = 0, k = 0; l < 64; ++l) {
                    if (!((masks[p] >> l) & 1)) {
                        ASSERT_EQ(byMask[p][l], kSentinel) << lights << " lights, point " << p << ", light " << l;
                        continue;
                    }
                    ASSERT_EQ(byMask[p][l], vis[k]) << lights << " lights, radius " << radius << ", point " << p << ", light " << l;
                    partial += vis[k] > 0 && vis[k] < 1;
                    ++k;
                }
            }
            EXPECT_GT(partial, 20) << lights << " lights, radius " << radius;
        }
}

// Formula (2) averages each light's bits over a node set that does not depend on the
// lights, so with 130 lights in three groups every light's value is its value alone (the
// light mesh run one light, one bit, at a time), to the bit; point by point and in blocks
// (VisibilityMany, which the renderer calls); with ranges too, for the lights in range
// (their nodes evaluate no bit beyond range + reach).
TEST(LightMeshGroups, ManyLightsEqualTheLightMeshRunLightByLight) {
    for (const bool ranged : {false, true}) {
        Scene s = ManyLightScene(130);
        if (ranged)
            for (PointLight& l : s.lights) l.range = 3.4f;
        const LightMeshOptions options = testing::LightMeshSettings(40, 2.0f, "consensus");
        testing::LightMeshProbe many(s, options);
        ASSERT_EQ(many.lmm->BytesPerNode(), LightMeshBytesPerNode(130));
        std::vector<ShadingPoint> points;
        for (float x = -2.2f; x <= 2.6f; x += 0.173f)
            for (float z = -2.1f; z <= 2.2f; z += 0.191f) points.push_back(RenderedFloorPoint(x, z));
        const size_t n = s.lights.size();
        std::vector<uint8_t> needed(points.size() * n);
        for (size_t p = 0; p < points.size(); ++p)
            for (size_t l = 0; l < n; ++l)
                needed[p * n + l] = !ranged || Length(points[p].p - s.lights[l].position) <= s.lights[l].range;
        std::vector<float> one(points.size() * n, -1.0f), block(points.size() * n, -1.0f);
        RenderCounters c;
        for (size_t p = 0; p < points.size(); ++p)
            testing::FlaggedVisibility(*many.lmm, points[p], &needed[p * n], n, &one[p * n], c);
        testing::FlaggedVisibilityMany(*many.lmm, points.data(), points.size(), needed.data(), n, block.data(), c);
        int partial = 0, checked = 0;
        for (size_t l = 0; l < n; l += 3) {  // every third light alone (a mesh each)
            Scene alone = s;
            alone.lights = {s.lights[l]};
            alone.lights[0].range = Infinity;
            testing::LightMeshProbe single(alone, options);
            for (size_t p = 0; p < points.size(); ++p) {
                if (!needed[p * n + l]) continue;
                const float own = single.Vis(points[p]);
                ASSERT_EQ(one[p * n + l], own) << "light " << l << ", point " << p << (ranged ? ", ranged" : "");
                ASSERT_EQ(block[p * n + l], own) << "light " << l << ", point " << p << (ranged ? ", ranged" : "");
                partial += own > 0 && own < 1;
                ++checked;
            }
        }
        EXPECT_GT(partial, 200) << ranged;  // penumbrae were compared
        if (ranged) {
            EXPECT_LT(checked, 0.6 * static_cast<double>(points.size() * ((n + 2) / 3))) << "ranges cut nothing";
        }
    }
}

}  // namespace
}  // namespace light_mesh_groups_test
}  // namespace lm
