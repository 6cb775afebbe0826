#include "lightmesh/render/whitted.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>

#include "support/floor_scenes.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace whitted_test {
namespace {

using testing::AddBox;
using testing::FloorScene;

struct Rig {
    std::unique_ptr<Accelerator> accel;
    std::unique_ptr<ShadowMethod> shadows;
    std::unique_ptr<WhittedRenderer> renderer;
    Rig(const Scene& s, const std::string& method = "rt", const std::string& accelName = "brute") {
        accel = CreateAccelerator(accelName, s.mesh);
        shadows = CreateShadowMethod(method, s, *accel, s.render);
        renderer = std::make_unique<WhittedRenderer>(s, *accel, *shadows, s.render);
    }
};

// Formula (1) by hand at the floor point seen through pixel (x, y).
Color ExpectedFloor(const Scene& s, int x, int y) {
    const CameraRays cam(s.camera, s.render.width, s.render.height);
    const Ray r = cam.Generate(x + 0.5f, y + 0.5f);
    const float t = -r.o.y / r.d.y;  // the floor is y = 0
    const Vec3 p = r.At(t);
    const Material& m = s.materials[0];
    Color expected = s.ambient * m.kd;
    for (const PointLight& l : s.lights) {
        const Vec3 toL = l.position - p;
        const float d2 = LengthSquared(toL);
        const float cosTheta = toL.y / std::sqrt(d2);  // n = (0, 1, 0)
        const Vec3 toEye = Normalize(-r.d);
        const Vec3 refl = Reflect(-Normalize(toL), Vec3(0, 1, 0));
        Color local = m.kd * cosTheta;
        const float cosR = Dot(refl, toEye);
        if (cosR > 0) local += m.ks * std::pow(cosR, m.phong);
        const float falloff = l.falloff == Falloff::InverseSquare ? 1.0f / d2 : 1.0f;
        expected += l.intensity * local * falloff;
    }
    return expected;
}

void ExpectColorNear(const Color& a, const Color& b, float rel = 1e-4f) {
    EXPECT_NEAR(a.r, b.r, rel * std::max(1.0f, std::abs(b.r)));
    EXPECT_NEAR(a.g, b.g, rel * std::max(1.0f, std::abs(b.g)));
    EXPECT_NEAR(a.b, b.b, rel * std::max(1.0f, std::abs(b.b)));
}

TEST(Whitted, UnoccludedPlaneMatchesFormulaOne) {
    Scene s = FloorScene();
    s.materials[0].ks = Color(0.3f);
    s.materials[0].phong = 8.0f;
    s.lights.push_back({{-3, 2, 1}, Color(0.4f, 0.5f, 0.6f), Falloff::None});
    Rig setup(s);
    RenderCounters c;
    for (auto [x, y] : {std::pair{24, 18}, {3, 30}, {40, 20}, {10, 5}, {47, 35}}) {
        SCOPED_TRACE(::testing::Message() << "pixel " << x << "," << y);
        ExpectColorNear(setup.renderer->Pixel(x, y, c), ExpectedFloor(s, x, y));
    }
    EXPECT_GT(c.shadowRays, 0u);
}

TEST(Whitted, FullyOccludedReceiverGetsAmbientOnly) {
    Scene s = FloorScene();
    AddBox(&s, {-20, 3.0f, -20}, {20, 3.5f, 20});  // a roof between the light and the floor
    s.camera = Camera{{0, 1, 4}, {0, 0, 0}, {0, 1, 0}, 40.0f};
    Rig setup(s);
    RenderCounters c;
    const Color ambientOnly = s.ambient * s.materials[0].kd;
    for (auto [x, y] : {std::pair{24, 30}, {5, 33}, {44, 28}}) EXPECT_EQ(setup.renderer->Pixel(x, y, c), ambientOnly);
    // With shadows off the same pixels are lit.
    Rig lit(s, "none");
    EXPECT_GT(lit.renderer->Pixel(24, 30, c).r, ambientOnly.r * 2);
}

TEST(Whitted, MirrorShowsTheReflectedColour) {
    Scene s = FloorScene();
    s.materials[0] = {"mirror", Color(0.0f), Color(0.0f), 1.0f, Color(0.8f, 0.5f, 0.25f)};
    s.ambient = Color(0.0f);
    Rig setup(s);
    RenderCounters c;
    // Every camera ray that hits the floor reflects up into the background.
    const Color expected = s.background * s.materials[0].mirror;
    EXPECT_EQ(setup.renderer->Pixel(24, 30, c), expected);
    EXPECT_EQ(c.reflectionRays, 1u);
    // A diffuse wall behind the camera is seen in the mirror: it is lit, so not background.
    AddBox(&s, {-20, 0, -7}, {20, 20, -6});  // the mirror reflects away from the camera
    s.materials[1].kd = Color(1.0f, 0.0f, 0.0f);
    s.lights[0].position = Vec3(0, 4, -5);
    Rig walled(s);
    const Color seen = walled.renderer->Pixel(24, 30, c);
    EXPECT_GT(seen.r, 0.0f);
    EXPECT_EQ(seen.g, 0.0f);
    EXPECT_EQ(seen.b, 0.0f);
    // max_depth 1: no reflected rays, so black.
    s.render.maxDepth = 1;
    Rig shallow(s);
    EXPECT_EQ(shallow.renderer->Pixel(24, 30, c), Color(0.0f));
}

TEST(Whitted, MissesShowTheBackground) {
    Scene s = FloorScene();
    s.camera = Camera{{0, 3, 4}, {0, 6, 0}, {0, 1, 0}, 30.0f};  // looking up, away from the floor
    Rig setup(s);
    RenderCounters c;
    EXPECT_EQ(setup.renderer->Pixel(24, 18, c), s.background);
}

TEST(Whitted, NoShadowAcneOnLargeAndSmallScenes) {
    // A lit floor must be lit at every pixel, at any scale: a self-hit would darken some.
    for (float scale : {1e-3f, 1.0f, 1e4f}) {
        Scene s = FloorScene(10.0f * scale);
        s.lights[0].position = s.lights[0].position * scale;
        s.lights[0].falloff = Falloff::None;
        s.camera.position = s.camera.position * scale;
        Rig setup(s);
        const RenderResult r = setup.renderer->Render();
        Rig lit(s, "none");
        const RenderResult expected = lit.renderer->Render();
        EXPECT_EQ(r.image.pixels, expected.image.pixels) << "scale " << scale;
    }
}

// The estimate bounded in time (bench's probes): slow tiles (area sampling with
// 256 rays per light on the brute-force back-end) stop being started after half the bound
// in each half, and the figure, from the tiles done, stays near the unbounded one.
TEST(Whitted, EstimateStopsAtItsTimeBound) {
    Scene s = FloorScene();
    AddBox(&s, {-0.5f, 0, -0.5f}, {0.5f, 1, 0.5f});
    s.render.width = 256;
    s.render.height = 256;
    s.render.areaLight.radius = 0.3f;
    s.render.areaLight.samples = 256;
    Rig setup(s, "area", "brute");
    auto timed = [&](double bound, double* seconds) {
        const auto start = std::chrono::steady_clock::now();
        const double e = setup.renderer->EstimateSeconds(64, bound);
        *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return e;
    };
    double fullTook = 0, boundedTook = 0;
    const double full = timed(0, &fullTook);
    const double bounded = timed(0.1, &boundedTook);
    EXPECT_GT(bounded, 0);
    // 64 tiles against 0.1 s and the tiles in flight (comparisons, not a clock's figure).
    EXPECT_LT(boundedTook, 0.5 * fullTook) << boundedTook << " s against " << fullTook << " s";
    EXPECT_GT(bounded, full / 3);
    EXPECT_LT(bounded, full * 3);
}

TEST(Whitted, ImageIsIdenticalForAnyThreadCount) {
    Scene s = FloorScene();
    AddBox(&s, {-0.5f, 0, -0.5f}, {0.5f, 1, 0.5f});
    s.render.aa = 2;
    Rig setup(s, "rt", "grid");
    RenderResult one, many;
    tbb::task_arena(1).execute([&] { one = setup.renderer->Render(); });
    tbb::task_arena(4).execute([&] { many = setup.renderer->Render(); });
    EXPECT_EQ(one.image.pixels, many.image.pixels);
    EXPECT_EQ(one.counters.shadowRays, many.counters.shadowRays);
    EXPECT_EQ(one.counters.cameraRays, 4u * s.render.width * s.render.height);
}

// Render() traces each 8x8 block's camera rays as one packet (IntersectMany); Pixel() traces
// them one by one. Every back-end answers a ray in a packet as alone, so the two give the
// same pixels bit for bit: on an image whose size is not a multiple of the blocks, with
// sub-pixel samples, a mirror and boxes, on every back-end.
TEST(Whitted, PacketTracedTilesEqualPixelByPixel) {
    Scene s = FloorScene();
    AddBox(&s, {-0.5f, 0, -0.5f}, {0.5f, 1, 0.5f});
    AddBox(&s, {0.7f, 0, 0.2f}, {1.1f, 0.3f, 0.6f});
    s.materials[0].mirror = Color(0.3f);
    s.camera.lookAt = {0, 2.0f, 0};  // the floor's far edge and the sky beyond it in view
    s.render.width = 37;
    s.render.height = 29;
    for (int aa : {1, 2}) {
        s.render.aa = aa;
        for (const char* accel : {"brute", "grid", "embree"}) {
#ifndef LIGHTMESH_HAS_EMBREE
            if (std::string(accel) == "embree") continue;
#endif
            Rig setup(s, "rt", accel);
            const RenderResult r = setup.renderer->Render();
            RenderCounters c;
            int differ = 0, background = 0;
            for (int y = 0; y < s.render.height; ++y)
                for (int x = 0; x < s.render.width; ++x) {
                    const Color one = setup.renderer->Pixel(x, y, c);
                    differ += !(one == r.image.At(x, y));
                    background += one == s.background;
                }
            EXPECT_EQ(differ, 0) << accel << " aa " << aa;
            EXPECT_GT(background, 0) << accel;  // some rays miss everything
            EXPECT_LT(background, s.render.width * s.render.height / 2) << accel;
            EXPECT_EQ(r.counters.cameraRays, uint64_t(aa * aa) * uint64_t(s.render.width * s.render.height));
        }
    }
}

TEST(Whitted, BadSettingsAreErrors) {
    Scene s = FloorScene();
    s.camera.lookAt = s.camera.position;
    EXPECT_THROW(Rig{s}, Error);
    s = FloorScene();
    s.camera.up = s.camera.lookAt - s.camera.position;
    EXPECT_THROW(Rig{s}, Error);
    s = FloorScene();
    s.render.aa = 0;
    EXPECT_THROW(Rig{s}, Error);
}

}  // namespace
}  // namespace whitted_test
}  // namespace lm
