// Tests of LoadScene: the JSON scene format, its error messages, and bare-mesh framing. Over
// 500 lines as one concept: most of it is the table of bad inputs and their exact messages.
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/settings/render_settings.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>

#include "lightmesh/scene/demo_scene.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/util/error.h"
#include "support/sanitized.h"

namespace lm {
namespace scene_file_test {
namespace {

namespace fs = std::filesystem;

const std::string DataDir = std::string(LIGHTMESH_TEST_DATA) + "/scene_file";

/// A fresh, empty folder for the running test under the gtest temp dir.
std::string TempFolder() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    fs::path p = fs::path(::testing::TempDir()) /
                 ("lightmesh_" + std::string(info->test_suite_name()) + "_" + info->name());
    fs::remove_all(p);
    fs::create_directories(p);
    return p.string();
}

std::string WriteFile(const std::string& folder, const std::string& name, const std::string& text) {
    const std::string path = folder + "/" + name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
}

/// The message of the Error that loading throws ("<no error>" if none).
std::string LoadError(const std::string& spec, bool strict = false,
                      std::vector<std::string>* warnings = nullptr) {
    std::vector<std::string> ignored;
    try {
        LoadScene(spec, SceneLoadOptions{strict}, warnings ? warnings : &ignored);
    } catch (const Error& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("<not an lm::Error> ") + e.what();
    }
    return "<no error>";
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
    for (size_t pos = s.find(from); pos != std::string::npos; pos = s.find(from, pos + to.size()))
        s.replace(pos, from.size(), to);
    return s;
}

bool Near(const Vec3& a, const Vec3& b, float eps = 1e-5f) {
    return Length(a - b) <= eps;
}

TEST(SceneFile, GoodSceneRoundTrips) {
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(DataDir + "/good.json", {}, &warnings);
    EXPECT_TRUE(warnings.empty()) << warnings.front();

    EXPECT_EQ(scene.camera.position, Vec3(0, 2, 8));
    EXPECT_EQ(scene.camera.lookAt, Vec3(0, 1, 0));
    EXPECT_EQ(scene.camera.up, Vec3(0, 1, 0));
    EXPECT_EQ(scene.camera.fovY, 40.0f);
    EXPECT_EQ(scene.ambient, Color(0.1f, 0.2f, 0.3f));
    EXPECT_EQ(scene.background, Color(0.25f));

    ASSERT_EQ(scene.lights.size(), 2u);
    EXPECT_EQ(scene.lights[0].position, Vec3(4, 8, 4));
    EXPECT_EQ(scene.lights[0].intensity, Color(60, 50, 40));
    EXPECT_EQ(scene.lights[0].falloff, Falloff::InverseSquare);
    EXPECT_EQ(scene.lights[1].intensity, Color(0.5f));
    EXPECT_EQ(scene.lights[1].falloff, Falloff::None);
    // Light 0 states its radius; light 1 gets 2 % of its distance to the centre of the
    // scene's box, ground included ([-7, -1, -12] - [17, 2, 12], centre [5, 0.5, 0]), and
    // a note says so.
    EXPECT_EQ(scene.lights[0].radius, 0.25f);
    const float expected = 0.02f * Length(Vec3(-5, 6, 2) - Vec3(5, 0.5f, 0));
    EXPECT_NEAR(scene.lights[1].radius, expected, 1e-4f);
    EXPECT_EQ(scene.lights[1].radius, DefaultLightRadius(scene.mesh.Bounds(), scene.lights[1].position));
    EXPECT_EQ(scene.report.notes,
              std::vector<std::string>{StringPrintf("light 1 has no \"radius\": %.3g (2 %% of its distance to the "
                                                    "scene's centre); \"radius\": 0 makes it a point",
                                                    static_cast<double>(scene.lights[1].radius))});

    // The scene's materials, then the file's (only Red is used: Hidden is excluded).
    ASSERT_EQ(scene.materials.size(), 4u);
    EXPECT_EQ(scene.materials[0].name, "wood");
    EXPECT_EQ(scene.materials[0].kd, Color(0.6f, 0.4f, 0.2f));
    EXPECT_EQ(scene.materials[0].ks, Color(0.1f));
    EXPECT_EQ(scene.materials[0].phong, 20.0f);
    EXPECT_EQ(scene.materials[1].name, "mirror");
    EXPECT_EQ(scene.materials[1].mirror, Color(0.8f));
    EXPECT_EQ(scene.materials[1].phong, 200.0f);
    EXPECT_EQ(scene.materials[2].name, "floor");
    EXPECT_EQ(scene.materials[3].name, "Red");
    EXPECT_EQ(scene.materials[3].kd, Color(0.8f, 0.1f, 0.1f));

    // Two cubes (12 triangles each; each file's tetrahedron excluded) and the ground slab.
    ASSERT_EQ(scene.mesh.TriangleCount(), 36u);
    EXPECT_EQ(scene.report.meshesExcluded, 2u);
    EXPECT_EQ(scene.report.sources.size(), 2u);
    for (size_t t = 0; t < 12; ++t) EXPECT_EQ(scene.mesh.materialIds[t], 0u);  // "material": "wood"
    for (size_t t = 12; t < 24; ++t) EXPECT_EQ(scene.mesh.materialIds[t], 3u);  // Red from the MTL

    // Cube corner (1, 1, 1): scale [2, 1, 1] → (2, 1, 1); 90° about +y → (1, 1, -2);
    // translate [0, 1, 0] → (1, 2, -2).
    bool found = false;
    for (uint32_t t = 0; t < 12; ++t)
        for (int k = 0; k < 3; ++k) found |= Near(scene.mesh.Vertex(t, k), Vec3(1, 2, -2));
    EXPECT_TRUE(found);
    Bounds3 first, second;
    for (uint32_t t = 0; t < 12; ++t)
        for (int k = 0; k < 3; ++k) first.Extend(scene.mesh.Vertex(t, k));
    for (uint32_t t = 12; t < 24; ++t)
        for (int k = 0; k < 3; ++k) second.Extend(scene.mesh.Vertex(t, k));
    EXPECT_TRUE(Near(first.lo, Vec3(-1, 0, -2)) && Near(first.hi, Vec3(1, 2, 2)));
    EXPECT_TRUE(Near(second.lo, Vec3(9, -1, -1)) && Near(second.hi, Vec3(11, 1, 1)));  // the matrix

    // Ground: a closed slab with its top face at y = -0.5, centred under the box
    // x ∈ [-1, 11], z ∈ [-2, 2], side 2 × 12, 1 % of the side thick.
    Bounds3 ground;
    int upFaces = 0;
    for (uint32_t t = 24; t < 36; ++t) {
        EXPECT_EQ(scene.mesh.materialIds[t], 2u);
        for (int k = 0; k < 3; ++k) ground.Extend(scene.mesh.Vertex(t, k));
        const Vec3 n = Cross(scene.mesh.Vertex(t, 1) - scene.mesh.Vertex(t, 0),
                             scene.mesh.Vertex(t, 2) - scene.mesh.Vertex(t, 0));
        upFaces += n.y > 0 && scene.mesh.Vertex(t, 0).y == -0.5f;  // the top faces up
    }
    EXPECT_EQ(upFaces, 2);
    EXPECT_TRUE(Near(ground.lo, Vec3(-7, -0.5f - 0.24f, -12)) && Near(ground.hi, Vec3(17, -0.5f, 12)));
    EXPECT_TRUE(AnalyzeEdges(scene.mesh).Closed());

    const RenderOptions& ro = scene.render;
    EXPECT_EQ(ro.width, 320);
    EXPECT_EQ(ro.height, 200);
    EXPECT_EQ(ro.aa, 2);
    EXPECT_EQ(ro.maxDepth, 3);
    EXPECT_EQ(ro.shadows, "lmm");
    EXPECT_EQ(ro.accel, "brute");
    EXPECT_EQ(ro.accelOptions.gridResolution, 16);
    EXPECT_EQ(ro.lightMesh.cc, 200);
    EXPECT_EQ(ro.lightMesh.ki, 1.5f);
    EXPECT_EQ(ro.lightMesh.variant, "templates");
    EXPECT_EQ(ro.lightMesh.ns, 8);
    EXPECT_EQ(ro.lightMesh.templateDir, "/tmp/templates");
}

TEST(SceneFile, DefaultsOfAMinimalScene) {
    const std::string folder = TempFolder();
    const std::string path = WriteFile(folder, "min.json", R"({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "lights": [{"position": [0, 5, 0]}],
        "meshes": [{"file": ")" + DataDir + R"(/quad.ply"}]})");
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(path, {}, &warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(scene.ambient, Color(0.05f));
    EXPECT_EQ(scene.background, Color(0.0f));
    EXPECT_EQ(scene.camera.fovY, 45.0f);
    EXPECT_EQ(scene.lights[0].intensity, Color(1.0f));
    EXPECT_EQ(scene.lights[0].falloff, Falloff::InverseSquare);
    ASSERT_EQ(scene.materials.size(), 1u);
    EXPECT_EQ(scene.materials[0].kd, Color(0.8f));  // a PLY has no materials: the default grey
    EXPECT_EQ(scene.mesh.TriangleCount(), 2u);      // no ground unless asked for
    const RenderOptions defaults;
    EXPECT_EQ(scene.render.width, defaults.width);
    EXPECT_EQ(scene.render.shadows, defaults.shadows);
}

// The default size: 2 % of the distance to the centre of the scene's box, so every light
// without "radius" subtends the same angle from the middle of the scene.
TEST(SceneFile, DefaultLightRadiusIsTwoPercentOfTheDistanceToTheCentre) {
    Bounds3 room;
    room.Extend(Vec3(-2, 0, -3));
    room.Extend(Vec3(2, 3, 3));  // centre [0, 1.5, 0]
    EXPECT_FLOAT_EQ(DefaultLightRadius(room, Vec3(0, 3.5f, 0)), 0.04f);  // 2 m above the centre: 4 cm
    EXPECT_FLOAT_EQ(DefaultLightRadius(room, Vec3(3, 5.5f, 0)), 0.1f);   // 5 m away
    EXPECT_EQ(DefaultLightRadius(room, Vec3(0, 1.5f, 0)), 0.0f);         // at the centre: a point
    // The same angle from the centre wherever the light is: sin α = 0.02, about 1.15°.
    for (const Vec3& p : {Vec3(1, 2, 3), Vec3(-40, 70, 12), Vec3(1e4f, 2e4f, -3e4f)}) {
        const float d = Length(p - room.Center());
        EXPECT_NEAR(std::asin(DefaultLightRadius(room, p) / d) * 180 / Pi, 1.146, 1e-3);
    }
}

// Lights without "radius" get the default, listed in one note; "radius": 0 stays a point
// and is not listed.
TEST(SceneFile, LightRadiusKeyAndTheDefaultsNote) {
    const std::string folder = TempFolder();
    // The quad: [0, 1]² at z = 0, centre [0.5, 0.5, 0].
    const std::string path = WriteFile(folder, "radii.json", R"({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "lights": [{"position": [0.5, 5.5, 0]}, {"position": [0, 0, 4], "radius": 0},
                   {"position": [3, 0, 4], "radius": 0.3}, {"position": [0.5, 0.5, -10]}],
        "meshes": [{"file": ")" + DataDir + R"(/quad.ply"}]})");
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(path, {}, &warnings);
    EXPECT_TRUE(warnings.empty());
    ASSERT_EQ(scene.lights.size(), 4u);
    EXPECT_FLOAT_EQ(scene.lights[0].radius, 0.1f);
    EXPECT_EQ(scene.lights[1].radius, 0.0f);
    EXPECT_EQ(scene.lights[2].radius, 0.3f);
    EXPECT_FLOAT_EQ(scene.lights[3].radius, 0.2f);
    EXPECT_EQ(scene.report.notes,
              std::vector<std::string>{"lights 0 and 3 have no \"radius\": 0.1 and 0.2 (2 % of each one's distance "
                                       "to the scene's centre); \"radius\": 0 makes a light a point"});
    // One light: the note of the brief.
    const std::string one = WriteFile(folder, "one.json", R"({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "lights": [{"position": [0.5, 0.5, 8.65]}],
        "meshes": [{"file": ")" + DataDir + R"(/quad.ply"}]})");
    EXPECT_EQ(LoadScene(one, {}, &warnings).report.notes,
              std::vector<std::string>{"light 0 has no \"radius\": 0.173 (2 % of its distance to the scene's "
                                       "centre); \"radius\": 0 makes it a point"});
    // Every light sized: no note.
    const std::string sized = WriteFile(folder, "sized.json", R"({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "lights": [{"position": [0, 5, 0], "radius": 0}],
        "meshes": [{"file": ")" + DataDir + R"(/quad.ply"}]})");
    EXPECT_TRUE(LoadScene(sized, {}, &warnings).report.notes.empty());
    EXPECT_TRUE(warnings.empty());
}

