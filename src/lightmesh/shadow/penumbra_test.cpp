// Contact-hardening penumbrae of the light mesh (a light radius R > 0; light_mesh.h): the
// blocker distances the nodes store, the width law w = R·(d_P − d_b)/d_b against the
// analytic penumbra of a sphere light over a plane, the thin-occluder check, determinism
// and leak-freedom.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "support/floor_scenes.h"
#include "support/light_mesh_probe.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/demo_scene.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace penumbra_test {
namespace {

using testing::AddBox;
using Lmc = LightMeshCount;
using testing::FloorPoint;
using testing::FloorScene;

// The default variant at CC 100 with a light radius.
struct Penumbra : testing::LightMeshProbe {
    Penumbra(const Scene& s, float radius, float ki = 2.0f, const std::string& accelName = "grid")
        : LightMeshProbe(s, testing::LightMeshSettings(100, ki, "", radius), accelName) {}
    float Vis(const ShadingPoint& sp, RenderCounters* counters = nullptr) const {
        return LightMeshProbe::Vis(sp, 0, counters);
    }
};

// A thin plate over the half x > 0 of the floor at height `height`; the light straight
// above the plate's edge at height `lightHeight`.
Scene PlateScene(float height, float lightHeight = 8.0f) {
    Scene s = FloorScene();
    AddBox(&s, {0.0f, height, -6.0f}, {6.0f, height + 0.02f, 6.0f});
    s.lights = {{{0.0f, lightHeight, 0.0f}, Color(1.0f), Falloff::None}};
    return s;
}

// The visible share of a disc of unit radius on one side of a chord at signed offset u.
double DiscShare(double u) {
    u = std::clamp(u, -1.0, 1.0);
    return 0.5 + (u * std::sqrt(1 - u * u) + std::asin(u)) / M_PI;
}

TEST(Penumbra, NodesStoreTheirNearestBlocker) {
    const float height = 2.0f, lightY = 8.0f;
    const Scene s = PlateScene(height, lightY);
    Penumbra p(s, 0.3f);
    const LightMeshLattice& L = p.lmm->Lattice();
    int blocked = 0, visible = 0;
    for (int k = 0; k < L.nz; k += 7)
        for (int j = 0; j < L.ny; j += 3)
            for (int i = 0; i < L.nx; i += 5) {
                const uint64_t index = L.Index(i, j, k);
                const Vec3 x = L.Node(i, j, k);
                const float t = p.lmm->NodeBlockerParameter(index, 0);
                if (p.lmm->NodeVisibility(index) & 1) {
                    EXPECT_EQ(t, 0.0f);
                    ++visible;
                    continue;
                }
                ++blocked;
                // Below the plate, the nearest blocker is its lower face: t = (H − y)/(Ly − y).
                if (x.y > 0.01f && x.y < height - 0.01f && x.x > 0.05f && x.x < 5.5f && std::abs(x.z) < 5.5f) {
                    const float expected = (height - x.y) / (lightY - x.y);
                    EXPECT_NEAR(t, expected, 1e-4f) << x.x << " " << x.y << " " << x.z;
                }
                EXPECT_GT(t, 0.0f);
                EXPECT_LT(t, 1.0f);
            }
    EXPECT_GT(blocked, 50);
    EXPECT_GT(visible, 50);
    // Storage: the visibility word plus 2 bytes per light; without a light radius, none.
    EXPECT_EQ(p.lmm->BytesPerNode(), 1 + 2);
    Penumbra plain(s, 0.0f);
    EXPECT_EQ(plain.lmm->BytesPerNode(), 1);
    EXPECT_EQ(plain.lmm->NodeBlockerParameter(L.Index(L.nx / 2 + 5, 3, L.nz / 2), 0), 0.0f);
}

// The 25 %–75 % band of V across the plate's shadow edge, measured on the floor, against the
// analytic band of a sphere light of radius R: w = R·H/(D − H) (d_P = D, d_b = D − H), and
// V = DiscShare(−x/w) across it. V is averaged over 19 lines across the edge (the narrow
// penumbrae are sampled, 8 rays), and the band runs from where that mean falls through
// 0.75 to where it falls through 0.25 (linear interpolation between samples).
double MeasuredBand(const Penumbra& p, double w, RenderCounters* counters) {
    const double span = 2 * w + 1.0;
    const double step = std::min(w / 20, 0.01);
    std::vector<double> xs, mean;
    for (double x = -span; x <= span; x += step) {
        double sum = 0;
        int lines = 0;
        for (int line = -9; line <= 9; ++line, ++lines) sum += p.Vis(FloorPoint(static_cast<float>(x), 0.1f * line), counters);
        xs.push_back(x);
        mean.push_back(sum / lines);
    }
    auto crossing = [&](double level) {
        for (size_t i = 1; i < xs.size(); ++i)
            if (mean[i - 1] >= level && mean[i] < level)
                return xs[i - 1] + (mean[i - 1] - level) / (mean[i - 1] - mean[i]) * step;
        return std::nan("");
    };
    return crossing(0.25) - crossing(0.75);
}

TEST(Penumbra, WidthGrowsWithTheOccluderDistanceAsTheLawSays) {
    const float R = 0.4f, D = 8.0f;
    // The analytic band: DiscShare(u) = 0.25 at u = −u0.
    double lo = 0, hi = 1;
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (DiscShare(-mid) > 0.25 ? lo : hi) = mid;
    }
    const double u0 = 0.5 * (lo + hi);
    double previous = 0;
    // Heights 1, 2.5, 4: half-widths 0.057 (below the lattice's step 0.2: the light is
    // sampled), 0.18 and 0.4 (the nodes' kernel); kI 3 so that r = 0.6 holds the widest.
    for (const float H : {1.0f, 2.5f, 4.0f}) {
        const Scene s = PlateScene(H, D);
        Penumbra p(s, R, 3.0f);
        const double w = R * H / (D - H);
        const double analytic = 2 * u0 * w;
        RenderCounters c;
        const double measured = MeasuredBand(p, w, &c);
        // Which regime answered: rays to the light's disc below 1.5·h = 0.3 of support
        // (1.44·w), the nodes' kernel above.
        if (H < 3) {
            EXPECT_GT(Count(c, Lmc::kPenumbraSampled), 100u) << H;
            EXPECT_EQ(Count(c, Lmc::kPenumbraKernel), 0u) << H;
        } else {
            EXPECT_GT(Count(c, Lmc::kPenumbraKernel), 100u) << H;
            EXPECT_EQ(Count(c, Lmc::kPenumbraSampled), 0u) << H;
        }
        std::printf("plate at height %g: w %.3f, 25-75%% band %.4f, analytic %.4f (%+.0f%%)\n", H, w, measured,
                    analytic, 100 * (measured / analytic - 1));
        EXPECT_NEAR(measured, analytic, 0.2 * analytic) << "plate at height " << H << ", w " << w;
        EXPECT_GT(measured, previous * 1.5) << "the penumbra must widen with the occluder's height";
        previous = measured;
    }
}

