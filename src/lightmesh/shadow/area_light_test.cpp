#include "lightmesh/shadow/area_light.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstdio>

#include "support/floor_scenes.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace area_light_test {
namespace {

using testing::AddBox;
using testing::FloorPoint;
using testing::FloorScene;


float Vis(const ShadowMethod& method, const ShadingPoint& sp, int light = 0) {
    const uint32_t needed[1] = {static_cast<uint32_t>(light)};
    float vis = -1;
    RenderCounters c;
    method.Visibility(sp, needed, &vis, c);
    return vis;
}

RenderOptions AreaOptions(const Scene& s, float radius, int samples) {
    RenderOptions o = s.render;
    o.shadows = "area";
    o.areaLight.radius = radius;
    o.areaLight.samples = samples;
    return o;
}

// The analytic scene: a spherical light of radius R centred at (0, H, 0) above the floor
// y = 0, and a thin half-plane occluder {y = h, x < 0} (a huge quad) between them, whose
// straight edge is the z axis lifted to y = h. From P, the rays that graze the edge form
// the plane through P and the edge; the light is visible on its +x side.
constexpr float H = 10.0f, h = 5.0f, R = 1.0f;

Scene HalfPlaneScene() {
    Scene s;
    s.name = "test:half-plane";
    s.materials = {{"occluder", Color(0.5f), Color(0.0f), 1.0f, Color(0.0f)}};
    const float big = 1000.0f;
    s.mesh.positions = {{-big, h, -big}, {0, h, -big}, {0, h, big}, {-big, h, big}};
    s.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
    s.mesh.materialIds = {0, 0};
    s.lights = {{{0, H, 0}, Color(1.0f), Falloff::InverseSquare}};
    return s;
}

// The exact fraction of the sphere's solid angle seen from O past the edge. The sphere
// subtends the cone of half-angle α (sin α = R/d) around c; the visible directions are
// those with w·m > 0, m the unit normal of the plane through O and the edge, and
// sin β = c·m. On the ring of directions at angle θ from c, w·m > 0 for the share
// acos(clamp(−tan β / tan θ))/π of its azimuths; weighting rings by solid angle,
//     V = ∫₀^α sin θ · acos(clamp(−tan β/tan θ, −1, 1))/π dθ / (1 − cos α),
// a one-dimensional integral, evaluated here by Simpson's rule (error ≪ 1e-4).
double ExactVisibleFraction(const Vec3& o) {
    const double cx = 0 - o.x, cy = H - o.y, cz = 0 - o.z;
    const double d = std::sqrt(cx * cx + cy * cy + cz * cz);
    const double mx = h - o.y, my = o.x;  // (E − O) × z for the edge point E = (0, h, o.z)
    const double ml = std::hypot(mx, my);
    const double sinBeta = (cx * mx + cy * my) / (d * ml);
    const double tanBeta = sinBeta / std::sqrt(1 - sinBeta * sinBeta);
    const double alpha = std::asin(R / d);
    auto f = [&](double theta) {
        if (theta == 0) return 0.0;
        const double x = std::clamp(-tanBeta / std::tan(theta), -1.0, 1.0);
        return std::sin(theta) * std::acos(x) / 3.14159265358979323846;
    };
    const int n = 4000;  // even
    double sum = f(0) + f(alpha);
    for (int i = 1; i < n; ++i) sum += f(alpha * i / n) * (i % 2 ? 4 : 2);
    return sum * (alpha / n) / 3 / (1 - std::cos(alpha));
}

// The textbook approximation: the light as a flat disc facing O, cut by a straight chord
// at signed distance δ = tan β / tan α (in disc radii) from its centre; the visible part
// is the disc minus a circular segment: 1 − (acos δ − δ·sqrt(1 − δ²))/π.
double DiscSegmentFraction(const Vec3& o) {
    const double cx = 0 - o.x, cy = H - o.y, cz = 0 - o.z;
    const double d = std::sqrt(cx * cx + cy * cy + cz * cz);
    const double mx = h - o.y, my = o.x;
    const double sinBeta = (cx * mx + cy * my) / (d * std::hypot(mx, my));
    const double delta = std::clamp(std::tan(std::asin(sinBeta)) / std::tan(std::asin(R / d)), -1.0, 1.0);
    return 1 - (std::acos(delta) - delta * std::sqrt(1 - delta * delta)) / 3.14159265358979323846;
}

TEST(AreaLight, ValidatesOptions) {
    const Scene s = FloorScene();
    auto accel = CreateAccelerator("brute", s.mesh);
    for (const auto& [radius, samples] : std::vector<std::pair<float, int>>{
             {-1.0f, 16}, {NAN, 16}, {INFINITY, 16}, {0.5f, 0}, {0.5f, 4097}, {0.5f, -3}}) {
        try {
            CreateShadowMethod("area", s, *accel, AreaOptions(s, radius, samples));
            FAIL() << "expected an error for radius " << radius << ", samples " << samples;
        } catch (const Error& e) {
            const std::string what = e.what();
            EXPECT_TRUE(what.find("must be") != std::string::npos) << what;
        }
    }
    EXPECT_NO_THROW(CreateShadowMethod("area", s, *accel, AreaOptions(s, 0.0f, 1)));
    EXPECT_NO_THROW(CreateShadowMethod("area", s, *accel, AreaOptions(s, 2.0f, 4096)));
    EXPECT_EQ(CreateShadowMethod("area", s, *accel, AreaOptions(s, 2.0f, 4)) ->Name(), "area");
}

// R = 0 is a point light: the very shadow ray of "rt", so the images are bit-identical.
// The lights have sizes of their own; the override --light-radius 0 makes them points.
TEST(AreaLight, ZeroRadiusEqualsRtBitForBit) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0.5f, -1}, {1, 1.5f, 1});
    s.lights.push_back({{-2, 3, 1}, Color(5.0f), Falloff::InverseSquare});
    for (PointLight& l : s.lights) l.radius = 0.4f;
    auto accel = CreateAccelerator("grid", s.mesh);
    const RenderOptions area = AreaOptions(s, 0.0f, 64);
    auto rt = CreateShadowMethod("rt", s, *accel, s.render);
    auto zero = CreateShadowMethod("area", s, *accel, area);
    const RenderResult a = WhittedRenderer(s, *accel, *rt, s.render).Render();
    const RenderResult b = WhittedRenderer(s, *accel, *zero, area).Render();
    EXPECT_EQ(a.image.pixels, b.image.pixels);
    EXPECT_EQ(a.counters.shadowRays, b.counters.shadowRays);
    // The shadow is really there (the test would be empty otherwise).
    EXPECT_EQ(Vis(*zero, FloorPoint(0.1f, 0.1f)), 0.0f);
}

