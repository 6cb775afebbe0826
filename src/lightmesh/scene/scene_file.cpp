// scene_file.cpp -- the JSON scene format (the checks and the framing of bare meshes are
// scene_checks.cpp and framing.cpp). Over 500 lines as one concept: the format's reference
// below and the readers of its keys, one function per object, which a reader checks
// against each other.
//
// A scene file is one JSON object (keys in any order; "name" is also allowed on lights
// and meshes):
//
//   "camera"     required. {"position": [x,y,z], "look_at": [x,y,z]} both required;
//                "up" (default [0,1,0], not parallel to the view direction), "fov" (vertical,
//                degrees, in (0, 180), default 45).
//   "ambient"    colour, default 0.05.        "background"  colour, default 0.
//   "materials"  {NAME: {"kd": colour (0.8), "ks": colour (0), "phong": number ≥ 0 (32),
//                "mirror": colour (0)}, ...}.
//   "lights"     required, ≥ 1: [{"position": [x,y,z] (required), "intensity": colour (1),
//                "falloff": "inverse_square" (default) | "none", "radius": number ≥ 0 (the
//                sphere the light stands for, scene units; 0 is a point; default 2 % of the
//                light's distance to the centre of the scene's bounding box, ground
//                included: DefaultLightRadius, recorded in a note), "range": number > 0
//                (beyond it the light gives nothing; default: no limit)}, ...].
//   "meshes"     required, ≥ 1: [{"file": path relative to the scene file's folder
//                (required), "transform": {"scale": number | [3] (non-zero), "rotate":
//                [[ax, ay, az, degrees], ...] (a single [ax, ay, az, degrees] is accepted too),
//                "translate": [3]} or {"matrix": [16 numbers]}; or "matrix": [16 numbers]
//                next to "file" -- a row-major affine 4×4 whose last row is 0 0 0 1.
//                Applied as scale, then the rotations in order, then translate.
//                A "file" of the form "cache:PATH" names PATH in the model cache
//                (ModelCacheDir(), filled by scripts/fetch-scenes.sh).
//                "material": NAME overrides the file's materials (without it, a file
//                material with the name of one of "materials" takes that definition);
//                "exclude_materials",
//                "exclude_names": glob patterns (* and ?; a string or a list) matched against
//                the file's material names and node / mesh names}, ...].
//   "ground"     optional: a square slab (a closed box, 1 % of its side thick, top face at
//                the ground height) centred under the meshes' bounding box,
//                {"height": number (default: the box's lowest point along "up"), "up":
//                "x" | "y" | "z" (default "y"), "size": side as a multiple of the box's
//                longest horizontal extent (> 0, default 3), "material": NAME (default a
//                light grey)}.
//   "render"     optional, fills Scene::render: "width", "height" (1..16384, width·height ≤
//                2^28), "aa" (1..16), "max_depth" (1..64), "shadows" ("none" | "rt" | "lmm" |
//                "area"), "accel" ("brute" | "grid" | "embree"), "grid" (0..4096),
//                "cc" (1..4096), "ki" (0.01..16), "variant" (string), "ns" (0..64),
//                "template_dir" (string), "cell_summaries" ("auto" | "on" | "off"),
//                "light_radius" (≥ 0: overrides every light's "radius": sampled by
//                "shadows": "area"; only this key turns on and sizes the contact-hardening
//                penumbrae of "lmm", the lights' own radii do not), "thin_check" ("off" |
//                "lit" | "all": with a light radius, P's own ray checks the nodes), "samples"
//                (1..4096, shadow rays per light), "exposure" (-32..32 stops: the radiance
//                times 2^exposure), "tonemap" ("clamp" | "reinhard" | "aces": PNG only).
//                The ranges and choices are the settings table's (settings/render_settings.cpp).
//
// A colour is a number (grey) or [r, g, b]; all numbers must be finite and colours ≥ 0.
// Unknown keys are warnings ("unknown key (ignored)"), errors with SceneLoadOptions::strict;
// so are duplicate keys (the last one wins). Every error names the file and JSON pointer.
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/scene/scene_load.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "lightmesh/geometry/instances.h"
#include "lightmesh/scene/demo_scene.h"
#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/scene/shapes.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

namespace fs = std::filesystem;
using namespace json;  // Reader, Object, the value readers
using namespace scene_load;  // the checks and the framing

Vec3 ReadVec3(const Reader& r, const Json& j, const std::string& path) {
    if (!j.is_array()) r.Fail(path, "expected 3 numbers, got " + Describe(j));
    if (j.size() != 3) r.Fail(path, StringPrintf("expected 3 numbers, got %zu", j.size()));
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = Float(r, j[i], Index(path, i));
    return v;
}

Color ReadColor(const Reader& r, const Json& j, const std::string& path) {
    if (j.is_number()) return Color(NonNegative(r, j, path));
    if (!j.is_array() || j.size() != 3) {
        r.Fail(path, "expected a number or 3 numbers, got " +
                         (j.is_array() ? StringPrintf("%zu numbers", j.size()) : Describe(j)));
    }
    return {NonNegative(r, j[0], Index(path, 0)), NonNegative(r, j[1], Index(path, 1)),
            NonNegative(r, j[2], Index(path, 2))};
}