TEST(SceneFile, AreaLightSettings) {
    const std::string folder = TempFolder();
    const std::string path = WriteFile(folder, "area.json", R"({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "lights": [{"position": [0, 5, 0]}],
        "meshes": [{"file": ")" + DataDir + R"(/quad.ply"}],
        "render": {"shadows": "area", "light_radius": 0.25, "samples": 64, "thin_check": "lit"}})");
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(path, {}, &warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(scene.render.shadows, "area");
    ASSERT_TRUE(scene.render.areaLight.radius.has_value());
    EXPECT_EQ(*scene.render.areaLight.radius, 0.25f);
    EXPECT_FALSE(RenderOptions().areaLight.radius.has_value());  // no override unless given
    EXPECT_EQ(scene.render.areaLight.samples, 64);
    EXPECT_EQ(scene.render.lightMesh.thinCheck, "lit");
    EXPECT_EQ(RenderOptions().lightMesh.thinCheck, "all");
}

// One bad scene and the exact error it must produce. The scene is the base scene below
// with some parts replaced, or `whole` verbatim; "$DATA" is the test data folder. The
// scene is written as <folder>/<name>.json; messages are compared with that path replaced
// by "scene.json".
struct BadCase {
    std::string name;
    std::string expected;
    std::string camera = R"({"position": [0, 1, 5], "look_at": [0, 0, 0]})";
    std::string lights = R"([{"position": [0, 5, 0]}])";
    std::string meshes = R"([{"file": "$DATA/two_boxes.obj"}])";
    std::string extra = "";  // more top-level keys, starting with a comma
    std::optional<std::string> whole = std::nullopt;
    bool strict = false;
    bool substring = false;  // expected is a substring (Assimp's own wording follows)
};

std::string SceneText(const BadCase& c) {
    if (c.whole) return *c.whole;
    std::string text = "{";
    if (!c.camera.empty()) text += "\"camera\": " + c.camera + ",\n";
    if (!c.lights.empty()) text += "\"lights\": " + c.lights + ",\n";
    if (!c.meshes.empty())
        text += "\"meshes\": " + c.meshes + "\n";
    else
        text.erase(text.size() - 2);  // the trailing ",\n"
    return Replace(text + c.extra + "}", "$DATA", DataDir);
}

// The place of an error is data (Error::Where), not only text: a value's JSON pointer, a
// syntax error's line and column.
TEST(SceneFile, ErrorsKeepTheirPlaceAsData) {
    const std::string folder = TempFolder();
    const std::string bad = WriteFile(folder, "bad.json", R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]},
 "lights": [{"position": [0, "up", 0]}], "meshes": [{"file": "x.obj"}]})");
    try {
        LoadScene(bad, SceneLoadOptions{}, nullptr);
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(e.Where().file, bad);
        EXPECT_EQ(e.Where().jsonPath, "/lights/0/position/1");
        EXPECT_EQ(e.Where().line, 0u);
        EXPECT_EQ(e.Reason(), "expected a number, got a string (\"up\")");
        EXPECT_EQ(std::string(e.what()), e.Where().Format() + ": " + e.Reason());
    }
    const std::string syntax = WriteFile(folder, "syntax.json", "{\n  \"camera\": {,\n}");
    try {
        LoadScene(syntax, SceneLoadOptions{}, nullptr);
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(e.Where().file, syntax);
        EXPECT_EQ(e.Where().line, 2u);
        EXPECT_EQ(e.Where().column, 14u);
        EXPECT_TRUE(e.Where().jsonPath.empty());
        EXPECT_EQ(e.Reason().rfind("parse error: ", 0), 0u) << e.Reason();
    }
}

// Each "render" value remembers its place in the file (RenderOptions::origins), for the
// messages of the factories that read it; defaults have none.
TEST(SceneFile, RenderValuesRememberTheirPlace) {
    const std::string folder = TempFolder();
    const std::string path = WriteFile(folder, "scene.json", R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]},
 "lights": [{"position": [0, 5, 0]}], "meshes": [{"file": ")" + std::string(LIGHTMESH_TEST_DATA) + R"(/scene_file/two_boxes.obj"}],
 "render": {"ki": 3, "variant": "object", "width": 64}})");
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(path, SceneLoadOptions{}, &warnings);
    ASSERT_EQ(scene.render.origins.size(), 3u);
    EXPECT_EQ(scene.render.origins.at("ki").Format(), path + " /render/ki");
    EXPECT_EQ(scene.render.origins.at("variant").jsonPath, "/render/variant");
    EXPECT_EQ(scene.render.origins.at("width").file, path);
    EXPECT_EQ(scene.render.origins.count("cc"), 0u);
}

