// scene_sections.cpp -- the readers of a JSON scene file's sections, one function per
// object ("camera", "materials", "lights", "meshes"' entries, "ground", "render"), each
// checking its values and naming the JSON path of the first mistake.
#include "lightmesh/scene/scene_file_parts.h"
#include "lightmesh/scene/scene_load.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm::scene_load {

namespace fs = std::filesystem;
using namespace json;  // Reader, Object, the value readers

namespace {

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

}  // namespace

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
    return ReadRegularFile(path, "scene file");
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

void ReadRender(const Reader& r, const Json& j, RenderOptions* ro, const std::string& path) {
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
    if (const Json* v = o.Find("light_cut")) ro->lightCut = number(*v, "light_cut");
    if (const Json* v = o.Find("textures")) ro->textures = Bool(r, *v, o.Child("textures"));
    if (const Json* v = o.Find("instancing")) ro->instancing = Bool(r, *v, o.Child("instancing"));
    if (const Json* v = o.Find("exposure")) ro->exposure = number(*v, "exposure");
    if (const Json* v = o.Find("tonemap")) ro->tonemap = choice(*v, "tonemap");
    // Where each value came from, for the messages of the factories that read it.
    for (const RenderSetting& s : RenderSettings())
        if (o.Find(s.key)) ro->origins[s.key] = SourceLoc(r.File(), 0, 0, o.Child(s.key));
    o.Finish();
}

void ReadMaterials(const Reader& r, const Json& j, Scene* scene, std::vector<std::string>* names) {
    Object mats(r, j, "/materials");
    for (const std::string& name : r.KeysInOrder("/materials", j)) {
        const Json& value = *mats.Find(name);
        scene->materials.push_back(ReadMaterial(r, value, mats.Child(name), name));
        names->push_back(name);
    }
    mats.Finish();
}

void ReadLights(const Reader& r, const Json& lj, Scene* scene, std::vector<size_t>* unsized) {
    if (!lj.is_array()) r.Fail("/lights", "expected a list of lights [...], got " + Describe(lj));
    if (lj.empty()) r.Fail("/lights", "a scene needs at least one light, got an empty list");
    for (size_t i = 0; i < lj.size(); ++i) {
        bool hasRadius = false;
        scene->lights.push_back(ReadLight(r, lj[i], Index("/lights", i), &hasRadius));
        if (!hasRadius) unsized->push_back(i);
    }
}

MeshEntry ReadMeshEntry(const Reader& r, const Json& j, const std::string& path, const std::string& folder,
                        const SceneLoadOptions& options, const std::vector<std::string>& materialNames) {
    MeshEntry e;
    e.load.smoothAngle = options.smoothNormals;
    e.path = path;
    Object o(r, j, e.path);
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
        e.resolved = fs::path(e.file).is_absolute() ? e.file : (fs::path(folder) / e.file).string();
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
    if (const Json* v = o.Find("smooth_normals")) {
        const double degrees = Number(r, *v, o.Child("smooth_normals"));
        if (!(degrees >= 0 && degrees <= 180))
            r.Fail(o.Child("smooth_normals"), StringPrintf("must be 0 to 180 degrees, got %g", degrees));
        if (options.smoothNormals < 0) e.load.smoothAngle = static_cast<float>(degrees);  // the CLI's wins
    }
    o.Finish();
    return e;
}

GroundEntry ReadGround(const Reader& r, const Json& j, const std::vector<std::string>& materialNames) {
    GroundEntry ground;
    Object o(r, j, "/ground");
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
    return ground;
}

}  // namespace lm::scene_load
