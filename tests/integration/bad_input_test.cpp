// The bad-input corpus (over 500 lines as one concept: a table of cases): every
// kind of bad scene, mesh, option and output path the renderer may be given, run through
// the real executable. Each case checks the exit code
// (1: bad input; never a crash), the message (the whole line where it is stable, else a
// distinctive part naming the file and JSON path), and that the output file does not
// appear -- or, when it existed before, is byte-identical afterwards with no temporary
// file left beside it. A few cases are accepted with a warning and do write the image.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "run_lightmesh.h"

namespace bad_input_test {
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
/// n lights in rows of ten above the box.
std::string ManyLights(int n) {
    std::string s = "[";
    for (int i = 0; i < n; ++i)
        s += (i ? ", " : "") + std::string("{\"position\": [") + std::to_string(i % 10 - 5) + ", 6, " +
             std::to_string(i / 10) + "]}";
    return s + "]";
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



// --- Builders of hostile inputs ----------------------------------------------------------------

/// A glTF 2 file with one triangle mesh and the given nodes (JSON array text).
std::string Gltf(const std::string& nodes, const std::string& buffer =
                     "\"data:application/octet-stream;base64,"
                     "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"") {
    return R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": )" +
           nodes +
           R"(, "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
 "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                "max": [1, 1, 0], "min": [0, 0, 0]}],
 "bufferViews": [{"buffer": 0, "byteLength": 36}],
 "buffers": [{"byteLength": 36, "uri": )" + buffer + "}]}\n";
}

/// Nodes 0 .. levels-1, each with two references to the next: 2^levels paths.
std::string GltfSharedChildren(int levels) {
    std::string s = "[";
    for (int i = 0; i < levels; ++i)
        s += "{\"children\": [" + std::to_string(i + 1) + ", " + std::to_string(i + 1) + "]}, ";
    return s + "{\"mesh\": 0}]";
}

/// A chain of `levels` nodes.
std::string GltfChain(int levels) {
    std::string s = "[";
    for (int i = 0; i + 1 < levels; ++i) s += "{\"children\": [" + std::to_string(i + 1) + "]}, ";
    return s + "{\"mesh\": 0}]";
}

const char* kColladaHead =
    "<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" "
    "version=\"1.4.1\">\n";
const char* kColladaTail =
    "<scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>\n";

/// COLLADA whose node "a" instantiates itself (through "b" when `viaB`).
std::string ColladaCycle(bool viaB) {
    return std::string(kColladaHead) + "<library_nodes><node id=\"a\"><instance_node url=\"#" +
           (viaB ? "b" : "a") + "\"/></node>" +
           (viaB ? "<node id=\"b\"><instance_node url=\"#a\"/></node>" : "") +
           "</library_nodes>\n<library_visual_scenes><visual_scene id=\"s\"><node id=\"r\">"
           "<instance_node url=\"#a\"/></node></visual_scene></library_visual_scenes>\n" +
           kColladaTail;
}

std::string ColladaDeep(int levels) {
    std::string s = std::string(kColladaHead) + "<library_visual_scenes><visual_scene id=\"s\">";
    for (int i = 0; i < levels; ++i) s += "<node>";
    for (int i = 0; i < levels; ++i) s += "</node>";
    return s + "</visual_scene></library_visual_scenes>\n" + kColladaTail;
}

std::string Ac3dDeep(int levels) {
    std::string s =
        "AC3Db\nMATERIAL \"m\" rgb 1 1 1  amb 0.2 0.2 0.2  emis 0 0 0  spec 0 0 0  shi 0  "
        "trans 0\nOBJECT world\nkids 1\n";
    for (int i = 0; i < levels; ++i) s += "OBJECT group\nkids 1\n";
    return s +
           "OBJECT poly\nnumvert 3\n0 0 0\n1 0 0\n0 1 0\nnumsurf 1\nSURF 0x10\nmat 0\nrefs 3\n"
           "0 0 0\n1 0 0\n2 0 0\nkids 0\n";
}

/// A PLY whose header promises 2 vertices but whose face uses 4: Assimp's triangulation
/// asserts (ai_assert, which aborts in Debian's build).
const char* kLyingPly =
    "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty "
    "float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n0 1 0\n1 1 0\n4 0 1 2 3\n";

/// A playground: a 20 x 20 lawn at y = 0 facing up, and a box standing on it.
const char* kPlayground =
    "v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\nf 1 4 3 2\n"
    "v -1 0 -1\nv 1 0 -1\nv 1 2 -1\nv -1 2 -1\nv -1 0 1\nv 1 0 1\nv 1 2 1\nv -1 2 1\n"
    "f 5 8 7 6\nf 9 10 11 12\nf 5 6 10 9\nf 8 12 11 7\nf 5 9 12 8\nf 6 7 11 10\n";

/// `levels` objects {"a": ...} (or arrays [...]) nested around a 1.
std::string Nested(size_t levels, bool arrays) {
    std::string s;
    s.reserve(levels * 6 + 1);
    for (size_t i = 0; i < levels; ++i) s += arrays ? "[" : "{\"a\": ";
    s += "1";
    for (size_t i = 0; i < levels; ++i) s += arrays ? "]" : "}";
    return s;
}

/// "[item, item, ...]" with n items.
std::string Repeated(const std::string& item, int n) {
    std::string s = "[";
    for (int i = 0; i < n; ++i) s += (i ? ", " : "") + item;
    return s + "]";
}

/// An OBJ of a flat n x n grid of quads in y = 0 (2n² triangles).
std::string GridObj(int n) {
    std::string s;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) s += "v " + std::to_string(i) + " 0 " + std::to_string(j) + "\n";
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const int a = 1 + i * (n + 1) + j;
            s += "f " + std::to_string(a) + " " + std::to_string(a + 1) + " " + std::to_string(a + n + 2) + " " +
                 std::to_string(a + n + 1) + "\n";
        }
    return s;
}

/// `n` references to `file`, each lifted by its index: a "meshes" list.
std::string References(const std::string& file, int n) {
    std::string s = "[";
    for (int i = 0; i < n; ++i)
        s += (i ? ", {\"file\": \"" : "{\"file\": \"") + file + "\", \"transform\": {\"translate\": [0, " +
             std::to_string(i) + ", 0]}}";
    return s + "]";
}

/// The head of a PNG of w x h RGB texels, 8 bits: the signature and the IHDR chunk, and no
/// image data.
std::string PngHead(uint32_t w, uint32_t h) {
    std::string s("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR", 16);
    for (const uint32_t v : {w, h})
        for (int shift = 24; shift >= 0; shift -= 8) s += static_cast<char>((v >> shift) & 0xff);
    return s + std::string("\x08\x02\0\0\0\0\0\0\0", 9);
}

