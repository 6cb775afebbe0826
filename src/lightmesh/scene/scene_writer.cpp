// scene_writer.cpp -- a rendered scene written back as a scene file (scene_writer.h).
#include "lightmesh/scene/scene_writer.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "lightmesh/scene/camera_overrides.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

namespace fs = std::filesystem;
using OJson = nlohmann::ordered_json;

// A float as the shortest decimal that reads back as the same float (std::to_chars), held
// as the double of that decimal, which JSON prints in its own shortest form: 0.1f is
// written 0.1, not 0.100000001.
OJson Num(float f) {
    char text[64];
    const auto end = std::to_chars(text, text + sizeof text, f).ptr;
    *end = 0;
    return OJson(std::strtod(text, nullptr));
}

OJson Vec(const Vec3& v) { return OJson::array({Num(v.x), Num(v.y), Num(v.z)}); }
OJson Col(const Color& c) {
    if (c.r == c.g && c.g == c.b) return Num(c.r);
    return OJson::array({Num(c.r), Num(c.g), Num(c.b)});
}

bool IsBuiltin(const std::string& spec) { return spec.rfind("builtin:", 0) == 0; }
bool IsSceneFile(const std::string& spec) { return json::Lower(fs::path(spec).extension().string()) == ".json"; }

// `file`, a path relative to folder `from` (or absolute), as a path relative to folder `to`
// (absolute when no relative path leads there).
std::string Rebased(const std::string& file, const fs::path& from, const fs::path& to) {
    if (file.rfind("cache:", 0) == 0 || fs::path(file).is_absolute()) return file;
    std::error_code ec;
    const fs::path absolute = fs::absolute(from / file, ec).lexically_normal();
    if (ec) return file;
    const fs::path folder = fs::absolute(to, ec).lexically_normal();
    const fs::path relative = absolute.lexically_relative(folder);
    // Relative where both share a folder below the root (a scene beside or near its
    // model), else absolute (/tmp/x.json and /home/me/model.obj).
    const bool near = std::distance(absolute.begin(), absolute.end()) > 2 &&
                      std::distance(folder.begin(), folder.end()) > 1 && *std::next(absolute.begin()) == *std::next(folder.begin());
    return relative.empty() || ec || !near ? absolute.string() : relative.generic_string();
}

OJson CameraJson(const Camera& c) {
    OJson j;
    j["position"] = Vec(c.position);
    j["look_at"] = Vec(c.lookAt);
    j["up"] = Vec(c.up);
    j["fov"] = Num(c.fovY);
    return j;
}

// One light, over `j` (a scene file's own light object, whose other keys, a name, stay).
OJson LightJson(const PointLight& l, OJson j) {
    j["intensity"] = Col(l.intensity);
    if (l.kind == LightKind::Sun) {  // at infinity: its far sphere is placed again on loading
        for (const char* key : {"position", "falloff", "radius", "range", "spot"}) j.erase(key);
        j["sun"] = OJson{{"direction", Vec(l.sun.statedDirection)}, {"angle", Num(l.sun.angleDegrees)}};
        return j;
    }
    j.erase("sun");
    if (l.kind == LightKind::Spot)
        j["spot"] = OJson{{"direction", Vec(l.spot.statedDirection)},
                          {"inner", Num(l.spot.innerDegrees)},
                          {"outer", Num(l.spot.outerDegrees)}};
    else
        j.erase("spot");
    j["position"] = Vec(l.position);
    j["falloff"] = l.falloff == Falloff::None ? "none" : "inverse_square";
    j["radius"] = Num(l.radius);
    if (std::isfinite(l.range)) j["range"] = Num(l.range);
    else j.erase("range");
    return j;
}

// The settings table's keys the render set (its origins), with the values it used; width
// and height always (a bare mesh was framed for them).
OJson RenderJson(const RenderOptions& o, const SceneSource& source) {
    OJson j;
    j["width"] = o.width;
    j["height"] = o.height;
    auto set = [&](const char* key) { return o.origins.count(key) > 0; };
    if (set("aa")) j["aa"] = o.aa;
    if (set("max_depth")) j["max_depth"] = o.maxDepth;
    if (set("shadows")) j["shadows"] = o.shadows;
    if (set("accel")) j["accel"] = o.accel;
    if (set("grid")) j["grid"] = o.accelOptions.gridResolution;
    if (set("cc")) j["cc"] = o.lightMesh.cc;
    if (set("ki")) j["ki"] = Num(o.lightMesh.ki);
    if (set("variant") && !o.lightMesh.variant.empty()) j["variant"] = o.lightMesh.variant;
    if (set("ns")) j["ns"] = o.lightMesh.ns;
    if (set("template_dir")) j["template_dir"] = o.lightMesh.templateDir;
    if (set("cell_summaries")) j["cell_summaries"] = o.lightMesh.cellSummaries;
    if (o.areaLight.radius) j["light_radius"] = Num(*o.areaLight.radius);
    if (set("thin_check")) j["thin_check"] = o.lightMesh.thinCheck;
    if (set("samples")) j["samples"] = o.areaLight.samples;
    if (set("soft_samples")) j["soft_samples"] = o.soft.samples;
    if (set("light_cut")) j["light_cut"] = Num(o.lightCut);
    if (!o.textures || !source.textures) j["textures"] = false;
    if (!o.instancing || !source.instancing) j["instancing"] = false;
    if (o.exposure != 0) j["exposure"] = Num(o.exposure);
    if (o.tonemap != "clamp") j["tonemap"] = o.tonemap;
    return j;
}

