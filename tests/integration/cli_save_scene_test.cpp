// End-to-end tests of `render --save-scene`: the scene file it writes renders the same
// image bytes, for a bare mesh (turned by --up, seen by a camera option), a glTF and a
// scene file; what cannot be saved is refused before the render.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

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
