#include "lightmesh/render/light_cut.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>

#include "lightmesh/util/error.h"

namespace lm {
namespace light_cut_test {
namespace {

float Luma(const Color& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

bool SameBits(const Color& a, const Color& b) {
    return std::bit_cast<uint32_t>(a.r) == std::bit_cast<uint32_t>(b.r) &&
           std::bit_cast<uint32_t>(a.g) == std::bit_cast<uint32_t>(b.g) &&
           std::bit_cast<uint32_t>(a.b) == std::bit_cast<uint32_t>(b.b);
}

// Lights over a 20 × 4 × 20 room in rings and at random: of either falloff, some with a
// range, some spots pointing down, coloured and white, a few black, and a sun.
std::vector<PointLight> MakeLights(std::mt19937& rng, size_t count) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<PointLight> lights(count);
    for (size_t i = 0; i < count; ++i) {
        PointLight& l = lights[i];
        l.position = Vec3(20 * u(rng) - 10, 2 + 2 * u(rng), 20 * u(rng) - 10);
        l.intensity = i % 17 == 0 ? Color(0.0f) : Color(0.5f + u(rng), 0.5f + u(rng), i % 3 ? 1.0f : 0.2f) * 4.0f;
        l.falloff = i % 5 == 0 ? Falloff::None : Falloff::InverseSquare;
        if (i % 4 == 1) l.range = 3 + 6 * u(rng);
        if (i % 7 == 3) {
            l.kind = LightKind::Spot;
            l.spot.direction = Vec3(0, -1, 0);
            l.spot.cosInner = std::cos(20.0f * Pi / 180.0f);
            l.spot.cosOuter = std::cos(50.0f * Pi / 180.0f);
        }
    }
    PointLight sun;
    sun.kind = LightKind::Sun;
    sun.position = Vec3(300, 1000, 200);
    sun.falloff = Falloff::None;
    sun.intensity = Color(0.3f);
    lights.push_back(sun);
    return lights;
}

// A point on the floor, a wall or in the air, facing any way, with or without a highlight.
LightTermPoint MakePoint(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    LightTermPoint pt;
    pt.p = Vec3(10 * u(rng), 1.5f + 1.5f * u(rng), 10 * u(rng));
    pt.n = pt.ns = Normalize(Vec3(u(rng), u(rng) + 0.8f, u(rng)));
    pt.toEye = Normalize(pt.n + Vec3(u(rng), u(rng), u(rng)) * 0.5f);
    pt.kd = Color(0.3f + 0.3f * std::abs(u(rng)), 0.5f, 0.4f);
    if (u(rng) > 0) pt.ks = Color(0.2f), pt.phong = 20;
    return pt;
}

// With error 0 every node is split: the cut is the exact list, every term bit for bit the
// terms of all lights, in ascending order, on scenes of 100 to 1,000 lights.
TEST(LightCuts, ZeroBoundIsTheExactList) {
    std::mt19937 rng(7);
    for (size_t count : {100, 257, 1000}) {
        const std::vector<PointLight> lights = MakeLights(rng, count);
        const LightTerms terms(lights);
        const LightCuts cuts(lights, terms, 0.0f);
        EXPECT_EQ(cuts.NodeCount(), 2 * count - 1);  // the sun is apart
        std::vector<Color> a(lights.size()), b(lights.size());
        std::vector<uint32_t> ia(lights.size()), ib(lights.size());
        for (int k = 0; k < 300; ++k) {
            const LightTermPoint pt = MakePoint(rng);
            const uint32_t na = terms.All(pt, a.data(), ia.data());
            const uint32_t nb = cuts.Cut(pt, b.data(), ib.data());
            ASSERT_EQ(na, nb) << count << " lights, point " << k;
            for (uint32_t i = 0; i < na; ++i) {
                ASSERT_EQ(ia[i], ib[i]);
                ASSERT_TRUE(SameBits(a[i], b[i])) << "light " << ia[i];
            }
        }
    }
}

// With a positive bound the cut is an estimate whose every cluster errs by at most
// error × the cut's total: the point's error is at most (clusters) × error × total. The
// cuts are much smaller than the lights, and a tighter bound gives larger cuts and smaller
// errors on average.
TEST(LightCuts, EveryClusterStaysWithinItsBound) {
    std::mt19937 rng(11);
    const std::vector<PointLight> lights = MakeLights(rng, 1024);
    const LightTerms terms(lights);
    std::vector<Color> a(lights.size()), b(lights.size());
    std::vector<uint32_t> ia(lights.size()), ib(lights.size());
    double meanError[2] = {0, 0}, meanCut[2] = {0, 0};
    const float bounds[2] = {0.1f, 0.01f};
    for (int e = 0; e < 2; ++e) {
        const LightCuts cuts(lights, terms, bounds[e]);
        std::mt19937 points(3);
        for (int k = 0; k < 400; ++k) {
            const LightTermPoint pt = MakePoint(points);
            const uint32_t na = terms.All(pt, a.data(), ia.data());
            const uint32_t nb = cuts.Cut(pt, b.data(), ib.data());
            double exact = 0, cut = 0;
            for (uint32_t i = 0; i < na; ++i) exact += Luma(a[i]);
            for (uint32_t i = 0; i < nb; ++i) cut += Luma(b[i]);
            for (uint32_t i = 1; i < nb; ++i) ASSERT_LT(ib[i - 1], ib[i]);  // ascending, each once
            const double clusters = nb;  // an upper bound on the clusters among the entries
            EXPECT_LE(std::abs(cut - exact), clusters * bounds[e] * cut * 1.001 + 1e-6) << "point " << k;
            meanError[e] += exact > 0 ? std::abs(cut - exact) / exact : 0;
            meanCut[e] += nb;
        }
        meanError[e] /= 400, meanCut[e] /= 400;
    }
    EXPECT_LT(meanCut[0], 1024.0 / 8);
    EXPECT_LT(meanCut[0], meanCut[1]);
    EXPECT_LT(meanError[1], meanError[0]);
    EXPECT_LT(meanError[1], 0.01);
}

// A node is left out only where none of its lights can light the point: out of range
// everywhere, or behind the surface. Lights all below a floor facing up give an empty cut;
// lights out of range give an empty cut; a light exactly at its range's end is kept.
TEST(LightCuts, LeavesOutOnlyWhatCannotLight) {
    std::vector<PointLight> below(64);
    for (size_t i = 0; i < below.size(); ++i) below[i].position = Vec3(float(i % 8), -1.0f - float(i / 8), 0.5f);
    LightTermPoint pt;
    pt.p = Vec3(3, 0, 0);
    pt.n = pt.ns = Vec3(0, 1, 0);
    pt.toEye = Vec3(0, 1, 0);
    pt.kd = Color(0.5f);
    std::vector<Color> o(64);
    std::vector<uint32_t> ids(64);
    {
        const LightTerms terms(below);
        EXPECT_EQ(LightCuts(below, terms, 0.02f).Cut(pt, o.data(), ids.data()), 0u);
    }
    std::vector<PointLight> far = below;
    for (PointLight& l : far) l.position.y = -l.position.y, l.range = 0.5f;
    far[5].position = Vec3(3, 2, 0), far[5].range = 2.0f;  // exactly at its range from P
    const LightTerms terms(far);
    for (float error : {0.0f, 0.02f}) {
        ASSERT_EQ(LightCuts(far, terms, error).Cut(pt, o.data(), ids.data()), 1u) << error;
        EXPECT_EQ(ids[0], 5u);
    }
}

TEST(LightCuts, RefusesABadBoundAndResolvesTheAutomaticOne) {
    std::vector<PointLight> lights(kLightCutMinLights);
    const LightTerms terms(lights);
    EXPECT_THROW(LightCuts(lights, terms, -0.5f), Error);
    EXPECT_THROW(LightCuts(lights, terms, std::nanf("")), Error);
    EXPECT_EQ(ResolvedLightCutError(-1, "soft", lights), kDefaultLightCutError);
    EXPECT_EQ(ResolvedLightCutError(-1, "rt", lights), 0.0f);
    EXPECT_EQ(ResolvedLightCutError(0.05f, "rt", lights), 0.0f);  // the soft default's only
    EXPECT_EQ(ResolvedLightCutError(0.05f, "soft", lights), 0.05f);
    EXPECT_EQ(ResolvedLightCutError(-1, "soft", std::vector<PointLight>(kLightCutMinLights - 1)), 0.0f);
    lights[0].range = 5;  // fewer lights than the threshold reach everywhere
    EXPECT_EQ(ResolvedLightCutError(-1, "soft", lights), 0.0f);
    EXPECT_EQ(ResolvedLightCutError(0, "soft", lights), 0.0f);
}

}  // namespace
}  // namespace light_cut_test
}  // namespace lm
