// scene_file.cpp -- the JSON scene format: its reference below, and the assembling of a
// scene from its sections (read by scene_sections.cpp) and its mesh files (loaded by
// scene_meshes.cpp); the checks and the framing of bare meshes are scene_checks.cpp and
// framing.cpp.
//
//
// A scene file is one JSON object (keys in any order; "name" is also allowed on lights
// and meshes):
//
//   "camera"     {"position": [x,y,z], "look_at": [x,y,z]} both required;
//                "up" (default [0,1,0], not parallel to the view direction), "fov" (vertical,
//                degrees, in (0, 180), default 45). Without it: the camera of the first mesh
//                file that has cameras (--camera picks which), moved by its entry's
//                transform; none: the meshes framed as a bare mesh is.
//   "ambient"    colour, default 0.05.        "background"  colour, default 0.
//   "materials"  {NAME: {"kd": colour (0.8), "ks": colour (0), "phong": number ≥ 0 (32),
//                "mirror": colour (0)}, ...}.
//   "lights"     ≥ 1 (without it: every mesh file's own lights, each moved by its entry's
//                transform; none: a key and a fill light as for a bare mesh):
//                [{"position": [x,y,z] (required), "intensity": colour (1),
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
#include "lightmesh/scene/scene_file_parts.h"
#include "lightmesh/scene/scene_load.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "lightmesh/scene/demo_scene.h"
#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

namespace fs = std::filesystem;
using namespace json;  // Reader, Object, the value readers
using namespace scene_load;  // the sections, the mesh files, the checks and the framing

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

/// "meshes": a non-empty list of entries, each read before any file is loaded.
std::vector<MeshEntry> ReadMeshEntries(const Reader& r, Object* top, const std::string& spec,
                                       const SceneLoadOptions& options, const std::vector<std::string>& materialNames) {
    const Json& mj = top->Require("meshes", "a scene needs at least one mesh");
    if (!mj.is_array()) r.Fail("/meshes", "expected a list of meshes [...], got " + Describe(mj));
    if (mj.empty()) r.Fail("/meshes", "a scene needs at least one mesh, got an empty list");
    const std::string folder = fs::path(spec).parent_path().string();
    std::vector<MeshEntry> entries;
    for (size_t i = 0; i < mj.size(); ++i)
        entries.push_back(ReadMeshEntry(r, mj[i], Index("/meshes", i), folder, options, materialNames));
    return entries;
}

/// The "ground" slab under the loaded meshes.
void AddSceneGround(const Reader& r, const GroundEntry& ground, Scene* scene) {
    const Bounds3 box = scene->mesh.Bounds();
    uint32_t material;
    if (ground.material >= 0) {
        material = static_cast<uint32_t>(ground.material);
    } else {
        material = static_cast<uint32_t>(scene->materials.size());
        scene->materials.push_back(GroundMaterial());
    }
    const float height = ground.hasHeight ? ground.height : box.lo[ground.axis];
    if (!ground.hasHeight)
        scene->report.notes.push_back(StringPrintf(
            "ground plane at %c = %g, the scene's lowest point", 'x' + ground.axis, height));
    AddGround(scene, box, ground.axis, height, ground.size, material);
    // The slab's size and height were each checked as numbers; what reaches the rays
    // is the slab, so it is checked as coordinates (the check above saw the meshes).
    const Bounds3 all = scene->mesh.Bounds();
    const float reach = std::max(Reach(all.lo), Reach(all.hi));
    if (!(reach <= kMaxCoordinate)) {
        const bool byHeight = !(std::abs(height) <= kMaxCoordinate);
        r.Fail(byHeight ? "/ground/height" : "/ground/size",
               StringPrintf("the ground slab reaches %g, beyond the ±%g that single-precision "
                            "rendering allows",
                            double(reach), double(kMaxCoordinate)));
    }
}

/// A scene file without "camera": its mesh files' camera, else the automatic framing of
/// the meshes (`box`, without the ground) for the image's aspect.
void CameraFromMeshFiles(const Reader& r, const SceneLoadOptions& options, const std::vector<EntryCamerasLights>& kept,
                         const Bounds3& box, Scene* scene) {
    const bool hinted = options.frameWidth > 0 && options.frameHeight > 0;
    const float aspect =
        hinted ? static_cast<float>(options.frameWidth) / static_cast<float>(options.frameHeight)
               : static_cast<float>(scene->render.width) / static_cast<float>(scene->render.height);
    if (UseMeshFileCamera(r, kept, options, aspect, scene)) return;
    scene->report.notes.push_back("no \"camera\" in the scene file or its mesh files: framing the meshes automatically");
    FrameCamera(r, box, aspect, options.frameFovY, scene);
}

