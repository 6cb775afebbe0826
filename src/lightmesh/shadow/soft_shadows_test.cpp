#include "lightmesh/shadow/soft_shadows.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "support/floor_scenes.h"
#include "support/light_indices.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/shapes.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace soft_shadows_test {
namespace {

/// A heightfield terrain (a 24 × 24 grid over [-12, 12]², gentle hills) with two closed
/// buildings standing on it, a pole and a railing of bars thinner than a light-mesh cell,
/// and a wall with a slot in it: the cases the soft mode must get right (thin occluders and
/// gaps, contact with the ground, no light through solids).
Scene TerrainScene(float lightRadius) {
    Scene s;
    s.name = "test:terrain";
    s.materials = {{"ground", Color(0.5f), Color(0.0f), 1.0f, Color(0.0f)}, {"stone", Color(0.7f), Color(0.0f), 1.0f, Color(0.0f)}};
    const int n = 24;
    auto height = [](float x, float z) { return 0.6f * std::sin(0.35f * x) * std::cos(0.3f * z) + 0.02f * x; };
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const float x = -12.0f + 24.0f * static_cast<float>(i) / n, z = -12.0f + 24.0f * static_cast<float>(j) / n;
            s.mesh.positions.push_back({x, height(x, z), z});
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t a = static_cast<uint32_t>(j * (n + 1) + i), b = a + 1, c = a + n + 1, d = c + 1;
            s.mesh.triangles.push_back({a, c, b});
            s.mesh.triangles.push_back({b, c, d});
            s.mesh.materialIds.push_back(0);
            s.mesh.materialIds.push_back(0);
        }
    ShapeBuilder b(&s.mesh);
    b.Box({-6, -1, -3}, {-2, 3.5f, 1}, 1);               // a building sunk into the hill
    b.Box({3, -1, 2}, {6, 2.5f, 5}, 1);                  // another
    b.Beam({0, -0.5f, -4}, {0, 4, -4}, 0.04f, 1);        // a pole thinner than a cell
    for (int k = 0; k < 8; ++k)                          // a railing of thin bars
        b.Beam({-1.0f + 0.3f * k, -0.5f, 5}, {-1.0f + 0.3f * k, 1.5f, 5}, 0.05f, 1);
    b.Box({6, -1, -8}, {6.3f, 3, -5.2f}, 1);             // a wall with a slot between its halves
    b.Box({6, -1, -5.0f}, {6.3f, 3, -2}, 1);
    s.lights = {{{-8, 14, 6}, Color(200.0f), Falloff::InverseSquare}, {{10, 9, -4}, Color(80.0f), Falloff::InverseSquare}};
    s.lights[0].radius = lightRadius;
    s.lights[1].radius = 0.5f * lightRadius;
    s.camera = Camera{{0, 14, 16}, {0, 0, 0}, {0, 1, 0}, 55.0f};
    s.render.width = 64;
    s.render.height = 48;
    return s;
}

struct Probe {
    ShadingPoint sp;
    bool needed[2];
};

/// Shading points where rays from above hit the scene, each with the lights that face it.
std::vector<Probe> Probes(const Scene& s, const Accelerator& accel, int count, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-11.5f, 11.5f);
    std::vector<Probe> out;
    while (static_cast<int>(out.size()) < count) {
        const Vec3 from(u(rng), 20.0f, u(rng));
        const Ray ray{from, Vec3(0.05f, -1.0f, 0.03f), 0.0f, Infinity};
        Hit hit;
        if (!accel.Intersect(ray, &hit)) continue;
        Probe p;
        p.sp = WhittedRenderer::MakeShadingPoint(s.mesh, ray, hit);
        bool any = false;
        for (int l = 0; l < 2; ++l) any |= (p.needed[l] = Dot(p.sp.n, s.lights[l].position - p.sp.p) > 0);
        if (any) out.push_back(p);
    }
    return out;
}

