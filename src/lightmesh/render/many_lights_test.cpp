// Scenes of many lights (100 and more, up to 4,096) through the renderer, in every method:
// determinism, and the lights' ranges culling nothing they should not.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <memory>

#include "support/floor_scenes.h"
#include "lightmesh/render/whitted.h"

namespace lm {
namespace {

using testing::AddBox;
using testing::FloorScene;

// A floor with boxes under `n` lights in a 16-wide grid, 2.5 to 3.5 units up.
Scene ManyLights(int n, float range = Infinity) {
    Scene s = FloorScene(6.0f);
    AddBox(&s, {-1, 0, -1}, {0.6f, 0.5f, 0.3f});
    AddBox(&s, {0.9f, 0.7f, -0.4f}, {1.6f, 0.8f, 0.9f});
    AddBox(&s, {-2.5f, 0, 1.0f}, {-2.3f, 1.4f, 1.2f});
    s.lights.clear();
    const int rows = (n + 15) / 16;
    for (int i = 0; i < n; ++i) {
        const float x = -4.0f + 8.0f * static_cast<float>(i % 16) / 15.0f;
        const float z = -4.0f + 8.0f * static_cast<float>(i / 16) / static_cast<float>(std::max(rows - 1, 1));
        PointLight l{Vec3(x, 2.5f + 0.37f * static_cast<float>(i % 3), z), Color(8.0f / static_cast<float>(n)),
                     Falloff::InverseSquare};
        l.radius = 0.06f;
        l.range = range;
        s.lights.push_back(l);
    }
    s.render.width = 40;
    s.render.height = 30;
    s.render.lightMesh.cc = 40;
    s.render.areaLight.samples = 4;
    return s;
}

Image Render(const Scene& s, const std::string& method, int threads = 2) {
    auto accel = CreateAccelerator("embree", s.mesh);
    Image image;
    tbb::task_arena(threads).execute([&] {
        auto shadows = CreateShadowMethod(method, s, *accel, s.render);
        image = WhittedRenderer(s, *accel, *shadows, s.render).Render().image;
    });
    return image;
}

const char* const kMethods[] = {"rt", "soft", "lmm", "area"};

TEST(ManyLights, ImagesAreIdenticalForAnyThreadCount) {
    for (const float range : {Infinity, 2.5f}) {
        const Scene s = ManyLights(130, range);
        for (const char* method : kMethods) {
            const Image one = Render(s, method, 1), many = Render(s, method, 4);
            EXPECT_EQ(one.pixels, many.pixels) << method << ", range " << range;
        }
    }
}

// A range longer than the scene culls nothing: the image is the one without ranges, to the
// bit, in every method (the lights' terms add in the same order through the cells' lists).
TEST(ManyLights, RangeCoveringTheSceneCullsNothing) {
    const Scene without = ManyLights(130), with = ManyLights(130, 100.0f);
    for (const char* method : kMethods) EXPECT_EQ(Render(without, method).pixels, Render(with, method).pixels) << method;
}

// RT with culling: where every light is in range of the point a pixel sees, the pixel is
// the one RT gives without ranges; elsewhere the lights beyond range are missing, so those
// pixels are darker or equal.
TEST(ManyLights, RtWithCullingEqualsRtWithoutWhereLightsAreInRange) {
    Scene with = ManyLights(130, 2.9f), without = ManyLights(130);
    with.render.maxDepth = without.render.maxDepth = 1;
    const Image a = Render(with, "rt"), b = Render(without, "rt");
    auto accel = CreateAccelerator("embree", with.mesh);
    const CameraRays camera(with.camera, with.render.width, with.render.height);
    int inRange = 0, culled = 0;
    for (int y = 0; y < with.render.height; ++y)
        for (int x = 0; x < with.render.width; ++x) {
            const Ray ray = camera.Generate(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
            Hit hit;
            if (!accel->Intersect(ray, &hit)) continue;
            const Vec3 p = WhittedRenderer::MakeShadingPoint(with.mesh, ray, hit).p;
            bool all = true;
            for (const PointLight& l : with.lights) all = all && LengthSquared(p - l.position) <= l.range * l.range;
            const Color &ca = a.At(x, y), &cb = b.At(x, y);
            if (all) {
                ++inRange;
                EXPECT_EQ(ca.r, cb.r) << x << ", " << y;
                EXPECT_EQ(ca.g, cb.g) << x << ", " << y;
                EXPECT_EQ(ca.b, cb.b) << x << ", " << y;
            } else {
                culled += ca.r < cb.r;
                EXPECT_LE(ca.r, cb.r) << x << ", " << y;
            }
        }
    EXPECT_GT(culled, 100);
    // Everything in range: the range sphere covers the scene, and the images agree wholly.
    Scene all = ManyLights(130, 30.0f);
    all.render.maxDepth = 1;
    EXPECT_EQ(Render(all, "rt").pixels, b.pixels);
}

// 4,096 lights in every method (a light mesh of 67 groups), with ranges: the images light
// the floor, and every method sees the same lights (the unshadowed image is the same).
TEST(ManyLights, FourThousandLightsInEveryMethod) {
    Scene s = ManyLights(4096, 1.5f);
    s.render.width = 24;
    s.render.height = 18;
    const Image none = Render(s, "none");
    double sum = 0;
    for (const Color& c : none.pixels) sum += c.r;
    EXPECT_GT(sum / static_cast<double>(none.pixels.size()), 0.02);
    for (const char* method : kMethods) {
        const Image img = Render(s, method);
        double lit = 0;
        for (size_t i = 0; i < img.pixels.size(); ++i) {
            ASSERT_LE(img.pixels[i].r, none.pixels[i].r + 1e-6f) << method;
            lit += img.pixels[i].r;
        }
        EXPECT_GT(lit, 0.5 * sum) << method;
    }
}

}  // namespace
}  // namespace lm