// The render object read on its own (the Python module's keywords): the file's checks and
// messages, each value's origin, unknown keys refused with the near one.
TEST(SceneFile, RenderSettingsReadOnTheirOwn) {
    RenderOptions options;
    options.width = 100;
    ReadRenderSettings("kw", R"({"width": 64, "cc": 12, "light_radius": 0.5, "shadows": "rt"})", &options);
    EXPECT_EQ(options.width, 64);
    EXPECT_EQ(options.height, 480);
    EXPECT_EQ(options.lightMesh.cc, 12);
    EXPECT_EQ(options.soft.cc, 12);
    EXPECT_EQ(options.areaLight.radius, 0.5f);
    EXPECT_EQ(options.shadows, "rt");
    EXPECT_EQ(options.origins.at("cc").Format(), "kw /cc");
    auto message = [](const std::string& json) {
        RenderOptions o;
        try {
            ReadRenderSettings("kw", json, &o);
        } catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_EQ(message(R"({"width": 0})"), "kw /width: must be between 1 and 16384, got 0");
    EXPECT_EQ(message(R"({"shadows": "hard"})").rfind("kw /shadows: ", 0), 0u);
    EXPECT_NE(message(R"({"widht": 3})").find("did you mean \"width\""), std::string::npos);
    EXPECT_EQ(message(R"({"variant": ""})"), "kw /variant: must not be empty (leave the key out for the default)");
}

TEST(SceneFile, BadInputsGiveExactMessages) {
    const std::string wood = R"(, "materials": {"wood": {"kd": 0.5}, "mirror": {"mirror": 1}})";
    const std::vector<BadCase> cases = {
        // JSON syntax and top level
        {.name = "syntax",
         .expected = "scene.json:2:36: parse error: syntax error while parsing object key - "
                     "unexpected ','; expected string literal",
         .whole = "{\n  \"camera\": {\"position\": [0, 2, 8],,\n}"},
        {.name = "trailing_comma",
         .expected = "scene.json:1:22: parse error: syntax error while parsing object key - "
                     "unexpected '}'; expected string literal",
         .whole = "{\"camera\": {\"fov\": 1,}}"},
        {.name = "unterminated",
         .expected = "scene.json:3:1: parse error: syntax error while parsing object - "
                     "unexpected end of input; expected '}'",
         .whole = "{\n \"lights\": []\n"},
        {.name = "empty_file", .expected = "scene.json: the file is empty", .whole = ""},
        {.name = "blank_file", .expected = "scene.json: the file is empty", .whole = " \n\t\n"},
        {.name = "top_level_array",
         .expected = "scene.json: expected a JSON object {...} at the top level, got an array of 2",
         .whole = "[1, 2]"},
        {.name = "top_level_string",
         .expected =
             "scene.json: expected a JSON object {...} at the top level, got a string (\"scene\")",
         .whole = "\"scene\""},
        {.name = "number_overflow",
         .expected =
             "scene.json /lights/0/position/1: number 1e999 is out of range (line 2, column 29)",
         .lights = R"([{"position": [0, 1e999, 0]}])"},
        // required keys and types
        {.name = "camera_array",
         .expected = "scene.json /camera: expected an object {...}, got an array of 3",
         .camera = "[0, 1, 2]"},
        {.name = "camera_no_look_at",
         .expected = "scene.json /camera/look_at: missing required key",
         .camera = R"({"position": [0, 1, 5]})"},
        {.name = "empty_lights",
         .expected = "scene.json /lights: a scene needs at least one light, got an empty list",
         .lights = "[]"},
        {.name = "lights_object",
         .expected = "scene.json /lights: expected a list of lights [...], got an object",
         .lights = R"({"position": [0, 5, 0]})"},
        {.name = "light_two_numbers",
         .expected = "scene.json /lights/1/position: expected 3 numbers, got 2",
         .lights = R"([{"position": [0, 5, 0]}, {"position": [1, 2]}])"},
        {.name = "light_position_string",
         .expected = "scene.json /lights/0/position: expected 3 numbers, got a string (\"0 5 0\")",
         .lights = R"([{"position": "0 5 0"}])"},
        {.name = "light_nan_string",
         .expected = "scene.json /lights/0/position/0: expected a number, got a string (\"NaN\")",
         .lights = R"([{"position": ["NaN", 5, 0]}])"},
        {.name = "light_no_position",
         .expected = "scene.json /lights/0/position: missing required key",
         .lights = R"([{"intensity": 1}])"},
        {.name = "light_negative",
         .expected = "scene.json /lights/0/intensity/2: must not be negative, got -1",
         .lights = R"([{"position": [0, 5, 0], "intensity": [1, 1, -1]}])"},
        {.name = "light_float_overflow",
         .expected = "scene.json /lights/0/intensity: number out of range, got 1e+300",
         .lights = R"([{"position": [0, 5, 0], "intensity": 1e300}])"},
        {.name = "light_falloff",
         .expected = "scene.json /lights/0/falloff: must be one of \"inverse_square\", \"none\"; "
                     "got \"linear\"",
         .lights = R"([{"position": [0, 5, 0], "falloff": "linear"}])"},
        {.name = "light_radius_negative",
         .expected = "scene.json /lights/1/radius: must not be negative, got -0.1",
         .lights = R"([{"position": [0, 5, 0], "radius": 0.1}, {"position": [1, 5, 0], "radius": -0.1}])"},
        {.name = "light_radius_nan_string",
         .expected = "scene.json /lights/0/radius: expected a number, got a string (\"NaN\")",
         .lights = R"([{"position": [0, 5, 0], "radius": "NaN"}])"},
        {.name = "light_radius_string",
         .expected = "scene.json /lights/0/radius: expected a number, got a string (\"0.2\")",
         .lights = R"([{"position": [0, 5, 0], "radius": "0.2"}])"},
        {.name = "light_radius_overflow",
         .expected = "scene.json /lights/0/radius: number out of range, got 1e+300",
         .lights = R"([{"position": [0, 5, 0], "radius": 1e300}])"},
        {.name = "light_radius_list",
         .expected = "scene.json /lights/0/radius: expected a number, got an array of 1",
         .lights = R"([{"position": [0, 5, 0], "radius": [0.2]}])"},
        {.name = "light_name_number",
         .expected = "scene.json /lights/0/name: expected a string, got the number 3",
         .lights = R"([{"position": [0, 5, 0], "name": 3}])"},
        {.name = "no_meshes",
         .expected = "scene.json /meshes: missing required key (a scene needs at least one mesh)",
         .meshes = ""},
        {.name = "empty_meshes",
         .expected = "scene.json /meshes: a scene needs at least one mesh, got an empty list",
         .meshes = "[]"},
        {.name = "mesh_no_file",
         .expected = "scene.json /meshes/0/file: missing required key",
         .meshes = R"([{"material": "wood"}])"},
        {.name = "mesh_file_number",
         .expected = "scene.json /meshes/0/file: expected a string, got the number 7",
         .meshes = R"([{"file": 7}])"},
        // materials
        {.name = "material_kd_string",
         .expected = "scene.json /materials/wood/kd: expected a number or 3 numbers, got a string "
                     "(\"brown\")",
         .extra = R"(, "materials": {"wood": {"kd": "brown"}})"},
        {.name = "material_kd_two",
         .expected = "scene.json /materials/wood/kd: expected a number or 3 numbers, got 2 numbers",
         .extra = R"(, "materials": {"wood": {"kd": [1, 2]}})"},
        {.name = "material_negative",
         .expected = "scene.json /materials/wood/kd/1: must not be negative, got -0.5",
         .extra = R"(, "materials": {"wood": {"kd": [0.5, -0.5, 0.5]}})"},
        {.name = "material_phong",
         .expected = "scene.json /materials/wood/phong: must not be negative, got -2",
         .extra = R"(, "materials": {"wood": {"phong": -2}})"},
        {.name = "material_slash_name",
         .expected = "scene.json /materials/a~1b/ks: expected a number or 3 numbers, got null",
         .extra = R"(, "materials": {"a/b": {"ks": null}})"},
        {.name = "materials_list",
         .expected = "scene.json /materials: expected an object {...}, got an array of 0",
         .extra = R"(, "materials": [])"},
        {.name = "unknown_material",
         .expected =
             "scene.json /meshes/0/material: unknown material \"woood\" (defined: wood, mirror)",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "material": "woood"}])",
         .extra = wood},
        {.name = "unknown_material_none",
         .expected = "scene.json /meshes/0/material: unknown material \"wood\" (the scene defines "
                     "no materials)",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "material": "wood"}])"},
        // camera
        {.name = "fov_190",
         .expected = "scene.json /camera/fov: must be between 0 and 180 degrees, got 190",
         .camera = R"({"position": [0, 1, 5], "look_at": [0, 0, 0], "fov": 190})"},
        {.name = "fov_0",
         .expected = "scene.json /camera/fov: must be between 0 and 180 degrees, got 0",
         .camera = R"({"position": [0, 1, 5], "look_at": [0, 0, 0], "fov": 0})"},
        {.name = "camera_look_at_position",
         .expected =
             "scene.json /camera/look_at: equals the position, so the camera has no view direction",
         .camera = R"({"position": [1, 2, 3], "look_at": [1, 2, 3]})"},
        {.name = "camera_up_parallel",
         .expected =
             "scene.json /camera/up: is parallel to the view direction (from position to look_at)",
         .camera = R"({"position": [0, 5, 0], "look_at": [0, 0, 0]})"},
        {.name = "camera_up_zero",
         .expected = "scene.json /camera/up: must not be zero",
         .camera = R"({"position": [0, 1, 5], "look_at": [0, 0, 0], "up": [0, 0, 0]})"},
        // render options
        {.name = "width_0",
         .expected = "scene.json /render/width: must be between 1 and 16384, got 0",
         .extra = R"(, "render": {"width": 0})"},
        {.name = "height_negative",
         .expected = "scene.json /render/height: must be between 1 and 16384, got -480",
         .extra = R"(, "render": {"height": -480})"},
        {.name = "width_absurd",
         .expected = "scene.json /render/width: must be between 1 and 16384, got 1000000000000",
         .extra = R"(, "render": {"width": 1000000000000})"},
        {.name = "width_fraction",
         .expected = "scene.json /render/width: expected an integer, got 640.5",
         .extra = R"(, "render": {"width": 640.5})"},
        {.name = "width_string",
         .expected = "scene.json /render/width: expected an integer, got a string (\"640\")",
         .extra = R"(, "render": {"width": "640"})"},
        {.name = "aa_0",
         .expected = "scene.json /render/aa: must be between 1 and 16, got 0",
         .extra = R"(, "render": {"aa": 0})"},
        {.name = "max_depth_0",
         .expected = "scene.json /render/max_depth: must be between 1 and 64, got 0",
         .extra = R"(, "render": {"max_depth": 0})"},
        {.name = "cc_0",
         .expected = "scene.json /render/cc: must be between 1 and 4096, got 0",
         .extra = R"(, "render": {"cc": 0})"},
        {.name = "cc_negative",
         .expected = "scene.json /render/cc: must be between 1 and 4096, got -100",
         .extra = R"(, "render": {"cc": -100})"},
        {.name = "cc_huge",
         .expected = "scene.json /render/cc: must be between 1 and 4096, got 100000",
         .extra = R"(, "render": {"cc": 100000})"},
        {.name = "ki_0",
         .expected = "scene.json /render/ki: must be between 0.01 and 16, got 0",
         .extra = R"(, "render": {"ki": 0})"},
        {.name = "ki_negative",
         .expected = "scene.json /render/ki: must be between 0.01 and 16, got -2",
         .extra = R"(, "render": {"ki": -2})"},
        {.name = "ki_absurd",
         .expected = "scene.json /render/ki: must be between 0.01 and 16, got 1000",
         .extra = R"(, "render": {"ki": 1000})"},
        {.name = "ns_65",
         .expected = "scene.json /render/ns: must be between 0 and 64, got 65",
         .extra = R"(, "render": {"ns": 65})"},
        {.name = "ns_negative",
         .expected = "scene.json /render/ns: must be between 0 and 64, got -1",
         .extra = R"(, "render": {"ns": -1})"},
        {.name = "grid_negative",
         .expected = "scene.json /render/grid: must be between 0 and 4096, got -1",
         .extra = R"(, "render": {"grid": -1})"},
        {.name = "shadows",
         .expected = "scene.json /render/shadows: must be one of \"soft\", \"exact\", \"none\", \"rt\", \"lmm\", "
                     "\"area\", \"denoised\"; got \"hard\"",
         .extra = R"(, "render": {"shadows": "hard"})"},
        {.name = "light_radius_negative",
         .expected = "scene.json /render/light_radius: must not be negative, got -0.5",
         .extra = R"(, "render": {"light_radius": -0.5})"},
        {.name = "thin_check",
         .expected = "scene.json /render/thin_check: must be one of \"off\", \"lit\", \"all\"; got \"on\"",
         .extra = R"(, "render": {"thin_check": "on"})"},
        {.name = "samples_0",
         .expected = "scene.json /render/samples: must be between 1 and 4096, got 0",
         .extra = R"(, "render": {"samples": 0})"},
        {.name = "samples_huge",
         .expected = "scene.json /render/samples: must be between 1 and 4096, got 5000",
         .extra = R"(, "render": {"samples": 5000})"},
        {.name = "accel",
         .expected = "scene.json /render/accel: must be one of \"brute\", \"grid\", \"embree\"; "
                     "got \"bvh\"",
         .extra = R"(, "render": {"accel": "bvh"})"},
        {.name = "variant_number",
         .expected = "scene.json /render/variant: expected a string, got the number 2",
         .extra = R"(, "render": {"variant": 2})"},
        // transforms
        {.name = "scale_zero",
         .expected =
             "scene.json /meshes/0/transform/scale: must not be zero (it would flatten the mesh)",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "transform": {"scale": [1, 0, 1]}}])"},
        {.name = "scale_two",
         .expected = "scene.json /meshes/0/transform/scale: expected a number or 3 numbers, got an "
                     "array of 2",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "transform": {"scale": [1, 2]}}])"},
        {.name = "rotate_three",
         .expected = "scene.json /meshes/0/transform/rotate/1: expected [ax, ay, az, degrees], got "
                     "an array of 3",
         .meshes =
             R"([{"file": "$DATA/two_boxes.obj", "transform": {"rotate": [[1, 0, 0, 90], [0, 1, 0]]}}])"},
        {.name = "rotate_zero_axis",
         .expected = "scene.json /meshes/0/transform/rotate: the rotation axis must not be zero",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "transform": {"rotate": [0, 0, 0, 90]}}])"},
        {.name = "translate_string",
         .expected =
             "scene.json /meshes/0/transform/translate/2: expected a number, got a string (\"1\")",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "transform": {"translate": [0, 0, "1"]}}])"},
        {.name = "matrix_15",
         .expected =
             "scene.json /meshes/0/matrix: expected 16 numbers (a row-major 4x4 matrix), got 15",
         .meshes =
             R"([{"file": "$DATA/two_boxes.obj", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0]}])"},
        {.name = "matrix_projective",
         .expected = "scene.json /meshes/0/matrix: the last row must be 0 0 0 1 (only affine "
                     "transforms are supported), got 0 0 1 0",
         .meshes =
             R"([{"file": "$DATA/two_boxes.obj", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,0]}])"},
        {.name = "matrix_singular",
         .expected = "scene.json /meshes/0/transform/matrix: the matrix is singular (it would "
                     "flatten the mesh)",
         .meshes =
             R"([{"file": "$DATA/two_boxes.obj", "transform": {"matrix": [1,0,0,0, 2,0,0,0, 0,0,1,0, 0,0,0,1]}}])"},
        {.name = "matrix_and_transform",
         .expected = "scene.json /meshes/0: give either \"transform\" or \"matrix\", not both",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "transform": {}, "matrix": []}])"},
        {.name = "matrix_and_scale",
         .expected = "scene.json /meshes/0/transform: give either \"matrix\" or "
                     "\"scale\"/\"rotate\"/\"translate\", not both",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "transform": {"scale": 2, "matrix": []}}])"},
        {.name = "transform_overflow",
         .expected = "scene.json /meshes/0: the transform makes coordinates non-finite (too large)",
         .meshes =
             R"([{"file": "$DATA/two_boxes.obj", "transform": {"scale": 1e38, "translate": [3e38, 0, 0]}}])"},
        {.name = "exclude_number",
         .expected = "scene.json /meshes/0/exclude_names/1: expected a string, got the number 5",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "exclude_names": ["a", 5]}])"},
        {.name = "smooth_normals_range",
         .expected = "scene.json /meshes/0/smooth_normals: must be 0 to 180 degrees, got 181",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "smooth_normals": 181}])"},
        {.name = "smooth_normals_string",
         .expected = "scene.json /meshes/0/smooth_normals: expected a number, got a string (\"60\")",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "smooth_normals": "60"}])"},
        // ground
        {.name = "ground_up",
         .expected = "scene.json /ground/up: must be one of \"x\", \"y\", \"z\"; got \"w\"",
         .extra = R"(, "ground": {"up": "w"})"},
        {.name = "ground_size",
         .expected = "scene.json /ground/size: must be positive, got 0",
         .extra = R"(, "ground": {"size": 0})"},
        {.name = "ground_material",
         .expected =
             "scene.json /ground/material: unknown material \"floor\" (defined: wood, mirror)",
         .extra = wood + R"(, "ground": {"material": "floor"})"},
        {.name = "ground_bool",
         .expected = "scene.json /ground: expected an object {...}, got true",
         .extra = R"(, "ground": true)"},
        // unknown keys are errors in strict mode
        {.name = "strict_unknown",
         .expected = "scene.json /lights/0/intensty: unknown key; did you mean \"intensity\"?",
         .lights = R"([{"position": [0, 5, 0], "intensty": 2}])",
         .strict = true},
        {.name = "strict_unknown_top",
         .expected = "scene.json /shadows: unknown key",
         .extra = R"(, "shadows": "rt")",
         .strict = true},
        {.name = "strict_duplicate",
         .expected = "scene.json /camera/fov: duplicate key",
         .camera = R"({"position": [0, 1, 5], "look_at": [0, 0, 0], "fov": 30, "fov": 40})",
         .strict = true},
        // mesh files (written next to the scene by the test)
        {.name = "mesh_missing",
         .expected = "scene.json /meshes/0/file: cannot read \"nothere.obj\": no such file",
         .meshes = R"([{"file": "nothere.obj"}])"},
        {.name = "mesh_empty",
         .expected = "scene.json /meshes/0/file: cannot read \"empty.obj\": the file is empty",
         .meshes = R"([{"file": "empty.obj"}])"},
        {.name = "mesh_directory",
         .expected =
             "scene.json /meshes/0/file: cannot read \"models\": is a directory, not a mesh file",
         .meshes = R"([{"file": "models"}])"},
        {.name = "mesh_garbage",
         .expected = "scene.json /meshes/0/file: cannot read \"garbage.obj\": no meshes found in "
                     "it (is the file really in this format?)",
         .meshes = R"([{"file": "garbage.obj"}])"},
        {.name = "mesh_unknown_format",
         .expected = "scene.json /meshes/0/file: cannot read \"notes.xyz\": Assimp has no reader "
                     "for this file format",
         .meshes = R"([{"file": "notes.xyz"}])"},
        {.name = "mesh_truncated",
         .expected = "scene.json /meshes/0/file: cannot read \"truncated.obj\": OBJ: line 4: face corner \"9\" "
                     "refers to vertex 9, but 3 vertices are defined before it",
         .meshes = R"([{"file": "truncated.obj"}])"},
        {.name = "mesh_lines",
         .expected = "scene.json /meshes/0/file: \"lines.obj\": no triangles (only points/lines)",
         .meshes = R"([{"file": "lines.obj"}])"},
        {.name = "mesh_nan",
         .expected = "scene.json /meshes/0/file: \"nan.obj\": vertex ",
         .meshes = R"([{"file": "nan.obj"}])",
         .substring = true},
        {.name = "mesh_inf",
         .expected = "non-finite coordinate",
         .meshes = R"([{"file": "inf.obj"}])",
         .substring = true},
        {.name = "zero_extent",
         .expected = "scene.json /meshes: the scene has zero extent: all 2 triangles are "
                     "degenerate (zero area)",
         .meshes = R"([{"file": "point.obj"}])"},
        {.name = "all_excluded",
         .expected = "scene.json /meshes: the scene has no triangles: all 2 meshes were excluded",
         .meshes = R"([{"file": "$DATA/two_boxes.obj", "exclude_names": "*"}])"},
    };

    // Mesh files the cases refer to, next to the scenes.
    const std::string folder = TempFolder();
    WriteFile(folder, "empty.obj", "");
    fs::create_directories(folder + "/models");
    WriteFile(folder, "garbage.obj",
              std::string("\x7f\x01\x02\x03 garbage \xff\xfe\n\x00\x01", 18));
    WriteFile(folder, "notes.xyz", "these are not a mesh\n");
    WriteFile(folder, "truncated.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    WriteFile(folder, "lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\np 3\n");
    WriteFile(folder, "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    WriteFile(folder, "inf.obj", "v 0 0 0\nv 1 0 0\nv 0 1e999 0\nf 1 2 3\n");
    WriteFile(folder, "point.obj", "v 1 1 1\nv 1 1 1\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 1 2 4\n");

    for (const BadCase& c : cases) {
        SCOPED_TRACE(c.name);
        const std::string path = WriteFile(folder, c.name + ".json", SceneText(c));
        const std::string message = Replace(LoadError(path, c.strict), path, "scene.json");
        if (getenv("LM_PRINT")) printf("%-24s %s\n", c.name.c_str(), message.c_str());
        if (c.substring)
            EXPECT_NE(message.find(c.expected), std::string::npos) << message;
        else
            EXPECT_EQ(message, c.expected);
    }
}

// Every numeric knob of the "render" object takes its range from the settings table, the one
// the CLI checks too: its ends load, just outside them is an error naming the range.
TEST(SceneFile, RenderKnobsFollowTheSettingsTable) {
    const std::string folder = TempFolder();
    int checked = 0;
    for (const RenderSetting& row : RenderSettings()) {
        if (row.kind != RenderSetting::Kind::Int && row.kind != RenderSetting::Kind::Float) continue;
        SCOPED_TRACE(row.key);
        const bool integer = row.kind == RenderSetting::Kind::Int;
        const double step = integer ? 1 : 0.005;
        auto load = [&](double v) {
            BadCase c;
            c.extra = StringPrintf(R"(, "render": {"%s": %.17g})", row.key, v);
            // Keep width·height under the pixel limit while the other one is at its end.
            if (std::string(row.key) == "width" || std::string(row.key) == "height")
                c.extra = StringPrintf(R"(, "render": {"width": 64, "height": 64, "%s": %.17g})", row.key, v);
            const std::string path = WriteFile(folder, std::string(row.key) + ".json", SceneText(c));
            return Replace(LoadError(path), path, "scene.json");
        };
        EXPECT_EQ(load(row.lo), "<no error>");
        EXPECT_NE(load(row.lo - step).find(StringPrintf("scene.json /render/%s: must ", row.key)), std::string::npos);
        if (std::isfinite(row.hi)) {
            EXPECT_EQ(load(row.hi), "<no error>");
            EXPECT_NE(load(row.hi + step).find(integer ? StringPrintf("must be between %g and %g, got", row.lo, row.hi)
                                                       : StringPrintf("must be between %g and %g", row.lo, row.hi)),
                      std::string::npos);
        }
        ++checked;
    }
    EXPECT_GE(checked, 9);
}

TEST(SceneFile, CorruptedScenesThrowOnlyErrors) {
    // Truncations and random character substitutions of a good scene: each either loads
    // or throws lm::Error (anything else escapes and fails the test), and never crashes.
    std::ifstream in(DataDir + "/good.json");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text = Replace(text, "\"two_boxes.obj\"", "\"" + DataDir + "/two_boxes.obj\"");
    const std::string folder = TempFolder();
    std::mt19937 rng(12345);
    const std::string alphabet = "{}[],:\"0123456789.-e+ xyz\\";
    int loaded = 0;
    for (int i = 0; i < 300; ++i) {
        std::string t = text;
        if (i < 100) {
            t.resize(rng() % t.size());
        } else {
            for (int k = 0; k <= i % 3; ++k)
                t[rng() % t.size()] = alphabet[rng() % alphabet.size()];
        }
        WriteFile(folder, "fuzz.json", t);
        std::vector<std::string> warnings;
        try {
            LoadScene(folder + "/fuzz.json", {}, &warnings);
            ++loaded;
        } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()).rfind(folder + "/fuzz.json", 0), 0u) << e.what();
        }
    }
    EXPECT_GT(loaded, 0);
}

