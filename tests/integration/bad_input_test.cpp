// The bad-input corpus (issue 8): every kind of bad scene, mesh, option and output path the
// renderer may be given, run through the real executable. Each case checks the exit code
// (1: bad input; never a crash), the message (the whole line where it is stable, else a
// distinctive part naming the file and JSON path), and that the output file does not
// appear -- or, when it existed before, is byte-identical afterwards with no temporary
// file left beside it. A few cases are accepted with a warning and do write the image.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "run_lightmesh.h"

namespace {

namespace fs = std::filesystem;
using lm::testing::CliResult;
using lm::testing::FileBytes;

std::string Replace(std::string s, const std::string& from, const std::string& to) {
    for (size_t pos = s.find(from); pos != std::string::npos; pos = s.find(from, pos + to.size()))
        s.replace(pos, from.size(), to);
    return s;
}

void Write(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary) << bytes;
}

// ---------------------------------------------------------------------------------------
// Inputs

/// A closed unit cube [-1, 1]³ with outward winding.
const char* kBox =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// A JSON scene around box.obj, with any part replaced.
struct SceneParts {
    std::string camera = R"({"position": [0, 2, 8], "look_at": [0, 0, 0]})";
    std::string lights = R"([{"position": [3, 6, 4], "intensity": 40}])";
    std::string meshes = R"([{"file": "box.obj"}])";
    std::string extra = R"(, "ground": {})";
};

std::string SceneJson(const SceneParts& p) {
    return "{\n  \"camera\": " + p.camera + ",\n  \"lights\": " + p.lights +
           ",\n  \"meshes\": " + p.meshes + p.extra + "\n}\n";
}

/// A scene differing from the good one in one part.
std::string WithCamera(const std::string& camera) {
    SceneParts p;
    p.camera = camera;
    return SceneJson(p);
}
std::string WithLights(const std::string& lights) {
    SceneParts p;
    p.lights = lights;
    return SceneJson(p);
}
std::string WithMeshes(const std::string& meshes) {
    SceneParts p;
    p.meshes = meshes;
    return SceneJson(p);
}
std::string WithExtra(const std::string& extra) {
    SceneParts p;
    p.extra = extra;
    return SceneJson(p);
}

/// n lights in a ring above the box.
std::string ManyLights(int n) {
    std::string s = "[";
    for (int i = 0; i < n; ++i)
        s += (i ? ", " : "") + std::string("{\"position\": [") + std::to_string(i % 10 - 5) +
             ", 6, " + std::to_string(i / 10) + "]}";
    return s + "]";
}

struct Case {
    std::string name;
    /// Arguments after `lightmesh`; $D is the case's folder, $OUT the output path.
    std::string args;
    /// Expected in the output ($D replaced): the whole "lightmesh: error: ..." line where
    /// the message is stable.
    std::string expected;
    /// Files written into $D before the run (name -> content); box.obj is always there.
    std::map<std::string, std::string> files = {};
    int exitCode = 1;
    /// The output path ($D replaced); every case renders into it if it gets that far.
    std::string output = "$D/out/out.png";
    /// Run as an unprivileged user (root ignores file permissions).
    bool unprivileged = false;
    /// Environment for the run, e.g. "LIGHTMESH_MEMORY_LIMIT=64M".
    std::string env = "";
};

/// The scene most cases render: small, fast.
const std::string kRender = "render $D/scene.json --width 16 --height 12 -o $OUT";