std::string ReadTextFile(const Reader& r, const std::string& path) {
    if (std::string problem = RegularFileProblem(path, "scene file"); !problem.empty())
        r.Fail("", problem);
    try {
        return ReadRegularFile(path, "scene file");
    } catch (const Error& e) {
        throw;
    }
}

Camera ReadCamera(const Reader& r, const Json& j) {
    Object o(r, j, "/camera");
    Camera c;
    c.position = ReadVec3(r, o.Require("position"), o.Child("position"));
    c.lookAt = ReadVec3(r, o.Require("look_at"), o.Child("look_at"));
    if (const Json* v = o.Find("up")) c.up = ReadVec3(r, *v, o.Child("up"));
    if (const Json* v = o.Find("fov")) {
        const double fov = Number(r, *v, o.Child("fov"));
        if (!(fov > 0 && fov < 180))
            r.Fail(o.Child("fov"), StringPrintf("must be between 0 and 180 degrees, got %g", fov));
        c.fovY = static_cast<float>(fov);
    }
    o.Finish();
    if (std::string p = CoordinateProblem(c.position, "the camera position"); !p.empty())
        r.Fail(o.Child("position"), p);
    if (std::string p = CoordinateProblem(c.lookAt, "the point looked at"); !p.empty())
        r.Fail(o.Child("look_at"), p);
    std::string key;
    if (std::string problem = CameraProblem(c, &key); !problem.empty())
        r.Fail(o.Child(key), problem);
    return c;
}

Material ReadMaterial(const Reader& r, const Json& j, const std::string& path,
                      const std::string& name) {
    Object o(r, j, path);
    Material m;
    m.name = name;
    if (const Json* v = o.Find("kd")) m.kd = ReadColor(r, *v, o.Child("kd"));
    if (const Json* v = o.Find("ks")) m.ks = ReadColor(r, *v, o.Child("ks"));
    if (const Json* v = o.Find("phong")) m.phong = NonNegative(r, *v, o.Child("phong"));
    if (const Json* v = o.Find("mirror")) m.mirror = ReadColor(r, *v, o.Child("mirror"));
    o.Finish();
    return m;
}

/// One entry of "lights"; *hasRadius tells whether it states its "radius" (the others get
/// the default once the meshes give the scene's bounds).
PointLight ReadLight(const Reader& r, const Json& j, const std::string& path, bool* hasRadius) {
    Object o(r, j, path);
    PointLight light;
    if (const Json* v = o.Find("sun")) {
        // The sun: at infinity, placed once the scene's bounds are known (PlaceSuns).
        for (const char* key : {"position", "falloff", "radius", "range", "spot"})
            if (o.Find(key))
                r.Fail(o.Child(key), StringPrintf("a sun has no \"%s\" (it is a direction at infinity; its size is "
                                                  "\"angle\" in \"sun\")",
                                                  key));
        ReadSunKey(r, *v, o.Child("sun"), &light);
        if (const Json* i = o.Find("intensity")) light.intensity = ReadColor(r, *i, o.Child("intensity"));
        if (const Json* n = o.Find("name")) light.name = String(r, *n, o.Child("name"));
        o.Finish();
        *hasRadius = true;
        return light;
    }
    light.position = ReadVec3(r, o.Require("position"), o.Child("position"));
    if (const Json* v = o.Find("spot")) ReadSpotKey(r, *v, o.Child("spot"), &light);
    if (const Json* v = o.Find("intensity"))
        light.intensity = ReadColor(r, *v, o.Child("intensity"));
    if (const Json* v = o.Find("falloff")) {
        light.falloff = Enum(r, *v, o.Child("falloff"), {"inverse_square", "none"}) == "none"
                            ? Falloff::None
                            : Falloff::InverseSquare;
    }
    *hasRadius = false;
    if (const Json* v = o.Find("radius")) {
        light.radius = NonNegative(r, *v, o.Child("radius"));
        *hasRadius = true;
    }
    if (const Json* v = o.Find("range")) {
        light.range = Float(r, *v, o.Child("range"));
        if (!(light.range > 0)) r.Fail(o.Child("range"), "must be greater than 0, got " + NumberText(*v));
    }
    if (const Json* v = o.Find("name")) light.name = String(r, *v, o.Child("name"));
    o.Finish();
    if (std::string p = CoordinateProblem(light.position, "the light"); !p.empty())
        r.Fail(o.Child("position"), p);
    return light;
}

/// A 4×4 row-major affine matrix.
Affine ReadMatrix(const Reader& r, const Json& j, const std::string& path) {
    if (!j.is_array() || j.size() != 16) {
        r.Fail(path, "expected 16 numbers (a row-major 4x4 matrix), got " +
                         (j.is_array() ? StringPrintf("%zu", j.size()) : Describe(j)));
    }
    float v[16];
    for (int i = 0; i < 16; ++i) v[i] = Float(r, j[i], Index(path, i));
    if (v[12] != 0 || v[13] != 0 || v[14] != 0 || v[15] != 1) {
        r.Fail(path, StringPrintf("the last row must be 0 0 0 1 (only affine transforms are "
                                  "supported), got %g %g %g %g",
                                  v[12], v[13], v[14], v[15]));
    }
    Affine a;
    for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 4; ++col) a.m[row][col] = v[row * 4 + col];
    float scale = 0;
    for (int row = 0; row < 3; ++row)
        for (int col = 0; col < 3; ++col) scale = std::max(scale, std::abs(a.m[row][col]));
    if (!(std::abs(a.Determinant()) > 1e-9f * scale * scale * scale))
        r.Fail(path, "the matrix is singular (it would flatten the mesh)");
    return a;
}