// One pattern that excludes nothing, over 1,024 references to one file, is one warning
// with the count, not one per reference (nor three per reference with every mesh excluded).
TEST(SceneFile, AWarningAboutAFilesReferencesIsSaidOnce) {
    const std::string folder = TempFolder();
    std::string meshes;
    for (int i = 0; i < 1024; ++i)
        meshes += std::string(i ? ", " : "") + R"({"file": "$DATA/two_boxes.obj", "exclude_materials": ["Nothing*"], )" +
                  R"("exclude_names": "*", "transform": {"translate": [)" + std::to_string(3 * i) + ", 0, 0]}}";
    const std::string path = WriteFile(
        folder, "scene.json",
        Replace(R"({"camera": {"position": [0, 1, 5], "look_at": [0, 0, 0]}, "lights": [{"position": [0, 5, 0]}],
                    "meshes": [)" + meshes + R"(, {"file": "$DATA/two_boxes.obj"}]})",
                "$DATA", DataDir));
    std::vector<std::string> warnings;
    LoadScene(path, {}, &warnings);
    for (std::string& w : warnings) w = Replace(w, folder + "/", "");
    const std::vector<std::string> expected = {
        "scene.json /meshes/0/exclude_materials/0: pattern \"Nothing*\" matched no material of \"" + DataDir +
            "/two_boxes.obj\" (and in 1,023 other references to it)",
        "scene.json /meshes/0: every mesh of \"" + DataDir +
            "/two_boxes.obj\" was excluded (and in 1,023 other references to it)",
    };
    EXPECT_EQ(warnings, expected);
}

