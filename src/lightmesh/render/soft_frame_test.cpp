#include "lightmesh/render/soft_frame.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "lightmesh/io/compare.h"
#include "lightmesh/render/render_job.h"
#include "support/cutout_scenes.h"
#include "support/floor_scenes.h"

namespace lm {
namespace soft_frame_test {
namespace {

using testing::AddBox;
using testing::FloorScene;

/// The floor, a box on legs (its shadow's penumbra widens away from the legs), a thin pole
/// (a shadow narrower than its penumbra) and a wall standing on the floor (a contact
/// shadow at the junction), under one spherical light.
Scene PenumbraScene() {
    Scene s = FloorScene();
    AddBox(&s, {-1.2f, 1.0f, -0.8f}, {0.4f, 1.2f, 0.8f});       // the table top
    for (float x : {-1.1f, 0.25f})
        for (float z : {-0.7f, 0.65f}) AddBox(&s, {x, 0, z}, {x + 0.05f, 1.0f, z + 0.05f});  // its legs
    AddBox(&s, {1.2f, 0, -1.5f}, {1.23f, 2.0f, -1.47f});       // a thin pole
    AddBox(&s, {-2.5f, 0, -2.6f}, {2.5f, 1.0f, -2.4f});        // a low wall on the floor
    return s;
}

RenderOptions Options(const Scene& s, const std::string& shadows, int width = 160, int height = 120) {
    RenderOptions o = s.render;
    o.width = width;
    o.height = height;
    o.shadows = shadows;
    o.areaLight.radius = 0.35f;
    o.areaLight.samples = 1024;  // the reference's
    return o;
}

Image Render(const Scene& s, const RenderOptions& o) { return RenderJob(s, o).Render().image; }

// Against area's image with 1024 rays per light: the default is far closer than hard
// shadows, its total shadow within 2 % of the reference's, and close to the exact mode.
TEST(SoftFrame, MatchesTheAreaReference) {
    const Scene s = PenumbraScene();
    const Image ref = Render(s, Options(s, "area")), none = Render(s, Options(s, "none"));
    const Image soft = Render(s, Options(s, "soft")), rt = Render(s, Options(s, "rt"));
    const double psnrSoft = CompareImages(ref, soft).psnr, psnrRt = CompareImages(ref, rt).psnr;
    const double ratio = ShadowTotal(none, soft) / ShadowTotal(none, ref);
    std::printf("soft %.2f dB, rt %.2f dB, shadow total / reference %.4f\n", psnrSoft, psnrRt, ratio);
    EXPECT_GT(psnrSoft, psnrRt + 10.0);
    EXPECT_GT(psnrSoft, 45.0);
    EXPECT_NEAR(ratio, 1.0, 0.02);
}

// No penumbra is missed: where the reference's shading differs from hard shadows (a
// penumbra), the default is within the sampling noise of 16 rays, not at the probe's 0 or
// 1. Counted in display values: a pixel more than 0.2 off is a miss. (Without the
// silhouette points' marking every penumbra pixel keeps its probe: hundreds of misses.)
TEST(SoftFrame, FindsEveryPenumbra) {
    const Scene s = PenumbraScene();
    const Image ref = Render(s, Options(s, "area")), soft = Render(s, Options(s, "soft"));
    const Image rt = Render(s, Options(s, "rt"));
    int penumbra = 0, misses = 0;
    for (size_t i = 0; i < ref.pixels.size(); ++i) {
        const float r = SrgbEncode(ref.pixels[i].g), h = SrgbEncode(rt.pixels[i].g), v = SrgbEncode(soft.pixels[i].g);
        if (std::abs(r - h) > 0.05f) ++penumbra;
        if (std::abs(r - v) > 0.2f) ++misses;
    }
    std::printf("penumbra pixels %d, misses %d\n", penumbra, misses);
    EXPECT_GT(penumbra, 500);
    EXPECT_LE(misses, 2);
}

// The same bytes for 1 and 4 threads, and for the image rendered in bands of rows (as MPI
// ranks render it), with anti-aliasing too.
TEST(SoftFrame, DeterministicForThreadsAndBands) {
    const Scene s = PenumbraScene();
    for (int aa : {1, 2}) {
        RenderOptions o = Options(s, "soft", 64, 300);
        o.aa = aa;
        const RenderJob job(s, o);
        ASSERT_NE(job.Bands(), nullptr);
        RenderResult one, many;
        tbb::task_arena(1).execute([&] { one = job.Render(); });
        tbb::task_arena(4).execute([&] { many = job.Render(); });
        EXPECT_EQ(one.image.pixels, many.image.pixels) << aa;
        Image bands(o.width, o.height);
        RenderCounters c;
        for (const auto& [y0, y1] : {std::pair{0, 16}, {16, 144}, {144, 300}}) job.Bands()->RenderRows(y0, y1, &bands, c);
        EXPECT_EQ(bands.pixels, one.image.pixels) << aa;
    }
}

// Radius-0 lights are points: their probe is the answer, rt's hard shadow (the sums' order
// differs from the renderer's by a rounding).
TEST(SoftFrame, PointLightsAreHardShadows) {
    const Scene s = PenumbraScene();
    RenderOptions o = Options(s, "soft");
    o.areaLight.radius = 0.0f;
    RenderOptions rt = o;
    rt.shadows = "rt";
    EXPECT_GT(CompareImages(Render(s, rt), Render(s, o)).psnr, 90.0);
}

// Anti-aliased, the default still matches the reference rendered with the same sub-pixels.
TEST(SoftFrame, AntiAliased) {
    const Scene s = PenumbraScene();
    RenderOptions o = Options(s, "soft", 80, 60), a = Options(s, "area", 80, 60);
    o.aa = a.aa = 3;
    const double psnr = CompareImages(Render(s, a), Render(s, o)).psnr;
    std::printf("aa 3: %.2f dB\n", psnr);
    EXPECT_GT(psnr, 45.0);
}

// An alpha cut-out's holes let light through: a checker casts a checker, as the area
// reference (whose rays see the holes) has it, and unlike the same quad solid.
TEST(SoftFrame, CutoutsCastTheirHoles) {
    const Scene cut = testing::CheckerScene(true), solid = testing::CheckerScene(false);
    RenderOptions o = cut.render;
    o.width = 96;
    o.height = 72;
    RenderOptions area = o, none = o;
    o.shadows = "soft", area.shadows = "area", none.shadows = "none";
    area.areaLight.samples = 256;
    const Image lit = Render(cut, none), ref = Render(cut, area), soft = Render(cut, o);
    const double ratio = ShadowTotal(lit, soft) / ShadowTotal(lit, ref);
    const double psnr = CompareImages(ref, soft).psnr;
    std::printf("cut-outs: %.2f dB against area, shadow total / area's %.4f\n", psnr, ratio);
    EXPECT_GT(psnr, 40.0);
    EXPECT_NEAR(ratio, 1.0, 0.03);
    // The solid quad's shadow is another image: the holes are what the shadow shows.
    EXPECT_LT(CompareImages(Render(solid, o), soft).psnr, psnr - 10.0);
}

// Bad ray counts are refused with the option's name.
TEST(SoftFrame, RefusesBadSampleCounts) {
    const Scene s = PenumbraScene();
    for (int bad : {2, 6, 260}) {
        RenderOptions o = Options(s, "soft");
        o.soft.samples = bad;
        EXPECT_THROW(RenderJob(s, o), Error) << bad;
    }
}

}  // namespace
}  // namespace soft_frame_test
}  // namespace lm