Affine ReadTransform(const Reader& r, const Json& j, const std::string& path) {
    Object o(r, j, path);
    const Json* matrix = o.Find("matrix");
    const Json* scale = o.Find("scale");
    const Json* rotate = o.Find("rotate");
    const Json* translate = o.Find("translate");
    if (matrix) {
        if (scale || rotate || translate)
            r.Fail(path, "give either \"matrix\" or \"scale\"/\"rotate\"/\"translate\", not both");
        o.Finish();
        return ReadMatrix(r, *matrix, o.Child("matrix"));
    }
    Affine result;
    if (scale) {
        const std::string p = o.Child("scale");
        Vec3 s;
        if (scale->is_number())
            s = Vec3(Float(r, *scale, p));
        else if (scale->is_array() && scale->size() == 3)
            s = ReadVec3(r, *scale, p);
        else
            r.Fail(p, "expected a number or 3 numbers, got " + Describe(*scale));
        if (s.x == 0 || s.y == 0 || s.z == 0)
            r.Fail(p, "must not be zero (it would flatten the mesh)");
        result = Affine::Scale(s);
    }
    if (rotate) {
        const std::string p = o.Child("rotate");
        if (!rotate->is_array())
            r.Fail(p, "expected a list of [ax, ay, az, degrees], got " + Describe(*rotate));
        // One rotation [ax, ay, az, degrees] or a list of them.
        std::vector<std::pair<const Json*, std::string>> list;
        if (!rotate->empty() && (*rotate)[0].is_number())
            list.push_back({rotate, p});
        else
            for (size_t i = 0; i < rotate->size(); ++i)
                list.push_back({&(*rotate)[i], Index(p, i)});
        for (const auto& [rj, rp] : list) {
            if (!rj->is_array() || rj->size() != 4)
                r.Fail(rp, "expected [ax, ay, az, degrees], got " + Describe(*rj));
            Vec3 axis;
            for (int k = 0; k < 3; ++k) axis[k] = Float(r, (*rj)[k], Index(rp, k));
            const float degrees = Float(r, (*rj)[3], Index(rp, 3));
            if (!(LengthSquared(axis) > 0)) r.Fail(rp, "the rotation axis must not be zero");
            result = Affine::Rotate(axis, degrees) * result;
        }
    }
    if (translate)
        result = Affine::Translate(ReadVec3(r, *translate, o.Child("translate"))) * result;
    o.Finish();
    return result;
}

bool Bool(const Reader& r, const Json& j, const std::string& path) {
    if (!j.is_boolean()) r.Fail(path, "expected true or false, got " + Describe(j));
    return j.get<bool>();
}

void ReadRender(const Reader& r, const Json& j, RenderOptions* ro, const std::string& path = "/render") {
    Object o(r, j, path);
    // The knobs' ranges and choices come from the settings table (the CLI checks the same rows).
    auto integer = [&](const Json& v, const char* key) { return SettingInt(r, v, o.Child(key), RenderSettingFor(key)); };
    auto number = [&](const Json& v, const char* key) { return SettingFloat(r, v, o.Child(key), RenderSettingFor(key)); };
    auto choice = [&](const Json& v, const char* key) { return SettingChoice(r, v, o.Child(key), RenderSettingFor(key)); };
    if (const Json* v = o.Find("width")) ro->width = integer(*v, "width");
    if (const Json* v = o.Find("height")) ro->height = integer(*v, "height");
    constexpr int64_t MaxPixels = int64_t(1) << 28;
    if (int64_t(ro->width) * ro->height > MaxPixels) {
        r.Fail(path,
               StringPrintf("%d x %d is %lld pixels, more than the limit of %lld", ro->width,
                            ro->height, static_cast<long long>(int64_t(ro->width) * ro->height),
                            static_cast<long long>(MaxPixels)));
    }
    if (const Json* v = o.Find("aa")) ro->aa = integer(*v, "aa");
    if (const Json* v = o.Find("max_depth")) ro->maxDepth = integer(*v, "max_depth");
    if (const Json* v = o.Find("shadows")) ro->shadows = choice(*v, "shadows");
    if (const Json* v = o.Find("accel")) ro->accel = choice(*v, "accel");
    if (const Json* v = o.Find("grid")) ro->accelOptions.gridResolution = integer(*v, "grid");
    if (const Json* v = o.Find("cc")) ro->lightMesh.cc = ro->soft.cc = integer(*v, "cc");
    if (const Json* v = o.Find("ki")) ro->lightMesh.ki = number(*v, "ki");
    if (const Json* v = o.Find("variant")) {
        ro->lightMesh.variant = String(r, *v, o.Child("variant"));
        if (ro->lightMesh.variant.empty())
            r.Fail(o.Child("variant"), "must not be empty (leave the key out for the default)");
    }
    if (const Json* v = o.Find("ns")) ro->lightMesh.ns = integer(*v, "ns");
    if (const Json* v = o.Find("template_dir"))
    {
        ro->lightMesh.templateDir = String(r, *v, o.Child("template_dir"));
        if (ro->lightMesh.templateDir.find('\0') != std::string::npos)
            r.Fail(o.Child("template_dir"), "contains a NUL byte (\\u0000), which no file name can hold");
    }
    if (const Json* v = o.Find("cell_summaries")) ro->lightMesh.cellSummaries = choice(*v, "cell_summaries");
    if (const Json* v = o.Find("light_radius")) ro->areaLight.radius = number(*v, "light_radius");
    if (const Json* v = o.Find("thin_check")) ro->lightMesh.thinCheck = choice(*v, "thin_check");
    if (const Json* v = o.Find("samples")) ro->areaLight.samples = integer(*v, "samples");
    if (const Json* v = o.Find("soft_samples")) ro->soft.samples = integer(*v, "soft_samples");
    if (const Json* v = o.Find("textures")) ro->textures = Bool(r, *v, o.Child("textures"));
    if (const Json* v = o.Find("instancing")) ro->instancing = Bool(r, *v, o.Child("instancing"));
    if (const Json* v = o.Find("exposure")) ro->exposure = number(*v, "exposure");
    if (const Json* v = o.Find("tonemap")) ro->tonemap = choice(*v, "tonemap");
    // Where each value came from, for the messages of the factories that read it.
    for (const RenderSetting& s : RenderSettings())
        if (o.Find(s.key)) ro->origins[s.key] = SourceLoc(r.File(), 0, 0, o.Child(s.key));
    o.Finish();
}

