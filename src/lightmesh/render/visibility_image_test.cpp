// visibility_image_test.cpp -- the per-light visibility a render hands out: the image does
// not change, the values are the same for any thread count and for bands of rows, RT's are
// 0 or 1, pixels off the scene are NaN.
#include "lightmesh/render/visibility_image.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>

#include "lightmesh/render/render_job.h"
#include "lightmesh/scene/scene_file.h"

namespace lm {
namespace visibility_image_test {
namespace {

Scene Gazebo() {
    SceneLoadOptions o;
    std::vector<std::string> warnings;
    return LoadScene("builtin:gazebo", o, &warnings);
}

RenderOptions Options(const Scene& s, const std::string& shadows, int aa = 1) {
    RenderOptions o = s.render;
    o.width = 48, o.height = 36, o.aa = aa;
    o.shadows = shadows;
    o.areaLight.samples = 4;
    return o;
}

bool SameBytes(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(VisibilityImage, EveryMethodKeepsItsImageAndGivesValuesInRange) {
    const Scene s = Gazebo();
    ASSERT_GE(s.lights.size(), 1u);
    for (const char* shadows : {"rt", "soft", "exact", "area", "denoised", "lmm", "none"}) {
        for (int aa : {1, 2}) {
            const RenderJob job(s, Options(s, shadows, aa));
            VisibilityImage vis = job.MakeVisibility();
            const RenderResult with = job.Render(nullptr, &vis);
            const RenderResult without = job.Render();
            EXPECT_EQ(with.image.pixels, without.image.pixels) << shadows << " aa " << aa;
            size_t hit = 0, partial = 0, missed = 0;
            for (size_t i = 0; i < vis.values.size(); i += vis.lights) {
                if (std::isnan(vis.values[i])) {
                    ++missed;
                    for (size_t l = 0; l < vis.lights; ++l) EXPECT_TRUE(std::isnan(vis.values[i + l]));
                    continue;
                }
                ++hit;
                for (size_t l = 0; l < vis.lights; ++l) {
                    const float v = vis.values[i + l];
                    ASSERT_TRUE(v >= 0 && v <= 1) << shadows << " " << v;
                    partial += v > 0 && v < 1;
                    if (std::string(shadows) == "none" && aa == 1) EXPECT_TRUE(v == 0 || v == 1);  // 0: unlit
                }
            }
            EXPECT_GT(hit, 0u) << shadows;
            EXPECT_GT(missed, 0u) << shadows;  // the gazebo's sky
            // RT's values are 0 or 1 per sample: partial only as the mean of several.
            if (std::string(shadows) == "rt" && aa == 1) EXPECT_EQ(partial, 0u);
            if (std::string(shadows) != "rt" && std::string(shadows) != "none") EXPECT_GT(partial, 0u) << shadows;
        }
    }
}

TEST(VisibilityImage, SameForAnyThreadCountAndForBands) {
    const Scene s = Gazebo();
    for (const char* shadows : {"rt", "soft", "denoised", "area"}) {
        const RenderJob job(s, Options(s, shadows, 2));
        VisibilityImage one = job.MakeVisibility(), many = job.MakeVisibility();
        tbb::task_arena(1).execute([&] { job.Render(nullptr, &one); });
        tbb::task_arena(4).execute([&] { job.Render(nullptr, &many); });
        EXPECT_TRUE(SameBytes(one.values, many.values)) << shadows;
        if (!job.Bands()) continue;
        VisibilityImage bands = job.MakeVisibility();
        Image image(48, 36);
        RenderCounters c;
        for (const auto& [y0, y1] : {std::pair{0, 5}, {5, 20}, {20, 36}})
            job.Bands()->RenderRows(y0, y1, &image, c, nullptr, &bands);
        EXPECT_TRUE(SameBytes(bands.values, one.values)) << shadows;
    }
}

TEST(VisibilityImage, RefusesAnImageOfAnotherSize) {
    const Scene s = Gazebo();
    const RenderJob job(s, Options(s, "rt"));
    VisibilityImage wrong(47, 36, s.lights.size());
    EXPECT_THROW(job.Render(nullptr, &wrong), Error);
    EXPECT_THROW(VisibilityImage(0, 36, 1), Error);
}

TEST(VisibilityImage, FinishDividesByTheHitsOrGivesNaN) {
    float v[2] = {1.0f, 3.0f};
    FinishVisibility(v, 2, 4);
    EXPECT_EQ(v[0], 0.25f);
    EXPECT_EQ(v[1], 0.75f);
    FinishVisibility(v, 2, 0);
    EXPECT_TRUE(std::isnan(v[0]) && std::isnan(v[1]));
    const uint32_t ids[1] = {1};
    const float add[1] = {0.5f};
    float w[2] = {0, 0};
    AddVisibility(w, ids, add, 1);
    EXPECT_EQ(w[0], 0.0f);
    EXPECT_EQ(w[1], 0.5f);
}

}  // namespace
}  // namespace visibility_image_test
}  // namespace lm