TEST(SceneFile, UnknownAndDuplicateKeysWarn) {
    const std::string folder = TempFolder();
    const std::string path = WriteFile(folder, "scene.json",
                                       Replace(R"({
        "camera": {"position": [0, 1, 5], "look_at": [0, 0, 0], "fov": 30, "fov": 50, "aspect": 2},
        "lights": [{"position": [0, 5, 0], "intensty": 2}],
        "meshes": [{"file": "$DATA/two_boxes.obj", "exclude_names": ["Colision*"],
                    "exclude_materials": "Red"}],
        "shadow": "lmm"})",
                                               "$DATA", DataDir));
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(path, {}, &warnings);
    EXPECT_EQ(scene.camera.fovY, 50.0f);  // the last duplicate wins
    for (std::string& w : warnings) w = Replace(w, folder + "/", "");
    const std::vector<std::string> expected = {
        "scene.json /camera/fov: duplicate key (the last value is used)",
        "scene.json /camera/aspect: unknown key (ignored)",
        "scene.json /lights/0/intensty: unknown key (ignored; did you mean \"intensity\"?)",
        "scene.json /shadow: unknown key (ignored)",
        "scene.json /meshes/0/exclude_names/0: pattern \"Colision*\" matched no node or mesh of \"" +
            DataDir + "/two_boxes.obj\"",
    };
    EXPECT_EQ(warnings, expected);
    // Strict mode turns the first of them into an error.
    EXPECT_EQ(Replace(LoadError(path, true), folder + "/", ""),
              "scene.json /camera/fov: duplicate key");
}