/// tests/data/textures/checker_mask.gltf (a quad with an 8 x 8 cut-out texture in a data:
/// URI) with its image's payload replaced, and `from` replaced by `to` in it.
std::string CheckerGltf(const std::string& payload, const std::string& from = "", const std::string& to = "") {
    std::string g = FileBytes(std::string(LIGHTMESH_TEST_DATA) + "/textures/checker_mask.gltf");
    const size_t at = g.find("data:image/png;base64,") + 22;
    g.replace(at, g.find('"', at) - at, payload);
    return from.empty() ? g : Replace(g, from, to);
}

/// An OBJ of n objects ("o" lines) of one triangle each.
std::string ObjObjects(int n) {
    std::string s;
    for (int i = 0; i < n; ++i)
        s += "o ob" + std::to_string(i) + "\nv " + std::to_string(i) + " 0 0\nv " + std::to_string(i) + " 1 0\nv " +
             std::to_string(i) + " 0 1\nf -3 -2 -1\n";
    return s;
}

std::string ManyKeys(int n) {
    std::string s = "{";
    for (int i = 0; i < n; ++i) s += (i ? ", \"k" : "\"k") + std::to_string(i) + "\": 1";
    return s + "}";
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
        {.name = "camera_choice_without_file_cameras",
         .args = kRender + " --camera 0",
         .expected = "lightmesh: error: $D/scene.json: --camera 0: none of the scene's mesh files has cameras "
                     "(without \"camera\" it is framed automatically)\n",
         .files = {{"scene.json", R"({"lights": [{"position": [0, 5, 0]}], "meshes": [{"file": "box.obj"}]})"}}},
        {.name = "missing_look_at",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /camera/look_at: missing required key\n",
         .files = {{"scene.json", WithCamera(R"({"position": [0, 2, 8]})")}}},
        {.name = "missing_look_at_near_miss",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /camera/look_at: missing required key; \"lookat\" is not "
                     "a key: did you mean \"look_at\"?\n",
         .files = {{"scene.json", WithCamera(R"({"position": [0, 2, 8], "lookat": [0, 0, 0]})")}}},
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
        // (lightmesh's OBJ reader keeps the whole faces and says what it left out.)
        {.name = "mesh_truncated_face",
         .args = kRender,
         .expected = "lightmesh: warning: $D/cut.obj: OBJ: 1 face of fewer than 3 corners left out (line 13; is "
                     "the file truncated?)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "cut.obj"}])")},
                   {"cut.obj", std::string(kBox).substr(0, 120)}},
         .exitCode = 0},
        {.name = "mesh_truncated_vertices",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read "
                     "\"cut.obj\": OBJ: 5 vertices but no faces (is the file truncated?)\n",
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
         .expected = "$D/dirty.obj: dropped 1 degenerate (zero-area) and 1 duplicate triangle",
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
        // An open floor under the box makes the ways out below cross two surfaces (even),
        // which alone would accept the light; the closed parts alone say inside.
        {.name = "light_inside_object_over_an_open_floor",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/1/position: the light (0.5, 0.2, "
                     "0) is inside a closed object, so it would light nothing (lights must be "
                     "outside solids: move it or the object)\n",
         .files = {{"floor.obj", "v -9 -1.5 -9\nv 9 -1.5 -9\nv 9 -1.5 9\nv -9 -1.5 9\nf 1 4 3 2\n"},
                   {"scene.json", SceneJson({.lights = R"([{"position": [3, 6, 4]}, {"position": [0.5, 0.2, 0]}])",
                                             .meshes = R"([{"file": "box.obj"}, {"file": "floor.obj"}])",
                                             .extra = ""})}}},
        // ... and a light over that floor, outside the box, is not inside anything.
        {.name = "light_over_an_open_floor_beside_a_box",
         .args = kRender,
         .expected = "$D/out/out.png: 16x12, shadows soft",
         .files = {{"floor.obj", "v -9 -1.5 -9\nv 9 -1.5 -9\nv 9 -1.5 9\nv -9 -1.5 9\nf 1 4 3 2\n"},
                   {"scene.json", SceneJson({.lights = R"([{"position": [3, 0.2, 0]}])",
                                             .meshes = R"([{"file": "box.obj"}, {"file": "floor.obj"}])",
                                             .extra = ""})}},
         .exitCode = 0},
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
        // Not refused: a closed room (the box, 2 units wide) with the camera and the light
        // inside it, as in an interior scene whose walls, floor and ceiling are single faces.
        {.name = "light_inside_closed_room_with_the_camera_is_fine",
         .args = kRender,
         .expected = "out.png: 16x12",
         .files = {{"scene.json", SceneJson({.camera = R"({"position": [0, 0.3, 0.8], "look_at": [0, -0.5, -1]})",
                                             .lights = R"([{"position": [0.2, 0.7, 0.1], "intensity": 40}])"})}},
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
        {.name = "light_range_zero",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /lights/0/range: must be greater than 0, got 0\n",
         .files = {{"scene.json", WithLights(R"([{"position": [0, 6, 0], "range": 0}])")}}},
        {.name = "light_range_negative",
         .args = kRender + " --shadows lmm",
         .expected = "lightmesh: error: $D/scene.json /lights/1/range: must be greater than 0, got -2.5\n",
         .files = {{"scene.json", WithLights(R"([{"position": [0, 6, 0]}, {"position": [1, 6, 0], "range": -2.5}])")}}},
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
         .expected = "lightmesh: error: --width: must be between 1 and 16384, got 0\n"},
        {.name = "width_negative",
         .args = "render builtin:gazebo --width -640 -o $OUT",
         .expected = "--width: must be between 1 and 16384, got -640\n"},
        {.name = "height_absurd",
         .args = "render builtin:gazebo --height 10000000000 -o $OUT",
         .expected = "--height: must be between 1 and 16384, got 10000000000\n"},
        {.name = "width_not_a_number",
         .args = "render builtin:gazebo --width wide -o $OUT",
         .expected = "--width: expected an integer, got wide\n"},
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
         .expected = "--cc: must be between 1 and 4096, got 0\n"},
        {.name = "cc_negative",
         .args = "render builtin:gazebo --shadows lmm --cc -100 -o $OUT",
         .expected = "--cc: must be between 1 and 4096, got -100\n"},
        {.name = "cc_absurd",
         .args = "render builtin:gazebo --shadows lmm --cc 100000 -o $OUT",
         .expected = "--cc: must be between 1 and 4096, got 100000\n"},
        {.name = "ki_zero",
         .args = "render builtin:gazebo --shadows lmm --ki 0 -o $OUT",
         .expected = "--ki: must be between 0.01 and 16, got 0\n"},
        {.name = "ki_negative",
         .args = "render builtin:gazebo --shadows lmm --ki -2 -o $OUT",
         .expected = "--ki: must be between 0.01 and 16, got -2\n"},
        {.name = "ki_absurd",
         .args = "render builtin:gazebo --shadows lmm --ki 1000 -o $OUT",
         .expected = "--ki: must be between 0.01 and 16, got 1000\n"},
        {.name = "ki_nan",
         .args = "render builtin:gazebo --shadows lmm --ki nan -o $OUT",
         .expected = "lightmesh: error: --ki: expected a number, got nan\n"},
        {.name = "ns_negative",  // 0 is the default, as in a scene file (the settings table)
         .args = "render builtin:gazebo --shadows lmm --ns -1 -o $OUT",
         .expected = "--ns: must be between 0 and 64, got -1\n"},
        {.name = "ns_absurd",
         .args = "render builtin:gazebo --shadows lmm --ns 65 -o $OUT",
         .expected = "--ns: must be between 0 and 64, got 65\n"},
        {.name = "json_cc_zero",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/cc: must be between 1 and 4096, "
                     "got 0\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"cc": 0})")}}},
        {.name = "json_ki_negative",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/ki: must be between 0.01 and 16, got -2\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ki": -2})")}}},
        {.name = "json_ki_absurd",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/ki: must be between 0.01 and 16, got 1000\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ki": 1000})")}}},
        {.name = "json_ns_out_of_range",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/ns: must be between 0 and 64, got "
                     "65\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ns": 65})")}}},
        {.name = "variant_unknown",
         .args = "render builtin:gazebo --shadows lmm --variant fastest -o $OUT",
         .expected = "lightmesh: error: --variant: unknown light-mesh variant \"fastest\""},
        {.name = "json_variant_unknown",  // the factory's message names the file's key
         .args = "render $D/scene.json --shadows lmm -o $OUT",
         .expected = "lightmesh: error: $D/scene.json /render/variant: unknown light-mesh variant \"fastest\"",
         .files = {{"scene.json", WithExtra(R"(, "render": {"variant": "fastest"})")}}},
        {.name = "shadows_unknown",
         .args = "render builtin:gazebo --shadows hard -o $OUT",
         .expected = "--shadows: hard not in {soft,exact,none,rt,lmm"},
        // --- Memory: refused with the figure, before allocating -----------------------------
        {.name = "light_mesh_too_big_for_the_machine",
         .args = "render builtin:gazebo --shadows lmm --cc 4096 -o $OUT",
         .expected = "of node storage, more than half of this machine's"},
        {.name = "light_mesh_too_big_for_the_limit",
         .args = "render $D/scene.json --shadows lmm --cc 1000 -o $OUT",
         .expected = "lightmesh: error: --cc: light mesh 1006x350x1006 (CC 1000, kI 2) needs 337.8 "
                     "MiB of node storage, more than half of this machine's 64.0 MiB: lower "
                     "CC\n",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "light_mesh_with_blocker_distances_too_big_for_the_limit",
         // 1 + 2 bytes per node with one light: three times the plain mesh's 337.8 MiB.
         .args = "render $D/scene.json --shadows lmm --cc 1000 --light-radius 0.1 -o $OUT",
         .expected = "lightmesh: error: --cc: light mesh 1006x350x1006 (CC 1000, kI 2) needs 1013.4 "
                     "MiB of node storage (3 bytes per node with the blocker distances of the light "
                     "radius), more than half of this machine's 64.0 MiB: lower CC\n",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "denoiser_buffers_too_big_for_the_limit",
         // 52 bytes per pixel and 24 per light (one light): 76 MiB, the image itself 12 MiB.
         .args = "render $D/scene.json --shadows denoised --samples 1 --width 1024 --height 1024 -o $OUT",
         .expected = "--shadows denoised: its buffers for 1024x1024 pixels and 1 light would need 76.0 MiB, "
                     "more than half the memory budget (64.0 MiB); render a smaller image or fewer lights\n",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "light_mesh_of_many_lights_too_big_for_the_limit",
         // 200 lights: 4 groups of 50, a word of 8 bytes each per node.
         .args = "render $D/scene.json --shadows lmm --cc 300 -o $OUT",
         .expected = "lightmesh: error: --cc: light mesh 306x109x306 (CC 300, kI 2) needs 311.5 MiB of node "
                     "storage (32 bytes per node for 200 lights in 4 groups), more than half of this "
                     "machine's 64.0 MiB: lower CC\n",
         .files = {{"scene.json", WithLights(ManyLights(200))}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "soft_shadow_rows_of_many_lights_past_the_limit",
         // 200 lights over a box, every one shaded (--light-cut 0): a (hit, light) pair per light
         // in the rows of tiles in flight, 38 MiB at 640x480: past half of 64 MiB, it stops first.
         .args = "render $D/scene.json --light-cut 0 -o $OUT",
         .expected = "soft shadows: the 10 rows of tiles in flight hold 33.1 MiB for 200 lights, more than half "
                     "the memory budget (64.0 MiB); give the lights a \"range\", render a narrower image, or use "
                     "--shadows rt\n",
         .files = {{"scene.json", WithLights(ManyLights(200))}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "exact_soft_shadow_lists_of_many_lights_past_the_limit",
         // 200 lights over a box: the cells' lists (one per cell and light, built as points
         // need them) pass half of 64 MiB during the render, which stops and writes nothing.
         .args = "render $D/scene.json --shadows exact -o $OUT",
         .expected = "lightmesh: error: soft shadows: the cells' occluder lists for 200 lights have grown past "
                     "32.0 MiB, half of the 64.0 MiB this process may use; give the lights a \"range\", lower "
                     "--cc, or use --shadows lmm or rt\n",
         .files = {{"scene.json", WithLights(ManyLights(200))}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "image_too_big_for_the_limit",
         .args = "render $D/scene.json --width 4096 --height 4096 -o $OUT",
         .expected = "lightmesh: error: image 4096x4096 would need 192.0 MiB, more than half "
                     "of this machine's 64.0 MiB\n",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        // --- Crashes inside Assimp ----------------------------------------------------------
        // Stack overflows on cyclic or deep node hierarchies: the import runs in a child
        // process, so the crash is one line (under ASan the child exits instead of dying by
        // the signal, hence the shorter expectation for those).
        {.name = "collada_instance_node_self_reference",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read \"cycle.dae\": "
                     "the importer crashed (",
         .files = {{"scene.json", WithMeshes(R"([{"file": "cycle.dae"}])")},
                   {"cycle.dae", ColladaCycle(false)}}},
        {.name = "collada_instance_node_cycle_bare_info",
         .args = "info $D/cycle.dae",
         .expected = "lightmesh: error: $D/cycle.dae: the importer crashed (",
         .files = {{"cycle.dae", ColladaCycle(true)}}},
        {.name = "collada_instance_node_cycle_bench",
         .args = "bench --scene $D/cycle.dae --size 8x6 --repeat 1 -q --csv $OUT",
         .expected = "lightmesh: error: $D/cycle.dae: the importer crashed (",
         .files = {{"cycle.dae", ColladaCycle(true)}},
         .output = "$D/out/bench.csv"},
        {.name = "collada_deep_hierarchy",
         .args = "render $D/deep.dae -o $OUT",
         .expected = "lightmesh: error: $D/deep.dae: the importer crashed (",
         .files = {{"deep.dae", ColladaDeep(30000)}}},
        {.name = "ac3d_deep_hierarchy",
         .args = "render $D/deep.ac -o $OUT",
         .expected = "lightmesh: error: $D/deep.ac: the importer crashed (",
         .files = {{"deep.ac", Ac3dDeep(30000)}}},
        {.name = "gltf_cycle",
         .args = "info $D/cycle.gltf",
         .expected = "lightmesh: error: $D/cycle.gltf: glTF node 0 is its own descendant: the "
                     "node hierarchy has a cycle\n",
         .files = {{"cycle.gltf", Gltf(R"([{"children": [1]}, {"children": [0], "mesh": 0}])")}}},
        {.name = "gltf_deep_hierarchy",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read \"deep.gltf\": "
                     "the glTF node hierarchy is 50,000 levels deep, more than the limit of 1024\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "deep.gltf"}])")},
                   {"deep.gltf", Gltf(GltfChain(50000))}}},
        {.name = "ply_header_lies_assimp_assertion",
         .args = "render $D/lie.ply -o $OUT",
         .expected = "lightmesh: error: $D/lie.ply: Assimp's internal check failed (numOut != "
                     "pMesh->mNumFaces at TriangulateProcess.cpp:238): the file is malformed or "
                     "its counts lie\n",
         .files = {{"lie.ply", kLyingPly}}},
        // Found by fuzz_mesh_import: a PLY header without end_header makes Assimp read on at
        // the end of the file forever; the child process has a deadline.
        {.name = "ply_endless_loop_in_assimp",
         .args = "info $D/loop.ply",
         .expected = "lightmesh: error: $D/loop.ply: the importer did not finish within 1 s and "
                     "was stopped (Assimp loops forever on some malformed files; "
                     "LIGHTMESH_IMPORT_TIMEOUT sets the limit in seconds)\n",
         .files = {{"loop.ply", "ply\nformat ascii 1.0\nelement vertes\":[{\"mep\nendfacet\n"
                                "endsolid\asolid t\n_header\n0 0 0\n"}},
         .env = "LIGHTMESH_IMPORT_TIMEOUT=1"},
        // --- Values beyond what Embree takes ----------------------------------------------------
        {.name = "ground_size_beyond_range",
         .args = kRender + " --accel embree",
         .expected = "lightmesh: error: $D/scene.json /ground/size: the ground slab reaches 1e+30, "
                     "beyond the ±1e+18 that single-precision rendering allows\n",
         .files = {{"scene.json", WithExtra(R"(, "ground": {"size": 1e30})")}}},
        {.name = "ground_height_beyond_range",
         .args = kRender + " --accel embree",
         .expected = "lightmesh: error: $D/scene.json /ground/height: the ground slab reaches "
                     "1e+30, beyond the ±1e+18 that single-precision rendering allows\n",
         .files = {{"scene.json", WithExtra(R"(, "ground": {"height": 1e30})")}}},
        {.name = "camera_beyond_range",
         .args = kRender + " --accel embree",
         .expected = "lightmesh: error: $D/scene.json /camera/position: the camera position (0, "
                     "2e+30, 8) is beyond the ±1e+18 that single-precision rendering allows\n",
         .files = {{"scene.json", WithCamera(R"({"position": [0, 2e30, 8], "look_at": [0, 0, 0]})")}}},
        {.name = "light_beyond_range",
         .args = kRender + " --accel embree",
         .expected = "lightmesh: error: $D/scene.json /lights/0/position: the light (3, 6e+20, 4) "
                     "is beyond the ±1e+18 that single-precision rendering allows\n",
         .files = {{"scene.json", WithLights(R"([{"position": [3, 6e20, 4]}])")}}},
        {.name = "bare_mesh_framing_beyond_range",
         .args = "render $D/huge.obj --accel embree -o $OUT",
         .expected = "lightmesh: error: $D/huge.obj: automatic framing: the camera position (",
         .files = {{"huge.obj", "v -5e17 0 -5e17\nv 5e17 0 -5e17\nv 0 5e17 0\nf 1 2 3\n"}}},
        {.name = "scene_span_beyond_range",
         .args = kRender + " --accel embree",
         .expected = "lightmesh: error: $D/scene.json: the scene (meshes, ground, camera and "
                     "lights) spans 1.9e+18, more than the 1.8e+18 that single-precision ray "
                     "queries allow\n",
         .files = {{"scene.json", SceneJson({.lights = R"([{"position": [0, 9.5e17, 0]}, {"position": [0, -9.5e17, 0]}])",
                                             .extra = ""})}}},
        // Every command maps every exception to one line: bench's image folder cannot be
        // made (a std::filesystem_error, which must not escape bench).
        {.name = "bench_filesystem_error",
         .args = "bench --scene builtin:gazebo --size 8x6 --repeat 1 -q --html $OUT",
         .expected = "lightmesh: error: $D/out/r-images: Not a directory\n",
         .files = {{"out/r-images", "a file where the images' folder should be"}},
         .output = "$D/out/r.html"},
        // --- Hangs on FIFOs and special files --------------------------------------------------
        {.name = "mesh_is_a_fifo",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read \"fifo.obj\": "
                     "is not a regular file\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "fifo.obj"}])")}, {"mkfifo fifo.obj", ""}}},
        {.name = "obj_mtllib_is_a_fifo",
         .args = kRender,
         .expected = "lightmesh: warning: $D/tri.obj: $D/fifo.mtl: not opened: is not a regular file\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "tri.obj"}])")},
                   {"tri.obj", "mtllib fifo.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n"},
                   {"mkfifo fifo.mtl", ""}},
         .exitCode = 0},
        {.name = "gltf_buffer_is_a_fifo",
         .args = "render $D/buf.gltf -o $OUT",
         .expected = "lightmesh: error: $D/buf.gltf: GLTF: could not open referenced file "
                     "\"fifo.bin\" ($D/fifo.bin: not opened: is not a regular file)\n",
         .files = {{"buf.gltf", Gltf(R"([{"mesh": 0}])", "\"fifo.bin\"")}, {"mkfifo fifo.bin", ""}}},
        {.name = "compare_image_is_a_fifo",
         .args = "compare $D/fifo.png $D/fifo.png --diff $OUT",
         .expected = "lightmesh: error: $D/fifo.png: is not a regular file\n",
         .files = {{"mkfifo fifo.png", ""}}},
        {.name = "compare_exr_whose_attribute_asks_gigabytes",
         // Found by fuzz_image_decode: OpenEXR allocates what the attribute's size says.
         // compare reads in a child process: a crash or a bomb there is this one line.
         .args = "compare $D/bomb.exr $D/bomb.exr --diff $OUT",
         .expected = "lightmesh: error: $D/bomb.exr: cannot read EXR: ",
         .files = {{"bomb.exr", std::string(
                     "\x76\x2f\x31\x01\x02\x00\x00\x00\x63\x68\x61\x00\x00\x63\x68\x61\x6e\x6e\x65\x6c\x73\x00\x63\x68"
                     "\x6c\x69\x73\x74\x00\x37\x00\x00\x00\x6e\x6e\x65\x6c\x73\x00\x63\x68\x6c\x69\x73\x74\x00\x37\x00"
                     "\x00\x00\x42\x00\x02\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00"
                     "\x01\x00\x00\x00\x05\x00\x00\x00\x42\x4d\xb6\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\xff\x6c\x00"
                     "\x00\x00\x00\x00\x6e\x68\x63\x61\x6e\x65\x6c\x73\x00\x63\x68\x00\x6c\x00", 114)}},
         .output = "$D/out/diff.png"},
        {.name = "bench_matrix_is_a_fifo",
         .args = "bench --matrix $D/fifo.json --csv $OUT",
         .expected = "lightmesh: error: $D/fifo.json: is not a regular file\n",
         .files = {{"mkfifo fifo.json", ""}},
         .output = "$D/out/bench.csv"},
        {.name = "mesh_from_proc",
         .args = "render /proc/self/status -o $OUT",
         .expected = "lightmesh: error: /proc/self/status: reports a size of 0 but has content (a "
                     "/proc or /sys file?): not a mesh file\n"},
        // --- Small files that expand enormously -----------------------------------------------
        {.name = "gltf_shared_children_expand",
         .args = "info $D/dag.gltf",
         .expected = "lightmesh: error: $D/dag.gltf: the glTF nodes share children so that they "
                     "expand to 33,554,431 node instances, more than the importer's budget of "
                     "4,194,304\n",
         .files = {{"dag.gltf", Gltf(GltfSharedChildren(24))}}},
        {.name = "gltf_instances_beyond_the_triangle_budget",
         .args = "info $D/dag.gltf",
         .expected = "lightmesh: error: $D/dag.gltf: expanding its instances gives more than 256 "
                     "triangles, the budget for 32.0 KiB of memory (128 B per triangle; "
                     "LIGHTMESH_MEMORY_LIMIT)\n",
         .files = {{"dag.gltf", Gltf(GltfSharedChildren(9))}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64K"},
        {.name = "off_count_overflows_memory_budget",
         .args = "render $D/big.off -o $OUT",
         .expected = "lightmesh: error: $D/big.off: the importer ",
         .files = {{"big.off", "OFF\n2000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"}},
         .env = "LIGHTMESH_MEMORY_LIMIT=256M"},
        // --- Silent acceptance and wrong exit codes --------------------------------------------
        {.name = "json_file_name_with_nul",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: contains a NUL byte "
                     "(\\u0000), which no file name can hold\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "box.obj\u0000.png"}])")}}},
        {.name = "variant_empty",
         .args = "render builtin:gazebo --shadows lmm --variant \"\" -o $OUT",
         .expected = "lightmesh: error: --variant: must not be empty (leave it out for the default)\n"},
        {.name = "json_variant_empty",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /render/variant: must not be empty (leave the "
                     "key out for the default)\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"variant": ""})")}}},
        {.name = "compare_threshold_nan",
         .args = "compare $D/a.png $D/b.png --threshold-psnr nan --diff $OUT",
         .expected = "lightmesh: error: --threshold-psnr: must be a finite number of dB, got nan\n"},
        {.name = "unused_option_warns",
         .args = kRender + " --shadows rt --light-radius 0.5",
         .expected = "lightmesh: warning: --light-radius is not used by --shadows rt (only by "
                     "soft, exact, area, denoised and lmm); ignored\n",
         .files = {{"scene.json", good}},
         .exitCode = 0},
        {.name = "thin_check_without_a_light_radius_warns",
         .args = kRender + " --shadows lmm --thin-check lit",
         .expected = "lightmesh: warning: --thin-check is used only with a light radius (--light-radius > 0); ignored\n",
         .files = {{"scene.json", good}},
         .exitCode = 0},
        {.name = "area_with_point_lights_warns",
         .args = kRender + " --shadows area",
         .expected = "lightmesh: warning: --shadows area with every light's radius 0: point lights, the same image "
                     "as --shadows rt (give the lights a \"radius\" or set --light-radius)\n",
         .files = {{"scene.json", WithLights(R"([{"position": [3, 6, 4], "intensity": 40, "radius": 0}])")}},
         .exitCode = 0},
        {.name = "light_radius_negative",
         .args = kRender + " --shadows area",
         .expected = "lightmesh: error: $D/scene.json /lights/1/radius: must not be negative, got -0.2\n",
         .files = {{"scene.json", WithLights(R"([{"position": [3, 6, 4]}, {"position": [-3, 6, 4], "radius": -0.2}])")}}},
        {.name = "thin_check_unknown",
         .args = kRender + " --shadows lmm --light-radius 0.5 --thin-check on",
         .expected = "--thin-check: on not in {off,lit,all}",
         .files = {{"scene.json", good}}},
        {.name = "light_radius_with_a_variant_other_than_consensus",
         .args = kRender + " --shadows lmm --light-radius 0.5 --variant none",
         .expected = "lightmesh: error: --light-radius: light mesh: a light radius (contact-hardening penumbrae) needs the "
                     "consensus variant (the default), not none\n",
         .files = {{"scene.json", good}}},
        {.name = "output_name_of_252_characters",
         .args = kRender,
         .expected = "out.png: 16x12",
         .files = {{"scene.json", good}},
         .exitCode = 0,
         .output = "$D/out/" + std::string(245, 'n') + "out.png"},
        // --- Clear messages ----------------------------------------------------------------------
        {.name = "mesh_symlink_loop",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read \"loop.obj\": "
                     "cannot open: Too many levels of symbolic links\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "loop.obj"}])")},
                   {"symlink loop.obj", "loop2.obj"},
                   {"symlink loop2.obj", "loop.obj"}}},
        {.name = "mesh_name_too_long",
         .args = kRender,
         .expected = "cannot read \"" + std::string(300, 'm') + ".obj\": cannot open: File name too long\n",
         .files = {{"scene.json", WithMeshes("[{\"file\": \"" + std::string(300, 'm') + ".obj\"}]")}}},
        {.name = "mesh_parent_is_a_file",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes/0/file: cannot read \"box.obj/x.obj\": "
                     "cannot open: a folder on its path is a file (Not a directory)\n",
         .files = {{"scene.json", WithMeshes(R"([{"file": "box.obj/x.obj"}])")}}},
        {.name = "output_parent_is_a_file",
         .args = "render $D/scene.json -o $OUT",
         .expected = "lightmesh: error: $D/box.obj/out.png: \"$D/box.obj\" is a file, not a folder\n",
         .files = {{"scene.json", good}},
         .output = "$D/box.obj/out.png"},
        {.name = "scene_beyond_float_precision",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /meshes: all 12 triangles are degenerate in "
                     "single precision: at coordinates around 1e+12 single precision cannot tell "
                     "its vertices apart (they span 0; move the model nearer the origin)\n",
         .files = {{"scene.json",
                    WithMeshes(R"([{"file": "box.obj", "transform": {"translate": [1e12, 1e12, 1e12]}}])")}}},
        {.name = "json_many_keys_is_fast",
         .args = kRender,
         .expected = "lightmesh: warning: $D/scene.json /camera: ... and 199990 more unknown keys "
                     "(ignored)\n",
         .files = {{"scene.json", WithCamera(R"({"position": [0, 2, 8], "look_at": [0, 0, 0], )" +
                                             ManyKeys(200000).substr(1))}},
         .exitCode = 0},
        // --- The automatic ground under a model with its own floor -----------------------------
        {.name = "bare_mesh_with_its_own_floor",
         .args = "render $D/playground.obj --width 16 --height 12 -o $OUT",
         .expected = "lightmesh: no ground plane added: the model has its own floor at y = 0 (100% "
                     "of its footprint faces up there)\n",
         .files = {{"playground.obj", kPlayground}},
         .exitCode = 0},
        // --- Deep JSON, budgets, imports past the deadline ----------------------------------------
        // Deep JSON: refused at 256 levels, at once (100,000 levels must not take minutes).
        {.name = "json_nested_100000_levels",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json: nesting deeper than 256 levels at "
                     "/junk/a/a/a/...(250 levels).../a/a (the most a JSON file may nest)\n",
         .files = {{"scene.json", WithExtra(", \"junk\": " + Nested(100000, false))}}},
        {.name = "json_arrays_nested_1000000_levels_in_a_matrix",
         .args = "bench --matrix $D/m.json --csv $OUT",
         .expected = "lightmesh: error: $D/m.json: nesting deeper than 256 levels at "
                     "/scenes/0/0/0/...(250 levels).../0/0 (the most a JSON file may nest)\n",
         .files = {{"m.json", "{\"scenes\": " + Nested(1000000, true) + "}"}},
         .output = "$D/out/bench.csv"},
        // Budgets: refused with the estimate, before the work.
        {.name = "templates_beyond_their_index",
         .args = "templates --ns 64 --ki 16 --template-dir $D/out",
         .expected = "lightmesh: error: templates ns 64, kI 16: about 4,",
         .output = "$D/out/sphere-ns64-ki16.lmt"},
        {.name = "templates_beyond_the_memory_budget",
         .args = "templates --ns 32 --ki 16 --template-dir $D/out",
         .expected = "lightmesh: error: templates ns 32, kI 16 would need about 1.7 GiB (6",
         .output = "$D/out/sphere-ns32-ki16.lmt",
         .env = "LIGHTMESH_MEMORY_LIMIT=256M"},
        {.name = "templates_beyond_the_memory_budget_say_what_fits",
         .args = "templates --ns 32 --ki 16 --template-dir $D/out",
         .expected = "entries, 3 bytes each), more than half of this machine's 256.0 MiB (LIGHTMESH_MEMORY_LIMIT); "
                     "with kI 16, ns up to 12 fits; with ns 32, kI up to 6.6\n",
         .output = "$D/out/sphere-ns32-ki16.lmt",
         .env = "LIGHTMESH_MEMORY_LIMIT=256M"},
        {.name = "light_mesh_templates_beyond_the_memory_budget",
         .args = "render builtin:gazebo --shadows lmm --variant templates --ns 32 --ki 16 --cc 8 --template-dir $D/out "
                 "-o $OUT",
         .expected = "lightmesh: error: light mesh: sphere templates ns 32, kI 16 would need about 6.",
         .env = "LIGHTMESH_MEMORY_LIMIT=256M"},
        {.name = "bench_estimated_beyond_the_limit",
         .args = "bench --size 16384x16384 --repeat 100 -q --csv $OUT",
         .expected = "more than the limit of 1 h 0 min (measured on sampled tiles of RT and LMM renders at "
                     "16384x16384); make it smaller, or --force runs it anyway\n",
         .output = "$D/out/bench.csv"},
        {.name = "bench_matrix_of_ten_billion_cells",
         .args = "bench --matrix $D/m.json --csv $OUT",
         .expected = "lightmesh: error: bench: the matrix has 10,000,020,000 cells, more than the 100,000,000 one run "
                     "may hold (scenes x sizes x CC x kI x variants, plus RT and no shadows)\n",
         .files = {{"m.json", "{\"scenes\": " + Repeated("\"builtin:gazebo\"", 100) + ", \"sizes\": " +
                                  Repeated("[8, 6]", 100) + ", \"cc\": " + Repeated("10", 100) + ", \"ki\": " +
                                  Repeated("2", 100) + ", \"variants\": " + Repeated("\"grid\"", 100) + "}"}},
         .output = "$D/out/bench.csv"},
        {.name = "bench_variants_empty",
         .args = "bench --variants \"\" --csv $OUT",
         .expected = "lightmesh: error: --variants: must not be empty (list LMM variants, comma-separated, or leave "
                     "the option out for the default)\n",
         .output = "$D/out/bench.csv"},
        {.name = "bench_matrix_variant_empty",
         .args = "bench --matrix $D/m.json --csv $OUT",
         .expected = "lightmesh: error: $D/m.json /variants/1: must not be empty (leave the key out for the default)\n",
         .files = {{"m.json", R"({"variants": ["grid", ""]})"}},
         .output = "$D/out/bench.csv"},
        // Import: a file of zeros refused at once; an OBJ whose objects would outlast the
        // deadline in Assimp's quadratic lookup refused with the estimate.
        {.name = "mesh_of_zeros",
         .args = "render $D/zeros.obj -o $OUT",
         .expected = "lightmesh: error: $D/zeros.obj: its first 4,096 bytes are all zero (NUL): not a mesh file (a "
                     "zeroed or sparse file?)\n",
         .files = {{"zeros.obj", std::string(100000, '\0')}}},
        // Many objects are read within the deadline (Assimp's reader is quadratic in them).
        {.name = "obj_objects_within_the_deadline",
         .args = "render $D/objects.obj --width 32 --height 24 -o $OUT",
         .expected = "$D/out/out.png: 32x24, shadows soft, accel embree, 60,012 triangles",
         .files = {{"objects.obj", ObjObjects(60000)}},
         .exitCode = 0,
         .env = "LIGHTMESH_IMPORT_TIMEOUT=2"},
        // Messages that pointed the wrong way.
        {.name = "json_cc_too_large_for_memory",
         .args = kRender + " --shadows lmm",
         .expected = "lightmesh: error: $D/scene.json /render/cc: light mesh 1006x1006x1006 (CC 1000, kI 2) needs "
                     "970.9 MiB of node storage, more than half of this machine's 64.0 MiB: lower CC\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"cc": 1000})")}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "bench_matrix_cc_too_large_for_memory",
         .args = "bench --matrix $D/m.json --csv $OUT",
         .expected = "lightmesh: error: $D/m.json /cc/1: light mesh ",
         .files = {{"m.json", R"({"sizes": [[16, 12]], "cc": [10, 3000], "variants": ["grid"]})"}},
         .output = "$D/out/bench.csv",
         .env = "LIGHTMESH_MEMORY_LIMIT=64M"},
        {.name = "bench_matrix_unknown_back_end",
         .args = "bench --matrix $D/m.json --csv $OUT",
         .expected = "lightmesh: error: $D/m.json /accels/1: unknown ray-query back-end \"embre\" (choose ",
         .files = {{"m.json", R"({"accels": ["grid", "embre"]})"}},
         .output = "$D/out/bench.csv"},
        {.name = "json_ki_just_above_the_range",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json /render/ki: must be between 0.01 and 16, got 16.000001\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ki": 16.000001})")}}},
        {.name = "light_radius_beyond_float",
         .args = kRender + " --shadows area --light-radius 1e39",
         .expected = "lightmesh: error: --light-radius: must be a finite number >= 0 within single precision "
                     "(3.4e38), got 1e39\n"},
        {.name = "bench_matrix_variant_with_a_nul_byte",
         .args = "bench --matrix $D/m.json --csv $OUT",
         .expected = "lightmesh: error: $D/m.json /variants/0: unknown light-mesh variant \"gr<U+0000>id\" (choose",
         .files = {{"m.json", R"({"variants": ["gr\u0000id"]})"}},
         .output = "$D/out/bench.csv"},
        {.name = "scene_at_1e-17_scale_loads_and_is_refused_for_rendering_by_its_span",
         .args = kRender,
         .expected = "lightmesh: error: $D/scene.json: the scene (meshes, ground, camera and lights) spans 1.1e-16, "
                     "less than the 1e-06 that single-precision ray queries resolve with --accel embree (scale the "
                     "model up)\n",
         .files = {{"scene.json", SceneJson({.camera = R"({"position": [0, 2e-17, 8e-17], "look_at": [0, 0, 0]})",
                                             .lights = R"([{"position": [3e-17, 6e-17, 4e-17]}])",
                                             .meshes = R"([{"file": "box.obj", "transform": {"scale": 1e-17}}])"})}}},
        {.name = "scene_at_1e-10_scale_renders_on_the_grid",
         .args = kRender + " --accel grid",
         .expected = "out.png: 16x12",
         .files = {{"scene.json", SceneJson({.camera = R"({"position": [0, 2e-10, 8e-10], "look_at": [0, 0, 0]})",
                                             .lights = R"([{"position": [3e-10, 6e-10, 4e-10], "falloff": "none"}])",
                                             .meshes = R"([{"file": "box.obj", "transform": {"scale": 1e-10}}])"})}},
         .exitCode = 0},
        {.name = "file_name_with_a_newline",
         .args = "render \"$D/new\nline.json\" -o $OUT",
         .expected = "lightmesh: error: $D/new<U+000A>line.json: no such file\n"},
        {.name = "scene_name_taken_for_an_option",
         .args = "render -scene.json -o $OUT",
         .expected = "lightmesh: error: -scene.json: not an option of `render`; a file whose name starts with '-' is "
                     "given as ./-scene.json (or after --)\n"},
        {.name = "bench_matrix_symlink_loop",
         .args = "bench --matrix $D/loop.json --csv $OUT",
         .expected = "lightmesh: error: $D/loop.json: cannot open: Too many levels of symbolic links\n",
         .files = {{"symlink loop.json", "loop2.json"}, {"symlink loop2.json", "loop.json"}},
         .output = "$D/out/bench.csv"},
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
        // One message for a folder, whatever its name looks like.
        {.name = "output_is_a_folder_without_extension",
         .args = "render $D/scene.json -o $D/out/folder",
         .expected = "lightmesh: error: $D/out/folder: is a folder, not a file\n",
         .files = {{"scene.json", good}, {"out/folder/", ""}}},
        {.name = "output_is_the_current_folder",
         .args = "render $D/scene.json -o $D/out/.",
         .expected = "lightmesh: error: $D/out/.: is a folder, not a file\n",
         .files = {{"scene.json", good}}},
        {.name = "output_names_a_folder",
         .args = "render $D/scene.json -o $D/out/new/",
         .expected = "lightmesh: error: $D/out/new/: names a folder, not a file\n",
         .files = {{"scene.json", good}}},
        // --- Command-line mistakes ---------------------------------------------------------
        {.name = "command_mistyped",
         .args = "rendr $D/scene.json -o $OUT",
         .expected = "lightmesh: error: unknown command \"rendr\"; did you mean render?\n",
         .files = {{"scene.json", good}}},
        {.name = "command_missing",
         .args = "",
         .expected = "lightmesh: error: a command is required: render, info, templates, compare or bench\n"},
        {.name = "option_mistyped",
         .args = kRender + " --shadow lmm",
         .expected = "lightmesh: error: --shadow: not an option of `render`; did you mean --shadows?\n",
         .files = {{"scene.json", good}}},
        {.name = "option_unknown",
         .args = kRender + " --frobnicate",
         .expected = "lightmesh: error: --frobnicate: not an option of `render`\n",
         .files = {{"scene.json", good}}},
        {.name = "argument_unexpected",
         .args = kRender + " $D/other.json",
         .expected = "lightmesh: error: unexpected argument for `render`: $D/other.json\n",
         .files = {{"scene.json", good}}},
        // The same range, the same words from the command line as from a scene file.
        {.name = "option_out_of_range_worded_as_the_scene_file",
         .args = kRender + " --shadows lmm --ki 20",
         .expected = "lightmesh: error: --ki: must be between 0.01 and 16, got 20\n",
         .files = {{"scene.json", good}}},
        {.name = "scene_out_of_range",
         .args = kRender + " --shadows lmm",
         .expected = "lightmesh: error: $D/scene.json /render/ki: must be between 0.01 and 16, got 20\n",
         .files = {{"scene.json", WithExtra(R"(, "render": {"ki": 20})")}}},
        {.name = "option_not_an_integer",
         .args = kRender + " --aa 1.5",
         .expected = "lightmesh: error: --aa: expected an integer, got 1.5\n",
         .files = {{"scene.json", good}}},
        {.name = "option_out_of_range_threads",
         .args = kRender + " --threads 0",
         .expected = "lightmesh: error: --threads: must be between 1 and 1024, got 0\n",
         .files = {{"scene.json", good}}},
        // --- glTF images in data: URIs, glTF JSON errors in its own words ---------------------
        {.name = "gltf_data_uri_not_base64",
         .args = "render $D/m.gltf -o $OUT",
         .expected = "lightmesh: warning: $D/m.gltf: image 0: its data: URI is not base64 (\"!\" at character 5 of "
                     "12); the materials using it get their flat colour\n",
         .files = {{"m.gltf", CheckerGltf("iVBO!not b64")}},
         .exitCode = 0},
        {.name = "gltf_data_uri_empty",
         .args = "render $D/m.gltf -o $OUT",
         .expected = "lightmesh: warning: $D/m.gltf: image 0: its data: URI holds no bytes; the materials using it "
                     "get their flat colour\n",
         .files = {{"m.gltf", CheckerGltf("")}},
         .exitCode = 0},
        {.name = "gltf_bare_nan_token",
         .args = "render $D/m.gltf -o $OUT",
         .expected = "lightmesh: error: $D/m.gltf: its glTF JSON does not parse, at line 69, column 18: syntax error "
                     "while parsing value - invalid literal; last read: '\"byteLength\": N'\n",
         .files = {{"m.gltf", CheckerGltf("iVBORw0KGgoAAAANSUhEUgAAAAgAAAAICAYAAADED76LAAAAGklEQVR42mM4ceLEfyBmwEUz4"
                                          "JME0QzDwgQA6Su14QhVneoAAAAASUVORK5CYII=",
                                          "\"byteLength\": 92", "\"byteLength\": NaN")}}},
        // --- Copies and flattening refused first, naming the scene and the option -------------
        {.name = "no_instancing_copies_past_the_budget",
         .args = kRender + " --no-instancing",
         .expected = "lightmesh: error: $D/scene.json /meshes/0: \"box.obj\" (12 triangles) is referenced 100,000 "
                     "times and copied each time (--no-instancing): the scene's copies, 1,200,000 triangles, would "
                     "take about 146.5 MiB (128 B a triangle through the pipeline), more than half of the 256.0 MiB "
                     "this process may use (LIGHTMESH_MEMORY_LIMIT); with instancing on, a file referenced many "
                     "times is placed as instances of one import\n",
         .files = {{"scene.json", SceneJson({.meshes = References("box.obj", 100000)})}},
         .env = "LIGHTMESH_MEMORY_LIMIT=256M"},
        {.name = "bench_copies_past_the_budget",
         .args = "bench --scene $D/scene.json --csv $OUT",
         .expected = "lightmesh: error: $D/scene.json /meshes/0: \"box.obj\" (12 triangles) is referenced 100,000 "
                     "times and copied each time (bench, which copies every reference so that every method sees the "
                     "same triangles): the scene's copies, 1,200,000 triangles, would take about 146.5 MiB",
         .files = {{"scene.json", SceneJson({.meshes = References("box.obj", 100000)})}},
         .output = "$D/out/bench.csv",
         .env = "LIGHTMESH_MEMORY_LIMIT=256M"},
        {.name = "flattening_for_lmm_names_the_scene_and_the_option",
         .args = kRender + " --shadows lmm",
         .expected = "lightmesh: error: $D/scene.json: --shadows lmm: flattening 64 instances into 67,7",
         .files = {{"grid.obj", GridObj(23)}, {"scene.json", SceneJson({.meshes = References("grid.obj", 64)})}},
         .env = "LIGHTMESH_MEMORY_LIMIT=12M"},
        {.name = "flattening_for_the_grid_names_the_scene_and_the_option",
         .args = kRender + " --accel grid",
         .expected = "lightmesh: error: $D/scene.json: --accel grid: flattening 64 instances into 67,7",
         .files = {{"grid.obj", GridObj(23)}, {"scene.json", SceneJson({.meshes = References("grid.obj", 64)})}},
         .env = "LIGHTMESH_MEMORY_LIMIT=12M"},
        {.name = "compare_past_the_budget",
         .args = "compare $D/a.png $D/b.png --diff $OUT",
         .expected = "lightmesh: error: $D/a.png and $D/b.png are 16384x16384 (268,435,456 pixels): comparing them "
                     "takes about 24.0 GiB (96 B a pixel), more than half of the 1.0 GiB this process may use "
                     "(LIGHTMESH_MEMORY_LIMIT)\n",
         .files = {{"a.png", PngHead(16384, 16384)}, {"b.png", PngHead(16384, 16384)}},
         .output = "$D/out/diff.png",
         .env = "LIGHTMESH_MEMORY_LIMIT=1G"},
        {.name = "compare_sizes_differ_before_reading",
         .args = "compare $D/a.png $D/b.png --diff $OUT",
         .expected = "lightmesh: error: $D/a.png is 16384x16384 and $D/b.png is 16384x16383: images of different "
                     "sizes cannot be compared\n",
         .files = {{"a.png", PngHead(16384, 16384)}, {"b.png", PngHead(16384, 16383)}},
         .output = "$D/out/diff.png"},
        // --- A memory budget outside the grammar is an error, not ignored ----------------------
        {.name = "memory_limit_not_a_size",
         .args = kRender,
         .expected = "lightmesh: error: LIGHTMESH_MEMORY_LIMIT=abc: not a size; write bytes or a number with K, M, "
                     "G or T (powers of 1024), e.g. 8G, 8GB, 8GiB, 512M, 1073741824\n",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=abc"},
        {.name = "memory_limit_negative",
         .args = "info builtin:gazebo",
         .expected = "lightmesh: error: LIGHTMESH_MEMORY_LIMIT=-5G: not a size: no sign is allowed; ",
         .env = "LIGHTMESH_MEMORY_LIMIT=-5G"},
        {.name = "memory_limit_exponent",
         .args = "compare $D/a.png $D/a.png --diff $OUT",
         .expected = "lightmesh: error: LIGHTMESH_MEMORY_LIMIT=1e3G: not a size: unknown unit \"e3G\"; ",
         .output = "$D/out/diff.png",
         .env = "LIGHTMESH_MEMORY_LIMIT=1e3G"},
        {.name = "memory_limit_overflows",
         .args = "bench --csv $OUT",
         .expected = "lightmesh: error: LIGHTMESH_MEMORY_LIMIT=99999999999999999999: too large (more than 16 EiB); ",
         .output = "$D/out/bench.csv",
         .env = "LIGHTMESH_MEMORY_LIMIT=99999999999999999999"},
        {.name = "memory_limit_zero",
         .args = kRender,
         .expected = "lightmesh: error: LIGHTMESH_MEMORY_LIMIT=0G: must be at least 1 byte; ",
         .files = {{"scene.json", good}},
         .env = "LIGHTMESH_MEMORY_LIMIT=0G"},
        // The spellings people write are budgets: 64KiB and 64kB as 64K (they were ignored).
        {.name = "memory_limit_kib_is_a_budget",
         .args = "info $D/dag.gltf",
         .expected = "lightmesh: error: $D/dag.gltf: expanding its instances gives more than 256 "
                     "triangles, the budget for 32.0 KiB of memory",
         .files = {{"dag.gltf", Gltf(GltfSharedChildren(9))}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64KiB"},
        {.name = "memory_limit_kb_is_a_budget",
         .args = "info $D/dag.gltf",
         .expected = "lightmesh: error: $D/dag.gltf: expanding its instances gives more than 256 "
                     "triangles, the budget for 32.0 KiB of memory",
         .files = {{"dag.gltf", Gltf(GltfSharedChildren(9))}},
         .env = "LIGHTMESH_MEMORY_LIMIT=64kB"},
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
        else if (name.rfind("mkfifo ", 0) == 0)
            mkfifo((dir / name.substr(7)).c_str(), 0644);
        else if (name.rfind("symlink ", 0) == 0)
            fs::create_symlink(content, dir / name.substr(8), ec);
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
        std::error_code removeError;
        fs::remove(out, removeError);
        const auto started = std::chrono::steady_clock::now();
        const CliResult run = lm::testing::RunLightmesh(args, prefix);
        if (getenv("LM_PRINT"))
            printf("%-36s %d %.2f s %s", c.name.c_str(), run.exitCode,
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(), run.output.c_str());
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
}  // namespace bad_input_test
