// scene_file_parts.h -- the JSON scene file's reader in parts (not part of the scene
// interface): the readers of its sections (scene_sections.cpp), the loading of its mesh
// files into one mesh (scene_meshes.cpp); scene_file.cpp assembles them.
#pragma once

#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "lightmesh/geometry/instances.h"
#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/scene/scene_file.h"

namespace lm::scene_load {

// ---- Sections (scene_sections.cpp) -----------------------------------------------------

/// One entry of "meshes", read before any file is loaded so JSON mistakes show up first.
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

/// The "ground" object.
struct GroundEntry {
    bool present = false;
    bool hasHeight = false;
    float height = 0;
    int axis = 1;
    float size = 3;
    int material = -1;
};

Vec3 ReadVec3(const json::Reader& r, const Json& j, const std::string& path);
/// A number (grey) or [r, g, b], each ≥ 0.
Color ReadColor(const json::Reader& r, const Json& j, const std::string& path);
/// The scene file's text (its errors name the file).
std::string ReadTextFile(const json::Reader& r, const std::string& path);
/// "camera", checked as a camera that forms an image.
Camera ReadCamera(const json::Reader& r, const Json& j);
/// "materials", in the file's order, into scene->materials; their names into *names.
void ReadMaterials(const json::Reader& r, const Json& j, Scene* scene, std::vector<std::string>* names);
/// "lights" (a non-empty list) into scene->lights; the indices of those without "radius"
/// into *unsized (they get the default once the meshes give the scene's bounds).
void ReadLights(const json::Reader& r, const Json& j, Scene* scene, std::vector<size_t>* unsized);
/// One entry of "meshes" at `path`; files are resolved against `folder`.
MeshEntry ReadMeshEntry(const json::Reader& r, const Json& j, const std::string& path, const std::string& folder,
                        const SceneLoadOptions& options, const std::vector<std::string>& materialNames);
/// "ground".
GroundEntry ReadGround(const json::Reader& r, const Json& j, const std::vector<std::string>& materialNames);
/// "render" (or, for ReadRenderSettings, an object of its keys at `path` "") into *ro.
void ReadRender(const json::Reader& r, const Json& j, RenderOptions* ro, const std::string& path = "/render");

// ---- Mesh files (scene_meshes.cpp) -----------------------------------------------------

/// The cameras and lights a mesh entry's file brings (file_cameras_lights.h), in the file's
/// space: the entry's transform is applied when they are used.
struct EntryCamerasLights {
    const MeshEntry* entry = nullptr;
    std::vector<FileCamera> cameras;
    std::vector<FileLight> lights;
};

/// Whether `refs` references to a file whose mesh holds `triangles` become instances of
/// one prototype rather than copies: where that saves memory (docs/scene-format.md).
bool InstancesSaveMemory(int refs, size_t triangles);

/// Loads the mesh files of a scene file's "meshes" into scene->mesh and scene->materials,
/// entry by entry (Add), then Finish. A file named by several entries with the same
/// exclude patterns (placed twice, say) is imported once, and its importer warnings are
/// said once; the import is kept until its last entry.
class MeshAssembler {
  public:
    MeshAssembler(const json::Reader& r, const SceneLoadOptions& options, const std::vector<MeshEntry>& entries,
                  const std::vector<std::string>& materialNames, Scene* scene);
    /// Keep the cameras of the first file that has some, and every file's lights, for
    /// Kept(): for a scene file without "camera" or without "lights".
    void KeepCamerasAndLights(bool cameras, bool lights) {
        keepCameras_ = cameras;
        keepLights_ = lights;
    }
    void Add(const MeshEntry& e);
    /// The warnings held back for their counts, the triangles repeated across meshes, the
    /// instances handed to the scene's mesh.
    void Finish(const std::string& spec);
    /// The entries whose files brought what KeepCamerasAndLights asked for, in "meshes"' order.
    const std::vector<EntryCamerasLights>& Kept() const { return kept_; }

  private:
    static std::string ImportKey(const MeshEntry& e);
    static std::string GroupKey(const MeshEntry& e);
    LoadedMesh Import(const MeshEntry& e, const std::string& key);
    void WarnOnce(const std::string& key, const std::string& message);
    void WarnUnmatched(const MeshEntry& e, const char* key, const std::vector<std::string>& patterns,
                       const std::vector<bool>& matched, bool list, const char* what);
    void CheckCopies(const MeshEntry& e, const std::string& group, size_t triangles);
    void Place(const MeshEntry& e, uint32_t proto);
    void AssignMaterials(const MeshEntry& e, LoadedMesh* loaded);

    const json::Reader& r_;
    const SceneLoadOptions& options_;
    const std::vector<std::string>& materialNames_;
    Scene* scene_;
    std::unordered_map<std::string, int> importsLeft_;
    std::unordered_map<std::string, int> groupRefs_;
    std::unordered_map<std::string, uint32_t> prototypeOf_;
    std::shared_ptr<InstancedMeshes> instances_;
    // The triangles the copied references will hold, counted at each file's first import
    // (its triangles times its references): past the budget the scene is refused there,
    // before the copies are made, rather than after minutes of copying and building when
    // memory runs out.
    uint64_t copiedTriangles_ = 0;
    std::unordered_set<std::string> copiedGroups_;
    std::unordered_map<std::string, LoadedMesh> imported_;
    std::unordered_set<std::string> said_;  // the clean-up's warnings, once per file and message
    // A warning about a file's references (a pattern that excluded nothing, every mesh
    // excluded) is said once, at its first reference, with the count of the others, so a
    // file placed a thousand times gives one line, not a thousand.
    std::vector<std::pair<std::string, size_t>> repeated_;  // (message, references), in order
    std::unordered_map<std::string, size_t> repeatedAt_;
    TextureCache textureCache_;  // each image read once, however many models name it
    bool keepCameras_ = false, keepLights_ = false;
    std::vector<EntryCamerasLights> kept_;
};

// ---- The mesh files' cameras and lights (scene_file_cameras_lights.cpp) ----------------

/// A scene file without "camera": the camera `options.camera` picks ("" the first
/// perspective one) of the first entry of `kept` whose file has cameras, moved by that
/// entry's transform, as the scene's, with a note naming the file. False when no file has
/// cameras (an error if --camera asked for one) or the chosen file's are all orthographic.
bool UseMeshFileCamera(const json::Reader& r, const std::vector<EntryCamerasLights>& kept,
                       const SceneLoadOptions& options, float aspect, Scene* scene);
/// A scene file without "lights": every light of every entry's file (file_cameras_lights.h's
/// conversions), moved by the entry's transform, point lights and spots sized from `bounds`
/// (the scene's, ground included), with a note; false when they have none lightmesh renders.
bool UseMeshFileLights(const json::Reader& r, const std::vector<EntryCamerasLights>& kept, const Bounds3& bounds,
                       Scene* scene);

}  // namespace lm::scene_load
