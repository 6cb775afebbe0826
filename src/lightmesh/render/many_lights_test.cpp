// Scenes of many lights (100 and more, up to 4,096) through the renderer, in every method:
// determinism, and the lights' ranges culling nothing they should not.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "support/floor_scenes.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/render/whitted.h"

namespace lm {
namespace many_lights_test {
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

const char* const kMethods[] = {"rt", "soft", "exact", "lmm", "area"};

TEST(ManyLights, ImagesAreIdenticalForAnyThreadCount) {
    for (const float range : {Infinity, 2.5f}) {
        const Scene s = ManyLights(130, range);
        for (const char* method : kMethods) {
            const Image one = Render(s, method, 1), many = Render(s, method, 4);
            EXPECT_EQ(one.pixels, many.pixels) << method << ", range " << range;
        }
        Scene cut = s;  // the soft default's light cut (render/light_cut.h)
        cut.render.lightCut = kDefaultLightCutError;
        EXPECT_EQ(Render(cut, "soft", 1).pixels, Render(cut, "soft", 4).pixels) << "light cut, range " << range;
    }
}

// A range longer than the scene culls nothing: the image is the one without ranges, to the
// bit, in every method (the lights' terms add in the same order through the cells' lists).
// Soft shades every light (--light-cut 0), as it does automatically below 512 lights.
TEST(ManyLights, RangeCoveringTheSceneCullsNothing) {
    Scene without = ManyLights(130), with = ManyLights(130, 100.0f);
    without.render.lightCut = with.render.lightCut = 0;
    for (const char* method : kMethods) EXPECT_EQ(Render(without, method).pixels, Render(with, method).pixels) << method;
}

// The soft default with a light cut of the default bound (render/light_cut.h; made
// automatically from 512 lights) under 130 lights: the image stays near the exact sum's
// (every pixel within 3 % of its value, the mean within 0.3 %), for fewer (point, light)
// pairs; 0 is the exact sum itself.
TEST(ManyLights, TheSoftDefaultsLightCutStaysNearTheExactSum) {
    Scene s = ManyLights(130);
    s.render.maxDepth = 1;
    s.render.lightCut = kDefaultLightCutError;
    auto accel = CreateAccelerator("embree", s.mesh);
    auto shadows = CreateShadowMethod("soft", s, *accel, s.render);
    const WhittedRenderer cut(s, *accel, *shadows, s.render);
    ASSERT_NE(cut.Cuts(), nullptr);
    EXPECT_EQ(cut.Cuts()->Error(), kDefaultLightCutError);
    const RenderResult a = cut.Render();
    s.render.lightCut = 0;
    const WhittedRenderer exact(s, *accel, *shadows, s.render);
    EXPECT_EQ(exact.Cuts(), nullptr);
    const RenderResult b = exact.Render();
    EXPECT_GT(a.counters.cutEntries, 0u);
    EXPECT_LT(a.counters.cutEntries, a.counters.shadingPoints * 130 * 9 / 10);
    EXPECT_LE(a.counters.cutLargest, 130u);
    double sumA = 0, sumB = 0;
    for (size_t i = 0; i < a.image.pixels.size(); ++i) {
        const Color &p = a.image.pixels[i], &q = b.image.pixels[i];
        EXPECT_NEAR(p.g, q.g, 0.03f * q.g + 1e-4f) << i;
        sumA += p.g, sumB += q.g;
    }
    EXPECT_NEAR(sumA, sumB, 0.003 * sumB);
    EXPECT_NE(a.image.pixels, b.image.pixels);  // the cut is an estimate, not the sum
}

// The soft default's frame with a light cut: the same bytes for any thread count.
TEST(ManyLights, TheSoftFramesLightCutIsTheSameForAnyThreadCount) {
    Scene s = ManyLights(130);
    s.render.lightCut = kDefaultLightCutError;
    const RenderJob job(s, s.render);
    ASSERT_NE(job.Renderer().Cuts(), nullptr);
    RenderResult one, many;
    tbb::task_arena(1).execute([&] { one = job.Render(); });
    tbb::task_arena(4).execute([&] { many = job.Render(); });
    EXPECT_EQ(one.image.pixels, many.image.pixels);
    EXPECT_GT(one.counters.cutEntries, 0u);
    EXPECT_EQ(one.counters.cutEntries, many.counters.cutEntries);
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

// With ranges a point needs few of the scene's lights, and every method is handed those
// only (ShadowMethod::Visibility's list): it writes their values, in the list's order, and
// nothing past them (every other entry of a buffer with room for all the scene's lights
// keeps its sentinel); each value is the one the light gets asked alone, point by point
// and in blocks (VisibilityMany, which the renderer calls); RT traces one ray per listed
// light and no more.
TEST(ManyLights, EveryMethodWritesOnlyTheLightsAPointNeeds) {
    Scene s = ManyLights(130, 2.8f);
    auto accel = CreateAccelerator("embree", s.mesh);
    const CameraRays camera(s.camera, s.render.width, s.render.height);
    std::vector<ShadingPoint> points;
    std::vector<std::vector<uint32_t>> lists;
    size_t listed = 0, most = 0;
    for (int y = 0; y < s.render.height; y += 2)
        for (int x = 0; x < s.render.width; x += 2) {
            const Ray ray = camera.Generate(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
            Hit hit;
            if (!accel->Intersect(ray, &hit)) continue;
            const ShadingPoint sp = WhittedRenderer::MakeShadingPoint(s.mesh, ray, hit);
            std::vector<uint32_t> ids;
            for (size_t l = 0; l < s.lights.size(); ++l) {
                const Vec3 d = s.lights[l].position - sp.p;
                if (LengthSquared(d) <= s.lights[l].range * s.lights[l].range && Dot(sp.n, d) > 0)
                    ids.push_back(static_cast<uint32_t>(l));
            }
            if (ids.empty()) continue;
            listed += ids.size(), most = std::max(most, ids.size());
            points.push_back(sp), lists.push_back(std::move(ids));
        }
    ASSERT_GT(points.size(), 100u);
    ASSERT_LT(most, 40u);  // few of the 130 lights at every point
    ASSERT_LT(static_cast<double>(listed) / static_cast<double>(points.size()), 20.0);
    const float kSentinel = -7.0f;
    struct Case {
        const char* method;
        float lightRadius;  // > 0: the override (lmm's contact-hardening mode)
    };
    for (const Case c : {Case{"none", 0}, Case{"rt", 0}, Case{"soft", 0}, Case{"exact", 0}, Case{"area", 0}, Case{"denoised", 0},
                         Case{"lmm", 0}, Case{"lmm", 0.06f}}) {
        RenderOptions options = s.render;
        if (c.lightRadius > 0) options.areaLight.radius = c.lightRadius;
        const auto method = CreateShadowMethod(c.method, s, *accel, options);
        const std::string what = std::string(c.method) + (c.lightRadius > 0 ? " with a light radius" : "");
        std::vector<std::vector<float>> block(points.size(), std::vector<float>(s.lights.size() + 1, kSentinel));
        std::vector<LightIndices> spans(lists.begin(), lists.end());
        std::vector<float*> out;
        for (auto& b : block) out.push_back(b.data());
        RenderCounters many;
        method->VisibilityMany(points.data(), spans.data(), out.data(), points.size(), many);
        uint64_t rays = 0;
        for (size_t p = 0; p < points.size(); ++p) {
            std::vector<float> vis(s.lights.size() + 1, kSentinel);
            RenderCounters one;
            method->Visibility(points[p], lists[p], vis.data(), one);
            rays += one.shadowRays;
            for (size_t k = 0; k < vis.size(); ++k) {
                if (k >= lists[p].size()) {
                    ASSERT_EQ(vis[k], kSentinel) << what << ": point " << p << " wrote entry " << k << " past its list";
                    ASSERT_EQ(block[p][k], kSentinel) << what << " (block): point " << p << " wrote entry " << k;
                    continue;
                }
                ASSERT_TRUE(vis[k] >= 0.0f && vis[k] <= 1.0f) << what << ": point " << p << ", entry " << k;
                ASSERT_EQ(std::memcmp(&block[p][k], &vis[k], sizeof(float)), 0) << what << ": point " << p << ", entry " << k;
                float alone = kSentinel;
                RenderCounters c1;
                method->Visibility(points[p], LightIndices(&lists[p][k], 1), &alone, c1);
                ASSERT_EQ(std::memcmp(&alone, &vis[k], sizeof(float)), 0)
                    << what << ": point " << p << ", light " << lists[p][k] << " alone";
            }
        }
        if (std::string(c.method) == "rt") {
            EXPECT_EQ(rays, listed);
            EXPECT_EQ(many.shadowRays, listed);
        }
        if (std::string(c.method) == "none") {
            EXPECT_EQ(rays, 0u);
        }
    }
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
}  // namespace many_lights_test
}  // namespace lm