/// One entry of "meshes", read before any file is loaded so JSON mistakes show up first.
/// Whether `refs` references to a file whose mesh holds `triangles` become instances of
/// one prototype rather than copies: where that saves memory (docs/scene-format.md).
bool InstancesSaveMemory(int refs, size_t triangles) {
    return refs >= 2 && triangles >= kInstanceMinTriangles &&
           static_cast<double>(refs) * static_cast<double>(triangles) >= static_cast<double>(kInstanceMinTotal);
}

struct MeshEntry {
    std::string path;      ///< JSON path, "/meshes/0"
    std::string file;      ///< as written
    std::string resolved;  ///< relative to the scene file's folder
    Affine transform;
    bool hasTransform = false;
    int material = -1;  ///< override, index into Scene::materials
    MeshLoadOptions load;
    bool excludeMaterialsIsList = false, excludeNamesIsList = false;  // for JSON paths
};

struct GroundEntry {
    bool present = false;
    bool hasHeight = false;
    float height = 0;
    int axis = 1;
    float size = 3;
    int material = -1;
};

/// Index of a material defined in "materials", with an error listing the defined ones.
int LookUpMaterial(const Reader& r, const Json& j, const std::string& path,
                   const std::vector<std::string>& defined) {
    const std::string name = String(r, j, path);
    for (size_t i = 0; i < defined.size(); ++i)
        if (defined[i] == name) return static_cast<int>(i);
    std::string list;
    for (const auto& d : defined) list += (list.empty() ? "" : ", ") + d;
    r.Fail(path, "unknown material " + Quoted(name) +
                     (defined.empty() ? " (the scene defines no materials)"
                                      : " (defined: " + list + ")"));
}

/// Gives the lights `unsized` (indices into scene->lights, ascending) DefaultLightRadius
/// from the finished scene's bounds (ground included: the box `lightmesh info` prints), and
/// says so in one note: a soft shadow nobody asked for should be explained, with the way
/// back to a point.
void SizeUnsizedLights(Scene* scene, const std::vector<size_t>& unsized) {
    if (unsized.empty()) return;
    const Bounds3 bounds = scene->mesh.Bounds();
    // At most this many lights by name; a file with hundreds of lights gets a count.
    constexpr size_t kListed = 8;
    std::string which, radii;
    for (size_t k = 0; k < unsized.size(); ++k) {
        PointLight& light = scene->lights[unsized[k]];
        light.radius = DefaultLightRadius(bounds, light.position);
        if (k >= kListed) continue;
        const char* sep = k == 0 ? "" : (k + 1 == unsized.size() ? " and " : ", ");
        which += sep + std::to_string(unsized[k]);
        radii += sep + StringPrintf("%.3g", static_cast<double>(light.radius));
    }
    if (unsized.size() > kListed) {
        const std::string more = StringPrintf(" and %zu more", unsized.size() - kListed);
        which += more;
        radii += more;
    }
    const int share = static_cast<int>(std::lround(100 * kDefaultLightRadiusShare));
    scene->report.notes.push_back(
        unsized.size() == 1
            ? StringPrintf("light %s has no \"radius\": %s (%d %% of its distance to the scene's centre); "
                           "\"radius\": 0 makes it a point",
                           which.c_str(), radii.c_str(), share)
            : StringPrintf("lights %s have no \"radius\": %s (%d %% of each one's distance to the scene's "
                           "centre); \"radius\": 0 makes a light a point",
                           which.c_str(), radii.c_str(), share));
}

// ---------------------------------------------------------------------------------------
// The three kinds of scene

