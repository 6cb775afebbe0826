// End-to-end tests of `render --save-scene`: the scene file it writes renders the same
// image bytes, for a bare mesh (turned by --up, seen by a camera option), a glTF and a
// scene file; what cannot be saved is refused before the render.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "run_lightmesh.h"

namespace cli_save_scene_test {
namespace {

namespace fs = std::filesystem;
using CliRun = lm::testing::CliResult;

CliRun Lightmesh(const std::string& args) { return lm::testing::RunLightmesh(args); }

std::string Temp(const std::string& name) { return lm::testing::TestTempPath("lm_cli_save", name); }

std::string Data(const std::string& path) { return std::string(LIGHTMESH_TEST_DATA) + "/" + path; }

// Renders `scene` with `options` and --save-scene, renders the saved scene, and expects
// the same EXR bytes.
void ExpectRoundTrip(const std::string& name, const std::string& scene, const std::string& options) {
    SCOPED_TRACE(name);
    const std::string saved = Temp(name + ".json"), a = Temp(name + "-a.exr"), b = Temp(name + "-b.exr");
    fs::remove(saved);
    const CliRun first = Lightmesh("render " + scene + " " + options + " -q --save-scene " + saved + " -o " + a);
    ASSERT_EQ(first.exitCode, 0) << first.output;
    ASSERT_TRUE(fs::exists(saved));
    const CliRun second = Lightmesh("render " + saved + " -q -o " + b);
    ASSERT_EQ(second.exitCode, 0) << second.output << lm::testing::FileBytes(saved);
    const std::string bytesA = lm::testing::FileBytes(a), bytesB = lm::testing::FileBytes(b);
    EXPECT_GT(bytesA.size(), 1000u);
    EXPECT_TRUE(bytesA == bytesB) << "the saved scene renders other bytes:\n" << lm::testing::FileBytes(saved);
}

TEST(CliSaveScene, BareMeshRendersTheSameBytes) {
    ExpectRoundTrip("obj", Data("scene_file/two_boxes.obj"), "--width 96");
    ExpectRoundTrip("ply", Data("scene_file/quad.ply"), "--width 64 --height 64 --light-radius 0.05");
    // Turned by --up z, seen from a camera option, with an exposure: all in the file.
    ExpectRoundTrip("obj-up", Data("scene_file/two_boxes.obj"),
                    "--width 80 --height 60 --up z --camera-position 3,4,9 --exposure -1.5 --shadows rt");
}

// Smooth normals: a bare mesh's default and --smooth-normals become each mesh entry's
// "smooth_normals", so a low-poly sphere without normals renders smooth from the file too.
TEST(CliSaveScene, SmoothNormalsAreSaved) {
    std::string obj;
    const int rings = 6, segments = 10;
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j < segments; ++j) {
            const double th = 3.14159265358979 * i / rings, ph = 2 * 3.14159265358979 * j / segments;
            obj += "v " + std::to_string(std::sin(th) * std::cos(ph)) + " " + std::to_string(1 + std::cos(th)) + " " +
                   std::to_string(std::sin(th) * std::sin(ph)) + "\n";
        }
    auto at = [&](int i, int j) { return std::to_string(i * segments + j % segments + 1); };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            if (i > 0) obj += "f " + at(i, j) + " " + at(i + 1, j) + " " + at(i, j + 1) + "\n";
            if (i + 1 < rings) obj += "f " + at(i, j + 1) + " " + at(i + 1, j) + " " + at(i + 1, j + 1) + "\n";
        }
    const std::string sphere = Temp("sphere.obj");
    std::ofstream(sphere) << obj;
    ExpectRoundTrip("smooth-default", sphere, "--width 64 --height 48");
    EXPECT_NE(lm::testing::FileBytes(Temp("smooth-default.json")).find("\"smooth_normals\": 60.0"), std::string::npos);
    ExpectRoundTrip("smooth-20", sphere, "--width 64 --height 48 --smooth-normals 20");
    EXPECT_NE(lm::testing::FileBytes(Temp("smooth-20.json")).find("\"smooth_normals\": 20.0"), std::string::npos);
    ExpectRoundTrip("flat", sphere, "--width 64 --height 48 --smooth-normals 0");
    EXPECT_EQ(lm::testing::FileBytes(Temp("flat.json")).find("smooth_normals"), std::string::npos);
    EXPECT_NE(lm::testing::FileBytes(Temp("smooth-default-a.exr")), lm::testing::FileBytes(Temp("flat-a.exr")));
    // A scene file's meshes take --smooth-normals over their own key.
    ExpectRoundTrip("scene-smooth", Temp("smooth-default.json"), "--smooth-normals 35");
    EXPECT_NE(lm::testing::FileBytes(Temp("scene-smooth.json")).find("\"smooth_normals\": 35.0"), std::string::npos);
}