std::unique_ptr<ShadowMethod> Method(const Scene& s, const Accelerator& accel, const char* name, int samples = 16,
                                     int denseEntries = 512) {
    RenderOptions o = s.render;
    o.areaLight.samples = samples;
    o.soft.denseEntries = denseEntries;
    return CreateShadowMethod(name, s, accel, o);
}

struct Comparison {
    double meanError = 0, maxError = 0, shadowSoft = 0, shadowRef = 0;
    int lightsInRefLit = 0, darkInSoft = 0, lightsInRefDark = 0, litInSoft = 0;
};

Comparison Compare(const Scene& s, const Accelerator& accel, const ShadowMethod& soft, const ShadowMethod& ref,
                   int count, uint32_t seed) {
    Comparison c;
    int n = 0;
    RenderCounters counters;
    for (const Probe& p : Probes(s, accel, count, seed)) {
        float vs[2] = {-1, -1}, vr[2] = {-1, -1};
        testing::FlaggedVisibility(soft, p.sp, p.needed, 2, vs, counters);
        testing::FlaggedVisibility(ref, p.sp, p.needed, 2, vr, counters);
        for (int l = 0; l < 2; ++l) {
            if (!p.needed[l]) continue;
            const double e = std::abs(vs[l] - vr[l]);
            c.meanError += e;
            c.maxError = std::max(c.maxError, e);
            c.shadowSoft += 1 - vs[l];
            c.shadowRef += 1 - vr[l];
            if (vr[l] == 1) ++c.lightsInRefLit, c.darkInSoft += vs[l] < 0.9f;
            if (vr[l] == 0) ++c.lightsInRefDark, c.litInSoft += vs[l] > 0.1f;
            ++n;
        }
    }
    c.meanError /= std::max(n, 1);
    return c;
}

// The soft mode estimates the area reference's quantity: against 1,024 stratified rays per
// light its 64 directions differ by sampling noise alone, its total shadow agrees within
// 2 %, and where the reference sees the whole light or none of it (open ground, behind
// the buildings and the wall, next to where they meet the ground) so does the soft mode.
TEST(SoftShadows, MatchesTheAreaReferenceOnATerrainWithBuildings) {
    const Scene s = TerrainScene(0.8f);
    const auto accel = CreateAccelerator("grid", s.mesh);
    const auto soft = Method(s, *accel, "exact");
    const auto ref = Method(s, *accel, "area", 1024);
    const Comparison c = Compare(s, *accel, *soft, *ref, 1500, 1);
    EXPECT_LT(c.meanError, 0.006);
    EXPECT_LT(c.maxError, 0.2);
    EXPECT_NEAR(c.shadowSoft, c.shadowRef, 0.02 * c.shadowRef);
    EXPECT_GT(c.lightsInRefLit, 500);
    EXPECT_GT(c.lightsInRefDark, 50);
    EXPECT_EQ(c.darkInSoft, 0) << "dark seams or false shadows";
    EXPECT_EQ(c.litInSoft, 0) << "light leaking into the umbra";
}

// Cells too full to pay (here every one) trace rays through the back-end instead: the same
// quantity, with 16 samples.
TEST(SoftShadows, DenseCellsTraceRaysAndStillMatch) {
    const Scene s = TerrainScene(0.8f);
    const auto accel = CreateAccelerator("grid", s.mesh);
    const auto soft = Method(s, *accel, "exact", 16, 1);
    const auto ref = Method(s, *accel, "area", 1024);
    const Comparison c = Compare(s, *accel, *soft, *ref, 500, 2);
    EXPECT_LT(c.meanError, 0.02);
    EXPECT_NEAR(c.shadowSoft, c.shadowRef, 0.05 * c.shadowRef);
}

