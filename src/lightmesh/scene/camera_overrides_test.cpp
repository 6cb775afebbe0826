#include "lightmesh/scene/camera_overrides.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "lightmesh/util/error.h"

namespace lm {
namespace camera_overrides_test {
namespace {

std::string ErrorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(CameraOverrides, ParsesVectorsAndRefusesTheRest) {
    EXPECT_EQ(ParseVec3Option("--look-at", "1,2.5,-3"), Vec3(1, 2.5f, -3));
    EXPECT_EQ(ParseVec3Option("--look-at", " 1 , 2 , 3 "), Vec3(1, 2, 3));
    EXPECT_EQ(ErrorOf([] { ParseVec3Option("--look-at", "1,2"); }), "--look-at: expected X,Y,Z (3 numbers), got 1,2");
    EXPECT_EQ(ErrorOf([] { ParseVec3Option("--look-at", "1,2,3,4"); }),
              "--look-at: expected X,Y,Z (3 numbers), got 1,2,3,4");
    EXPECT_NE(ErrorOf([] { ParseVec3Option("--camera-position", "nan,0,0"); }).find("finite"), std::string::npos);
    EXPECT_NE(ErrorOf([] { ParseVec3Option("--camera-position", "1e30,0,0"); }).find("finite"), std::string::npos);
    EXPECT_EQ(ParseUpOption("z"), Vec3(0, 0, 1));
    EXPECT_EQ(ParseUpOption("X"), Vec3(1, 0, 0));
    EXPECT_EQ(ParseUpOption("0,0,2"), Vec3(0, 0, 2));
    EXPECT_EQ(ParseFovOption("30"), 30.0f);
    for (const char* bad : {"0", "180", "-5", "nan", "inf", "1e40", "x"})
        EXPECT_NE(ErrorOf([&] { ParseFovOption(bad); }).find("--fov: must be"), std::string::npos) << bad;
}

TEST(CameraOverrides, ReplaceOnlyTheKeysGiven) {
    Camera c;
    c.position = Vec3(0, 2, 8);
    c.lookAt = Vec3(0, 1, 0);
    c.fovY = 40;
    CameraOverrides o;
    o.position = Vec3(5, 5, 5);
    ApplyCameraOverrides(o, &c);
    EXPECT_EQ(c.position, Vec3(5, 5, 5));
    EXPECT_EQ(c.lookAt, Vec3(0, 1, 0));
    EXPECT_EQ(c.up, Vec3(0, 1, 0));
    EXPECT_EQ(c.fovY, 40.0f);
    CameraOverrides bad;
    bad.lookAt = Vec3(5, 5, 5);
    EXPECT_NE(ErrorOf([&] { ApplyCameraOverrides(bad, &c); }).find("--look-at: "), std::string::npos);
    CameraOverrides straightDown;
    straightDown.position = Vec3(0, 10, 0);
    straightDown.lookAt = Vec3(0, 0, 0);
    EXPECT_NE(ErrorOf([&] { ApplyCameraOverrides(straightDown, &c); }).find("give --up too"), std::string::npos);
}

// Before the scene is read: a mesh file's letter up turns the model and its fov frames it;
// a scene file keeps both on the camera. Messages use the names given (the Python keywords).
TEST(CameraOverrides, PreparedForTheSceneKind) {
    CameraOverrides o;
    o.up = ParseUpOption("z");
    o.upAxis = AxisOfLetter("z");
    o.fovY = 30;
    SceneLoadOptions load;
    PrepareCameraOverrides("model.STL", &o, &load);
    EXPECT_EQ(load.upAxis, 2);
    EXPECT_EQ(load.frameFovY, 30.0f);
    EXPECT_FALSE(o.up.has_value());
    EXPECT_EQ(o.fovY, 30.0f);
    CameraOverrides s = o;
    s.up = ParseUpOption("z");
    s.upAxis = 2;
    SceneLoadOptions sceneLoad;
    PrepareCameraOverrides("scene.JSON", &s, &sceneLoad);
    EXPECT_EQ(sceneLoad.upAxis, 1);
    EXPECT_EQ(sceneLoad.frameFovY, 30.0f);  // a scene file without "camera" is framed for it
    SceneLoadOptions builtinLoad;
    CameraOverrides b = o;
    PrepareCameraOverrides("builtin:gazebo", &b, &builtinLoad);
    EXPECT_EQ(builtinLoad.frameFovY, 0.0f);
    EXPECT_EQ(s.up, Vec3(0, 0, 1));
    EXPECT_FALSE(IsMeshFileSpec("builtin:gazebo"));
    EXPECT_TRUE(IsMeshFileSpec("model.glb"));

    CameraOverrides zero;
    zero.names = {"camera_position=", "look_at=", "up=", "fov="};
    zero.up = Vec3(0, 0, 0);
    EXPECT_EQ(ErrorOf([&] { PrepareCameraOverrides("scene.json", &zero, &sceneLoad); }), "up=: must not be zero");
    CameraOverrides same;
    same.names = zero.names;
    same.position = same.lookAt = Vec3(1, 2, 3);
    EXPECT_NE(ErrorOf([&] { PrepareCameraOverrides("scene.json", &same, &sceneLoad); }).find("look_at=: the camera"),
              std::string::npos);
    EXPECT_EQ(ErrorOf([] { FovOption("fov=", 180, "180"); }),
              "fov=: must be a number of degrees between 0 and 180 (both excluded), got 180");
    const double nan[3] = {0, std::nan(""), 0};
    EXPECT_NE(ErrorOf([&] { Vec3Option("look_at=", nan, "(0, nan, 0)"); }).find("look_at=: every number"),
              std::string::npos);
    EXPECT_EQ(SmoothNormalsProblem(180, "180"), "");
    EXPECT_EQ(SmoothNormalsProblem(-1, "-1"), "must be between 0 and 180, got -1");
    EXPECT_NE(SmoothNormalsProblem(std::nan(""), "nan"), "");
}

// The turn a Z-up model gets: +z becomes +y (up), -y (a Z-up model's front) becomes +z.
TEST(CameraOverrides, UpAxisTurnsThatAxisToY) {
    EXPECT_EQ(UpAxisToY(2).ApplyPoint(Vec3(0, 0, 1)), Vec3(0, 1, 0));
    EXPECT_EQ(UpAxisToY(2).ApplyPoint(Vec3(0, -1, 0)), Vec3(0, 0, 1));
    EXPECT_EQ(UpAxisToY(0).ApplyPoint(Vec3(1, 0, 0)), Vec3(0, 1, 0));
    EXPECT_EQ(UpAxisToY(1).ApplyPoint(Vec3(1, 2, 3)), Vec3(1, 2, 3));
    EXPECT_GT(UpAxisToY(2).Determinant(), 0);  // a rotation, not a mirror
    EXPECT_GT(UpAxisToY(0).Determinant(), 0);
}

}  // namespace
}  // namespace camera_overrides_test
}  // namespace lm

namespace lm {
namespace camera_overrides_test {
namespace {

// A camera moved so far that the scene's span passes what single-precision rays allow.
TEST(CameraOverrides, TheMovedCameraKeepsTheSpanUsable) {
    Scene scene;
    scene.mesh.positions = {Vec3(-1e18f, 0, 0), Vec3(-1e18f, 1, 0), Vec3(-1e18f, 0, 1)};
    scene.mesh.triangles = {{0, 1, 2}};
    scene.lights.push_back(PointLight{});
    scene.camera.position = Vec3(0, 0, 5);
    CameraOverrides near;
    near.position = Vec3(0, 0, 10);
    ApplyCameraOverrides(near, &scene);
    EXPECT_EQ(scene.camera.position, Vec3(0, 0, 10));
    CameraOverrides far;
    far.position = Vec3(1e18f, 0, 0);
    EXPECT_NE(ErrorOf([&] { ApplyCameraOverrides(far, &scene); }).find("--camera-position: the scene"),
              std::string::npos);
}

}  // namespace
}  // namespace camera_overrides_test
}  // namespace lm
