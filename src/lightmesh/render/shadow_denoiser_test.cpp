#include "lightmesh/render/shadow_denoiser.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cstdio>
#include <functional>
#include <random>

#include "lightmesh/io/compare.h"
#include "lightmesh/render/render_job.h"
#include "support/floor_scenes.h"

namespace lm {
namespace shadow_denoiser_test {
namespace {

using testing::AddBox;
using testing::FloorScene;

// A frame of w × h pixels on the plane z = 0 (normal +z), pixel (x, y) at (x, y, 0)·0.01,
// each pixel 0.01 wide; a layer lit by one light of weight 1 everywhere.
DenoiseFrame PlaneFrame(int w, int h) {
    DenoiseFrame f;
    f.width = w;
    f.height = h;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            f.position.push_back(Vec3(0.01f * x, 0.01f * y, 0));
            f.normal.push_back(Vec3(0, 0, 1));
            f.footprint.push_back(0.01f);
        }
    return f;
}

DenoiseLayer UniformLayer(size_t pixels, float v, float penumbra) {
    DenoiseLayer l;
    l.visibility.assign(pixels, v);
    l.weight.assign(pixels, 1.0f);
    l.penumbra.assign(pixels, penumbra);
    return l;
}

std::vector<float> Filter(const DenoiseFrame& f, const DenoiseLayer& l) {
    std::vector<float> out(static_cast<size_t>(f.width) * f.height);
    FilterShadowLayer(f, l, 0, f.height, out.data());
    return out;
}

// Fully lit and fully shadowed regions come out unchanged, bit for bit: uniform layers,
// and the parts of a layer far from its noisy penumbra strip.
TEST(ShadowDenoiser, KeepsFullyLitAndFullyShadowedRegions) {
    const DenoiseFrame f = PlaneFrame(96, 64);
    const size_t n = f.position.size();
    EXPECT_EQ(Filter(f, UniformLayer(n, 1.0f, -1.0f)), std::vector<float>(n, 1.0f));
    EXPECT_EQ(Filter(f, UniformLayer(n, 0.0f, 6.0f)), std::vector<float>(n, 0.0f));

    // Lit on the left, shadowed on the right, a noisy penumbra strip of columns 40..55 between.
    DenoiseLayer l = UniformLayer(n, 1.0f, -1.0f);
    std::mt19937 rng(7);
    for (int y = 0; y < f.height; ++y)
        for (int x = 40; x < 96; ++x) {
            const size_t i = f.Index(x, y);
            l.visibility[i] = x < 56 ? static_cast<float>(rng() % 2) : 0.0f;
            if (l.visibility[i] == 0) l.penumbra[i] = 4.0f;
        }
    const std::vector<float> out = Filter(f, l);
    int changed = 0;
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x) {
            const size_t i = f.Index(x, y);
            // Beyond the blocks next to the strip's blocks the values stay.
            if (x < 40 - 2 * kDenoiseBlock || x >= 56 + 2 * kDenoiseBlock) {
                EXPECT_EQ(out[i], l.visibility[i]) << x << "," << y;
            }
            changed += out[i] != l.visibility[i];
            EXPECT_GE(out[i], 0.0f);
            EXPECT_LE(out[i], 1.0f);
        }
    EXPECT_GT(changed, 16 * 64 / 2);  // the strip is filtered
    // And the strip's noise falls: its values gather round ½.
    double before = 0, after = 0;
    for (int y = 0; y < f.height; ++y)
        for (int x = 44; x < 52; ++x) {
            const size_t i = f.Index(x, y);
            before += (l.visibility[i] - 0.5) * (l.visibility[i] - 0.5);
            after += (out[i] - 0.5) * (out[i] - 0.5);
        }
    EXPECT_LT(after, before / 4);
}

// A noisy layer over two surfaces; changing the visibility on one of them must not change
// the filtered values on the other.
void ExpectNoBleed(const DenoiseFrame& f, const std::function<bool(int x, int y)>& onWall) {
    const size_t n = f.position.size();
    DenoiseLayer a = UniformLayer(n, 0.0f, 8.0f), b = a;
    std::mt19937 rng(3);
    for (size_t i = 0; i < n; ++i) {
        a.visibility[i] = static_cast<float>(rng() % 2);
        b.visibility[i] = a.visibility[i];
    }
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x)
            if (!onWall(x, y)) b.visibility[f.Index(x, y)] = static_cast<float>(rng() % 2);
    const std::vector<float> oa = Filter(f, a), ob = Filter(f, b);
    int wall = 0, floorChanged = 0, wallFiltered = 0;
    for (int y = 0; y < f.height; ++y)
        for (int x = 0; x < f.width; ++x) {
            const size_t i = f.Index(x, y);
            if (onWall(x, y)) {
                ++wall;
                EXPECT_EQ(oa[i], ob[i]) << x << "," << y;
                wallFiltered += oa[i] != a.visibility[i];
            } else {
                floorChanged += oa[i] != ob[i];
            }
        }
    EXPECT_GT(wall, 0);
    EXPECT_GT(wallFiltered, wall / 2);  // the wall is filtered, from itself only
    EXPECT_GT(floorChanged, 0);         // the change of the floor's noise is seen there
}

// A wall in front of a floor: the wall's rows (y < 32) at z = 1 (a depth edge), its
// normal the floor's.
TEST(ShadowDenoiser, StopsAtDepthEdges) {
    DenoiseFrame f = PlaneFrame(64, 64);
    auto onWall = [](int, int y) { return y < 32; };
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x) f.position[f.Index(x, y)].z = 1.0f;
    ExpectNoBleed(f, onWall);
}