std::vector<Case> Corpus() {
    const std::string good = SceneJson({});
    return {
        // --- The scene file itself -----------------------------------------------------
        {.name = "json_malformed",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json:2:36: parse error: syntax error while "
                     "parsing object key - unexpected ','; expected string literal\n",
         .files = {{"scene.json", "{\n  \"camera\": {\"position\": [0, 2, 8],,\n}"}}},
        {.name = "json_truncated",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json:2:33: parse error: syntax error while "
                     "parsing value - unexpected end of input; expected '[', '{', or a literal\n",
         .files = {{"scene.json", good.substr(0, 34)}}},
        {.name = "json_binary",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json:1:1: parse error: syntax error while "
                     "parsing value - invalid literal; last read: '<U+007F>'\n",
         .files = {{"scene.json", std::string("\x7f\x45\x4c\x46\x02\x01\x01\x00\xff\xfe", 10)}}},
        {.name = "json_empty",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json: the file is empty\n",
         .files = {{"scene.json", ""}}},
        {.name = "json_top_level_array",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json: expected a JSON object {...} at the top "
                     "level, got an array of 0\n",
         .files = {{"scene.json", "[]"}}},
        {.name = "scene_missing",
         .args = "render $D/missing.json -o $OUT",
         .expected = "lightmesh: error: $D/missing.json: no such file\n"},
        {.name = "scene_is_a_folder",
         .args = "render $D/folder.json -o $OUT",
         .expected = "lightmesh: error: $D/folder.json: is a directory, not a scene file\n",
         .files = {{"folder.json/", ""}}},
        {.name = "scene_unreadable",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json: cannot open: Permission denied\n",
         .files = {{"scene.json", good}, {"chmod 000", "scene.json"}},
         .unprivileged = true},
        {.name = "builtin_unknown",
         .args = "render builtin:nothing -o $OUT",
         .expected = "unknown built-in scene"},
        // --- Wrong types and missing required keys -----------------------------------------
        {.name = "type_position_string",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/0/position: expected 3 numbers, "
                     "got a string (\"0 5 0\")\n",
         .files = {{"scene.json", WithLights(R"([{"position": "0 5 0"}])")}}},
        {.name = "type_position_two_numbers",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/0/position: expected 3 numbers, "
                     "got 2\n",
         .files = {{"scene.json", WithLights(R"([{"position": [0, 5]}])")}}},
        {.name = "type_meshes_object",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes: expected a list of meshes [...], "
                     "got an object\n",
         .files = {{"scene.json", WithMeshes(R"({"file": "box.obj"})")}}},
        {.name = "type_render_width_string",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /render/width: expected an integer, got a "
                     "string (\"640\")\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"width": "640"})")}}},
        {.name = "missing_camera",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /camera: missing required key\n",
         .files = {{"scene.json", R"({"lights": [{"position": [0, 5, 0]}], "meshes": [{"file": "box.obj"}]})"}}},
        {.name = "missing_look_at",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /camera/look_at: missing required key\n",
         .files = {{"scene.json", WithCamera(R"({"position": [0, 2, 8]})")}}},
        {.name = "missing_lights",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights: a scene needs at least one "
                     "light, got an empty list\n",
         .files = {{"scene.json", WithLights("[]")}}},
        {.name = "missing_mesh_file_key",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: missing required key\n",
         .files = {{"scene.json", WithMeshes(R"([{"material": "wood"}])")}}},
        // --- Unknown keys: a warning with the JSON path; --strict makes them errors -------
        {.name = "unknown_key_warns",
         .args = kRender,
         .expected = "$D/scene.json /camera/fox: unknown key (ignored; did you mean \"fov\"?)",
         .files = {{"scene.json",
                    WithCamera(R"({"position": [0, 2, 8], "look_at": [0, 0, 0], "fox": 40})")}},
         .exitCode = 0},
        {.name = "unknown_key_strict",
         .args = kRender + " --strict",
         .expected = "lightmesh: error: $D/scene.json /camera/fox: unknown key; did you mean "
                     "\"fov\"?\n",
         .files = {{"scene.json",
                    WithCamera(R"({"position": [0, 2, 8], "look_at": [0, 0, 0], "fox": 40})")}}},
        {.name = "unknown_top_level_key_strict",
         .args = kRender + " --strict",
         .expected = "lightmesh: error: $D/scene.json /shadow: unknown key\n",
         .files = {{"scene.json", WithExtra(R"(, "shadow": "soft")")}}},
        // --- Mesh files ---------------------------------------------------------------------
        {.name = "mesh_missing",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"nothere.obj\": no such file\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "nothere.obj"}])")}}},
        {.name = "mesh_unreadable",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"secret.obj\": cannot open: Permission denied\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "secret.obj"}])")},
                   {"secret.obj", kBox},
                   {"chmod 000", "secret.obj"}},
         .unprivileged = true},
        {.name = "mesh_empty",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"empty.obj\": the file is empty\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "empty.obj"}])")}, {"empty.obj", ""}}},
        {.name = "mesh_truncated_face",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"cut.obj\": malformed or truncated (Assimp: aiMesh::mFaces[4] is a POINT but "
                     "aiMesh::mPrimitiveTypes does not report the POINT flag)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "cut.obj"}])")},
                   {"cut.obj", std::string(kBox).substr(0, 120)}}},
        {.name = "mesh_truncated_vertices",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"cut.obj\": a mesh in it has no faces (is the file truncated?)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "cut.obj"}])")},
                   {"cut.obj", std::string(kBox).substr(0, 50)}}},
        {.name = "mesh_is_a_folder",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read \"models\": "
                     "is a directory, not a mesh file\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "models"}])")}, {"models/", ""}}},
        {.name = "mesh_unknown_format",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"notes.xyz\": Assimp has no reader for this file format\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "notes.xyz"}])")},
                   {"notes.xyz", "these are not a mesh\n"}}},
        {.name = "mesh_garbage",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"garbage.obj\": no meshes found in it (is the file really in this "
                     "format?)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "garbage.obj"}])")},
                   {"garbage.obj", std::string("\x7f\x01\x02\x03 garbage \xff\xfe\n\x00\x01", 18)}}},
        {.name = "mesh_no_triangles",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: \"lines.obj\": no "
                     "triangles (only points/lines)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "lines.obj"}])")},
                   {"lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\np 3\n"}}},
        {.name = "mesh_nan",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: \"nan.obj\": vertex 1 of "
                     "mesh \"defaultobject\" has a non-finite coordinate (nan, 0, 0)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "nan.obj"}])")},
                   {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"}}},
        {.name = "mesh_infinite",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: \"inf.obj\": vertex 2 of "
                     "mesh \"defaultobject\" has a non-finite coordinate (0, inf, 0)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "inf.obj"}])")},
                   {"inf.obj", "v 0 0 0\nv 1 0 0\nv 0 1e999 0\nf 1 2 3\n"}}},
        {.name = "bare_mesh_empty",
         .args = "render $D/empty.obj -o $OUT",
         .expected = "lightmesh: error: $D/empty.obj: the file is empty\n",
         .files = {{"empty.obj", ""}}},
        {.name = "bare_mesh_unknown_format",
         .args = "render $D/notes.xyz -o $OUT",
         .expected = "lightmesh: error: $D/notes.xyz: Assimp has no reader for this file format\n",
         .files = {{"notes.xyz", "these are not a mesh\n"}}},
        {.name = "bare_mesh_nan",
         .args = "render $D/nan.obj -o $OUT",
         .expected = "lightmesh: error: $D/nan.obj: vertex 1 of mesh \"defaultobject\" has a "
                     "non-finite coordinate (nan, 0, 0)\n",
         .files = {{"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"}}},
        // Degenerate and duplicate triangles: dropped, counted in a warning.
        {.name = "mesh_degenerate_and_duplicate",
         .args = kRender,
         .expected = "$D/dirty.obj: dropped 1 degenerate (zero-area) and 1 duplicate triangles",
         .files = {{"scene.json", WithMeshes(R"([{"file": "dirty.obj"}])")},
                   {"dirty.obj", std::string(kBox) + "f 1 2 6\nf 1 1 2\n"}},
         .exitCode = 0},
        {.name = "zero_extent",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes: the scene has zero extent: all 2 "
                     "triangles are degenerate (zero area)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "point.obj"}])")},
                   {"point.obj", "v 1 1 1\nv 1 1 1\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 1 2 4\n"}}},
        {.name = "coordinates_beyond_float_rendering",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes: the scene's coordinates reach "
                     "1e+30, beyond the ±1e+18 that single-precision rendering allows (scale "
                     "the model down)\n",
         .files = {{"scene.json",
                    WithMeshes(R"([{"file": "box.obj", "transform": {"translate": [0, 1e30, 0]}}])")}}},
        // --- Lights -------------------------------------------------------------------------
        {.name = "light_inside_object",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/1/position: the light (0.5, 0.2, "
                     "0) is inside a closed object, so it would light nothing (lights must be "
                     "outside solids: move it or the object)\n",
         .files = {{"scene.json",
                    WithLights(R"([{"position": [3, 6, 4]}, {"position": [0.5, 0.2, 0]}])")}}},
        {.name = "light_inside_ground_slab",
         .args = kRender,
         .expected = "$D/scene.json /lights/0/position: the light (0, -1.05, 0) is inside a "
                     "closed object",
         .files = {{"scene.json", WithLights(R"([{"position": [0, -1.05, 0]}])")}}},
        // Not inside: under an open lampshade (the box without its bottom face).
        {.name = "light_under_open_shade_is_fine",
         .args = kRender,
         .expected = "out.png: 16x12",
         .files = {{"scene.json", WithMeshes(R"([{"file": "shade.obj"}])")},
                   {"shade.obj", std::string(kBox).substr(0, std::string(kBox).find("f 1 4 3 2")) +
                                     "f 5 6 7 8\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\nf 1 2 6 5\n"}},
         .exitCode = 0},
        {.name = "light_nan",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/0/position/0: expected a number, "
                     "got a string (\"NaN\")\n",
         .files = {{"scene.json", WithLights(R"([{"position": ["NaN", 6, 0]}])")}}},
        {.name = "light_infinite",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/0/position/1: number 1e999 is out "
                     "of range (line 3, column 31)\n",
         .files = {{"scene.json", WithLights(R"([{"position": [0, 1e999, 0]}])")}}},
        {.name = "light_beyond_float",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/0/position/1: number out of "
                     "range, got 1e+39\n",
         .files = {{"scene.json", WithLights(R"([{"position": [0, 1e39, 0]}])")}}},
        {.name = "light_negative_intensity",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/0/intensity/2: must not be "
                     "negative, got -1\n",
         .files = {{"scene.json", WithLights(R"([{"position": [0, 6, 0], "intensity": [1, 1, -1]}])")}}},
        {.name = "lights_too_many_for_lmm",
         .args = kRender + " --shadows lmm",
         .expected = "lightmesh: error: light mesh: 63 lights; at most 62 are supported\n",
         .files = {{"scene.json", WithLights(ManyLights(63))}}},
        {.name = "lights_too_many_for_the_renderer",
         .args = kRender + " --shadows rt",
         .expected = "lightmesh: error: $D/scene.json: 65 lights; at most 64 are supported\n",
         .files = {{"scene.json", WithLights(ManyLights(65))}}},
        // --- Camera -------------------------------------------------------------------------
        {.name = "camera_look_at_is_position",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /camera/look_at: equals the position, so "
                     "the camera has no view direction\n",
         .files = {{"scene.json", WithCamera(R"({"position": [1, 2, 3], "look_at": [1, 2, 3]})")}}},
        {.name = "camera_up_parallel",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /camera/up: is parallel to the view "
                     "direction (from position to look_at)\n",
         .files = {{"scene.json", WithCamera(R"({"position": [0, 5, 0], "look_at": [0, 0, 0]})")}}},
        {.name = "camera_fov",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /camera/fov: must be between 0 and 180 "
                     "degrees, got 180\n",
         .files = {{"scene.json",
                    WithCamera(R"({"position": [0, 2, 8], "look_at": [0, 0, 0], "fov": 180})")}}},
        // --- Resolution ---------------------------------------------------------------------
        {.name = "width_zero",
         .args = "render builtin:gazebo --width 0 -o $OUT",
         .expected = "--width: Value 0 not in range 1 to 16384\n"},
        {.name = "width_negative",
         .args = "render builtin:gazebo --width -640 -o $OUT",
         .expected = "--width: Value -640 not in range 1 to 16384\n"},
        {.name = "height_absurd",
         .args = "render builtin:gazebo --height 10000000000 -o $OUT",
         .expected = "--height: Value 10000000000 not in range 1 to 16384\n"},
        {.name = "width_not_a_number",
         .args = "render builtin:gazebo --width wide -o $OUT",
         .expected = "--width: Value wide not in range 1 to 16384\n"},
        {.name = "json_width_zero",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/width: must be between 1 and "
                     "16384, got 0\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"width": 0})")}}},
        {.name = "json_height_negative",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/height: must be between 1 and "
                     "16384, got -480\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"height": -480})")}}},
        {.name = "json_width_absurd",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/width: must be between 1 and "
                     "16384, got 1000000000000\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"width": 1e12})")}}},
        {.name = "json_aa_absurd",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/aa: must be between 1 and 16, "
                     "got 1000\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"aa": 1000})")}}},
        // --- Light mesh parameters ------------------------------------------------------
        {.name = "cc_zero",
         .args = "render builtin:gazebo --shadows lmm --cc 0 -o $OUT",
         .expected = "--cc: Value 0 not in range 1 to 4096\n"},
        {.name = "cc_negative",
         .args = "render builtin:gazebo --shadows lmm --cc -100 -o $OUT",
         .expected = "--cc: Value -100 not in range 1 to 4096\n"},
        {.name = "cc_absurd",
         .args = "render builtin:gazebo --shadows lmm --cc 100000 -o $OUT",
         .expected = "--cc: Value 100000 not in range 1 to 4096\n"},
        {.name = "ki_zero",
         .args = "render builtin:gazebo --shadows lmm --ki 0 -o $OUT",
         .expected = "--ki: Value 0 not in range 0.010000 to 16.000000\n"},
        {.name = "ki_negative",
         .args = "render builtin:gazebo --shadows lmm --ki -2 -o $OUT",
         .expected = "--ki: Value -2 not in range 0.010000 to 16.000000\n"},
        {.name = "ki_absurd",
         .args = "render builtin:gazebo --shadows lmm --ki 1000 -o $OUT",
         .expected = "--ki: Value 1000 not in range 0.010000 to 16.000000\n"},
        {.name = "ki_nan",
         .args = "render builtin:gazebo --shadows lmm --ki nan -o $OUT",
         .expected = "lightmesh: error: light mesh: kI must be in (0, 16], got nan\n"},
        {.name = "ns_zero",
         .args = "render builtin:gazebo --shadows lmm --ns 0 -o $OUT",
         .expected = "--ns: Value 0 not in range 1 to 64\n"},
        {.name = "ns_absurd",
         .args = "render builtin:gazebo --shadows lmm --ns 65 -o $OUT",
         .expected = "--ns: Value 65 not in range 1 to 64\n"},
        {.name = "json_cc_zero",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/cc: must be between 1 and 4096, "
                     "got 0\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"cc": 0})")}}},
        {.name = "json_ki_negative",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/ki: must be in (0, 16], got -2\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ki": -2})")}}},
        {.name = "json_ki_absurd",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/ki: must be in (0, 16], got 1000\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ki": 1000})")}}},
        {.name = "json_ns_out_of_range",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/ns: must be between 0 and 64, got "
                     "65\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ns": 65})")}}},
        {.name = "variant_unknown",
         .args = "render builtin:gazebo --shadows lmm --variant fastest -o $OUT",
         .expected = "lightmesh: error: unknown light-mesh variant \"fastest\""},
        {.name = "shadows_unknown",
         .args = "render builtin:gazebo --shadows soft -o $OUT",
         .expected = "--shadows: soft not in {none,rt,lmm"},
        // --- Memory: refused with the figure, before allocating -----------------------------
        {.name = "light_mesh_too_big_for_the_machine",
         .args = "render builtin:gazebo --shadows lmm --cc 4096 -o $OUT",
         .expected = "of node storage, more than half of this machine's"},
        {.name = "light_mesh_too_big_for_the_limit",
         .args = "render $D/scene.json --shadows lmm --cc 1000 -o $OUT",
         .expected = "lightmesh: error: light mesh 1005x349x1005 (CC 1000, kI 2) needs 336.2 "
                     "MiB of node storage, more than half of this machine's 64.0 MiB: lower "
                     "--cc\n",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "image_too_big_for_the_limit",
         .args = "render $D/scene.json --width 4096 --height 4096 -o $OUT",
         .expected = "lightmesh: error: image 4096x4096 would need 192.0 MiB, more than half "
                     "of this machine's 64.0 MiB\n",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        // --- Output paths -------------------------------------------------------------------
        {.name = "output_folder_missing",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/nofolder/out.png: folder \"$D/nofolder\" does not "
                     "exist\n",
         .files = {{"scene.json", good}},
         .output = "$D/nofolder/out.png"},
        {.name = "output_folder_read_only",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/ro/out.png: folder \"$D/ro\" is not writable\n",
         .files = {{"scene.json", good}, {"ro/", ""}, {"chmod 555", "ro"}},
         .output = "$D/ro/out.png",
         .unprivileged = true},
        {.name = "output_extension_unknown",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/out/out.jpg: unknown image extension \".jpg\" (use "
                     ".png or .exr)\n",
         .files = {{"scene.json", good}},
         .output = "$D/out/out.jpg"},
        {.name = "output_extension_missing",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/out/image: unknown image extension \"\" (use .png or "
                     ".exr)\n",
         .files = {{"scene.json", good}},
         .output = "$D/out/image"},
        {.name = "output_is_a_folder",
         .args = "render $D/scene.json -o $D/out/folder.png",
         .expected = "lightmesh: error: $D/out/folder.png: is a folder, not a file\n",
         .files = {{"scene.json", good}, {"out/folder.png/", ""}}},
    };
}