TEST(Penumbra, ContactShadowsStayHardWhereTodaysMethodBlurs) {
    // A plate low over the floor (but above two layers of nodes, which the lattice needs
    // to see under it): w = 0.4·0.6/7.4 = 0.032, far below h = 0.2.
    const Scene s = PlateScene(0.6f);
    Penumbra p(s, 0.4f);
    LightMeshOptions o;
    o.cc = 100;
    o.ki = 2.0f;
    auto fixed = CreateLightMeshShadows(s, *p.accel, o);
    const uint32_t needed[1] = {0};
    int hardFixed = 0, hardPenumbra = 0, points = 0;
    for (float x = -0.5f; x <= 0.5f; x += 0.01f, ++points) {
        const ShadingPoint sp = FloorPoint(x, 0.3f);
        RenderCounters c;
        float vis[64] = {};
        fixed->Visibility(sp, needed, vis, c);
        hardFixed += vis[0] == 0.0f || vis[0] == 1.0f;
        const float v = p.Vis(sp);
        hardPenumbra += v == 0.0f || v == 1.0f;
        if (std::abs(x) > 0.05f) {
            EXPECT_EQ(v, x < 0 ? 1.0f : 0.0f) << x;
        }
    }
    // Soft only within the true penumbra (|x| <= w, about 7 of the points 0.01 apart);
    // today's fixed radius blurs a band of about 2r = 0.8 (the far part of it is dark).
    EXPECT_LE(points - hardPenumbra, 11);
    EXPECT_GE(points - hardFixed, 30);
}