Scene LoadJsonScene(const std::string& spec, const SceneLoadOptions& options,
                    std::vector<std::string>* warnings) {
    Reader r(spec, options.strict, warnings);
    const Json root = ParseJson(r, options.text ? *options.text : ReadTextFile(r, spec));
    if (!root.is_object())
        r.Fail("", "expected a JSON object {...} at the top level, got " + Describe(root));
    Object top(r, root, "");

    Scene scene;
    scene.name = spec;
    scene.camera = ReadCamera(r, top.Require("camera"));
    if (const Json* v = top.Find("ambient")) scene.ambient = ReadColor(r, *v, "/ambient");
    if (const Json* v = top.Find("background")) scene.background = ReadColor(r, *v, "/background");
    // Free text for people (what the scene is, where its model comes from); not used.
    for (const char* key : {"name", "description", "source"})
        if (const Json* v = top.Find(key)) String(r, *v, "/" + std::string(key));

    std::vector<std::string> materialNames;
    if (const Json* mj = top.Find("materials")) {
        Object mats(r, *mj, "/materials");
        for (const std::string& name : r.KeysInOrder("/materials", *mj)) {
            const Json& value = *mats.Find(name);
            scene.materials.push_back(ReadMaterial(r, value, mats.Child(name), name));
            materialNames.push_back(name);
        }
        mats.Finish();
    }

    const Json& lj = top.Require("lights", "a scene needs at least one point light");
    if (!lj.is_array()) r.Fail("/lights", "expected a list of lights [...], got " + Describe(lj));
    if (lj.empty()) r.Fail("/lights", "a scene needs at least one light, got an empty list");
    std::vector<size_t> unsized;  // lights without "radius": sized once the bounds are known
    for (size_t i = 0; i < lj.size(); ++i) {
        bool hasRadius = false;
        scene.lights.push_back(ReadLight(r, lj[i], Index("/lights", i), &hasRadius));
        if (!hasRadius) unsized.push_back(i);
    }

    const Json& mj = top.Require("meshes", "a scene needs at least one mesh");
    if (!mj.is_array()) r.Fail("/meshes", "expected a list of meshes [...], got " + Describe(mj));
    if (mj.empty()) r.Fail("/meshes", "a scene needs at least one mesh, got an empty list");
    const fs::path folder = fs::path(spec).parent_path();
    std::vector<MeshEntry> entries;
    for (size_t i = 0; i < mj.size(); ++i) {
        MeshEntry e;
        e.load.smoothAngle = options.smoothNormals;
        e.path = Index("/meshes", i);
        Object o(r, mj[i], e.path);
        e.file = String(r, o.Require("file"), o.Child("file"));
        if (e.file.empty()) r.Fail(o.Child("file"), "must not be empty");
        if (e.file.find('\0') != std::string::npos)
            r.Fail(o.Child("file"), "contains a NUL byte (\\u0000), which no file name can hold");
        if (e.file.rfind("cache:", 0) == 0) {
            // Models fetched from Debian packages by scripts/fetch-scenes.sh live in the
            // user's cache, outside the source tree.
            e.resolved = (fs::path(ModelCacheDir()) / e.file.substr(6)).string();
            std::error_code ec;
            if (!fs::exists(e.resolved, ec))
                r.Fail(o.Child("file"), "cannot read " + Quoted(e.file) + ": " + e.resolved +
                                            " does not exist (run scripts/fetch-scenes.sh to fetch the model)");
        } else {
            e.resolved = fs::path(e.file).is_absolute() ? e.file : (folder / e.file).string();
        }
        const Json* transform = o.Find("transform");
        const Json* matrix = o.Find("matrix");
        if (transform && matrix)
            r.Fail(e.path, "give either \"transform\" or \"matrix\", not both");
        if (transform) e.transform = ReadTransform(r, *transform, o.Child("transform"));
        if (matrix) e.transform = ReadMatrix(r, *matrix, o.Child("matrix"));
        e.hasTransform = transform || matrix;
        if (const Json* v = o.Find("material"))
            e.material = LookUpMaterial(r, *v, o.Child("material"), materialNames);
        if (const Json* v = o.Find("exclude_materials")) {
            e.load.excludeMaterials = StringList(r, *v, o.Child("exclude_materials"));
            e.excludeMaterialsIsList = v->is_array();
        }
        if (const Json* v = o.Find("exclude_names")) {
            e.load.excludeNames = StringList(r, *v, o.Child("exclude_names"));
            e.excludeNamesIsList = v->is_array();
        }
        if (const Json* v = o.Find("name")) String(r, *v, o.Child("name"));
        o.Finish();
        entries.push_back(std::move(e));
    }

    GroundEntry ground;
    if (const Json* gj = top.Find("ground")) {
        Object o(r, *gj, "/ground");
        ground.present = true;
        if (const Json* v = o.Find("up"))
            ground.axis = Enum(r, *v, o.Child("up"), {"x", "y", "z"})[0] - 'x';
        if (const Json* v = o.Find("height")) {
            ground.height = Float(r, *v, o.Child("height"));
            ground.hasHeight = true;
        }
        if (const Json* v = o.Find("size")) {
            ground.size = Float(r, *v, o.Child("size"));
            if (!(ground.size > 0))
                r.Fail(o.Child("size"), StringPrintf("must be positive, got %g", ground.size));
        }
        if (const Json* v = o.Find("material"))
            ground.material = LookUpMaterial(r, *v, o.Child("material"), materialNames);
        o.Finish();
    }
    if (const Json* v = top.Find("render")) ReadRender(r, *v, &scene.render);
    top.Finish();

    // Now the mesh files, JSON mistakes having been reported already. A file named by several
    // entries with the same exclude patterns (placed twice, say) is imported once, and its
    // importer warnings are said once; the import is kept until its last entry.
    auto importKey = [](const MeshEntry& e) {
        std::string key = e.resolved;
        for (const std::string& p : e.load.excludeMaterials) key += std::string(1, '\0') + "m" + p;
        for (const std::string& p : e.load.excludeNames) key += std::string(1, '\0') + "n" + p;
        return key;
    };
    std::unordered_map<std::string, int> importsLeft;
    for (const MeshEntry& e : entries) ++importsLeft[importKey(e)];
    // References that become instances (docs/scene-format.md, "Instancing"): those of one
    // file with the same exclusions and material, imported once as a prototype.
    auto groupKey = [&](const MeshEntry& e) { return importKey(e) + std::string(1, '\0') + std::to_string(e.material); };
    std::unordered_map<std::string, int> groupRefs;
    for (const MeshEntry& e : entries) ++groupRefs[groupKey(e)];
    std::unordered_map<std::string, uint32_t> prototypeOf;
    std::shared_ptr<InstancedMeshes> instances;
    // The triangles the copied references will hold, counted at each file's first import
    // (its triangles times its references): past the budget the scene is refused there,
    // before the copies are made (a million references under --no-instancing ran for
    // minutes into Embree's "out of memory" at 14.5 GB).
    uint64_t copiedTriangles = 0;
    std::unordered_set<std::string> copiedGroups;
    auto place = [&](const MeshEntry& e, uint32_t proto) {
        const Affine toWorld = e.hasTransform ? e.transform : Affine{};
        const size_t before = instances->Instances().size();
        try {
            instances->AddInstance(proto, toWorld);
        } catch (const Error& err) {
            r.Fail(e.path, err.what());  // the reference past the ids' limit
        }
        const Bounds3& b = instances->Instances()[before].bounds;
        if (!IsFinite(b.lo) || !IsFinite(b.hi)) r.Fail(e.path, "the transform makes coordinates non-finite (too large)");
    };
    std::unordered_map<std::string, LoadedMesh> imported;
    std::unordered_set<std::string> said;  // the clean-up's warnings, once per file and message
    // A warning about a file's references (a pattern that excluded nothing, every mesh
    // excluded) is said once, at its first reference, with the count of the others: one
    // pattern over 1,024 references printed 1,024 to 3,072 lines.
    std::vector<std::pair<std::string, size_t>> repeated;  // (message, references), in order
    std::unordered_map<std::string, size_t> repeatedAt;
    auto warnOnce = [&](const std::string& key, const std::string& message) {
        const auto [at, added] = repeatedAt.try_emplace(key, repeated.size());
        if (added) repeated.push_back({message, 0});
        ++repeated[at->second].second;
    };
    TextureCache textureCache;  // each image read once, however many models name it
    for (const MeshEntry& e : entries) {
        const std::string filePath = e.path + "/file";
        const std::string key = importKey(e);
        const bool again = imported.count(key) > 0;
        LoadedMesh loaded;
        if (again) {
            if (--importsLeft[key] == 0) {
                loaded = std::move(imported[key]);
                imported.erase(key);
            } else {
                loaded = imported[key];
            }
        } else {
            try {
                loaded = options.loadMesh ? options.loadMesh(e.resolved, e.load)
                                          : LoadMeshFile(e.resolved, e.load);
            } catch (const MeshFileError& err) {
                if (err.Unreadable())
                    r.Fail(filePath, "cannot read " + Quoted(e.file) + ": " + err.Reason());
                r.Fail(filePath, Quoted(e.file) + ": " + err.Reason());
            }
            for (const std::string& w : loaded.warnings) r.Warn(w);
            if (--importsLeft[key] > 0) imported[key] = loaded;
        }
        // Patterns that excluded nothing are probably typos.
        auto warnUnmatched = [&](const char* key, const std::vector<std::string>& patterns,
                                 const std::vector<bool>& matched, bool list, const char* what) {
            for (size_t k = 0; k < patterns.size(); ++k) {
                if (matched[k]) continue;
                const std::string path =
                    e.path + "/" + key + (list ? "/" + std::to_string(k) : std::string());
                warnOnce(std::string(key) + '\0' + patterns[k] + '\0' + e.file,
                         r.Where(path) + ": pattern " + Quoted(patterns[k]) + " matched no " + what + " of " +
                             Quoted(e.file));
            }
        };
        warnUnmatched("exclude_materials", e.load.excludeMaterials, loaded.excludeMaterialsMatched,
                      e.excludeMaterialsIsList, "material");
        warnUnmatched("exclude_names", e.load.excludeNames, loaded.excludeNamesMatched,
                      e.excludeNamesIsList, "node or mesh");
        scene.report.meshesExcluded += loaded.meshesExcluded;
        scene.report.sources.push_back(e.resolved);
        if (loaded.mesh.TriangleCount() == 0) {
            warnOnce(std::string("excluded") + '\0' + key, r.Where(e.path) + ": every mesh of " + Quoted(e.file) + " was excluded");
            continue;
        }
        const std::string group = groupKey(e);
        if (const auto p = prototypeOf.find(group); p != prototypeOf.end()) {
            place(e, p->second);
            continue;
        }
        const bool texturesOn = options.textures && scene.render.textures && e.material < 0;
        const bool instanced = options.instancing && scene.render.instancing &&
                               InstancesSaveMemory(groupRefs[group], loaded.mesh.TriangleCount());
        if (!instanced && copiedGroups.insert(group).second) {
            const uint64_t refs = static_cast<uint64_t>(groupRefs[group]);
            copiedTriangles += refs * loaded.mesh.TriangleCount();
            if (const std::string over = CopiesOverBudget(copiedTriangles); !over.empty()) {
                const std::string why = !options.instancing      ? " (" + options.noInstancingBy + ")"
                                        : !scene.render.instancing ? " (\"instancing\": false at /render/instancing)"
                                                                   : "";
                const std::string hint = !options.instancing || !scene.render.instancing
                                             ? "; with instancing on, a file referenced many times is placed as "
                                               "instances of one import"
                                             : "";
                r.Fail(e.path, Quoted(e.file) +
                                   StringPrintf(" (%s triangles) is referenced %s times and copied each time%s: the "
                                                "scene's copies, %s triangles, ",
                                                FormatCount(loaded.mesh.TriangleCount()).c_str(),
                                                FormatCount(refs).c_str(), why.c_str(),
                                                FormatCount(copiedTriangles).c_str()) +
                                   over + hint);
            }
        }
        if (e.hasTransform && !instanced) {
            TransformMesh(&loaded.mesh, e.transform);
            for (const Vec3& p : loaded.mesh.positions)
                if (!IsFinite(p))
                    r.Fail(e.path, "the transform makes coordinates non-finite (too large)");
        }
        const CleanReport clean = CleanMesh(&loaded.mesh);
        scene.report.degenerateRemoved += clean.degenerate;
        scene.report.duplicatesRemoved += clean.duplicate;
        if (clean.degenerate || clean.duplicate)
            if (const std::string w = e.resolved + ": " + DroppedMessage(clean); said.insert(w).second) r.Warn(w);
        // A file material the scene replaces by name reads no image (its look is the scene's).
        for (Material& m : loaded.materials)
            if (std::find(materialNames.begin(), materialNames.end(), m.name) != materialNames.end())
                m.texture = m.alphaTexture = -1;
        AttachTextures(r, e.resolved, texturesOn, &textureCache, &loaded, &scene);
        if (e.material >= 0) {
            std::fill(loaded.mesh.materialIds.begin(), loaded.mesh.materialIds.end(),
                      static_cast<uint32_t>(e.material));
        } else {
            // A file material named like one of the scene's "materials" takes the scene's
            // definition (how real models get their look without editing them); the
            // others are appended as the file defines them.
            std::vector<uint32_t> remap(loaded.materials.size());
            for (size_t m = 0; m < loaded.materials.size(); ++m) {
                const auto named = std::find(materialNames.begin(), materialNames.end(), loaded.materials[m].name);
                if (named != materialNames.end()) {
                    remap[m] = static_cast<uint32_t>(named - materialNames.begin());
                } else {
                    remap[m] = static_cast<uint32_t>(scene.materials.size());
                    scene.materials.push_back(loaded.materials[m]);
                }
            }
            for (uint32_t& id : loaded.mesh.materialIds) id = remap[id];
        }
        if (instanced) {
            if (!instances) instances = std::make_shared<InstancedMeshes>();
            // Its cut-outs in its own ids (the scene's mask answers for its instances).
            loaded.mesh.cutouts = MakeCutouts(loaded.mesh, scene, nullptr);
            const uint32_t proto = instances->AddPrototype(std::move(loaded.mesh));
            prototypeOf[group] = proto;
            place(e, proto);
            continue;
        }
        scene.mesh.Append(loaded.mesh);
    }
    for (const auto& [message, count] : repeated)
        r.Warn(count == 1 ? message
                          : message + " (and in " + FormatCount(count - 1) +
                                (count == 2 ? " other reference to it)" : " other references to it)"));
    // Triangles repeated across meshes (the same file placed twice at the same spot).
    const CleanReport across = CleanMesh(&scene.mesh);
    scene.report.degenerateRemoved += across.degenerate;
    scene.report.duplicatesRemoved += across.duplicate;
    if (across.duplicate)
        r.Warn(spec + ": dropped " + FormatCount(across.duplicate) +
               (across.duplicate == 1 ? " triangle that duplicates a triangle of another mesh"
                                      : " triangles that duplicate triangles of another mesh"));
    if (instances) {
        instances->HarmoniseAttributes(&scene.mesh);
        scene.mesh.instances = std::move(instances);
    }
    if (scene.mesh.PrimCount() == 0) r.Fail("/meshes", NoTrianglesMessage(scene.report, scene.mesh));
    CheckExtent(r, "/meshes", scene);

    if (ground.present) {
        const Bounds3 box = scene.mesh.Bounds();
        uint32_t material;
        if (ground.material >= 0) {
            material = static_cast<uint32_t>(ground.material);
        } else {
            material = static_cast<uint32_t>(scene.materials.size());
            scene.materials.push_back(GroundMaterial());
        }
        const float height = ground.hasHeight ? ground.height : box.lo[ground.axis];
        if (!ground.hasHeight)
            scene.report.notes.push_back(StringPrintf(
                "ground plane at %c = %g, the scene's lowest point", 'x' + ground.axis, height));
        AddGround(&scene, box, ground.axis, height, ground.size, material);
        // The slab's size and height were each checked as numbers; what reaches the rays
        // is the slab, so it is checked as coordinates (the check above saw the meshes).
        const Bounds3 all = scene.mesh.Bounds();
        const float reach = std::max(Reach(all.lo), Reach(all.hi));
        if (!(reach <= kMaxCoordinate)) {
            const bool byHeight = !(std::abs(height) <= kMaxCoordinate);
            r.Fail(byHeight ? "/ground/height" : "/ground/size",
                   StringPrintf("the ground slab reaches %g, beyond the ±%g that single-precision "
                                "rendering allows",
                                double(reach), double(kMaxCoordinate)));
        }
    }
    BuildCutouts(&scene);  // before the inside test: a cut-out surface is not a wall
    PlaceSuns(&scene, scene.mesh.Bounds());
    for (size_t i = 0; i < scene.lights.size(); ++i)
        if (scene.lights[i].kind == LightKind::Sun)
            if (std::string p = CoordinateProblem(scene.lights[i].position, "the sun's far sphere"); !p.empty())
                r.Fail(Index("/lights", i) + "/sun", p + " (the scene is too large for the sun's distance, " +
                                                         StringPrintf("%g times its size)", double(kSunDistanceFactor)));
    if (std::string p = SpanProblem(scene); !p.empty()) r.Fail("", p);
    CheckLightsOutsideSolids(r, scene);
    SizeUnsizedLights(&scene, unsized);
    return scene;
}