/// Sets up the case's folder: box.obj, the case's files ("name/" makes a folder, "chmod
/// MODE" -> "file" changes a mode) and the output folder.
std::string Prepare(const Case& c) {
    // Per process: several test runs may share /tmp.
    const fs::path dir = fs::path(::testing::TempDir()) /
                         ("lm_bad_input-" + std::to_string(getpid())) / c.name;
    std::error_code ec;
    fs::permissions(dir / "ro", fs::perms::owner_all, fs::perm_options::add, ec);
    fs::remove_all(dir, ec);
    fs::create_directories(dir / "out");
    // The unprivileged user the permission cases run as may write the output folder.
    chmod((dir / "out").c_str(), 0777);
    Write((dir / "box.obj").string(), kBox);
    std::vector<std::pair<std::string, std::string>> chmods;
    for (const auto& [name, content] : c.files) {
        if (name.rfind("chmod ", 0) == 0)
            chmods.push_back({name.substr(6), content});
        else if (!name.empty() && name.back() == '/')
            fs::create_directories(dir / name);
        else
            Write((dir / name).string(), content);
    }
    for (const auto& [mode, file] : chmods)
        chmod((dir / file).c_str(), static_cast<mode_t>(std::stoi(mode, nullptr, 8)));
    return dir.string();
}