TEST(SceneFile, DegenerateAndDuplicateTrianglesAreDroppedAndCounted) {
    const std::string folder = TempFolder();
    // Triangle 1 is good, 2 repeats it with another winding, 3 has zero area.
    WriteFile(folder, "dirty.obj",
              "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 2 3 1\nf 1 2 4\n");
    const std::string path = WriteFile(folder, "scene.json", R"({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "lights": [{"position": [0, 5, 0]}],
        "meshes": [{"file": "dirty.obj"}, {"file": "dirty.obj"}]})");
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(path, {}, &warnings);
    EXPECT_EQ(scene.mesh.TriangleCount(), 1u);
    EXPECT_EQ(scene.report.degenerateRemoved, 2u);
    EXPECT_EQ(scene.report.duplicatesRemoved, 3u);  // one per file, one across the files
    for (std::string& w : warnings) w = Replace(w, folder + "/", "");
    const std::vector<std::string> expected = {
        // The file is placed twice: imported once, its warning said once.
        "dirty.obj: dropped 1 degenerate (zero-area) and 1 duplicate triangle",
        "scene.json: dropped 1 triangle that duplicates a triangle of another mesh",
    };
    EXPECT_EQ(warnings, expected);
}

// A file placed twice with the same excludes is imported once; other excludes import it
// again.
TEST(SceneFile, AFilePlacedTwiceIsImportedOnce) {
    const std::string folder = TempFolder();
    WriteFile(folder, "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    const std::string path = WriteFile(folder, "scene.json", R"({
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "lights": [{"position": [0, 5, 0]}],
        "meshes": [{"file": "tri.obj"}, {"file": "tri.obj", "transform": {"translate": [2, 0, 0]}},
                   {"file": "tri.obj", "exclude_names": "nothing", "transform": {"translate": [4, 0, 0]}}]})");
    int imports = 0;
    SceneLoadOptions options;
    options.loadMesh = [&](const std::string& file, const MeshLoadOptions& load) {
        ++imports;
        return LoadMeshFile(file, load);
    };
    std::vector<std::string> warnings;
    const Scene scene = LoadScene(path, options, &warnings);
    EXPECT_EQ(imports, 2);
    EXPECT_EQ(scene.mesh.TriangleCount(), 3u);
}

TEST(SceneFile, ImporterWarningsReachTheUser) {
    const std::string folder = TempFolder();
    WriteFile(folder, "nomtl.obj", "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    std::vector<std::string> warnings;
    LoadScene(folder + "/nomtl.obj", {}, &warnings);
    ASSERT_FALSE(warnings.empty());
    EXPECT_EQ(warnings[0], folder + "/nomtl.obj: OBJ: Unable to locate material file gone.mtl");
}

TEST(SceneFile, SceneFileItselfBad) {
    const std::string folder = TempFolder();
    EXPECT_EQ(LoadError(folder + "/none.json"), folder + "/none.json: no such file");
    fs::create_directories(folder + "/dir.json");
    EXPECT_EQ(LoadError(folder + "/dir.json"),
              folder + "/dir.json: is a directory, not a scene file");
    EXPECT_EQ(LoadError(""),
              "no scene given: expected builtin:NAME, a .json scene file or a mesh file");
    // The extension decides, case-insensitively.
    WriteFile(folder, "UPPER.JSON", "[]");
    EXPECT_EQ(
        LoadError(folder + "/UPPER.JSON"),
        folder + "/UPPER.JSON: expected a JSON object {...} at the top level, got an array of 0");
}

TEST(SceneFile, BareMeshErrorsNameTheFile) {
    const std::string folder = TempFolder();
    // A relative spec stays relative in the message.
    EXPECT_EQ(LoadError("model.obj"), "model.obj: no such file");
    WriteFile(folder, "lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n");
    EXPECT_EQ(LoadError(folder + "/lines.obj"),
              folder + "/lines.obj: no triangles (only points/lines)");
    WriteFile(folder, "empty.ply", "");
    EXPECT_EQ(LoadError(folder + "/empty.ply"), folder + "/empty.ply: the file is empty");
    WriteFile(folder, "point.obj", "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n");
    EXPECT_EQ(
        LoadError(folder + "/point.obj"),
        folder +
            "/point.obj: the scene has zero extent: all 1 triangles are degenerate (zero area)");
    // Finite coordinates whose triangle's normal overflows: degeneracy is judged at the
    // triangle's own scale, so the triangle is kept and the scene's reach is what is refused,
    // with the advice to scale down.
    WriteFile(folder, "huge.obj", "v 0 0 0\nv 1e38 0 0\nv 0 1e38 0\nf 1 2 3\n");
    EXPECT_EQ(LoadError(folder + "/huge.obj"),
              folder + "/huge.obj: the scene's coordinates reach 1e+38, beyond the ±1e+18 that single-precision "
                       "rendering allows (scale the model down)");
    // A valid model at 1e-17 scale (its squared cross products underflow in float) loads;
    // only a flat triangle is degenerate.
    WriteFile(folder, "tiny.obj", "v 0 0 0\nv 1e-17 0 0\nv 0 1e-17 0\nv 0 0 1e-17\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    std::vector<std::string> warnings;
    const Scene tiny = LoadScene(folder + "/tiny.obj", {}, &warnings);
    EXPECT_EQ(tiny.report.degenerateRemoved, 0u);
    EXPECT_GE(tiny.mesh.TriangleCount(), 4u);
}

/// Projects p with the scene's pinhole camera; true if it lands inside the image.
bool InView(const Camera& cam, int width, int height, const Vec3& p) {
    const Vec3 forward = Normalize(cam.lookAt - cam.position);
    const Vec3 right = Normalize(Cross(forward, cam.up));
    const Vec3 up = Cross(right, forward);
    const Vec3 d = p - cam.position;
    const float z = Dot(d, forward);
    if (!(z > 0)) return false;
    const float tanY = std::tan(cam.fovY * 0.5f * Pi / 180.0f);
    const float tanX = tanY * static_cast<float>(width) / static_cast<float>(height);
    return std::abs(Dot(d, right) / z) <= tanX && std::abs(Dot(d, up) / z) <= tanY;
}

TEST(SceneFile, BareMeshIsFramedAutomatically) {
    std::vector<std::string> warnings;
    const std::string path = DataDir + "/two_boxes.obj";
    const Scene scene = LoadScene(path, {}, &warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(scene.name, path);
    // The model: the cube [-1, 1]³ and the tetrahedron at x ∈ [3, 4]; 16 triangles + the
    // ground slab's 12.
    ASSERT_EQ(scene.mesh.TriangleCount(), 28u);
    Bounds3 model;
    for (uint32_t t = 0; t < 16; ++t)
        for (int k = 0; k < 3; ++k) model.Extend(scene.mesh.Vertex(t, k));
    EXPECT_TRUE(Near(model.lo, Vec3(-1, -1, -1)) && Near(model.hi, Vec3(4, 1, 1)));

    // Every corner of the model's box is in view, and the camera is outside the box.
    for (int c = 0; c < 8; ++c) {
        const Vec3 corner((c & 1) ? model.hi.x : model.lo.x, (c & 2) ? model.hi.y : model.lo.y,
                          (c & 4) ? model.hi.z : model.lo.z);
        EXPECT_TRUE(InView(scene.camera, scene.render.width, scene.render.height, corner)) << c;
    }
    EXPECT_FALSE(model.Contains(scene.camera.position));

    // A ground slab with its top at the model's lowest point, under the whole model.
    Bounds3 ground;
    for (uint32_t t = 16; t < 28; ++t) {
        for (int k = 0; k < 3; ++k) ground.Extend(scene.mesh.Vertex(t, k));
        EXPECT_EQ(scene.materials[scene.mesh.materialIds[t]].name, "ground");
    }
    EXPECT_LT(ground.lo.y, -1.0f);
    EXPECT_EQ(ground.hi.y, -1.0f);
    EXPECT_LT(ground.lo.x, model.lo.x);
    EXPECT_GT(ground.hi.x, model.hi.x);
    EXPECT_LT(ground.lo.z, model.lo.z);
    EXPECT_GT(ground.hi.z, model.hi.z);

    // Two lights above the model, bright enough, and small spheres sized by the default
    // rule from the model's box.
    ASSERT_EQ(scene.lights.size(), 2u);
    for (const PointLight& l : scene.lights) {
        EXPECT_GT(l.position.y, model.hi.y);
        EXPECT_GT(l.intensity.r, 0);
        EXPECT_GT(l.radius, 0.0f);
        EXPECT_FLOAT_EQ(l.radius, DefaultLightRadius(model, l.position));
    }
    // The materials come from the MTL file.
    EXPECT_EQ(scene.materials[scene.mesh.materialIds[0]].name, "Red");

    // The choices are recorded for the CLI.
    ASSERT_GE(scene.report.notes.size(), 4u);
    std::string notes;
    for (const auto& n : scene.report.notes) notes += n + "\n";
    EXPECT_NE(notes.find("camera at"), std::string::npos) << notes;
    EXPECT_NE(notes.find("ground plane at y = -1"), std::string::npos) << notes;
    EXPECT_NE(notes.find("light"), std::string::npos) << notes;
    EXPECT_NE(notes.find(StringPrintf("radius %.3g and %.3g (2 %% of their distance to the model's centre",
                                      static_cast<double>(scene.lights[0].radius),
                                      static_cast<double>(scene.lights[1].radius))),
              std::string::npos)
        << notes;
    ASSERT_EQ(scene.report.sources.size(), 1u);
    EXPECT_EQ(scene.report.sources[0], path);
}

TEST(SceneFile, BareMeshFramingHoldsForAFlatWideModel) {
    // A long thin strip: the horizontal field of view matters, not just the vertical.
    const std::string folder = TempFolder();
    WriteFile(folder, "strip.obj",
              "v -50 0 -0.5\nv 50 0 -0.5\nv 50 0 0.5\nv -50 0 0.5\nf 1 2 3 4\n");
    const Scene scene = LoadScene(folder + "/strip.obj", {}, nullptr);
    for (const Vec3& p :
         {Vec3(-50, 0, -0.5f), Vec3(50, 0, -0.5f), Vec3(50, 0, 0.5f), Vec3(-50, 0, 0.5f)})
        EXPECT_TRUE(InView(scene.camera, scene.render.width, scene.render.height, p));

    // The caller can say it will render a portrait image instead.
    SceneLoadOptions portrait;
    portrait.frameWidth = 300;
    portrait.frameHeight = 1000;
    const Scene tall = LoadScene(folder + "/strip.obj", portrait, nullptr);
    EXPECT_FALSE(InView(scene.camera, 300, 1000, Vec3(50, 0, 0.5f)));
    for (const Vec3& p :
         {Vec3(-50, 0, -0.5f), Vec3(50, 0, -0.5f), Vec3(50, 0, 0.5f), Vec3(-50, 0, 0.5f)})
        EXPECT_TRUE(InView(tall.camera, 300, 1000, p));
}

TEST(SceneFile, BareFlatLevelModelGetsItsGroundBelowIt) {
    // A card lying level, facing down: a ground at its height would coincide with it.
    const std::string folder = TempFolder();
    const Scene card = LoadScene(WriteFile(folder, "card.obj", "v -1 0.5 -1\nv 1 0.5 -1\nv 1 0.5 1\nv -1 0.5 1\nf 1 2 3 4\n"),
                                 {}, nullptr);
    ASSERT_EQ(card.mesh.TriangleCount(), 14u);  // the card's 2 and the slab's 12
    float slabTop = -1e30f;
    for (uint32_t t = 2; t < 14; ++t)
        for (int k = 0; k < 3; ++k) slabTop = std::max(slabTop, card.mesh.Vertex(t, k).y);
    EXPECT_FLOAT_EQ(slabTop, 0.5f - 0.2f);  // 10 % of its width (2) below
    bool noted = false;
    for (const std::string& n : card.report.notes) noted = noted || n.find("the model is flat and level") != std::string::npos;
    EXPECT_TRUE(noted);
    // A card standing upright keeps its ground at its lowest point.
    const Scene upright = LoadScene(
        WriteFile(folder, "upright.obj", "v -1 0 0\nv 1 0 0\nv 1 2 0\nv -1 2 0\nf 1 2 3 4\n"), {}, nullptr);
    float top = -1e30f;
    for (uint32_t t = 2; t < upright.mesh.TriangleCount(); ++t)
        for (int k = 0; k < 3; ++k) top = std::max(top, upright.mesh.Vertex(t, k).y);
    EXPECT_EQ(top, 0.0f);
}

TEST(SceneFile, ExampleScenesLoad) {
    // The scenes/ folder for humans must keep loading without warnings.
    const fs::path scenes = fs::path(LIGHTMESH_TEST_DATA).parent_path().parent_path() / "scenes";
    size_t count = 0;
    for (const auto& entry : fs::directory_iterator(scenes)) {
        if (entry.path().extension() != ".json") continue;
        SCOPED_TRACE(entry.path().string());
        std::vector<std::string> warnings;
        const Scene scene = LoadScene(entry.path().string(), {true}, &warnings);
        EXPECT_TRUE(warnings.empty()) << warnings.front();
        EXPECT_GT(scene.mesh.TriangleCount(), 0u);
        ++count;
    }
    EXPECT_GE(count, 1u);
}

TEST(SceneFile, BuiltinScenesLoad) {
    for (const std::string& name : BuiltinSceneNames()) {
        SCOPED_TRACE(name);
        std::vector<std::string> warnings;
        const Scene scene = LoadScene("builtin:" + name, {}, &warnings);
        EXPECT_GT(scene.mesh.TriangleCount(), 0u);
        EXPECT_FALSE(scene.lights.empty());
    }
    EXPECT_NE(LoadError("builtin:no-such-scene"), "<no error>");
}

}  // namespace
}  // namespace scene_file_test
}  // namespace lm

namespace lm {
namespace scene_file_test {
namespace {

// A JSON object with 300,000 keys loads in well under a second (ordered_json would look
// keys up linearly: quadratic). The bound leaves room for sanitizer builds.
TEST(SceneFile, ManyKeysLoadInLinearTime) {
    const std::string folder = TempFolder();
    WriteFile(folder, "box.obj",
              "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
              "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n");
    std::string keys;
    for (int i = 0; i < 300000; ++i) keys += ", \"k" + std::to_string(i) + "\": " + std::to_string(i);
    const std::string path = WriteFile(
        folder, "keys.json",
        R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0])" + keys +
            R"(}, "lights": [{"position": [3, 6, 4]}], "meshes": [{"file": "box.obj"}]})");
    std::vector<std::string> warnings;
    const auto start = std::chrono::steady_clock::now();
    const Scene scene = LoadScene(path, {}, &warnings);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 10.0);
    EXPECT_EQ(scene.mesh.TriangleCount(), 12u);
    // Ten unknown keys one by one, in the file's order, then one line for the rest.
    ASSERT_EQ(warnings.size(), 11u);
    EXPECT_EQ(warnings[0], path + " /camera/k0: unknown key (ignored)");
    EXPECT_EQ(warnings[9], path + " /camera/k9: unknown key (ignored)");
    EXPECT_EQ(warnings[10], path + " /camera: ... and 299990 more unknown keys (ignored)");
}

// Nesting under an unknown key, and many objects in one array, must stay linear in time
// and memory (a naive reader is quadratic in the depth, and nlohmann's callback parser
// searches the enclosing array at each object's end). Deeper than kMaxJsonDepth is refused
// at once, naming the file and the pointer; everything else is linear.
TEST(SceneFile, DeepOrWideJsonIsLinearOrRefused) {
    const std::string folder = TempFolder();
    WriteFile(folder, "box.obj",
              "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
              "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n");
    auto scene = [&](const std::string& junk) {
        return R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]}, "lights": [{"position": [3, 6, 4]}],
                   "meshes": [{"file": "box.obj"}], "junk": )" + junk + "}";
    };
    auto nested = [](size_t levels, bool arrays) {
        std::string s;
        for (size_t i = 0; i < levels; ++i) s += arrays ? "[" : "{\"a\": ";
        s += "1";
        for (size_t i = 0; i < levels; ++i) s += arrays ? "]" : "}";
        return s;
    };
    const auto start = std::chrono::steady_clock::now();
    for (const bool arrays : {false, true}) {
        SCOPED_TRACE(arrays ? "arrays" : "objects");
        const std::string path = WriteFile(folder, "deep.json", scene(nested(100000, arrays)));
        const std::string token = arrays ? "0" : "a";
        EXPECT_EQ(LoadError(path, false),
                  path + ": nesting deeper than 256 levels at /junk/" + token + "/" + token + "/" + token +
                      "/...(250 levels).../" + token + "/" + token + " (the most a JSON file may nest)");
        // The top level counts as one: 255 more levels under "junk" load.
        const std::string ok = WriteFile(folder, "ok.json", scene(nested(json::kMaxJsonDepth - 1, arrays)));
        std::vector<std::string> warnings;
        EXPECT_EQ(LoadScene(ok, {}, &warnings).mesh.TriangleCount(), 12u);
        const std::string over = WriteFile(folder, "over.json", scene(nested(json::kMaxJsonDepth, arrays)));
        EXPECT_NE(LoadError(over, false).find("nesting deeper than 256 levels"), std::string::npos);
    }
    // Wide: 300,000 objects in one array, 300,000 object values in one object, under a
    // 10,000-character key (no pointer is copied per value).
    std::string wide = "{\"" + std::string(10000, 'k') + "\": [";
    for (int i = 0; i < 300000; ++i) wide += i ? ", {}" : "{}";
    wide += "], \"b\": {";
    for (int i = 0; i < 300000; ++i) wide += (i ? ", \"k" : "\"k") + std::to_string(i) + "\": {\"x\": 1}";
    wide += "}}";
    std::vector<std::string> warnings;
    EXPECT_EQ(LoadScene(WriteFile(folder, "wide.json", scene(wide)), {}, &warnings).mesh.TriangleCount(), 12u);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, std::max(10.0, 2.0 * testing::kSanitizerSlowdown));  // about 1.5 s here (Release); 24 s under ASan on a busy machine
}