Scene LoadBuiltin(const std::string& spec, std::vector<std::string>* warnings) {
    const Reader r(spec, SceneLoadOptions{}.strict, warnings);
    Scene scene = MakeBuiltinScene(std::string_view(spec).substr(std::strlen("builtin:")));
    if (scene.name.empty()) scene.name = spec;
    if (scene.report.sources.empty()) scene.report.sources.push_back(spec);
    const CleanReport clean = CleanMesh(&scene.mesh);
    scene.report.degenerateRemoved += clean.degenerate;
    scene.report.duplicatesRemoved += clean.duplicate;
    if (clean.degenerate || clean.duplicate) r.Warn(spec + ": " + DroppedMessage(clean));
    if (scene.mesh.TriangleCount() == 0) r.Fail("", NoTrianglesMessage(scene.report, scene.mesh));
    CheckExtent(r, "", scene);
    return scene;
}

}  // namespace

float DefaultLightRadius(const Bounds3& sceneBounds, const Vec3& position) {
    return kDefaultLightRadiusShare * Length(position - sceneBounds.Center());
}

std::string ModelCacheDir() {
    const std::string dir = CacheDir("models");
    return dir.empty() ? "lightmesh-models" : dir;
}

void ReadRenderSettings(const std::string& origin, const std::string& jsonText, RenderOptions* options,
                        std::vector<std::string>* warnings) {
    Reader r(origin, /*strict=*/true, warnings);
    const Json j = ParseJson(r, jsonText);
    ReadRender(r, j, options, "");
}