TEST(Penumbra, PointsOnTheSceneBoxsFarFacesGetItToo) {
    // A wall standing on the floor's far edge (z = 10, the box's largest z, on a lattice
    // plane: the templates reach the lattice's extra far node there) and a post in front
    // of it, lit from the front: the post's shadow on the wall.
    Scene s = FloorScene();
    s.mesh.positions.insert(s.mesh.positions.end(), {{-10, 0, 10}, {10, 0, 10}, {10, 4, 10}, {-10, 4, 10}});
    s.mesh.triangles.push_back({4, 5, 6});
    s.mesh.triangles.push_back({4, 6, 7});
    s.mesh.materialIds.insert(s.mesh.materialIds.end(), {0, 0});
    AddBox(&s, {-0.25f, 0.0f, 7.0f}, {0.25f, 3.0f, 7.5f});
    s.lights = {{{0.0f, 2.0f, -2.0f}, Color(1.0f), Falloff::None}};
    Penumbra p(s, 0.5f), fixed(s, 0.0f);
    RenderCounters c, cFixed;
    int differ = 0;
    for (float x = -1.5f; x <= 1.5f; x += 0.02f) {
        ShadingPoint sp;
        sp.p = Vec3(x, 1.0f, 10.0f);
        sp.n = Vec3(0, 0, -1);
        sp.origin = Vec3(x, 1.0f, 10.0f - 1e-4f);
        sp.prim = 2;
        differ += p.Vis(sp, &c) != fixed.Vis(sp, &cFixed);
    }
    EXPECT_GT(Count(c, Lmc::kPenumbraLights), 10u);
    EXPECT_EQ(Count(cFixed, Lmc::kPenumbraLights), 0u);
    EXPECT_GT(differ, 10);
    EXPECT_GT(Count(c, Lmc::kUniformCellPoints), 0u) << "the templates, with their cell summaries, must have answered";
}

TEST(Penumbra, StaysLeakFree) {
    // SegmentTestStopsLeaksThatNoTestLetsThrough's scene: a slab thinner than h just above
    // the floor, lit from high above; points deep inside its shadow must stay dark.
    Scene s = FloorScene();
    const float h = 20.0f / 100.0f, r = 2.0f * h;
    const float y0 = 0.25f * r, thickness = 0.1f * h, half = 3.0f;
    AddBox(&s, {-half, y0, -half}, {half, y0 + thickness, half});
    s.lights = {{{0.1f, 8, 0.2f}, Color(1.0f), Falloff::None}};
    for (const char* accel : {"grid", "embree"}) {
        const std::vector<std::string> names = AcceleratorNames();
        if (std::find(names.begin(), names.end(), accel) == names.end()) continue;
        Penumbra p(s, 0.3f, 2.0f, accel);
        const float inner = half * (8.0f - y0) / 8.0f - r - h;
        int leaks = 0, samples = 0;
        for (float x = -inner; x <= inner; x += h / 3)
            for (float z = -inner; z <= inner; z += h / 3, ++samples) leaks += p.Vis(FloorPoint(x, z)) > 0;
        EXPECT_GT(samples, 100);
        EXPECT_EQ(leaks, 0) << accel;
    }
}