// Without the override each light keeps its own radius: lights of radius 0 (the default of
// a scene built in code) are points, so the image is RT's bit for bit; with a size the
// shadow goes soft.
TEST(AreaLight, LightsOwnZeroRadiiEqualRtBitForBit) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0.5f, -1}, {1, 1.5f, 1});
    s.lights.push_back({{-2, 3, 1}, Color(5.0f), Falloff::InverseSquare});
    auto accel = CreateAccelerator("grid", s.mesh);
    RenderOptions area = s.render;
    area.shadows = "area";
    ASSERT_FALSE(area.areaLight.radius.has_value());
    auto rt = CreateShadowMethod("rt", s, *accel, s.render);
    auto points = CreateShadowMethod("area", s, *accel, area);
    const RenderResult a = WhittedRenderer(s, *accel, *rt, s.render).Render();
    const RenderResult b = WhittedRenderer(s, *accel, *points, area).Render();
    EXPECT_EQ(a.image.pixels, b.image.pixels);
    EXPECT_EQ(a.counters.shadowRays, b.counters.shadowRays);
    EXPECT_EQ(points->Figures(), (ShadowFigures{{"light radius", "0"}, {"samples per light", "1"}}));
    for (PointLight& l : s.lights) l.radius = 0.5f;
    auto sized = CreateShadowMethod("area", s, *accel, area);
    const RenderResult c = WhittedRenderer(s, *accel, *sized, area).Render();
    EXPECT_NE(a.image.pixels, c.image.pixels);
    EXPECT_EQ(c.counters.shadowRays, 16 * a.counters.shadowRays);  // 16 samples per light
}

