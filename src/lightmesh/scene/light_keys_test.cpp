// Spots and the sun in scene files (light_keys.cpp), the sun's far sphere (PlaceSuns) and a
// model file's cameras and lights made the scene's (file_cameras_lights.cpp).
#include <gtest/gtest.h>

#include <cmath>

#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace light_keys_test {
namespace {

const std::string kScene = std::string(LIGHTMESH_TEST_DATA) + "/scene_file/lights.json";

std::string SceneText(const std::string& light) {
    return R"({"camera": {"position": [0, 2, 6], "look_at": [0, 0, 0]}, "lights": [)" + light +
           R"(], "meshes": [{"file": "two_boxes.obj"}]})";
}

Scene Load(const std::string& light) {
    SceneLoadOptions o;
    o.text = SceneText(light);
    std::vector<std::string> warnings;
    return LoadScene(kScene, o, &warnings);
}

std::string LoadError(const std::string& light) {
    try {
        Load(light);
    } catch (const Error& e) {
        return e.what();
    }
    return "<no error>";
}

TEST(LightKeys, SpotReadsItsCone) {
    const Scene s = Load(R"({"position": [0, 5, 0], "spot": {"direction": [0, -2, 0], "inner": 10, "outer": 20}})");
    ASSERT_EQ(s.lights.size(), 1u);
    const PointLight& l = s.lights[0];
    EXPECT_EQ(l.kind, LightKind::Spot);
    EXPECT_EQ(l.spot.direction.y, -1.0f);
    EXPECT_NEAR(l.spot.cosInner, std::cos(10 * Pi / 180), 1e-6f);
    EXPECT_NEAR(l.spot.cosOuter, std::cos(20 * Pi / 180), 1e-6f);
    EXPECT_EQ(l.falloff, Falloff::InverseSquare);
    // glTF's defaults: inner 0, outer 45.
    const Scene d = Load(R"({"position": [0, 5, 0], "spot": {"direction": [0, -1, 0]}})");
    EXPECT_EQ(d.lights[0].spot.cosInner, 1.0f);
    EXPECT_NEAR(d.lights[0].spot.cosOuter, std::cos(45 * Pi / 180), 1e-6f);
}

TEST(LightKeys, BadSpotsAreErrorsNamingTheKey) {
    for (const auto& [light, text] : std::vector<std::pair<std::string, std::string>>{
             {R"({"position": [0, 5, 0], "spot": {"direction": [0, -1, 0], "inner": 30, "outer": 20}})",
              "/lights/0/spot/inner: must not exceed \"outer\" (20 degrees), got 30"},
             {R"({"position": [0, 5, 0], "spot": {"direction": [0, -1, 0], "outer": 95}})",
              "/lights/0/spot/outer: must be above 0 and at most 90 degrees, got 95"},
             {R"({"position": [0, 5, 0], "spot": {"direction": [0, -1, 0], "outer": 0}})",
              "/lights/0/spot/outer: must be above 0 and at most 90 degrees, got 0"},
             {R"({"position": [0, 5, 0], "spot": {"direction": [0, 0, 0]}})",
              "/lights/0/spot/direction: must be a non-zero direction, got (0, 0, 0)"},
             {R"({"position": [0, 5, 0], "spot": {"inner": 3}})", "/lights/0/spot/direction: missing required key"},
             {R"({"position": [0, 5, 0], "spot": {"direction": [0, -1, 0], "inner": -1}})",
              "/lights/0/spot/inner: must be at least 0 and at most 90 degrees, got -1"},
         }) {
        EXPECT_NE(LoadError(light).find(text), std::string::npos) << LoadError(light);
    }
}

TEST(LightKeys, TheSunIsAFarSphereSubtendingItsAngle) {
    const Scene s = Load(R"({"sun": {"direction": [1, -1, 0]}, "intensity": 0.8})");
    ASSERT_EQ(s.lights.size(), 1u);
    const PointLight& l = s.lights[0];
    EXPECT_EQ(l.kind, LightKind::Sun);
    EXPECT_EQ(l.falloff, Falloff::None);
    EXPECT_EQ(l.intensity.r, 0.8f);
    const Bounds3 box = s.mesh.Bounds();
    const Vec3 toSun = l.position - box.Center();
    const float distance = Length(toSun);
    EXPECT_NEAR(distance, kSunDistanceFactor * 0.5f * Length(box.Diagonal()), 1e-3f * distance);
    // Against the direction the light travels.
    EXPECT_NEAR(Dot(toSun / distance, Normalize(Vec3(-1, 1, 0))), 1.0f, 1e-6f);
    // The sphere subtends the sun's angular radius, 0.2665°, from the scene's centre.
    EXPECT_NEAR(std::asin(l.radius / distance) * 180 / Pi, kSunAngleDegrees, 1e-4f);
    const Scene hard = Load(R"({"sun": {"direction": [0, -1, 0], "angle": 0}})");
    EXPECT_EQ(hard.lights[0].radius, 0.0f);
}

TEST(LightKeys, LightRadiusOverridesLeaveTheSunsSizeExceptZero) {
    const Scene s = Load(R"({"sun": {"direction": [1, -1, 0]}}, {"position": [0, 5, 0], "radius": 0.3})");
    RenderOptions o;
    o.areaLight.radius = 0.5f;
    const std::vector<float> r = LightRadii(s, o);
    EXPECT_EQ(r[0], s.lights[0].radius);
    EXPECT_GT(r[0], 1.0f);
    EXPECT_EQ(r[1], 0.5f);
    o.areaLight.radius = 0.0f;
    EXPECT_EQ(LightRadii(s, o), std::vector<float>({0.0f, 0.0f}));
}

TEST(LightKeys, BadSunsAreErrorsNamingTheKey) {
    for (const auto& [light, text] : std::vector<std::pair<std::string, std::string>>{
             {R"({"sun": {"direction": [1, -1, 0]}, "position": [0, 1, 0]})", "/lights/0/position: a sun has no \"position\""},
             {R"({"sun": {"direction": [1, -1, 0]}, "radius": 2})", "/lights/0/radius: a sun has no \"radius\""},
             {R"({"sun": {"direction": [1, -1, 0]}, "falloff": "none"})", "/lights/0/falloff: a sun has no \"falloff\""},
             {R"({"sun": {"direction": [1, -1, 0], "angle": 50}})",
              "/lights/0/sun/angle: must be at least 0 and at most 45 degrees, got 50"},
             {R"({"sun": {"direction": [0, 0, 0]}})", "/lights/0/sun/direction: must be a non-zero direction"},
             {R"({"sun": {"angle": 1}})", "/lights/0/sun/direction: missing required key"},
         }) {
        EXPECT_NE(LoadError(light).find(text), std::string::npos) << LoadError(light);
    }
}

TEST(FileCamerasLights, SelectByNameOrIndex) {
    std::vector<FileCamera> cams(2);
    cams[0].name = "Main", cams[1].name = "Top";
    std::string problem;
    EXPECT_EQ(SelectFileCamera(cams, "", &problem), 0);
    EXPECT_EQ(SelectFileCamera(cams, "Top", &problem), 1);
    EXPECT_EQ(SelectFileCamera(cams, "1", &problem), 1);
    EXPECT_EQ(SelectFileCamera(cams, "99999999999999999999", &problem), -1);
    EXPECT_EQ(problem, "the file has 2 cameras (indices 0 to 1), no camera 99999999999999999999");
    EXPECT_EQ(SelectFileCamera(cams, "top", &problem), -1);
    EXPECT_EQ(problem, "the file has no camera named \"top\" (its cameras: \"Main\", \"Top\")");
    EXPECT_EQ(SelectFileCamera({}, "", &problem), -1);
    cams[0].orthographic = true;  // passed over by default, still chosen by name
    EXPECT_EQ(SelectFileCamera(cams, "", &problem), 1);
    EXPECT_EQ(SelectFileCamera(cams, "Main", &problem), 0);
    cams[1].orthographic = true;
    EXPECT_EQ(SelectFileCamera(cams, "", &problem), -1);
    EXPECT_EQ(problem, "");
}

TEST(FileCamerasLights, HorizontalHalfAngleAndAspectGiveTheVerticalFieldOfView) {
    FileCamera fc;
    fc.position = Vec3(0, 0, 5), fc.lookAt = Vec3(0, 0, -1), fc.up = Vec3(0, 1, 0);
    fc.horizontalFov = 0.5f;  // half the horizontal angle (Assimp's convention outside glTF)
    fc.aspect = 2.0f;
    Camera c;
    ASSERT_EQ(CameraFromFile(fc, 1.0f, &c), "");
    EXPECT_NEAR(c.fovY, 2 * std::atan(std::tan(0.5) / 2) * 180 / Pi, 1e-4f);
    // Aspect 0, negative or NaN: the image's.
    for (float aspect : {0.0f, -1.0f, NAN}) {
        fc.aspect = aspect;
        ASSERT_EQ(CameraFromFile(fc, 4.0f, &c), "");
        EXPECT_NEAR(c.fovY, 2 * std::atan(std::tan(0.5) / 4) * 180 / Pi, 1e-4f);
    }
    // COLLADA, FBX: the full horizontal angle.
    fc.fov = FileCamera::Fov::FullHorizontal, fc.horizontalFov = 1.0f, fc.aspect = 2.0f;
    ASSERT_EQ(CameraFromFile(fc, 1.0f, &c), "");
    EXPECT_NEAR(c.fovY, 2 * std::atan(std::tan(0.5) / 2) * 180 / Pi, 1e-4f);
    // glTF: yfov × aspect read back.
    fc.fov = FileCamera::Fov::GltfYfovTimesAspect, fc.horizontalFov = 0.6f, fc.aspect = 1.5f;
    ASSERT_EQ(CameraFromFile(fc, 1.0f, &c), "");
    EXPECT_NEAR(c.fovY, 0.4f * 180 / Pi, 1e-4f);
    // Hostile: NaN field of view, an up along the view, no view direction.
    fc.fov = FileCamera::Fov::HalfHorizontal, fc.horizontalFov = NAN;
    EXPECT_NE(CameraFromFile(fc, 1.0f, &c).find("horizontal field of view"), std::string::npos);
    fc.horizontalFov = 0.5f, fc.up = Vec3(0, 0, 2);
    EXPECT_EQ(CameraFromFile(fc, 1.0f, &c), "its up direction is zero or parallel to its view direction");
    fc.up = Vec3(0, 1, 0), fc.lookAt = Vec3(0, 0, 0);
    EXPECT_NE(CameraFromFile(fc, 1.0f, &c).find("no view direction"), std::string::npos);
}

TEST(FileCamerasLights, LightUnitsAndCones) {
    const Bounds3 box(Vec3(-1, 0, -1), Vec3(1, 1, 1));
    FileLight fl;
    fl.type = FileLight::Type::Point, fl.position = Vec3(0, 4, 0), fl.color = Color(40.0f);
    fl.constant = 0, fl.quadratic = 1;  // glTF: candela, inverse square
    PointLight l;
    ASSERT_EQ(LightFromFile(fl, box, &l), "");
    EXPECT_EQ(l.falloff, Falloff::InverseSquare);
    EXPECT_EQ(l.intensity.r, 40.0f);
    EXPECT_EQ(l.radius, DefaultLightRadius(box, l.position));
    fl.constant = 2, fl.quadratic = 0;  // constant attenuation only: no falloff
    ASSERT_EQ(LightFromFile(fl, box, &l), "");
    EXPECT_EQ(l.falloff, Falloff::None);
    EXPECT_EQ(l.intensity.r, 20.0f);
    fl.type = FileLight::Type::Spot, fl.direction = Vec3(0, -3, 0), fl.inner = 0.2f, fl.outer = 0.4f, fl.quadratic = 1;
    ASSERT_EQ(LightFromFile(fl, box, &l), "");
    EXPECT_EQ(l.kind, LightKind::Spot);
    EXPECT_EQ(l.spot.direction.y, -1.0f);
    EXPECT_EQ(l.spot.cosOuter, std::cos(0.4f));
    fl.outer = NAN;
    EXPECT_EQ(LightFromFile(fl, box, &l), "its cone angles are not finite");
    fl.type = FileLight::Type::Directional, fl.color = Color(1e5f);
    ASSERT_EQ(LightFromFile(fl, box, &l), "");
    EXPECT_EQ(l.kind, LightKind::Sun);
    EXPECT_EQ(l.intensity.r, 1e5f);  // lux: the irradiance
    EXPECT_NEAR(l.sun.angle * 180 / Pi, kSunAngleDegrees, 1e-6f);
    fl.color = Color(NAN);
    EXPECT_NE(LightFromFile(fl, box, &l).find("negative or not finite"), std::string::npos);
}

}  // namespace
}  // namespace light_keys_test
}  // namespace lm