TEST(Penumbra, ImagesAreIdenticalForAnyThreadCount) {
    Scene s = MakeBuiltinScene("gazebo");
    s.render.width = 96;
    s.render.height = 72;
    s.render.shadows = "lmm";
    s.render.areaLight.radius = 0.3f;
    auto accel = CreateAccelerator("grid", s.mesh);
    RenderResult one, many;
    tbb::task_arena(1).execute([&] {
        auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
        one = WhittedRenderer(s, *accel, *lmm, s.render).Render();
    });
    tbb::task_arena(4).execute([&] {
        auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
        many = WhittedRenderer(s, *accel, *lmm, s.render).Render();
    });
    EXPECT_EQ(one.image.pixels, many.image.pixels);
    EXPECT_GT(Count(one.counters, Lmc::kPenumbraLights), 0u);
    EXPECT_EQ(Count(one.counters, Lmc::kPenumbraLights), Count(many.counters, Lmc::kPenumbraLights));
    EXPECT_EQ(one.counters.shadowRays, many.counters.shadowRays);
    // And the light radius changes the image (it is not ignored by lmm).
    s.render.areaLight.radius = 0.0f;
    auto fixed = CreateShadowMethod("lmm", s, *accel, s.render);
    const RenderResult fixedImage = WhittedRenderer(s, *accel, *fixed, s.render).Render();
    EXPECT_NE(fixedImage.image.pixels, one.image.pixels);
    // Only the override turns the mode on: the gazebo's lights have radii of their own
    // (0.173, 0.164), and without --light-radius lmm is the fixed-radius method.
    ASSERT_GT(s.lights[0].radius, 0.0f);
    s.render.areaLight.radius.reset();
    auto own = CreateShadowMethod("lmm", s, *accel, s.render);
    const RenderResult ownImage = WhittedRenderer(s, *accel, *own, s.render).Render();
    EXPECT_EQ(ownImage.image.pixels, fixedImage.image.pixels);
    EXPECT_EQ(Count(ownImage.counters, Lmc::kPenumbraLights), 0u);
}

// A rod (or, with `slit`, a plate with a slit) thinner than the mesh step at height 1,
// along z, placed halfway between two columns of nodes so that no node's shadow segment
// meets it (or passes through it), under a light of radius 0.1 straight above it at
// height 8. The rod's strip seen from the floor below it covers the light's whole disc
// (0.03·8/1 = 0.24 > 0.2), so the true V there is 0 (through the slit: 1).
struct ThinScene {
    Scene scene;
    float x = 0;  // the rod's (slit's) centre line
    static constexpr float kHalfWidth = 0.015f, kHeight = 1.0f, kLightY = 8.0f;
    explicit ThinScene(bool slit) {
        // The lattice's columns do not depend on where the rod is (it stays inside the
        // floor's box in x and z): find them with the rod at 0, then move it between two.
        for (int pass = 0; pass < 2; ++pass) {
            scene = FloorScene();
            if (slit) {
                AddBox(&scene, {-6.0f, kHeight, -6.0f}, {x - kHalfWidth, kHeight + 0.02f, 6.0f});
                AddBox(&scene, {x + kHalfWidth, kHeight, -6.0f}, {6.0f, kHeight + 0.02f, 6.0f});
            } else {
                AddBox(&scene, {x - kHalfWidth, kHeight, -6.0f}, {x + kHalfWidth, kHeight + 0.02f, 6.0f});
            }
            scene.lights = {{{x, kLightY, 0.0f}, Color(1.0f), Falloff::None}};
            const LightMeshLattice L = LightMeshLattice::Make(scene.mesh.Bounds(), 100, 2.0f);
            const float column = L.origin.x + std::round((0.0f - L.origin.x) / L.h) * L.h;
            x = column + 0.5f * L.h;
        }
    }
    // The light mesh over it with the thin check `check` and light radius R.
    testing::LightMeshProbe Probe(const char* check, float R = 0.1f) const {
        LightMeshOptions options = testing::LightMeshSettings(100, 2.0f, "", R);
        options.thinCheck = check;
        return testing::LightMeshProbe(scene, options);
    }
};

