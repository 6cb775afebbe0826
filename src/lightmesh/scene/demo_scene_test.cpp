#include "lightmesh/scene/demo_scene.h"

#include <gtest/gtest.h>

#include "lightmesh/scene/scene_file.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace demo_scene_test {
namespace {

TEST(DemoScene, GazeboIsAFewThousandClosedTrianglesWithTwoLights) {
    const Scene s = MakeBuiltinScene("gazebo");
    EXPECT_EQ(s.name, "builtin:gazebo");
    EXPECT_GE(s.mesh.TriangleCount(), 300u);
    EXPECT_LE(s.mesh.TriangleCount(), 5000u);
    EXPECT_GE(s.lights.size(), 2u);
    EXPECT_EQ(s.mesh.materialIds.size(), s.mesh.TriangleCount());
    for (uint32_t m : s.mesh.materialIds) EXPECT_LT(m, s.materials.size());
    // Every object is a closed solid, so the inside-object test applies everywhere.
    EXPECT_TRUE(AnalyzeEdges(s.mesh).Closed());
    // Nothing to clean.
    TriangleMesh copy = s.mesh;
    const CleanReport r = CleanMesh(&copy);
    EXPECT_EQ(r.degenerate + r.duplicate, 0u);
    // The lights are outside every object, above the ground.
    for (const PointLight& l : s.lights) EXPECT_GT(l.position.y, s.mesh.Bounds().hi.y);
}

// The gazebo states its lights' sizes: the constants are the default rule's values, so
// the built-in scene looks as a scene file without "radius" would.
TEST(DemoScene, GazeboLightsHaveTheDefaultRulesRadii) {
    const Scene s = MakeBuiltinScene("gazebo");
    const Bounds3 box = s.mesh.Bounds();
    for (const PointLight& l : s.lights) {
        EXPECT_GT(l.radius, 0.1f);
        EXPECT_NEAR(l.radius, DefaultLightRadius(box, l.position), 1e-3f);
    }
}

TEST(DemoScene, UnknownNameIsAnError) {
    EXPECT_THROW(MakeBuiltinScene("cathedral"), Error);
    EXPECT_EQ(BuiltinSceneNames().front(), "gazebo");
}

}  // namespace
}  // namespace demo_scene_test
}  // namespace lm
