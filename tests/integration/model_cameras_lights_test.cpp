// A model file's own cameras and lights (glTF KHR_lights_punctual through Assimp): rendered
// from its camera with its point light, spot and sun; --camera; hostile cameras and lights.
// The files: tests/data/cameras_lights (make_test_files.py says what each holds).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "lightmesh/io/image.h"
#include "lightmesh/util/error.h"
#include "run_lightmesh.h"
#include "support/sanitized.h"

namespace model_cameras_lights_test {
namespace {

namespace fs = std::filesystem;
using lm::testing::CliResult;

const std::string kData = std::string(LIGHTMESH_TEST_DATA) + "/cameras_lights/";

std::string Temp(const std::string& name) {
    const fs::path dir = fs::path(::testing::TempDir()) / "lm_model_cameras_lights";
    fs::create_directories(dir);
    return (dir / name).string();
}

CliResult Render(const std::string& file, const std::string& out, const std::string& extra = "") {
    fs::remove(out);
    return lm::testing::RunLightmesh("render " + kData + file + " --width 160 --height 120 -o " + out + " " + extra);
}

float Luminance(const lm::Color& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

// The pixel that sees floor point (x, 0, z) from the file's "Top" camera: at (0, 12, 0)
// looking down, image up = -z, right = +x, 60° vertical field of view.
lm::Color TopViewFloor(const lm::Image& img, float x, float z) {
    const float tanY = std::tan(30.0f * 3.14159265f / 180.0f);
    const float tanX = tanY * static_cast<float>(img.width) / static_cast<float>(img.height);
    const float sx = x / 12.0f, sy = -z / 12.0f;
    const int px = static_cast<int>(std::floor((sx / tanX + 1.0f) * 0.5f * static_cast<float>(img.width)));
    const int py = static_cast<int>(std::floor((1.0f - sy / tanY) * 0.5f * static_cast<float>(img.height)));
    return img.At(px, py);
}

// The pixel that sees (x, y, z) from the file's "Main" camera: at (0, 3, 6) looking at
// (0, 0.5, 0), 40° vertical field of view, up +y.
lm::Color MainView(const lm::Image& img, float x, float y, float z) {
    const float fy = std::tan(20.0f * 3.14159265f / 180.0f);
    const float fx = fy * static_cast<float>(img.width) / static_cast<float>(img.height);
    const float len = std::sqrt(2.5f * 2.5f + 36.0f);
    const float f[3] = {0, -2.5f / len, -6.0f / len};  // forward
    const float u[3] = {0, -f[2], f[1]};               // up = right × forward, right = +x
    const float d[3] = {x, y - 3.0f, z - 6.0f};
    const float depth = d[0] * f[0] + d[1] * f[1] + d[2] * f[2];
    const float sx = d[0] / depth, sy = (d[1] * u[1] + d[2] * u[2]) / depth;
    return img.At(static_cast<int>((sx / fx + 1) * 0.5f * static_cast<float>(img.width)),
                  static_cast<int>((1 - sy / fy) * 0.5f * static_cast<float>(img.height)));
}

size_t Lines(const std::string& s) {
    size_t n = 0;
    for (char c : s) n += c == '\n';
    return n;
}

TEST(ModelCamerasLights, RendersFromTheFilesFirstCameraWithItsLights) {
    const std::string out = Temp("main.exr");
    const CliResult r = Render("lit_scene.gltf", out);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("the file's camera 0 \"Main\" (of 2; --camera NAME|INDEX picks another)"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("the file's lights: 1 point, 1 spot, 1 directional"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("key light"), std::string::npos) << r.output;
    const lm::Image img = lm::ReadImage(out);
    // The red cube's front at the image's centre, lit by the bulb (about 0.26 + the
    // ambient 0.05 × 0.9).
    const lm::Color centre = img.At(img.width / 2, img.height / 2);
    EXPECT_GT(centre.r, 0.2f);
    EXPECT_GT(centre.r, 3 * centre.g);
    // The floor, grey, below it.
    const lm::Color floor = img.At(img.width / 2, img.height - 3);
    EXPECT_NEAR(floor.r, floor.g, 1e-4f);
}

TEST(ModelCamerasLights, SpotConeAndSunShadowFromAbove) {
    const std::string byName = Temp("top_name.exr"), byIndex = Temp("top_index.exr");
    const CliResult r = Render("lit_scene.gltf", byName, "--camera Top");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("the file's camera 1 \"Top\""), std::string::npos) << r.output;
    ASSERT_EQ(Render("lit_scene.gltf", byIndex, "--camera 1").exitCode, 0);
    EXPECT_EQ(lm::testing::FileBytes(byName), lm::testing::FileBytes(byIndex));

    const lm::Image img = lm::ReadImage(byName);
    // The cube's top at the centre, red.
    const lm::Color top = img.At(img.width / 2, img.height / 2);
    EXPECT_GT(top.r, 3 * top.g);
    // The spot at (4, 5, 0) shines down, cone half-angles 10° and 20°: on the floor, full
    // inside 0.88 of its foot, nothing beyond 1.82, between them less than full.
    const float inside = Luminance(TopViewFloor(img, 4.0f, 0.0f));
    const float between = Luminance(TopViewFloor(img, 4.0f, 1.35f));
    const float outside = Luminance(TopViewFloor(img, 4.0f, 2.6f));
    // 25 cd at 5 m: 1 lux × 0.8; at 15° between the cones t = 0.57, t² = 0.33: about 0.24.
    EXPECT_GT(inside, outside + 0.6f) << inside << " " << outside;
    EXPECT_GT(between, outside + 0.12f) << between;
    EXPECT_LT(between, inside - 0.3f) << between;
    // Beyond the cone the floor has the sun, the point light and the ambient: no spot.
    const float mirrored = Luminance(TopViewFloor(img, -4.0f, 2.6f));
    EXPECT_GT(outside, 0.5f * mirrored);
    // The sun travels along (1, -1, 0): the cube's shadow covers x in [0.5, 1.5], |z| < 0.5.
    const float shadow = Luminance(TopViewFloor(img, 1.0f, 0.0f));
    const float sunlit = Luminance(TopViewFloor(img, 1.0f, -1.5f));
    EXPECT_LT(shadow, 0.75f * sunlit) << shadow << " " << sunlit;
    const float behindTheSun = Luminance(TopViewFloor(img, -1.0f, 0.0f));  // lit: the sun comes from -x
    EXPECT_GT(behindTheSun, shadow + 0.3f);
}

TEST(ModelCamerasLights, TheSunsShadowInEveryMethod) {
    // The sun alone (0.8 lux at 45° on a floor of albedo 0.8: 0.45), ambient 0.05 × 0.8.
    for (const char* method : {"soft", "area", "rt", "exact", "lmm", "denoised"}) {
        const std::string out = Temp(std::string("sun_") + method + ".exr");
        const CliResult r = lm::testing::RunLightmesh("render " + kData + "sun_only.gltf --width 160 --height 120 --camera 0 -o " +
                                                      out + " --shadows " + method);
        ASSERT_EQ(r.exitCode, 0) << method << "\n" << r.output;
        const lm::Image img = lm::ReadImage(out);
        // From the front camera, the floor in the cube's shadow and beside it.
        const auto project = [&](float x, float y, float z) { return MainView(img, x, y, z); };
        const float shadow = Luminance(project(1.0f, 0.0f, 0.0f));
        const float lit = Luminance(project(-1.5f, 0.0f, 0.0f));
        EXPECT_LT(shadow, 0.1f) << method;
        EXPECT_NEAR(lit, 0.4525f + 0.04f, 0.02f) << method;
    }
}

TEST(ModelCamerasLights, ColladaCameraAndLightsFollowItsConventions) {
    // COLLADA's xfov is the full horizontal angle (57.2° at aspect 1.5: 40° vertical), the
    // camera sits at its node (no position of its own), the bulb's quadratic attenuation
    // makes it inverse square.
    const std::string out = Temp("dae.exr");
    const CliResult r = Render("lit_scene.dae", out);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("the file's camera 0 \"Main\" (of 1) at (0, 3, 6) looking towards (0, 2.615, 5.077), 40° "
                            "vertical field of view"),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("the file's lights: 1 point, 0 spot, 1 directional"), std::string::npos) << r.output;
    const lm::Image img = lm::ReadImage(out);
    const float shadow = Luminance(MainView(img, 1.0f, 0.0f, 0.0f)), lit = Luminance(MainView(img, -1.5f, 0.0f, 0.0f));
    EXPECT_LT(shadow, 0.75f * lit) << shadow << " " << lit;
    // The cube's front, lit by the bulb at (0, 4, 4): 10 / 24.5 × cos 45° × 0.8 + ambient.
    EXPECT_NEAR(Luminance(MainView(img, 0.0f, 0.6f, 0.5f)), 10 / 24.5f * 0.7071f * 0.8f + 0.04f, 0.04f);
}

TEST(ModelCamerasLights, BadCameraChoiceIsOneErrorLine) {
    const std::string out = Temp("bad_choice.exr");
    for (const auto& [extra, text] :
         {std::pair<std::string, std::string>{"--camera Nope", "no camera named \"Nope\" (its cameras: \"Main\", \"Top\")"},
          {"--camera 2", "the file has 2 cameras (indices 0 to 1), no camera 2"}}) {
        const CliResult r = Render("lit_scene.gltf", out, extra);
        EXPECT_EQ(r.exitCode, 1) << r.output;
        EXPECT_NE(r.output.find(text), std::string::npos) << r.output;
        EXPECT_EQ(Lines(r.output), 1u) << r.output;
        EXPECT_FALSE(fs::exists(out));
    }
    // A file without cameras, and a scene file with its own "camera", have no cameras to choose.
    const CliResult obj = lm::testing::RunLightmesh("render " + std::string(LIGHTMESH_TEST_DATA) +
                                                    "/scene_file/two_boxes.obj --camera 0 -o " + out);
    EXPECT_EQ(obj.exitCode, 1);
    EXPECT_NE(obj.output.find("--camera 0: the file has no cameras"), std::string::npos) << obj.output;
    const CliResult json = lm::testing::RunLightmesh("render " + std::string(LIGHTMESH_TEST_DATA) +
                                                     "/scene_file/good.json --camera 0 -o " + out);
    EXPECT_EQ(json.exitCode, 1);
    EXPECT_NE(json.output.find("picks one of a mesh file's own cameras"), std::string::npos) << json.output;
}

TEST(ModelCamerasLights, ASceneFileWithoutCameraOrLightsRendersAsTheModel) {
    // The scene file places the model as it is and says nothing of a camera or lights: the
    // model's own are used, so the image is the bare file's, with --camera alike.
    const std::string scene = Temp("inherit.json");
    std::ofstream(scene) << "{\"meshes\": [{\"file\": \"" << kData << "lit_scene.gltf\"}]}\n";
    for (const std::string& extra : {std::string(), std::string("--camera Top")}) {
        SCOPED_TRACE(extra);
        const std::string bare = Temp("inherit_bare.exr"), viaScene = Temp("inherit_scene.exr");
        ASSERT_EQ(Render("lit_scene.gltf", bare, extra).exitCode, 0);
        fs::remove(viaScene);
        const CliResult r =
            lm::testing::RunLightmesh("render " + scene + " --width 160 --height 120 -o " + viaScene + " " + extra);
        ASSERT_EQ(r.exitCode, 0) << r.output;
        EXPECT_NE(r.output.find("lit_scene.gltf\" (/meshes/0;"), std::string::npos) << r.output;
        EXPECT_EQ(lm::testing::FileBytes(bare), lm::testing::FileBytes(viaScene));
    }
}

TEST(ModelCamerasLights, OrthographicCamerasArePassedOver) {
    // The file's first camera is orthographic: the default takes its perspective "Main";
    // --camera naming the orthographic one is one error line.
    const std::string out = Temp("ortho.exr"), main = Temp("ortho_main.exr");
    const CliResult r = Render("camera_orthographic.gltf", out);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("the file's camera 1 \"Main\" (of 2;"), std::string::npos) << r.output;
    ASSERT_EQ(Render("camera_orthographic.gltf", main, "--camera Main").exitCode, 0);
    EXPECT_EQ(lm::testing::FileBytes(out), lm::testing::FileBytes(main));
    const CliResult bad = Render("camera_orthographic.gltf", out, "--camera Ortho");
    EXPECT_EQ(bad.exitCode, 1);
    EXPECT_NE(bad.output.find("camera 0 \"Ortho\" cannot be used: it is orthographic"), std::string::npos) << bad.output;
    EXPECT_EQ(Lines(bad.output), 1u) << bad.output;
    EXPECT_FALSE(fs::exists(out));
}

TEST(ModelCamerasLights, HostileCamerasAndLightsAreOneErrorLine) {
    const std::string out = Temp("hostile.exr");
    for (const auto& [file, text] : std::vector<std::pair<std::string, std::string>>{
             {"camera_zero_fov.gltf", "the file's camera 0 \"Bad\" cannot be used: its vertical field of view is 0°"},
             {"camera_wide_fov.gltf", "the file's camera 0 \"Bad\" cannot be used: its vertical field of view is 189"},
             {"camera_zero_scale.gltf", "the file's camera 0 \"Bad\" cannot be used: it has no view direction"},
             {"spot_inner_outer.gltf", "malformed or truncated (Assimp: aiLight::mAngleInnerCone is larger than aiLight::mAngleOuterCone)"},
             {"spot_wide.gltf", "the file's light 0 \"S\" cannot be used: its outer cone angle is 97.4028°"},
             {"light_negative.gltf", "the file's light 0 \"S\" cannot be used: its colour (-5, -5, -5) is negative"},
             {"sun_zero_scale.gltf", "the file's light 0 \"S\" cannot be used: it has no direction"},
         }) {
        const CliResult r = Render(file, out);
        EXPECT_EQ(r.exitCode, 1) << file << "\n" << r.output;
        EXPECT_NE(r.output.find(kData + file + ": " + text), std::string::npos) << r.output;
        EXPECT_EQ(Lines(r.output), 1u) << r.output;
        EXPECT_FALSE(fs::exists(out)) << file;
    }
}

TEST(ModelCamerasLights, TenThousandLightsRender) {
    // lit_scene.gltf's floor and cube under 10,000 dim point lights, each on its own node.
    std::ifstream in(kData + "lit_scene.gltf");
    std::string text((std::istreambuf_iterator<char>(in)), {});
    const size_t lightsAt = text.find("\"KHR_lights_punctual\": {\n   \"lights\"");
    ASSERT_NE(lightsAt, std::string::npos);
    std::string lights = "\"KHR_lights_punctual\": {\"lights\": [";
    std::string nodes;
    // 10,000 in the Release build; 2,000 under the sanitizers (the same code paths: Assimp's
    // pairwise name check alone took 50 s of the ASan build's time at 10,000).
    const int count = lm::testing::SweepCases(10000, 5);
    for (int i = 0; i < count; ++i) {
        lights += std::string(i ? "," : "") + "{\"type\": \"point\", \"intensity\": 0.05, \"range\": 4}";
        nodes += lm::StringPrintf(",{\"name\": \"L%d\", \"translation\": [%g, 3, %g], \"extensions\": "
                                  "{\"KHR_lights_punctual\": {\"light\": %d}}}",
                                  i, -5 + 0.1 * (i % 100), -5 + (10.0 / (count / 100)) * (i / 100), i);
    }
    lights += "]}}";
    // Replace the file's lights and its light nodes (the last three nodes) by these.
    const size_t end = text.find("\n }", lightsAt);
    text = text.substr(0, lightsAt) + lights + text.substr(text.find("\n", end + 3));
    const std::string bulb = ",\n  {\n   \"name\": \"Bulb\"";
    const size_t nodesFrom = text.find(bulb), nodesTo = text.find("\n ],", nodesFrom);
    ASSERT_NE(nodesFrom, std::string::npos);
    text = text.substr(0, nodesFrom) + nodes + text.substr(nodesTo);
    std::string scene = "[0, 1, 2, 3";
    for (int i = 0; i < count; ++i) scene += "," + std::to_string(4 + i);
    const size_t sceneAt = text.find("\"nodes\": [");
    text = text.substr(0, sceneAt) + "\"nodes\": " + scene + "]" + text.substr(text.find("]", sceneAt) + 1);
    const std::string file = Temp("many_lights.gltf");
    std::ofstream(file) << text;
    const std::string out = Temp("many.exr");
    fs::remove(out);
    // Each light's glTF "range" (4) is its range: soft shadows render them (Assimp's
    // validation compares the lights' names pairwise: about 4 s of the import).
    const CliResult r = lm::testing::RunLightmesh("render " + file + " --width 32 --height 24 -o " + out);
    ASSERT_EQ(r.exitCode, 0) << r.output.substr(0, 2000);
    EXPECT_NE(r.output.find(lm::StringPrintf("the file's lights: %d point", count)), std::string::npos) << r.output.substr(0, 2000);
    const CliResult info = lm::testing::RunLightmesh("info " + file + " -q");
    EXPECT_NE(info.output.find("light 0  at [-5 3 -5], intensity [0.05 0.05 0.05], falloff inverse_square, radius "),
              std::string::npos)
        << info.output.substr(0, 2000);
    EXPECT_NE(info.output.find(", range 4\n"), std::string::npos) << info.output.substr(0, 2000);
    const lm::Image img = lm::ReadImage(out);
    EXPECT_GT(Luminance(img.At(16, 12)), 0.05f);
}

// --smooth-normals: a low-poly sphere without normals, shaded smoothly: the brightness steps
// at its facets' edges (flat shading) give way to a gradient. Without the option the
// faces stay flat (today's images).
TEST(ModelCamerasLights, SmoothNormalsSmoothALowPolySphere) {
    std::string obj;
    const int rings = 8, segments = 12;
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j < segments; ++j) {
            const double th = 3.14159265358979 * i / rings, ph = 2 * 3.14159265358979 * j / segments;
            obj += lm::StringPrintf("v %.6f %.6f %.6f\n", std::sin(th) * std::cos(ph), 1 + std::cos(th),
                                    std::sin(th) * std::sin(ph));
        }
    auto at = [&](int i, int j) { return i * segments + j % segments + 1; };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            if (i > 0) obj += lm::StringPrintf("f %d %d %d\n", at(i, j), at(i + 1, j), at(i, j + 1));
            if (i + 1 < rings) obj += lm::StringPrintf("f %d %d %d\n", at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
        }
    const std::string file = Temp("sphere.obj");
    std::ofstream(file) << obj;
    // The largest step in brightness between neighbouring pixels along a row across the
    // sphere's lit upper half.
    auto largestStep = [&](const std::string& extra) {
        const std::string out = Temp("sphere.exr");
        fs::remove(out);
        const CliResult r = lm::testing::RunLightmesh("render " + file + " --width 200 --height 150 --shadows none -q -o " +
                                                      out + " " + extra);
        EXPECT_EQ(r.exitCode, 0) << r.output;
        const lm::Image img = lm::ReadImage(out);
        float step = 0;
        for (int y = 50; y <= 70; y += 5)
            for (int x = 80; x < 120; ++x)
                step = std::max(step, std::abs(Luminance(img.At(x + 1, y)) - Luminance(img.At(x, y))));
        return step;
    };
    const float flat = largestStep("--smooth-normals 0"), smooth = largestStep("--smooth-normals 60");
    EXPECT_GT(flat, 0.04f);
    EXPECT_LT(smooth, 0.5f * flat) << smooth << " " << flat;
    EXPECT_EQ(largestStep(""), smooth);  // a bare mesh file's default
    // Its smooth normals do not cross a crease sharper than the angle: at 10° the 30° facet
    // edges stay.
    EXPECT_GT(largestStep("--smooth-normals 10"), 0.8f * flat);
}

}  // namespace
}  // namespace model_cameras_lights_test
