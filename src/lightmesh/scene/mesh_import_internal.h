// mesh_import_internal.h -- what the parts of the mesh import share; not part of
// mesh_loader.h's interface. The parts: mesh_loader.cpp (the entry points), assimp_import.cpp
// (the import itself, ImportMeshInProcess), assimp_material.cpp (materials), obj_import.cpp
// (OBJ files, in Assimp's OBJ importer's place), gltf_checks.cpp (glTF node graphs) and
// isolated_import.cpp (the child process).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/util/isolated_child.h"

struct aiMaterial;
namespace Assimp {
class Importer;
}
struct aiScene;

namespace lm {
namespace mesh_import {

// assimp_import.cpp

/// "4194304" as "4,194,304", for the budgets' messages.
std::string Thousands(uint64_t n);
/// Whether an importer message is known noise of a file that reads well (the Blender
/// reader's "<add reason>", "BlendDNA: Did not find a field named ...", textures and lights
/// lightmesh does not use): one line counts them.
bool KnownImporterNoise(const std::string& message);
/// Checks what Assimp would report less clearly: a missing file, a directory, a FIFO, an
/// empty or unreadable file, one whose first 4 KiB are all NUL bytes.
void CheckReadable(const std::string& path);
/// Assimp's error string as a reason.
std::string ImportErrorReason(std::string err, const ImportBudget& budget);

/// The child's result file while it imports (-1 in the parent and in-process imports).
extern int gResultFd;

// assimp_cameras_lights.cpp

/// The global transforms of the nodes named by cameras and lights (a camera or light is
/// placed by the node of its name): null until the walk finds the node (the first of that
/// name); row-major 4x4, as aiMatrix4x4.
struct NodeTransform {
    float m[16];
    /// glTF's light "range" (Assimp 5.2 puts it in the node's metadata, PBR_LightRange);
    /// NaN when the node has none.
    float lightRange;
};
using NodeTransforms = std::unordered_map<std::string, std::optional<NodeTransform>>;
/// The names of `scene`'s cameras and lights, each with no transform yet.
void WantedNodeNames(const aiScene& scene, NodeTransforms* wanted);
/// `scene`'s cameras and lights placed by their nodes' transforms into out->cameras and
/// out->lights (those no node places are left out).
void ReadCamerasAndLights(const aiScene& scene, const std::string& path, const NodeTransforms& placed,
                          LoadedMesh* out);

// assimp_material.cpp

/// An Assimp material as a Phong material of formula (1); the mapping is written out above
/// its definition. Its base-colour image, if any, is appended to *textures (a file resolved
/// against the folder of `modelPath`, or the bytes `scene` embeds) and the material's
/// `texture` indexes it; problems with it go to *warnings.
Material MaterialFromFile(const aiMaterial& am, const aiScene& scene, const std::string& modelPath,
                          std::vector<TextureSource>* textures, std::vector<std::string>* warnings);

// obj_import.cpp
/// Replaces `importer`'s OBJ reader (Assimp 5.2's is quadratic in the file's `o` objects)
/// by tinyobjloader's, laid out as Assimp's: same nodes, meshes and material keys, the
/// vertices welded as aiProcess_JoinIdenticalVertices would weld them (so that step is left
/// out for OBJ files). False, leaving Assimp's, when LIGHTMESH_OBJ_READER=assimp.
bool UseTinyObjReader(Assimp::Importer* importer);
/// Whether `path` ends in .obj (any case).
bool HasObjExtension(const std::string& path);
/// The importer's property (bool) that merges an OBJ's objects and groups into a mesh per
/// run of one material on the root node, for an import whose excludes name no node or mesh
/// (200,000 one-triangle objects make 200,000 meshes of Assimp's otherwise: 1.5 s).
inline constexpr const char* kObjMergeObjects = "LIGHTMESH_OBJ_MERGE_OBJECTS";

// gltf_checks.cpp

/// A .gltf's or .glb's node graph checked for cycles, depth and expansion against the budget
/// before Assimp sees it (MeshFileError); other files, and JSON Assimp rejects anyway, pass.
void CheckGltfHierarchy(const std::string& path, const ImportBudget& budget);
/// A .gltf's JSON with its images' data: URIs made what Assimp reads, or "" when none needs
/// it: a payload that is not base64 becomes empty (no image, the flat colour; Assimp 5.2
/// refused the whole file), an unpadded one is padded; each, and an empty payload (which
/// Assimp drops without a word), gets a warning in *warnings naming the image.
std::string RepairGltfDataUris(const std::string& path, std::vector<std::string>* warnings);

// ac3d_checks.cpp

/// An AC3D file's text with every `texture` line after an object's first left out, or ""
/// when the file is not AC3D or no object has more than one (the first texture layer is the
/// object's image, its coordinates the first pair of each `refs` line, the pair Assimp
/// reads; Assimp 5.2 keeps the last layer instead). `*dropped` (if given): the lines left out.
std::string RepairAc3dTextureLayers(const std::string& path, size_t* dropped = nullptr);

// isolated_import.cpp

/// The import deadline without LIGHTMESH_IMPORT_TIMEOUT: 60 s + 2 s per MB, at most this.
inline constexpr double kMaxDefaultImportSeconds = kMaxDefaultChildSeconds;
/// The import's deadline for `path`: LIGHTMESH_IMPORT_TIMEOUT (seconds, any value up to
/// 1e7) when set, else 60 s + 2 s per MB of the file, at most kMaxDefaultImportSeconds.
double ImportTimeoutSeconds(const std::string& path);

/// An error as the child's result, written to `fd` (Assimp's assertions in the child end
/// with it).
void WriteErrorResult(int fd, const std::string& reason, bool unreadable);
/// LoadMeshFile's import in a child process (see LoadMeshFile); in this process if there is
/// no memfd or no fork.
LoadedMesh ImportIsolated(const std::string& path, const MeshLoadOptions& options,
                          const ImportBudget& budget);

}  // namespace mesh_import
}  // namespace lm