Scene LoadScene(const std::string& spec, const SceneLoadOptions& options,
                std::vector<std::string>* warnings) {
    if (spec.empty())
        ThrowError("no scene given: expected builtin:NAME, a .json scene file or a mesh file");
    try {
        Scene scene;
        const bool bare = spec.rfind("builtin:", 0) != 0 && Lower(fs::path(spec).extension().string()) != ".json";
        if (!options.camera.empty() && !bare)
            throw Error(spec + ": --camera " + options.camera +
                        ": picks one of a mesh file's own cameras; a scene file or builtin scene has its camera");
        if (spec.rfind("builtin:", 0) == 0)
            scene = LoadBuiltin(spec, warnings);
        else if (Lower(fs::path(spec).extension().string()) == ".json")
            scene = LoadJsonScene(spec, options, warnings);
        else
            scene = LoadBareMesh(spec, options, warnings);
        Validate(scene);
        return scene;
    } catch (const Error&) {
        throw;
    } catch (const std::bad_alloc&) {
        const uint64_t budget = PhysicalMemoryBytes();
        throw Error(spec + ": out of memory while loading the scene (peak " +
                    FormatBytes(PeakMemoryBytes()) + ", budget " +
                    (budget ? FormatBytes(budget) : std::string("unknown")) +
                    "; LIGHTMESH_MEMORY_LIMIT lowers it)");
    } catch (const std::filesystem::filesystem_error& e) {
        throw Error(spec + ": " + e.path1().string() + ": " + e.code().message());
    } catch (const std::exception& e) {
        // Nothing but an Error may leave the loader.
        throw Error(spec + ": " + e.what());
    }
}

}  // namespace lm