/// Root ignores file permissions, so those cases run as "nobody" when the tests are root.
std::string Privileges(const Case& c) {
    if (!c.unprivileged || geteuid() != 0) return "";
    return "setpriv --reuid=65534 --regid=65534 --clear-groups";
}

bool TemporaryFilesIn(const std::string& folder) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) return false;
    for (const auto& entry : fs::directory_iterator(folder, ec))
        if (entry.path().filename().string().find(".tmp") != std::string::npos) return true;
    return false;
}

TEST(BadInput, EveryCaseIsAClearErrorAndLeavesTheOutputAlone) {
    for (const Case& c : Corpus()) {
        SCOPED_TRACE(c.name);
        const std::string dir = Prepare(c);
        const std::string out = Replace(c.output, "$D", dir);
        const std::string args = Replace(Replace(c.args, "$OUT", out), "$D", dir);
        const std::string expected = Replace(c.expected, "$D", dir);
        const std::string prefix = c.env + " " + Privileges(c);
        const std::string outFolder = fs::path(out).parent_path().string();

        // 1. No output file before: none after (unless the case is accepted).
        fs::remove(out);
        const CliResult run = lm::testing::RunLightmesh(args, prefix);
        if (getenv("LM_PRINT")) printf("%-36s %d %s", c.name.c_str(), run.exitCode, run.output.c_str());
        EXPECT_EQ(run.exitCode, c.exitCode) << run.output;
        EXPECT_LT(run.exitCode, 128) << "died by a signal:\n" << run.output;
        EXPECT_NE(run.output.find(expected), std::string::npos)
            << "expected: " << expected << "\ngot: " << run.output;
        EXPECT_EQ(run.output.find("internal error"), std::string::npos) << run.output;
        EXPECT_FALSE(TemporaryFilesIn(outFolder));
        if (c.exitCode != 0) {
            EXPECT_FALSE(fs::exists(out)) << out;
            // 2. An output file there before: byte-identical after.
            std::error_code ec;
            if (fs::is_directory(outFolder, ec) && !fs::is_directory(out, ec)) {
                const std::string previous = "a previous image, to be kept\n";
                Write(out, previous);
                const CliResult again = lm::testing::RunLightmesh(args, prefix);
                EXPECT_EQ(again.exitCode, c.exitCode) << again.output;
                EXPECT_EQ(FileBytes(out), previous) << out;
                EXPECT_FALSE(TemporaryFilesIn(outFolder));
            }
        } else {
            EXPECT_GT(FileBytes(out).size(), 50u) << "no image written to " << out;
        }
        std::error_code ec;
        fs::permissions(fs::path(dir) / "ro", fs::perms::owner_all, fs::perm_options::add, ec);
        if (!HasFailure()) fs::remove_all(dir, ec);
    }
    std::error_code ec;
    if (!HasFailure())
        fs::remove_all(fs::path(::testing::TempDir()) / ("lm_bad_input-" + std::to_string(getpid())), ec);
}

}  // namespace
