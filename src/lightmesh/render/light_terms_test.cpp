#include "lightmesh/render/light_terms.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numeric>
#include <random>

#include "lightmesh/util/error.h"

namespace lm {
namespace light_terms_test {
namespace {

// The term of one light as shading wrote it light by light (whitted.cpp before
// LightTerms), with Vec3's and Color's operations: false where the light does not light
// the point.
bool ScalarTerm(const PointLight& light, const LightTermPoint& pt, Color* omega) {
    const Vec3 toLight = light.position - pt.p;
    const float dist2 = LengthSquared(toLight);
    if (dist2 > light.range * light.range) return false;
    const Vec3 l = toLight / std::sqrt(dist2);
    const float cosN = Dot(pt.ns, l);
    if (!(Dot(pt.n, l) > 0 && cosN > 0)) return false;
    Color local = pt.kd * cosN;
    if (!pt.ks.IsBlack()) {
        const float cosR = Dot(Reflect(-l, pt.ns), pt.toEye);
        if (cosR > 0) local += pt.ks * std::pow(cosR, pt.phong);
    }
    const float falloff = light.falloff == Falloff::InverseSquare ? 1.0f / dist2 : 1.0f;
    *omega = light.intensity * local * falloff;
    return !omega->IsBlack();
}

// The same bits, not only equal values (a -0 for a +0 would differ).
bool SameBits(const Color& a, const Color& b) {
    return std::bit_cast<uint32_t>(a.r) == std::bit_cast<uint32_t>(b.r) &&
           std::bit_cast<uint32_t>(a.g) == std::bit_cast<uint32_t>(b.g) &&
           std::bit_cast<uint32_t>(a.b) == std::bit_cast<uint32_t>(b.b);
}

// The lanes this CPU runs: 4 always, 8 with AVX2.
std::vector<int> Widths() {
    std::vector<int> w{4};
    if (LightTerms({}, 0).Width() == 8) w.push_back(8);
    return w;
}

struct Case {
    std::vector<PointLight> lights;
    LightTermPoint pt;
};

// Lights around a point on integer-ish coordinates and random ones, of every kind: without
// and with a range (some exactly at the light's distance, some one ulp short), either
// falloff, black and coloured intensities, behind the geometric surface, between the
// geometric and the shading normal's planes, and one exactly at the point.
Case MakeCase(std::mt19937& rng, size_t count, bool specular) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::uniform_int_distribution<int> pick(0, 9), coord(-6, 6);
    Case c;
    c.pt.p = Vec3(static_cast<float>(coord(rng)), static_cast<float>(coord(rng)), static_cast<float>(coord(rng)));
    c.pt.n = Normalize(Vec3(u(rng), u(rng), u(rng)) + Vec3(0, 0.3f, 0));
    // The shading normal tilted off the geometric one, on its side.
    c.pt.ns = Normalize(c.pt.n + Vec3(u(rng), u(rng), u(rng)) * 0.6f);
    if (Dot(c.pt.ns, c.pt.n) < 0) c.pt.ns = -c.pt.ns;
    c.pt.toEye = Normalize(c.pt.n + Vec3(u(rng), u(rng), u(rng)));
    c.pt.kd = Color(0.2f + 0.5f * std::abs(u(rng)), 0.6f, pick(rng) == 0 ? 0.0f : 0.3f);
    if (specular) c.pt.ks = Color(0.3f, 0.25f * std::abs(u(rng)), 0.1f), c.pt.phong = 1.0f + 60.0f * std::abs(u(rng));
    c.lights.resize(count);
    for (size_t i = 0; i < count; ++i) {
        PointLight& l = c.lights[i];
        const int kind = pick(rng);
        if (kind < 4) {
            // Integer offsets: |toLight|² is exact, so a range of its square root is met exactly.
            const Vec3 off(static_cast<float>(coord(rng)), static_cast<float>(coord(rng)), static_cast<float>(coord(rng)));
            l.position = c.pt.p + off;
            const float d2 = LengthSquared(off), d = std::sqrt(d2);
            if (kind == 1 && d * d == d2) l.range = d;  // exactly at its range: lit
            if (kind == 2 && d * d == d2) l.range = std::nextafter(d, 0.0f);  // one ulp short: not lit
            if (kind == 3) l.range = d * (0.5f + std::abs(u(rng)));
        } else {
            l.position = c.pt.p + Vec3(u(rng), u(rng), u(rng)) * 8.0f;
            if (kind < 7) l.range = 0.1f + 9.0f * std::abs(u(rng));
        }
        if (pick(rng) == 0) l.position = c.pt.p;  // at the point: dist² = 0
        l.falloff = pick(rng) < 5 ? Falloff::InverseSquare : Falloff::None;
        l.intensity = pick(rng) == 0 ? Color(0.0f) : Color(std::abs(u(rng)), 0.5f, pick(rng) == 0 ? 0.0f : 2.0f);
    }
    return c;
}

// Every light's term and the lit list against the scalar formula, bit for bit, for every
// light count from 0 to 41 and a few hundred, both widths, with and without a specular
// term: All, Listed over random ascending subsets (runs of consecutive lights and gaps),
// and Listed in place (the ids in the output list itself).
TEST(LightTerms, EqualTheScalarFormulaBitForBit) {
    std::mt19937 rng(48);
    size_t lit = 0, unlit = 0, checked = 0;
    std::vector<size_t> counts(42);
    std::iota(counts.begin(), counts.end(), 0);
    counts.insert(counts.end(), {255, 256, 257, 1000});
    for (size_t count : counts)
        for (int trial = 0; trial < 6; ++trial) {
            const Case c = MakeCase(rng, count, trial % 2 == 1);
            // The reference, light by light.
            std::vector<uint32_t> refIds;
            std::vector<Color> refOmega(count);
            for (uint32_t i = 0; i < count; ++i) {
                Color w;
                if (ScalarTerm(c.lights[i], c.pt, &w)) refIds.push_back(i), refOmega[i] = w;
            }
            lit += refIds.size(), unlit += count - refIds.size();
            // A random ascending subset: runs kept and dropped.
            std::vector<uint32_t> subset;
            std::bernoulli_distribution keep(trial < 2 ? 0.9 : 0.4);
            for (uint32_t i = 0; i < count; ++i)
                if (keep(rng)) subset.push_back(i);
            for (int width : Widths()) {
                const LightTerms terms(c.lights, width);
                ASSERT_EQ(terms.Width(), width);
                std::vector<Color> omega(count + 1);
                std::vector<uint32_t> ids(count + 1);
                auto expectList = [&](const std::vector<uint32_t>& from, uint32_t n, const char* what) {
                    std::vector<uint32_t> want;
                    for (uint32_t i : from)
                        if (std::binary_search(refIds.begin(), refIds.end(), i)) want.push_back(i);
                    ASSERT_EQ(n, want.size()) << what << ", " << count << " lights, width " << width;
                    for (uint32_t k = 0; k < n; ++k) {
                        ASSERT_EQ(ids[k], want[k]) << what << ", entry " << k << ", width " << width;
                        ASSERT_TRUE(SameBits(omega[k], refOmega[want[k]]))
                            << what << ", light " << want[k] << ", width " << width << ": " << omega[k].r << " "
                            << omega[k].g << " " << omega[k].b << " against " << refOmega[want[k]].r;
                        ++checked;
                    }
                };
                std::vector<uint32_t> all(count);
                std::iota(all.begin(), all.end(), 0u);
                expectList(all, terms.All(c.pt, omega.data(), ids.data()), "All");
                expectList(subset, terms.Listed(c.pt, subset.data(), static_cast<uint32_t>(subset.size()), omega.data(), ids.data()),
                           "Listed");
                std::copy(subset.begin(), subset.end(), ids.begin());
                expectList(subset, terms.Listed(c.pt, ids.data(), static_cast<uint32_t>(subset.size()), omega.data(), ids.data()),
                           "Listed in place");
            }
        }
    // Both outcomes are well represented (the test cannot pass by listing nothing).
    EXPECT_GT(lit, 2000u);
    EXPECT_GT(unlit, 2000u);
    EXPECT_GT(checked, 10000u);
}

// The boundary cases one by one: a light exactly at its range is lit, one ulp farther is
// not; a light behind the geometric surface is not, even where the shading normal faces
// it; a light in front of the surface but behind the shading normal's plane is not.
TEST(LightTerms, RangeAndFacingBoundaries) {
    LightTermPoint pt;
    pt.p = Vec3(1, 2, 3);
    pt.n = Vec3(0, 1, 0);
    pt.ns = Normalize(Vec3(0.5f, 1, 0));
    pt.toEye = Vec3(0, 1, 0);
    pt.kd = Color(0.5f);
    std::vector<PointLight> lights(5);
    lights[0].position = pt.p + Vec3(3, 4, 0), lights[0].range = 5.0f;                        // |d|² = 25 = range²
    lights[1].position = pt.p + Vec3(3, 4, 0), lights[1].range = std::nextafter(5.0f, 0.0f);  // just short
    lights[2].position = pt.p + Vec3(4, -0.5f, 0);                                             // under the surface, ns·l > 0
    lights[3].position = pt.p + Vec3(-4, 1, 0);                                                // over it, ns·l < 0
    lights[4].position = pt.p + Vec3(0, 2, 0);
    for (int width : Widths()) {
        const LightTerms terms(lights, width);
        Color omega[5];
        uint32_t ids[5];
        ASSERT_EQ(terms.All(pt, omega, ids), 2u) << "width " << width;
        EXPECT_EQ(ids[0], 0u);
        EXPECT_EQ(ids[1], 4u);
        Color w;
        ASSERT_TRUE(ScalarTerm(lights[0], pt, &w));
        EXPECT_TRUE(SameBits(omega[0], w));
    }
    EXPECT_THROW(LightTerms(lights, 5), Error);
}

}  // namespace
}  // namespace light_terms_test
}  // namespace lm

