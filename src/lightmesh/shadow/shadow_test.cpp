#include "lightmesh/shadow/shadow.h"

#include <gtest/gtest.h>

#include <random>

#include "support/floor_scenes.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace {

using testing::AddBox;
using testing::FloorScene;

// LightsVisible traces a point's rays to the lights of a mask together (a packet on
// Embree, 16 at a time): each light must get LightVisible's answer, for any mask, also
// past 16 lights, where the rays go in more than one packet.
TEST(Shadow, LightsVisibleGivesEachLightItsOwnRaysAnswer) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0.5f, -1}, {1, 0.8f, 1});
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    s.lights.clear();
    for (int l = 0; l < 40; ++l) s.lights.push_back({{3 * u(rng), 2 + u(rng), 3 * u(rng)}, Color(1.0f), Falloff::None});
    for (const char* name : {"brute", "grid", "embree"}) {
        std::unique_ptr<Accelerator> accel;
        try {
            accel = CreateAccelerator(name, s.mesh);
        } catch (const Error&) {
            continue;  // a build without Embree
        }
        int visible = 0, checked = 0;
        for (int point = 0; point < 200; ++point) {
            const Vec3 origin(2 * u(rng), 1e-4f, 2 * u(rng));
            const uint64_t mask = (uint64_t(rng()) << 32 | rng()) & ((uint64_t(1) << s.lights.size()) - 1);
            const uint64_t got = LightsVisible(*accel, origin, s.lights, mask);
            EXPECT_EQ(got & ~mask, 0u) << name;
            for (size_t l = 0; l < s.lights.size(); ++l) {
                if (!((mask >> l) & 1)) continue;
                const bool alone = LightVisible(*accel, origin, s.lights[l].position);
                EXPECT_EQ(((got >> l) & 1) != 0, alone) << name << " light " << l;
                visible += alone;
                ++checked;
            }
        }
        EXPECT_GT(visible, checked / 10) << name;  // some lit, some in the box's shadow
        EXPECT_LT(visible, checked - checked / 10) << name;
    }
}

}  // namespace
}  // namespace lm