TEST(Penumbra, ThinCheckGivesOccludersThinnerThanTheMeshTheirShadow) {
    const ThinScene t(false);
    const testing::LightMeshProbe off = t.Probe("off"), lit = t.Probe("lit");
    const float h = off.lmm->Lattice().h;
    ASSERT_GT(h, 8 * ThinScene::kHalfWidth);
    // The nodes fall on both sides of the rod: without the check the floor under it is lit.
    EXPECT_EQ(off.Vis(FloorPoint(t.x, 0.3f)), 1.0f);
    RenderCounters c;
    int darker = 0;
    for (float dx = -0.3f; dx <= 0.3f; dx += 0.005f) {
        const ShadingPoint sp = FloorPoint(t.x + dx, 0.3f);
        const float vOff = off.Vis(sp), vLit = lit.Vis(sp, 0, &c);
        // The check only lowers a 1 to what rays to the light see: never more light.
        EXPECT_LE(vLit, vOff) << dx;
        darker += vLit < vOff;
        // The true shadow: the disc fully covered within 0.0054 of the line, fully visible
        // beyond 0.046 (the rod's half-width plus the penumbra w = R·H/(D − H) = 0.0143,
        // projected from height 1 to the floor: ×8/7).
        if (std::abs(dx) < 0.004f) {
            EXPECT_EQ(vLit, 0.0f) << dx;
        }
        if (std::abs(dx) > 0.05f) {
            EXPECT_EQ(vLit, 1.0f) << dx;
        }
    }
    // The points whose own ray the rod blocks (|dx| < 0.017: 7 of these); the outer part
    // of its penumbra, where P's ray passes, keeps the nodes' 1 (a limit of the check).
    EXPECT_GE(darker, 5);
    EXPECT_GT(Count(c, Lmc::kThinFound), 0u);
    EXPECT_GT(Count(c, Lmc::kThinChecks), Count(c, Lmc::kThinFound));
}

TEST(Penumbra, ThinCheckAllLetsLightThroughGapsThinnerThanTheMesh) {
    const ThinScene t(true);
    const testing::LightMeshProbe lit = t.Probe("lit"), all = t.Probe("all");
    // Under the slit the nodes are all in the plate's shadow; P sees the whole disc.
    EXPECT_EQ(lit.Vis(FloorPoint(t.x, 0.3f)), 0.0f);
    EXPECT_EQ(all.Vis(FloorPoint(t.x, 0.3f)), 1.0f);
    for (float dx = -0.3f; dx <= 0.3f; dx += 0.005f) {
        const ShadingPoint sp = FloorPoint(t.x + dx, 0.3f);
        const float vLit = lit.Vis(sp), vAll = all.Vis(sp);
        EXPECT_GE(vAll, vLit) << dx;
        if (std::abs(dx) > 0.05f) {
            EXPECT_EQ(vAll, 0.0f) << dx;
        }
    }
    // Without a light radius the setting does nothing: the fixed-radius method.
    const testing::LightMeshProbe fixedAll = t.Probe("all", 0.0f), fixedOff = t.Probe("off", 0.0f);
    for (float dx = -0.3f; dx <= 0.3f; dx += 0.01f)
        EXPECT_EQ(fixedAll.Vis(FloorPoint(t.x + dx, 0.3f)), fixedOff.Vis(FloorPoint(t.x + dx, 0.3f))) << dx;
}