/// A scene file without "lights": its mesh files' lights, sized from the scene's bounds
/// (ground included, as "radius" is for the file's own lights), else the key and fill
/// lights above the meshes (`box`).
void LightsFromMeshFiles(const Reader& r, const std::vector<EntryCamerasLights>& kept, const Bounds3& box,
                         Scene* scene) {
    if (UseMeshFileLights(r, kept, scene->mesh.Bounds(), scene)) return;
    scene->report.notes.push_back("no \"lights\" in the scene file or its mesh files: a key and a fill light");
    AddKeyAndFillLights(r, box, scene);
}

/// The finished mesh's cut-outs, the suns placed, the whole scene checked, the lights
/// without a stated size sized. `ownLights`: the lights are the file's "lights" (the
/// messages name their JSON paths), not its mesh files'.
void FinishScene(const Reader& r, const std::vector<size_t>& unsized, bool ownLights, Scene* scene) {
    BuildCutouts(scene);  // before the inside test: a cut-out surface is not a wall
    PlaceSuns(scene, scene->mesh.Bounds());
    for (size_t i = 0; i < scene->lights.size(); ++i)
        if (scene->lights[i].kind == LightKind::Sun)
            if (std::string p = CoordinateProblem(scene->lights[i].position, "the sun's far sphere"); !p.empty())
                r.Fail(ownLights ? Index("/lights", i) + "/sun" : std::string(),
                       p + " (the scene is too large for the sun's distance, " +
                           StringPrintf("%g times its size)", double(kSunDistanceFactor)));
    if (std::string p = SpanProblem(*scene); !p.empty()) r.Fail("", p);
    CheckLightsOutsideSolids(r, *scene, ownLights ? "/lights" : "");
    SizeUnsizedLights(scene, unsized);
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
    // Without "camera" or "lights" the mesh files' own are used, else the automatic ones.
    const Json* cameraJson = top.Find("camera");
    if (cameraJson && !options.camera.empty())
        r.Fail("/camera", "--camera " + options.camera +
                              " picks one of a mesh file's own cameras; this scene file sets its \"camera\" (leave "
                              "the key out to use its mesh files' cameras)");
    if (cameraJson) scene.camera = ReadCamera(r, *cameraJson);
    if (const Json* v = top.Find("ambient")) scene.ambient = ReadColor(r, *v, "/ambient");
    if (const Json* v = top.Find("background")) scene.background = ReadColor(r, *v, "/background");
    // Free text for people (what the scene is, where its model comes from); not used.
    for (const char* key : {"name", "description", "source"})
        if (const Json* v = top.Find(key)) String(r, *v, "/" + std::string(key));
    std::vector<std::string> materialNames;
    if (const Json* mj = top.Find("materials")) ReadMaterials(r, *mj, &scene, &materialNames);
    std::vector<size_t> unsized;  // lights without "radius": sized once the bounds are known
    const Json* lightsJson = top.Find("lights");
    if (lightsJson) ReadLights(r, *lightsJson, &scene, &unsized);
    const std::vector<MeshEntry> entries = ReadMeshEntries(r, &top, spec, options, materialNames);
    GroundEntry ground;
    if (const Json* gj = top.Find("ground")) ground = ReadGround(r, *gj, materialNames);
    if (const Json* v = top.Find("render")) ReadRender(r, *v, &scene.render);
    top.Finish();

    // Now the mesh files, JSON mistakes having been reported already.
    MeshAssembler meshes(r, options, entries, materialNames, &scene);
    meshes.KeepCamerasAndLights(!cameraJson, !lightsJson);
    for (const MeshEntry& e : entries) meshes.Add(e);
    meshes.Finish(spec);
    if (scene.mesh.PrimCount() == 0) r.Fail("/meshes", NoTrianglesMessage(scene.report, scene.mesh));
    CheckExtent(r, "/meshes", scene);
    const Bounds3 meshBox = scene.mesh.Bounds();
    if (!cameraJson) CameraFromMeshFiles(r, options, meshes.Kept(), meshBox, &scene);
    if (ground.present) AddSceneGround(r, ground, &scene);
    if (!lightsJson) LightsFromMeshFiles(r, meshes.Kept(), meshBox, &scene);
    FinishScene(r, unsized, lightsJson != nullptr, &scene);
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
        // A scene file's own "camera" and --camera: LoadJsonScene.
        if (!options.camera.empty() && spec.rfind("builtin:", 0) == 0)
            throw Error(spec + ": --camera " + options.camera +
                        ": picks one of a mesh file's own cameras; a builtin scene has its own camera");
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