// Occluders and gaps thinner than a cell keep their effect: the pole's and the bars'
// shadows and the light through the wall's slot, point by point.
TEST(SoftShadows, ThinOccludersAndGapsKeepTheirShadows) {
    const Scene s = TerrainScene(0.3f);
    const auto accel = CreateAccelerator("grid", s.mesh);  // the back-end only traces the reference's rays
    const auto soft = Method(s, *accel, "exact");
    const auto* ss = dynamic_cast<const SoftShadows*>(soft.get());
    ASSERT_NE(ss, nullptr);
    EXPECT_GT(ss->Step(), 0.3f);  // the cells are wider than the pole, the bars and the slot
    const auto ref = Method(s, *accel, "area", 1024);
    // Points along the pole's and the bars' shadows: the segments from the light through
    // them to the ground.
    const Vec3 light = s.lights[0].position;
    int shadowed = 0;
    RenderCounters counters;
    for (const Vec3 target : {Vec3(0, 2, -4), Vec3(0, 1, -4), Vec3(-0.7f, 1, 5), Vec3(0.2f, 0.5f, 5), Vec3(6.15f, 1.5f, -5.1f)}) {
        for (float along = -0.3f; along <= 0.3f; along += 0.02f) {
            // The ground (or whatever is there) just behind the thin object, from the light.
            const Vec3 dir = Normalize(Normalize(target - light) + Vec3(along * 0.1f, 0, 0));
            Hit hit;
            const Ray ray{target + dir * 0.5f, dir, 0.0f, Infinity};
            if (!accel->Intersect(ray, &hit)) continue;
            const ShadingPoint sp = WhittedRenderer::MakeShadingPoint(s.mesh, ray, hit);
            const uint32_t needed[1] = {0};
            float vs[1], vr[1];
            soft->Visibility(sp, needed, vs, counters);
            ref->Visibility(sp, needed, vr, counters);
            EXPECT_NEAR(vs[0], vr[0], 0.15f) << "at " << sp.p.x << " " << sp.p.y << " " << sp.p.z;
            shadowed += vr[0] < 0.9f;
        }
    }
    EXPECT_GT(shadowed, 10);
}

// A light of radius 0 gets the hard shadow: the answer of its one shadow ray, exactly.
TEST(SoftShadows, PointLightsGetRtsHardShadow) {
    const Scene s = TerrainScene(0.0f);
    const auto accel = CreateAccelerator("brute", s.mesh);
    const auto soft = Method(s, *accel, "exact");
    const auto rt = Method(s, *accel, "rt");
    RenderCounters counters;
    int shadowed = 0;
    for (const Probe& p : Probes(s, *accel, 3000, 3)) {
        float vs[2] = {-1, -1}, vr[2] = {-1, -1};
        testing::FlaggedVisibility(*soft, p.sp, p.needed, 2, vs, counters);
        testing::FlaggedVisibility(*rt, p.sp, p.needed, 2, vr, counters);
        for (int l = 0; l < 2; ++l)
            if (p.needed[l]) {
                EXPECT_EQ(vs[l], vr[l]);
                shadowed += vr[l] == 0;
            }
    }
    EXPECT_GT(shadowed, 100);
}

// The image is the same for any number of threads: a cell's lists depend on the cell
// alone, and each point's directions on the point alone.
TEST(SoftShadows, SameImageForAnyThreadCount) {
    Scene s = TerrainScene(0.8f);
    s.render.width = 96;
    s.render.height = 72;
    const auto accel = CreateAccelerator("brute", s.mesh);
    RenderOptions o = s.render;
    o.shadows = "exact";
    Image one, many;
    {
        const auto soft = CreateShadowMethod("exact", s, *accel, o);
        const WhittedRenderer r(s, *accel, *soft, o);
        tbb::task_arena(1).execute([&] { one = r.Render().image; });
    }
    {
        const auto soft = CreateShadowMethod("exact", s, *accel, o);
        const WhittedRenderer r(s, *accel, *soft, o);
        tbb::task_arena(4).execute([&] { many = r.Render().image; });
    }
    ASSERT_EQ(one.pixels.size(), many.pixels.size());
    EXPECT_TRUE(one.pixels == many.pixels);
}