// Each light with its own radius: two lights at the same place over the half-plane, light
// 0 a point (radius 0) and light 1 a sphere of radius R. Light 0 gets RT's visibility,
// exactly and with one ray, everywhere; light 1 the sphere's fractional visibility across
// the penumbra, within Monte Carlo error of the closed form.
TEST(AreaLight, EachLightIsSampledWithItsOwnRadius) {
    Scene s = HalfPlaneScene();
    s.lights.push_back(s.lights[0]);
    s.lights[0].radius = 0.0f;
    s.lights[1].radius = R;
    auto accel = CreateAccelerator("brute", s.mesh);
    RenderOptions area = s.render;
    area.shadows = "area";
    area.areaLight.samples = 1024;
    auto soft = CreateShadowMethod("area", s, *accel, area);
    auto rt = CreateShadowMethod("rt", s, *accel, s.render);
    int fractional = 0;
    for (int k = 0; k <= 20; ++k) {
        const float x = -1.5f + 0.15f * k;
        const ShadingPoint sp = FloorPoint(x, 0.3f);
        const uint32_t needed[2] = {0, 1};
        float vis[2] = {-1, -1}, hard[2] = {-1, -1};
        RenderCounters c, cr;
        soft->Visibility(sp, needed, vis, c);
        rt->Visibility(sp, needed, hard, cr);
        EXPECT_EQ(vis[0], hard[0]) << "x = " << x;  // the point light: RT's answer exactly
        EXPECT_EQ(c.shadowRays, 1u + 1024u) << "x = " << x;  // one ray to the point, N to the sphere
        EXPECT_NEAR(vis[1], ExactVisibleFraction(sp.origin), 0.01) << "x = " << x;
        fractional += vis[1] > 0.05f && vis[1] < 0.95f;
    }
    EXPECT_GE(fractional, 8);  // the penumbra, |x| < 1, is really sampled
    // The figures list the radii in light order.
    const ShadowFigures f = soft->Figures();
    EXPECT_EQ(f, (ShadowFigures{{"light radii", "0, 1"}, {"samples per light", "1024 (1 for the lights of radius 0)"}}));
    // The override replaces both: R for each, so light 0 is soft too.
    area.areaLight.radius = R;
    auto both = CreateShadowMethod("area", s, *accel, area);
    EXPECT_EQ(both->Figures(), (ShadowFigures{{"light radius", "1"}, {"samples per light", "1024"}}));
    EXPECT_NEAR(Vis(*both, FloorPoint(0.2f, 0.3f), 0), ExactVisibleFraction(FloorPoint(0.2f, 0.3f).origin), 0.01);
}

// A light with a bad radius of its own is refused (scene files cannot give one; code can).
TEST(AreaLight, RefusesABadLightRadius) {
    Scene s = FloorScene();
    auto accel = CreateAccelerator("brute", s.mesh);
    RenderOptions area = s.render;
    area.shadows = "area";
    for (float bad : {-0.5f, NAN, INFINITY}) {
        s.lights[0].radius = bad;
        try {
            CreateShadowMethod("area", s, *accel, area);
            FAIL() << "expected an error for radius " << bad;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("test:floor: light 0: radius"), std::string::npos) << e.what();
        }
    }
    area.areaLight.radius = 0.2f;  // the override replaces it
    EXPECT_NO_THROW(CreateShadowMethod("area", s, *accel, area));
}

// Nothing between the floor and a small sphere light: every sample reaches the light (no
// self-shadowing by the floor), so the image is RT's exactly, with N rays per light.
TEST(AreaLight, UnoccludedEqualsRtExactly) {
    const Scene s = FloorScene();
    auto accel = CreateAccelerator("grid", s.mesh);
    const RenderOptions area = AreaOptions(s, 0.5f, 16);
    auto rt = CreateShadowMethod("rt", s, *accel, s.render);
    auto soft = CreateShadowMethod("area", s, *accel, area);
    const RenderResult a = WhittedRenderer(s, *accel, *rt, s.render).Render();
    const RenderResult b = WhittedRenderer(s, *accel, *soft, area).Render();
    EXPECT_EQ(a.image.pixels, b.image.pixels);
    EXPECT_EQ(b.counters.shadowRays, 16 * a.counters.shadowRays);
}

TEST(AreaLight, PointInsideTheSphereSeesAllOfIt) {
    const Scene s = HalfPlaneScene();
    auto accel = CreateAccelerator("brute", s.mesh);
    auto soft = CreateShadowMethod("area", s, *accel, AreaOptions(s, 20.0f, 16));
    const uint32_t needed[1] = {0};
    float vis[1] = {0};
    RenderCounters c;
    soft->Visibility(FloorPoint(-3, 0), needed, vis, c);  // under the occluder, inside the light
    EXPECT_EQ(vis[0], 1.0f);
    EXPECT_EQ(c.shadowRays, 0u);
}

