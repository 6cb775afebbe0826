// scene_load.h -- the scene loader's pieces shared by its files (not part of the scene
// interface): the checks every scene passes before a ray is traced (scene_checks.cpp) and
// the automatic framing of a bare mesh with its ground slab (framing.cpp); the JSON format
// itself is scene_file.cpp and the files of scene_file_parts.h.
#pragma once

#include <string>

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/scene/scene_file.h"

namespace lm::scene_load {

// Squared distances between points must stay finite in float (max 3.4e38), and Embree
// asserts on ray origins and directions beyond ±1.844e18: every coordinate that reaches a
// ray (mesh, ground, camera, lights, automatic framing) stays within ±1e18.
inline constexpr float kMaxCoordinate = 1e18f;

// ---- Checks (scene_checks.cpp) ---------------------------------------------------------
std::string FormatVec(const Vec3& v);
/// "dropped N degenerate (zero-area) and M duplicate triangles", for the loader's warning.
std::string DroppedMessage(const CleanReport& c);
/// The largest absolute coordinate of p.
float Reach(const Vec3& p);
/// "" when p can be used in a ray, else why not.
std::string CoordinateProblem(const Vec3& p, const char* what);
/// Why the camera cannot form an image, or "" if it can; `*key` is the key to blame.
std::string CameraProblem(const Camera& c, std::string* key);
/// Why the span of the mesh, the lights and the camera is too large for rays, or "".
std::string SpanProblem(const Scene& scene);
/// Fails (at JSON path `path`) when the mesh reaches beyond kMaxCoordinate.
void CheckExtent(const json::Reader& r, const std::string& path, const Scene& scene);
/// Fails on the first light inside a closed solid, at `lightsPath`/N/position ("" when the
/// lights are not the file's own: at the file).
void CheckLightsOutsideSolids(const json::Reader& r, const Scene& scene, const std::string& lightsPath = "/lights");
/// "no triangles", with the reason when one is known.
std::string NoTrianglesMessage(const SceneReport& report, const TriangleMesh& mesh);
/// Checks that hold for every scene, whatever its source.
void Validate(const Scene& scene);

// ---- Textures (scene_textures.cpp) -----------------------------------------------------
/// Reads the images of `loaded`'s materials through `cache` into scene->textures (each
/// once) and points the materials' `texture` at them; an image that cannot be read gets a
/// warning (through `r`) and its material the flat colour. With `enabled` false, or when no
/// material keeps an image, the materials lose their textures and the mesh its texture
/// coordinates (an untextured scene carries none).
void AttachTextures(const json::Reader& r, const std::string& model, bool enabled, TextureCache* cache,
                    LoadedMesh* loaded, Scene* scene);

/// The mesh's cut-outs (TriangleMesh::cutouts) from the materials' alpha images: called
/// once the mesh is final (ground included). No cut-out material, no mask. With instances,
/// also when only their prototypes (whose masks MakeCutouts built) have cut-outs.
void BuildCutouts(Scene* scene);
/// The cut-outs of `mesh`'s flat triangles by `scene`'s materials and images; null when
/// none is cut out and `instances` (the mesh's) hold no prototype with cut-outs.
std::shared_ptr<const CutoutMask> MakeCutouts(const TriangleMesh& mesh, const Scene& scene,
                                              std::shared_ptr<const InstancedMeshes> instances);

// ---- Spots and the sun in scene files (light_keys.cpp) ---------------------------------
/// The largest angular radius a scene file's sun may have, degrees.
inline constexpr float kMaxSunAngleDegrees = 45.0f;
/// A light's "spot" object at `path`: {"direction" (required, non-zero), "outer" (degrees,
/// (0, 90], default 45), "inner" (degrees, [0, outer], default 0)} into light->spot.
void ReadSpotKey(const json::Reader& r, const Json& j, const std::string& path, PointLight* light);
/// A light's "sun" object at `path`: {"direction" (required, non-zero: where the light
/// travels), "angle" (angular radius, degrees, [0, kMaxSunAngleDegrees], default
/// kSunAngleDegrees)} into light->sun; the light becomes a Sun (placed by PlaceSuns).
void ReadSunKey(const json::Reader& r, const Json& j, const std::string& path, PointLight* light);

// ---- Ground slab and framing (framing.cpp) ---------------------------------------------
/// A thin closed slab under `box` whose top face is the ground at `height` along `axis`.
void AddGround(Scene* scene, const Bounds3& box, int axis, float height, float sizeFactor, uint32_t material);
/// The default ground material (light grey).
Material GroundMaterial();
/// The automatic camera: a three-quarter view of `box` from the front, with a note.
void FrameCamera(const json::Reader& r, const Bounds3& box, float aspect, float fovY, Scene* scene);
/// A file's camera `fc` (number `index` in its file) as *camera for an image of `aspect`:
/// the problem that keeps it from being used ("" when none). *which names it for messages
/// and notes ("camera 1 \"Top\"").
std::string TakeFileCamera(const FileCamera& fc, int index, float aspect, Camera* camera, std::string* which);
/// The automatic lights: a key light and a fill light above `box`, with a note.
void AddKeyAndFillLights(const json::Reader& r, const Bounds3& box, Scene* scene);
/// A bare mesh: frame it with a camera, a ground plane and two lights.
Scene LoadBareMesh(const std::string& spec, const SceneLoadOptions& options, std::vector<std::string>* warnings);

}  // namespace lm::scene_load