// The batched penumbra mode (VisibilityMany: every point's walk first, the narrow
// penumbrae's discs queued and traced several points to a light at a time, then the thin
// check's rays light by light as packets, then the disc where a ray disagrees) gives each
// point what Visibility gives it alone: the same values, the slots of lights not needed
// untouched, the same counts. Over more points than a block holds (150), one and three
// lights, with points under the rod and the slit where the check disagrees with the nodes,
// and along the edge of a plate low over the floor, whose penumbra is narrow (the discs).
TEST(Penumbra, BatchedPointsGetWhatEachGetsAlone) {
    const ThinScene rod(false), slit(true);
    Scene three = rod.scene;  // the rod with two more lights, off to the sides
    three.lights.push_back({{rod.x - 3.0f, 6.0f, 1.0f}, Color(0.5f), Falloff::None});
    three.lights.push_back({{rod.x + 2.0f, 7.0f, -2.0f}, Color(0.5f), Falloff::None});
    const Scene plate = PlateScene(0.5f);
    struct Case {
        const Scene* scene;
        float x;  // the thin object's line, or the plate's edge
        const char* check;
    };
    const Case cases[] = {{&rod.scene, rod.x, "lit"}, {&slit.scene, slit.x, "all"}, {&three, rod.x, "all"},
                          {&three, rod.x, "lit"},     {&plate, 0.0f, "off"},        {&plate, 0.0f, "all"}};
    uint64_t checks = 0, found = 0, sampled = 0;
    for (const Case& c : cases) {
        LightMeshOptions options = testing::LightMeshSettings(100, 2.0f, "", 0.1f);
        options.thinCheck = c.check;
        const testing::LightMeshProbe probe(*c.scene, options);
        const size_t lights = c.scene->lights.size();
        std::vector<ShadingPoint> points;
        for (int k = 0; k < 150; ++k) points.push_back(FloorPoint(c.x - 0.375f + 0.005f * k, 0.3f + 0.01f * (k % 7)));
        const size_t slots = points.size() * lights;
        std::unique_ptr<bool[]> needed(new bool[slots]);
        for (size_t i = 0; i < slots; ++i) needed[i] = lights == 1 || (i * 7) % 5 != 0;  // some lights not needed
        std::vector<float> one(slots, -1.0f), many(slots, -1.0f);
        RenderCounters cOne, cMany;
        for (size_t i = 0; i < points.size(); ++i)
            testing::FlaggedVisibility(*probe.lmm, points[i], needed.get() + i * lights, lights, one.data() + i * lights, cOne);
        testing::FlaggedVisibilityMany(*probe.lmm, points.data(), points.size(), needed.get(), lights, many.data(), cMany);
        EXPECT_EQ(many, one) << c.check << ", " << lights << " lights";
        EXPECT_EQ(cMany.shadowRays, cOne.shadowRays) << c.check;
        for (size_t k = 0; k < kMethodCounterSlots; ++k) EXPECT_EQ(cMany.method[k], cOne.method[k]) << c.check << " " << k;
        checks += Count(cOne, Lmc::kThinChecks);
        found += Count(cOne, Lmc::kThinFound);
        sampled += Count(cOne, Lmc::kPenumbraSampled);
    }
    EXPECT_GT(checks, 400u);
    EXPECT_GT(found, 10u);    // the check's disc ran
    EXPECT_GT(sampled, 50u);  // and the queued discs
}

TEST(Penumbra, BadLightRadiusOrVariantIsAnError) {
    const Scene s = PlateScene(2.0f);
    auto accel = CreateAccelerator("grid", s.mesh);
    LightMeshOptions o;
    o.lightRadius = -1.0f;
    EXPECT_THROW(CreateLightMeshShadows(s, *accel, o), Error);
    o.lightRadius = std::nanf("");
    EXPECT_THROW(CreateLightMeshShadows(s, *accel, o), Error);
    o.lightRadius = 0.3f;
    o.thinCheck = "some";
    EXPECT_THROW(CreateLightMeshShadows(s, *accel, o), Error);
    o.thinCheck = "all";
    o.variant = "none";
    try {
        CreateLightMeshShadows(s, *accel, o);
        FAIL() << "expected an error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("needs the consensus variant"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace penumbra_test
}  // namespace lm