// A shadowed receiver whose part of a cell lies wholly in the umbra of one triangle is
// certified dark once, for all its points: a floor under a wide slab.
TEST(SoftShadows, CertifiesTheUmbraUnderAWideSlab) {
    Scene s = testing::FloorScene(10.0f);
    testing::AddBox(&s, {-6, 2, -6}, {6, 2.2f, 6});
    s.lights[0].radius = 0.3f;
    const auto accel = CreateAccelerator("brute", s.mesh);
    const auto soft = Method(s, *accel, "exact");
    RenderCounters counters;
    for (float x = -2; x <= 2; x += 0.25f) {
        const ShadingPoint sp = testing::RenderedFloorPoint(x, 0.3f * x);
        const uint32_t needed[1] = {0};
        float v = -1;
        soft->Visibility(sp, needed, &v, counters);
        EXPECT_EQ(v, 0.0f);
    }
    // Those whose cones cross the diagonal between the slab's two bottom triangles are
    // sampled instead: no one triangle covers them.
    EXPECT_GT(counters.method[kSoftReceiverDark], 4u);
}

// A point whose own triangle is not among its cell's receivers tests the cell's whole list
// (each entry's plane read from the triangles' table) instead of its receiver's short list:
// every triangle that can block a direction is in both, so it matches the area reference as
// the receivers' answers do, without a light leak or a false shadow.
TEST(SoftShadows, TheWholeListMatchesTheAreaReferenceToo) {
    const Scene s = TerrainScene(0.8f);
    const auto accel = CreateAccelerator("grid", s.mesh);
    const auto soft = Method(s, *accel, "exact");
    const auto ref = Method(s, *accel, "area", 1024);
    RenderCounters counters, refCounters;
    double error = 0, shadowSoft = 0, shadowRef = 0;
    int compared = 0, refDark = 0, refLit = 0, leaks = 0, falseShadows = 0;
    for (const Probe& p : Probes(s, *accel, 800, 5)) {
        // The terrain's first triangle, at the corner (-12, -12): in no cell of a far point.
        if (p.sp.p.x < -9 && p.sp.p.z < -9) continue;
        ShadingPoint elsewhere = p.sp;
        elsewhere.prim = 0;
        for (uint32_t l = 0; l < 2; ++l) {
            if (!p.needed[l]) continue;
            const uint32_t needed[1] = {l};
            float v = -1, r = -1;
            soft->Visibility(elsewhere, needed, &v, counters);
            ref->Visibility(p.sp, needed, &r, refCounters);
            error += std::abs(v - r);
            shadowSoft += 1 - v, shadowRef += 1 - r;
            if (r == 0) ++refDark, leaks += v > 0.1f;
            if (r == 1) ++refLit, falseShadows += v < 0.9f;
            ++compared;
        }
    }
    ASSERT_GT(compared, 700);
    EXPECT_LT(error / compared, 0.006);
    EXPECT_NEAR(shadowSoft, shadowRef, 0.02 * shadowRef);
    EXPECT_GT(refDark, 30);
    EXPECT_GT(refLit, 300);
    EXPECT_EQ(leaks, 0) << "light leaking into the umbra";
    EXPECT_EQ(falseShadows, 0) << "false shadows";
    EXPECT_GT(counters.method[kSoftWholeList], 500u);  // the whole list was taken
}

TEST(SoftShadows, RefusesBadSampleCounts) {
    const Scene s = TerrainScene(0.5f);
    const auto accel = CreateAccelerator("brute", s.mesh);
    RenderOptions o = s.render;
    for (int bad : {-16, 8, 20, 512}) {  // 0 is the default (64)
        o.soft.samples = bad;
        EXPECT_THROW(CreateShadowMethod("exact", s, *accel, o), Error) << bad;
    }
}

}  // namespace
}  // namespace soft_shadows_test
}  // namespace lm