// The wall meets the floor along a line (continuous points): only the normals differ.
TEST(ShadowDenoiser, StopsAtNormalEdges) {
    DenoiseFrame f = PlaneFrame(64, 64);
    auto onWall = [](int, int y) { return y < 32; };
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x) {
            f.position[f.Index(x, y)] = Vec3(0.01f * x, 0.32f, 0.01f * (32 - y));
            f.normal[f.Index(x, y)] = Vec3(0, -1, 0);
        }
    ExpectNoBleed(f, onWall);
}

RenderOptions BoxOptions(const Scene& s, const std::string& shadows, int samples) {
    RenderOptions o = s.render;
    o.width = 96;
    o.height = 72;
    o.shadows = shadows;
    o.areaLight.radius = 0.6f;
    o.areaLight.samples = samples;
    return o;
}

Scene BoxScene() {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0.5f, -1}, {1, 1.5f, 1});
    return s;
}

// Against area's image with 1024 rays: the denoised image's error falls with N, and at
// N = 1 it is well below area's own N = 1.
TEST(ShadowDenoiser, NoiseFallsWithSamples) {
    const Scene s = BoxScene();
    const RenderJob ref(s, BoxOptions(s, "area", 1024));
    const Image reference = ref.Render().image;
    std::vector<double> psnr;
    for (int n : {1, 2, 4}) {
        const RenderJob job(s, BoxOptions(s, "denoised", n));
        ASSERT_NE(job.Denoiser(), nullptr);
        psnr.push_back(CompareImages(reference, job.Render().image).psnr);
        std::printf("denoised N = %d: %.2f dB\n", n, psnr.back());
    }
    EXPECT_LT(psnr[0], psnr[1]);
    EXPECT_LT(psnr[1], psnr[2]);
    const double area1 = CompareImages(reference, RenderJob(s, BoxOptions(s, "area", 1)).Render().image).psnr;
    std::printf("area N = 1: %.2f dB\n", area1);
    EXPECT_GT(psnr[0], area1 + 3.0);
}

// A canopy of small leaves (0.1-wide boxes, 1 to 1.6 m up, a pseudo-random two thirds of
// a grid) under a small light: a dappled shadow whose penumbrae are under a pixel wide
// (half width R·b/(d − b) ≈ 0.05·1.3/2.7 = 0.024 m against pixels of 0.039 m). Against
// area's image with 1024 rays, denoised N = 1 must gain at least 3 dB over area's N = 1
// there too: 3.2 dB; it gained 1.6 dB when its footprint was the penumbra's width alone
// (kDenoiseMinRadius 0: pass 2's taps round to the pixel itself).
TEST(ShadowDenoiser, GainsOnDappledShadowsOfThinPenumbrae) {
    Scene s = FloorScene();
    uint32_t state = 12345;
    auto next = [&] { return (state = state * 1664525u + 1013904223u) >> 8; };
    for (int i = 0; i < 12; ++i)
        for (int k = 0; k < 12; ++k) {
            if (next() % 3 == 0) continue;
            const float x = -1.4f + 0.22f * i, z = -1.4f + 0.22f * k, y = 1.0f + 0.6f * static_cast<float>(next() % 100) / 100.0f;
            AddBox(&s, {x, y, z}, {x + 0.1f, y + 0.1f, z + 0.1f});
        }
    auto options = [&](const std::string& shadows, int samples) {
        RenderOptions o = BoxOptions(s, shadows, samples);
        o.width = 160;
        o.height = 120;
        o.areaLight.radius = 0.05f;
        return o;
    };
    const Image reference = RenderJob(s, options("area", 1024)).Render().image;
    const double area1 = CompareImages(reference, RenderJob(s, options("area", 1)).Render().image).psnr;
    const double denoised1 = CompareImages(reference, RenderJob(s, options("denoised", 1)).Render().image).psnr;
    std::printf("dappled: area N = 1: %.2f dB, denoised N = 1: %.2f dB\n", area1, denoised1);
    EXPECT_GT(denoised1, area1 + 3.0);
}

// The same bytes for 1 and 4 threads, and for the image rendered in bands of rows with
// their aprons (as MPI ranks render it).
TEST(ShadowDenoiser, DeterministicForThreadsAndBands) {
    const Scene s = BoxScene();
    RenderOptions o = BoxOptions(s, "denoised", 2);
    o.height = 260;  // bands wider than the apron and narrower than the image
    o.width = 64;
    const RenderJob job(s, o);
    RenderResult one, many;
    tbb::task_arena(1).execute([&] { one = job.Render(); });
    tbb::task_arena(4).execute([&] { many = job.Render(); });
    EXPECT_EQ(one.image.pixels, many.image.pixels);
    Image bands(o.width, o.height);
    RenderCounters c;
    for (int y : {0, 48, 160}) job.Denoiser()->RenderRows(y, y == 0 ? 48 : y == 48 ? 160 : o.height, &bands, c);
    EXPECT_EQ(bands.pixels, one.image.pixels);
}

// Radius-0 lights are points: the denoiser leaves their hard shadows as rt traces them.
TEST(ShadowDenoiser, PointLightsKeepHardShadows) {
    const Scene s = BoxScene();
    RenderOptions o = BoxOptions(s, "denoised", 4);
    o.areaLight.radius = 0.0f;
    RenderOptions rt = o;
    rt.shadows = "rt";
    const ImageMetrics m = CompareImages(RenderJob(s, rt).Render().image, RenderJob(s, o).Render().image);
    EXPECT_GT(m.psnr, 80.0);
}

}  // namespace
}  // namespace shadow_denoiser_test
}  // namespace lm