OJson AffineJson(const Affine& a) {
    OJson m = OJson::array();
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) m.push_back(Num(a.m[r][c]));
    for (float v : {0.0f, 0.0f, 0.0f, 1.0f}) m.push_back(Num(v));
    return m;
}

// A bare mesh: its file, the --up turn, the ground the framing added.
OJson BareMeshScene(const Scene& scene, const SceneSource& source, const fs::path& to) {
    OJson root;
    OJson mesh;
    mesh["file"] = Rebased(source.spec, fs::current_path(), to);
    if (source.upAxis != 1) mesh["matrix"] = AffineJson(UpAxisToY(source.upAxis));
    const float smooth = source.smoothNormals >= 0 ? source.smoothNormals : kBareMeshSmoothNormals;
    if (smooth > 0) mesh["smooth_normals"] = Num(smooth);
    root["meshes"] = OJson::array({mesh});
    if (scene.ground) {
        OJson g;
        g["up"] = std::string(1, static_cast<char>('x' + scene.ground->axis));
        g["height"] = Num(scene.ground->height);
        g["size"] = Num(scene.ground->size);
        root["ground"] = g;
    }
    return root;
}

// A scene file: its own keys, its mesh paths made relative to the new file's folder.
OJson SceneFileKeys(const SceneSource& source, const fs::path& to) {
    OJson root = OJson::parse(ReadRegularFile(source.spec, "scene file"));
    const fs::path from = fs::path(source.spec).parent_path();
    if (root.contains("meshes") && root["meshes"].is_array())
        for (OJson& m : root["meshes"])
            if (m.is_object() && m.contains("file") && m["file"].is_string()) {
                m["file"] = Rebased(m["file"].get<std::string>(), from.empty() ? fs::path(".") : from, to);
                if (source.smoothNormals >= 0) m["smooth_normals"] = Num(source.smoothNormals);  // --smooth-normals won
            }
    return root;
}

// `j` as JSON text, indented by two spaces a level, with lists of numbers and strings
// (positions, colours, matrices) on one line.
void Write(const OJson& j, int indent, std::string* out) {
    const std::string pad(static_cast<size_t>(indent) + 2, ' ');
    if (j.is_object() && !j.empty()) {
        *out += "{\n";
        size_t i = 0;
        for (auto it = j.begin(); it != j.end(); ++it, ++i) {
            *out += pad + OJson(it.key()).dump() + ": ";
            Write(it.value(), indent + 2, out);
            *out += i + 1 < j.size() ? ",\n" : "\n";
        }
        *out += std::string(static_cast<size_t>(indent), ' ') + "}";
    } else if (j.is_array() && !j.empty() &&
               !std::all_of(j.begin(), j.end(), [](const OJson& e) { return e.is_primitive(); })) {
        *out += "[\n";
        for (size_t i = 0; i < j.size(); ++i) {
            *out += pad;
            Write(j[i], indent + 2, out);
            *out += i + 1 < j.size() ? ",\n" : "\n";
        }
        *out += std::string(static_cast<size_t>(indent), ' ') + "]";
    } else if (j.is_array()) {
        *out += "[";
        for (size_t i = 0; i < j.size(); ++i) *out += (i ? ", " : "") + j[i].dump();
        *out += "]";
    } else {
        *out += j.dump();
    }
}

}  // namespace

void CheckSceneSaveable(const std::string& path, const SceneSource& source, const char* flag) {
    if (IsBuiltin(source.spec))
        ThrowError("%s: %s is made by code, not read from files, so no scene file can refer to it; save a scene "
                   "file's or a mesh file's render",
                   flag, source.spec.c_str());
    if (!IsSceneFile(path)) ThrowError("%s %s: expected a .json file name", flag, Printable(path).c_str());
    std::error_code ec;
    if (fs::is_directory(path, ec)) ThrowErrorAt({path}, "is a folder, not a file");
    CheckWritableFolder(path);
}

std::string SceneFileText(const Scene& scene, const RenderOptions& options, const SceneSource& source,
                          const std::string& path) {
    fs::path to = fs::path(path).parent_path();
    if (to.empty()) to = ".";
    OJson root = IsSceneFile(source.spec) ? SceneFileKeys(source, to) : BareMeshScene(scene, source, to);
    OJson out;
    // The camera, lights and render settings as rendered; the scene's other keys after them.
    out["camera"] = CameraJson(scene.camera);
    const OJson* ownLights = root.contains("lights") && root["lights"].is_array() &&
                                    root["lights"].size() == scene.lights.size()
                                ? &root["lights"]
                                : nullptr;
    OJson lights = OJson::array();
    for (size_t i = 0; i < scene.lights.size(); ++i)
        lights.push_back(LightJson(scene.lights[i], ownLights && (*ownLights)[i].is_object() ? (*ownLights)[i] : OJson::object()));
    out["lights"] = lights;
    out["ambient"] = Col(scene.ambient);
    out["background"] = Col(scene.background);
    for (auto it = root.begin(); it != root.end(); ++it)
        if (it.key() != "camera" && it.key() != "lights" && it.key() != "render" && it.key() != "ambient" &&
            it.key() != "background")
            out[it.key()] = it.value();
    out["render"] = RenderJson(options, source);
    std::string text;
    Write(out, 0, &text);
    return text + "\n";
}

void WriteSceneFile(const std::string& path, const Scene& scene, const RenderOptions& options,
                    const SceneSource& source) {
    const std::string text = SceneFileText(scene, options, source, path);
    WriteFileAtomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp, std::ios::binary);
        out << text;
        out.close();
        if (!out) ThrowErrorAt({path}, "cannot be written");
    });
}

}  // namespace lm