// Values as given, not as stored: 16.000001 rounds to the float 16.000002, which is out
// of range, and must not be shown as "got 16".
TEST(SceneFile, NumbersInMessagesAreShownAsGiven) {
    EXPECT_EQ(json::NumberText(16.000001), "16.000001");
    EXPECT_EQ(json::NumberText(1e12), "1000000000000");
    EXPECT_EQ(json::NumberText(1e39), "1e+39");
    EXPECT_EQ(json::NumberText(-2.5), "-2.5");
    EXPECT_EQ(json::NumberText(0.0001), "0.0001");
    EXPECT_EQ(json::NumberText(Json::parse("-480")), "-480");
    EXPECT_EQ(json::NumberText(Json::parse("18446744073709551615")), "18446744073709551615");
    const std::string folder = TempFolder();
    WriteFile(folder, "box.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    const std::string path = WriteFile(
        folder, "ki.json",
        R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]}, "lights": [{"position": [3, 6, 4]}],
            "meshes": [{"file": "box.obj"}], "render": {"ki": 16.000001}})");
    EXPECT_EQ(LoadError(path, false), path + " /render/ki: must be between 0.01 and 16, got 16.000001");
}

// Materials keep the file's order (the JSON is a std::map now, ordered by key).
TEST(SceneFile, MaterialsKeepTheFilesOrder) {
    const std::string folder = TempFolder();
    WriteFile(folder, "box.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    const std::string path = WriteFile(
        folder, "m.json",
        R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]}, "lights": [{"position": [3, 6, 4]}],
            "materials": {"zebra": {"kd": 0.1}, "apple": {"kd": 0.2}, "mango": {"kd": 0.3}},
            "meshes": [{"file": "box.obj", "material": "apple"}]})");
    const Scene scene = LoadScene(path, {}, nullptr);
    ASSERT_GE(scene.materials.size(), 3u);
    EXPECT_EQ(scene.materials[0].name, "zebra");
    EXPECT_EQ(scene.materials[1].name, "apple");
    EXPECT_EQ(scene.materials[2].name, "mango");
    for (uint32_t id : scene.mesh.materialIds) EXPECT_EQ(id, 1u);
}