namespace lm {
namespace light_terms_test {
namespace {

// A spot's term is the point light's times its cone's factor: full inside the inner cone,
// nothing outside the outer one (not lit), t² between; the other lights' terms unchanged.
TEST(LightTerms, SpotConesScaleTheTermAndDropTheUnlit) {
    PointLight point{{0, 5, 0}, Color(25.0f), Falloff::InverseSquare};
    PointLight spot = point;
    spot.kind = LightKind::Spot;
    spot.spot.direction = Vec3(0, -1, 0);
    spot.spot.cosInner = std::cos(10.0f * Pi / 180.0f);
    spot.spot.cosOuter = std::cos(20.0f * Pi / 180.0f);
    for (int width : {4, 8}) {
        if (width == 8 && !__builtin_cpu_supports("avx2")) continue;
        const LightTerms terms({point, spot}, width);
        for (float x : {0.0f, 0.5f, 1.35f, 1.7f, 2.5f}) {
            const LightTermPoint pt{Vec3(x, 0, 0), Vec3(0, 1, 0), Vec3(0, 1, 0), Vec3(0, 1, 0), Color(0.8f), Color(0.0f), 1};
            Color omega[2];
            uint32_t lit[2];
            const uint32_t n = terms.All(pt, omega, lit);
            ASSERT_GE(n, 1u);
            EXPECT_EQ(lit[0], 0u);
            const float angle = std::atan2(x, 5.0f) * 180.0f / Pi;
            const float c = std::cos(angle * Pi / 180.0f);
            const float t = std::clamp((c - spot.spot.cosOuter) / (spot.spot.cosInner - spot.spot.cosOuter), 0.0f, 1.0f);
            if (angle >= 20.0f) {
                EXPECT_EQ(n, 1u) << x;  // outside the outer cone: not lit
                continue;
            }
            ASSERT_EQ(n, 2u) << x;
            EXPECT_EQ(lit[1], 1u);
            EXPECT_NEAR(omega[1].r, omega[0].r * t * t, 1e-6f * omega[0].r) << x;
            if (angle <= 10.0f) EXPECT_EQ(omega[1].r, omega[0].r) << x;
            // Listed gives the same.
            const uint32_t ids[2] = {0, 1};
            Color listed[2];
            uint32_t litListed[2];
            ASSERT_EQ(terms.Listed(pt, ids, 2, listed, litListed), 2u);
            EXPECT_EQ(listed[1].r, omega[1].r);
        }
    }
}

}  // namespace
}  // namespace light_terms_test
}  // namespace lm