// The sampled directions are unit vectors inside the cone, uniform in solid angle: the
// cap 1 − cos θ < k/2 holds half the solid angle, so half of the stratified samples.
TEST(AreaLight, ConeSamplesAreInsideAndUniformInSolidAngle) {
    const Vec3 axis = Normalize(Vec3(0.3f, 1.0f, -0.2f));
    const float k = 0.05f;  // 1 − cos θmax
    const int n = 1024;
    int inner = 0;
    for (int i = 0; i < n; ++i) {
        const Vec3 w = SampleConeStratified(axis, k, i, n, 0.37f, 0.81f);
        EXPECT_NEAR(Length(w), 1.0f, 1e-5f);
        const float oneMinusCos = 1.0f - Dot(w, axis);
        EXPECT_LE(oneMinusCos, k * 1.0001f + 1e-6f);
        inner += oneMinusCos < k / 2;
    }
    EXPECT_NEAR(inner, n / 2, 8);  // stratified: far tighter than the ±32 of random samples
}

// Analytic penumbra: a spherical light behind a straight edge. The estimate with N = 1024
// matches the exact visible solid-angle fraction at 11 points across the penumbra.
TEST(AreaLight, PenumbraBehindAStraightEdgeMatchesClosedForm) {
    const Scene s = HalfPlaneScene();
    auto accel = CreateAccelerator("brute", s.mesh);
    auto soft = CreateShadowMethod("area", s, *accel, AreaOptions(s, R, 1024));
    // By similar triangles the penumbra on the floor spans x ≈ ±R·h/(H − h) = ±1.
    double worstSegment = 0, worst = 0;
    for (int k = 0; k <= 10; ++k) {
        const float x = -1.0f + 0.2f * k;
        const ShadingPoint sp = FloorPoint(x, 0.37f * k - 2.0f);  // z does not matter
        const double exact = ExactVisibleFraction(sp.origin);
        EXPECT_NEAR(Vis(*soft, sp), exact, 0.01) << "x = " << x;
        worst = std::max(worst, std::abs(Vis(*soft, sp) - exact));
        worstSegment = std::max(worstSegment, std::abs(DiscSegmentFraction(sp.origin) - exact));
        if (k == 5) {
            EXPECT_NEAR(exact, 0.5, 1e-3);  // right under the edge: half the light
        }
    }
    // The flat-disc (circular segment) approximation is close too at this angular size
    // (sin α ≈ 0.1): it differs from the exact fraction by O(α²).
    EXPECT_LT(worstSegment, 0.005);
    std::printf("N = 1024: largest error %.4f; disc approximation off by up to %.4f\n", worst, worstSegment);
    EXPECT_LT(ExactVisibleFraction(Vec3(-1.3f, 1e-5f, 0)), 1e-6);  // umbra
    EXPECT_GT(ExactVisibleFraction(Vec3(1.3f, 1e-5f, 0)), 1 - 1e-6);  // fully lit
    EXPECT_EQ(Vis(*soft, FloorPoint(-1.3f, 0)), 0.0f);
    EXPECT_EQ(Vis(*soft, FloorPoint(1.3f, 0)), 1.0f);
}

// The light mesh's narrow-penumbra estimate (DiscLightVisibility, two rings of 4): 4 rays
// where the outer ring agrees (umbra, full light), 8 in the penumbra; averaged over the
// pattern's turns it follows the closed form within the rim the outer ring can miss.
TEST(AreaLight, DiscEstimateFollowsTheClosedFormAndStopsEarlyWhereTheRingAgrees) {
    const Scene s = HalfPlaneScene();
    auto accel = CreateAccelerator("brute", s.mesh);
    const Vec3 light = s.lights[0].position;
    int rays = 0;
    EXPECT_EQ(DiscLightVisibility(*accel, FloorPoint(-1.3f, 0).origin, light, R, 4, 1, &rays), 0.0f);
    EXPECT_EQ(rays, 4);
    EXPECT_EQ(DiscLightVisibility(*accel, FloorPoint(1.3f, 0).origin, light, R, 4, 1, &rays), 1.0f);
    EXPECT_EQ(rays, 4);
    EXPECT_EQ(DiscLightVisibility(*accel, light, light, R, 4, 1, &rays), 1.0f);  // inside the light
    EXPECT_EQ(rays, 0);
    for (int k = 1; k < 10; ++k) {
        const ShadingPoint sp = FloorPoint(-1.0f + 0.2f * k, 0.3f);
        double sum = 0;
        int traced = 0;
        for (uint64_t seed = 0; seed < 256; ++seed) {
            sum += DiscLightVisibility(*accel, sp.origin, light, R, 4, seed * 0x9E3779B97F4A7C15ull, &rays);
            traced += rays;
        }
        const double exact = ExactVisibleFraction(sp.origin);
        EXPECT_NEAR(sum / 256, exact, 0.08) << "x = " << sp.p.x;
        if (exact > 0.2 && exact < 0.8) {
            EXPECT_GT(traced, 256 * 7) << "the inner ring is traced in the penumbra";
        }
        // The same seed, the same estimate.
        EXPECT_EQ(DiscLightVisibility(*accel, sp.origin, light, R, 4, 42), DiscLightVisibility(*accel, sp.origin, light, R, 4, 42));
    }
}