// A bare model with its own floor at its lowest point gets no ground slab (it would be
// coplanar with the floor: z-fighting); one whose base only partly faces up gets the slab
// sunk below it; a closed model (its base faces down) keeps the slab at its base.
TEST(SceneFile, BareMeshWithItsOwnFloorGetsNoCoplanarSlab) {
    const std::string folder = TempFolder();
    const std::string box = "v -1 0 -1\nv 1 0 -1\nv 1 2 -1\nv -1 2 -1\nv -1 0 1\nv 1 0 1\nv 1 2 1\nv -1 2 1\n"
                            "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";
    const std::string lawn = "v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\nf 9 12 11 10\n";
    const std::string patch = "v 2 0 2\nv 4 0 2\nv 4 0 4\nv 2 0 4\nf 9 12 11 10\n";
    std::vector<std::string> warnings;
    const Scene withLawn = LoadScene(WriteFile(folder, "park.obj", box + lawn), {}, &warnings);
    EXPECT_EQ(withLawn.mesh.TriangleCount(), 14u);  // no slab
    const Scene withPatch = LoadScene(WriteFile(folder, "patch.obj", box + patch), {}, &warnings);
    ASSERT_EQ(withPatch.mesh.TriangleCount(), 26u);  // 12 + 2 + the slab's 12
    EXPECT_LT(withPatch.mesh.Bounds().lo.y, -0.001f);
    float slabTop = -1e30f;
    for (uint32_t t = 14; t < 26; ++t)
        for (int k = 0; k < 3; ++k) slabTop = std::max(slabTop, withPatch.mesh.Vertex(t, k).y);
    EXPECT_LT(slabTop, 0.0f);
    const Scene closed = LoadScene(WriteFile(folder, "box.obj", box), {}, &warnings);
    ASSERT_EQ(closed.mesh.TriangleCount(), 24u);
    float top = -1e30f;
    for (uint32_t t = 12; t < 24; ++t)
        for (int k = 0; k < 3; ++k) top = std::max(top, closed.mesh.Vertex(t, k).y);
    EXPECT_EQ(top, 0.0f);
}

}  // namespace
}  // namespace scene_file_test
}  // namespace lm
