// cutout_shadows_test.cpp -- the shadow of an alpha cut-out checker is a checker: the lit
// fraction under it is about a half for hard shadows, the area-light reference and the
// default soft shadows, on every back-end (a solid quad's is none).
#include <gtest/gtest.h>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/instances.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/scene_file.h"
#include "support/cutout_scenes.h"
#include "lightmesh/shadow/shadow.h"

namespace lm {
namespace cutout_shadows_test {
namespace {

using testing::CheckerScene;

/// The mean visibility of the light over a 40 × 40 grid of ground points under the quad's
/// middle (its shadow spans ±2.04 on the ground).
double LitFraction(const Scene& s, const Accelerator& accel, const std::string& method) {
    RenderOptions o = s.render;
    o.shadows = method;
    o.areaLight.samples = 64;
    const auto shadows = CreateShadowMethod(method, s, accel, o);
    RenderCounters counters;
    double sum = 0;
    int n = 0;
    for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) {
            const Ray ray{Vec3(-1.5f + 3.0f * (i + 0.5f) / 40, 0.5f, -1.5f + 3.0f * (j + 0.5f) / 40), Vec3(0, -1, 0), 0,
                          Infinity};
            Hit hit;
            if (!accel.Intersect(ray, &hit)) continue;
            const ShadingPoint sp = WhittedRenderer::MakeShadingPoint(s.mesh, ray, hit);
            const uint32_t needed[1] = {0};
            float vis[1] = {0};
            shadows->Visibility(sp, needed, vis, counters);
            sum += vis[0];
            ++n;
        }
    EXPECT_EQ(n, 1600);
    return sum / n;
}

TEST(CutoutShadows, ACheckersShadowIsACheckerForEveryMethodOnEveryBackEnd) {
    const Scene cut = CheckerScene(true), solid = CheckerScene(false);
    ASSERT_TRUE(cut.mesh.cutouts);
    for (const std::string& accelName : AcceleratorNames()) {
        const auto accel = CreateAccelerator(accelName, cut.mesh);
        const auto solidAccel = CreateAccelerator(accelName, solid.mesh);
        for (const char* method : {"rt", "area", "soft", "exact"}) {
            SCOPED_TRACE(accelName + " " + method);
            EXPECT_NEAR(LitFraction(cut, *accel, method), 0.5, 0.04);
            EXPECT_LT(LitFraction(solid, *solidAccel, method), 0.01);
        }
    }
}

/// The checker scene with its quad as an instance of a prototype (its own cut-out mask),
/// placed mirrored (x → −x: the prototype's barycentrics swap) where it was.
Scene InstancedChecker() {
    Scene s = CheckerScene(true);
    const CutoutMask& cut = *s.mesh.cutouts;
    TriangleMesh quad = s.mesh, rest = s.mesh;
    quad.triangles.clear(), quad.materialIds.clear(), rest.triangles.clear(), rest.materialIds.clear();
    quad.cutouts.reset(), rest.cutouts.reset();
    std::vector<CutoutMaterial> materials;
    for (uint32_t t = 0; t < s.mesh.TriangleCount(); ++t) {
        TriangleMesh& to = cut.IsCutout(t) ? quad : rest;
        to.triangles.push_back(s.mesh.triangles[t]);
        to.materialIds.push_back(s.mesh.materialIds[t]);
        if (cut.IsCutout(t) && materials.empty()) materials.push_back(*cut.MaterialOf(t));
    }
    EXPECT_EQ(quad.TriangleCount(), 2u);
    quad.cutouts = std::make_shared<const CutoutMask>(std::vector<int32_t>(quad.TriangleCount(), 0), materials);
    auto instances = std::make_shared<InstancedMeshes>();
    instances->AddInstance(instances->AddPrototype(quad), Affine::Scale({-1, 1, 1}));
    instances->HarmoniseAttributes(&rest);
    rest.instances = instances;
    rest.cutouts = std::make_shared<const CutoutMask>(std::vector<int32_t>(rest.TriangleCount(), -1),
                                                      std::vector<CutoutMaterial>{}, instances);
    s.mesh = std::move(rest);
    return s;
}

TEST(CutoutShadows, AnInstancedCheckersShadowIsAChecker) {
    const Scene cut = InstancedChecker();
    ASSERT_TRUE(cut.mesh.instances);
    EXPECT_EQ(cut.mesh.cutouts->Count(), 2u);
    for (const std::string& accelName : AcceleratorNames()) {
        const auto accel = CreateAccelerator(accelName, cut.mesh);
        for (const char* method : {"rt", "area", "soft", "exact"}) {
            SCOPED_TRACE(accelName + " " + method);
            EXPECT_NEAR(LitFraction(cut, *accel, method), 0.5, 0.04);
        }
    }
}

// The paper's light mesh interpolates its nodes' visibility (through the back-end's rays,
// which honour the holes): the checker's shadow is blurred over the interpolation radius,
// its mean kept.
TEST(CutoutShadows, TheLightMeshSeesTheHolesToo) {
    const Scene cut = CheckerScene(true);
    const auto accel = CreateAccelerator("grid", cut.mesh);
    EXPECT_NEAR(LitFraction(cut, *accel, "lmm"), 0.5, 0.08);
}

}  // namespace
}  // namespace cutout_shadows_test
}  // namespace lm