// Monte Carlo convergence: the RMS error over penumbra points, against N = 4096, falls at
// least about as fast as 1/√N (a factor 2 per quadrupling of N). Stratified samples do
// better: for an edge across the cone, theory says N^-3/4 (2.8 per quadrupling), and we
// measure 2.6 then 4.3 (at N = 256 the estimates, multiples of 1/N, are mostly within one
// sample of the truth). So the test accepts 1.5 to 8 per quadrupling: slower would not be
// Monte Carlo convergence, faster than N^-3/2 would mean the reference shares the
// estimates' errors. Independent random samples would give ≈ 0.09 at N = 16.
TEST(AreaLight, ErrorFallsAsSamplesGrow) {
    const Scene s = HalfPlaneScene();
    auto accel = CreateAccelerator("brute", s.mesh);
    std::vector<ShadingPoint> points;
    for (int i = 0; i < 16; ++i)
        for (int j = 0; j < 8; ++j) points.push_back(FloorPoint(-0.9f + 1.8f * i / 15, -3.0f + 6.0f * j / 7));
    auto estimate = [&](int n) {
        auto m = CreateShadowMethod("area", s, *accel, AreaOptions(s, R, n));
        std::vector<double> v;
        for (const ShadingPoint& sp : points) v.push_back(Vis(*m, sp));
        return v;
    };
    const std::vector<double> reference = estimate(4096);
    std::vector<double> errors;
    for (int n : {16, 64, 256}) {
        const std::vector<double> v = estimate(n);
        double sq = 0, sqExact = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            sq += (v[i] - reference[i]) * (v[i] - reference[i]);
            const double e = v[i] - ExactVisibleFraction(points[i].origin);
            sqExact += e * e;
        }
        errors.push_back(std::sqrt(sq / v.size()));
        std::printf("N = %4d: RMSE %.5f against N = 4096, %.5f against the exact fraction\n", n,
                    errors.back(), std::sqrt(sqExact / v.size()));
    }
    for (size_t i = 1; i < errors.size(); ++i) {
        const double ratio = errors[i - 1] / errors[i];
        EXPECT_GE(ratio, 1.5) << "N x4 step " << i;
        EXPECT_LE(ratio, 8.0) << "N x4 step " << i;
    }
    EXPECT_GE(errors[0] / errors[2], 4.0);  // at least 1/√N over N × 16
    EXPECT_LT(errors[0], 0.05);  // stratification: below the ≈ 0.09 of independent samples
}

// The estimate depends only on the shading point: the same image for 1 and 4 threads, and
// the same visibility for the same point whenever it is asked.
TEST(AreaLight, DeterministicForAnyThreadCount) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0.5f, -1}, {1, 1.5f, 1});
    auto accel = CreateAccelerator("grid", s.mesh);
    const RenderOptions area = AreaOptions(s, 0.6f, 8);
    auto soft = CreateShadowMethod("area", s, *accel, area);
    const WhittedRenderer renderer(s, *accel, *soft, area);
    RenderResult one, many;
    tbb::task_arena(1).execute([&] { one = renderer.Render(); });
    tbb::task_arena(4).execute([&] { many = renderer.Render(); });
    EXPECT_EQ(one.image.pixels, many.image.pixels);
    const ShadingPoint sp = FloorPoint(1.3f, 0.2f);
    const float v = Vis(*soft, sp);
    EXPECT_GT(v, 0.0f);  // a penumbra point: the test is not trivially 0 or 1
    EXPECT_LT(v, 1.0f);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(Vis(*soft, sp), v);
    // Different points get different random shifts.
    EXPECT_NE(AreaLightSeed(sp, 0), AreaLightSeed(FloorPoint(1.3f, 0.2001f), 0));
    EXPECT_NE(AreaLightSeed(sp, 0), AreaLightSeed(sp, 1));
}

}  // namespace
}  // namespace area_light_test
}  // namespace lm
