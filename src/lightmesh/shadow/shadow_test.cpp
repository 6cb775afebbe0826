#include "lightmesh/shadow/shadow.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <vector>

#include "support/floor_scenes.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace shadow_test {
namespace {

using testing::AddBox;
using testing::FloorScene;

// A box floating over the floor and `lights` lights above it at random, drawn from rng.
Scene BoxUnderLights(int lights, std::mt19937& rng) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0.5f, -1}, {1, 0.8f, 1});
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    s.lights.clear();
    for (int l = 0; l < lights; ++l) s.lights.push_back({{3 * u(rng), 2 + u(rng), 3 * u(rng)}, Color(1.0f), Falloff::None});
    return s;
}

// Calls f(name, accel) for each back-end this build has.
template <typename F>
void ForEachAccel(const Scene& s, F&& f) {
    for (const char* name : {"brute", "grid", "embree"}) {
        std::unique_ptr<Accelerator> accel;
        try {
            accel = CreateAccelerator(name, s.mesh);
        } catch (const Error&) {
            continue;  // a build without Embree
        }
        f(name, *accel);
    }
}

// LightRadii: each light's own radius, unless the override (--light-radius, the scene's
// "light_radius", or code such as the bench setting areaLight.radius) is given, which then
// replaces every one, 0 included.
TEST(Shadow, LightRadiiAreTheLightsOwnUnlessOverridden) {
    Scene s = FloorScene();
    s.lights.push_back({{-2, 3, 1}, Color(5.0f), Falloff::InverseSquare, 0.25f});
    s.lights.push_back({{2, 3, 1}, Color(5.0f), Falloff::InverseSquare, 0.0f});
    s.lights[0].radius = 0.1f;
    RenderOptions o;
    EXPECT_EQ(LightRadii(s, o), (std::vector<float>{0.1f, 0.25f, 0.0f}));
    o.areaLight.radius = 0.5f;
    EXPECT_EQ(LightRadii(s, o), (std::vector<float>{0.5f, 0.5f, 0.5f}));
    o.areaLight.radius = 0.0f;  // every light a point
    EXPECT_EQ(LightRadii(s, o), (std::vector<float>{0.0f, 0.0f, 0.0f}));
    o.areaLight.radius.reset();
    EXPECT_EQ(LightRadii(s, o), (std::vector<float>{0.1f, 0.25f, 0.0f}));
    s.lights.clear();
    EXPECT_TRUE(LightRadii(s, o).empty());
}

// LightsVisible traces a point's rays to the lights of a mask together (a packet on
// Embree, 16 at a time): each light must get LightVisible's answer, for any mask, also
// past 16 lights, where the rays go in more than one packet.
TEST(Shadow, LightsVisibleGivesEachLightItsOwnRaysAnswer) {
    std::mt19937 rng(5);
    const Scene s = BoxUnderLights(40, rng);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    ForEachAccel(s, [&](const char* name, const Accelerator& accel) {
        int visible = 0, checked = 0;
        for (int point = 0; point < 200; ++point) {
            const Vec3 origin(2 * u(rng), 1e-4f, 2 * u(rng));
            const uint64_t mask = (uint64_t(rng()) << 32 | rng()) & ((uint64_t(1) << s.lights.size()) - 1);
            const uint64_t got = LightsVisible(accel, origin, s.lights, mask);
            EXPECT_EQ(got & ~mask, 0u) << name;
            for (size_t l = 0; l < s.lights.size(); ++l) {
                if (!((mask >> l) & 1)) continue;
                const bool alone = LightVisible(accel, origin, s.lights[l].position);
                EXPECT_EQ(((got >> l) & 1) != 0, alone) << name << " light " << l;
                visible += alone;
                ++checked;
            }
        }
        EXPECT_GT(visible, checked / 10) << name;  // some lit, some in the box's shadow
        EXPECT_LT(visible, checked - checked / 10) << name;
    });
}

// LightsVisibleMany traces many points' rays light by light (64 at a time): each (point,
// light) of the masks must get LightVisible's answer, the bits outside a mask stay clear,
// and the count of rays is the masks' bits; over more points than a chunk holds.
TEST(Shadow, LightsVisibleManyGivesEachPointItsOwnRaysAnswer) {
    std::mt19937 rng(7);
    const Scene s = BoxUnderLights(5, rng);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    ForEachAccel(s, [&](const char* name, const Accelerator& accel) {
        constexpr size_t kPoints = 150;
        std::vector<ShadingPoint> points(kPoints);
        std::vector<uint64_t> masks(kPoints), visible(kPoints, ~uint64_t(0));
        uint64_t bits = 0;
        for (size_t i = 0; i < kPoints; ++i) {
            points[i].p = Vec3(2 * u(rng), 0, 2 * u(rng));
            points[i].n = Vec3(0, 1, 0);
            points[i].origin = points[i].p + Vec3(0, 1e-4f, 0);
            masks[i] = rng() & 31;
            bits += static_cast<uint64_t>(__builtin_popcountll(masks[i]));
        }
        EXPECT_EQ(LightsVisibleMany(accel, points.data(), kPoints, s.lights, masks.data(), visible.data()), bits) << name;
        int seen = 0, checked = 0;
        for (size_t i = 0; i < kPoints; ++i) {
            EXPECT_EQ(visible[i] & ~masks[i], 0u) << name;
            for (size_t l = 0; l < s.lights.size(); ++l) {
                if (!((masks[i] >> l) & 1)) continue;
                const bool alone = LightVisible(accel, points[i].origin, s.lights[l].position);
                EXPECT_EQ(((visible[i] >> l) & 1) != 0, alone) << name << " point " << i << " light " << l;
                seen += alone;
                ++checked;
            }
        }
        EXPECT_GT(seen, checked / 10) << name;  // some lit, some in the box's shadow
        EXPECT_LT(seen, checked - checked / 10) << name;
    });
}

}  // namespace
}  // namespace shadow_test
}  // namespace lm