TEST(CliSaveScene, GltfRendersTheSameBytes) {
    ExpectRoundTrip("gltf", Data("textures/checker_mask.gltf"), "--width 64 --height 48");
    ExpectRoundTrip("glb", Data("textures/checker_mask.glb"), "--width 64 --height 48 --aa 2");
}

// A model's own camera, point light, spot and sun, saved as scene-file keys ("spot", "sun"
// with their stated directions and angles): the same bytes back, also turned by --up.
TEST(CliSaveScene, AModelsOwnCameraAndLightsRenderTheSameBytes) {
    ExpectRoundTrip("lit", Data("cameras_lights/lit_scene.gltf"), "--width 64 --height 48");
    const std::string text = lm::testing::FileBytes(Temp("lit.json"));
    for (const char* key : {"\"spot\"", "\"sun\"", "\"inner\"", "\"angle\""})
        EXPECT_NE(text.find(key), std::string::npos) << key << "\n" << text;
    ExpectRoundTrip("sun", Data("cameras_lights/sun_only.gltf"), "--width 48 --height 32 --up z");
}

TEST(CliSaveScene, SceneFileRendersTheSameBytes) {
    ExpectRoundTrip("json", Data("scene_file/good.json"),
                    "--width 100 --look-at 0,0.5,0 --fov 30 --shadows area --samples 4 --light-radius 0.1");
    const std::string text = lm::testing::FileBytes(Temp("json.json"));
    // The file's own keys kept: the light's name, the materials, the ground.
    for (const char* kept : {"\"name\": \"key\"", "\"wood\"", "\"material\": \"floor\"", "\"exclude_names\"",
                             "\"look_at\": [0.0, 0.5, 0.0]", "\"fov\": 30.0", "\"light_radius\": 0.1"})
        EXPECT_NE(text.find(kept), std::string::npos) << kept << "\n" << text;
}

// A light cut asked for on the command line is saved, and the saved scene renders the
// same bytes with it.
TEST(CliSaveScene, TheLightCutIsSaved) {
    ExpectRoundTrip("cut", Data("scene_file/good.json"), "--width 48 --light-cut 0.05");
    const std::string text = lm::testing::FileBytes(Temp("cut.json"));
    EXPECT_NE(text.find("\"light_cut\": 0.05"), std::string::npos) << text;
}

TEST(CliSaveScene, WhatCannotBeSavedIsRefusedFirst) {
    const std::string out = Temp("refused.png");
    fs::remove(out);
    const CliRun builtin = Lightmesh("render builtin:gazebo --width 16 --height 12 --save-scene " + Temp("g.json") +
                                     " -o " + out);
    EXPECT_EQ(builtin.exitCode, 1);
    EXPECT_EQ(builtin.output.rfind("lightmesh: error: --save-scene: builtin:gazebo is made by code", 0), 0u)
        << builtin.output;
    EXPECT_FALSE(fs::exists(out));
    const CliRun notJson = Lightmesh("render " + Data("scene_file/quad.ply") + " -q --save-scene " + Temp("s.txt") +
                                     " -o " + out);
    EXPECT_EQ(notJson.exitCode, 1);
    EXPECT_NE(notJson.output.find("--save-scene " + Temp("s.txt") + ": expected a .json file name"), std::string::npos)
        << notJson.output;
    const CliRun noFolder = Lightmesh("render " + Data("scene_file/quad.ply") + " -q --save-scene " +
                                      Temp("missing/s.json") + " -o " + out);
    EXPECT_EQ(noFolder.exitCode, 1);
    EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace cli_save_scene_test
