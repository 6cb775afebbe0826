// mesh_loader.h -- mesh files of any format Assimp reads, flattened into one TriangleMesh.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "lightmesh/geometry/affine.h"  // Affine, TransformMesh: for this header's users
#include "lightmesh/geometry/mesh.h"
#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/texture/texture_cache.h"
#include "lightmesh/util/error.h"

namespace lm {

/// What LoadMeshFile throws: an Error at the file (Where().file), "<path>: <reason>"; the
/// reason is kept apart (Reason()) so that a scene file can name its JSON path first.
class MeshFileError : public Error {
  public:
    MeshFileError(const std::string& path, const std::string& reason, bool unreadable)
        : Error(SourceLoc(path), reason), unreadable_(unreadable) {}
    const std::string& Path() const { return Where().file; }
    /// True when the file could not be read at all (missing, a directory, empty, a format
    /// or content Assimp rejects); false when it was read but holds nothing usable (no
    /// triangles, non-finite coordinates).
    bool Unreadable() const { return unreadable_; }

  private:
    bool unreadable_;
};

struct MeshLoadOptions {
    /// Glob patterns (`*` any run of characters, `?` one character; case-sensitive) matched
    /// against material names: a mesh whose material matches is left out.
    std::vector<std::string> excludeMaterials;
    /// Glob patterns matched against node names (a match excludes the node's whole subtree)
    /// and mesh names.
    std::vector<std::string> excludeNames;
    /// Smooth normals for the meshes that have none (SmoothNormals, crease angle in degrees,
    /// up to 180); 0 or negative: none (shading uses face normals there).
    float smoothAngle = -1.0f;
};

/// What one import may produce; beyond it the file is refused with the figure (a small
/// file can expand enormously: shared children, lying counts).
struct ImportBudget {
    /// Bytes a triangle costs through the pipeline (mesh, vertices, back-end), for the
    /// triangle budget.
    static constexpr uint64_t kBytesPerTriangle = kPipelineBytesPerTriangle;
    uint64_t memory = 0;        ///< bytes the importer may use (0: no limit)
    size_t triangles = 0;       ///< triangles after instances are expanded
    size_t instances = 0;       ///< mesh instances placed (node × mesh pairs)
    size_t nodes = 0;           ///< node instances visited (a shared subtree counts each time)
    unsigned depth = 0;         ///< levels of the node hierarchy

    /// Half of PhysicalMemoryBytes() (LIGHTMESH_MEMORY_LIMIT lowers it) for the importer;
    /// triangles = that / kBytesPerTriangle; 4,194,304 instances and nodes; 1,024 levels.
    static ImportBudget ForThisMachine();
};

struct LoadedMesh {
    /// The file's triangles with the node hierarchy's transforms applied, in the file's
    /// units. Every instance of a shared mesh is expanded. Normals are kept only if every
    /// placed mesh has them.
    TriangleMesh mesh;
    /// The materials the placed meshes use, indexed by mesh.materialIds. Their `texture`
    /// indexes `textures`.
    std::vector<Material> materials;
    /// The images the materials name, found but not read (the scene reads each once:
    /// TextureCache). mesh.uvs holds texture coordinates only when some material has one.
    std::vector<TextureSource> textures;
    size_t meshesPlaced = 0;    ///< mesh instances placed (each node × mesh pair)
    size_t meshesExcluded = 0;  ///< mesh instances left out by the exclude patterns
    /// Per pattern of MeshLoadOptions: whether it excluded anything (to warn about typos).
    std::vector<bool> excludeMaterialsMatched, excludeNamesMatched;
    /// The importer's warnings (e.g. a missing .mtl file), each prefixed with the path.
    std::vector<std::string> warnings;
    /// The file's cameras and lights that a node places, in the file's order, in world
    /// space (file_cameras_lights.h).
    std::vector<FileCamera> cameras;
    std::vector<FileLight> lights;
};

/// Reads a mesh file in any format Assimp knows (OBJ+MTL, glTF 2, PLY, STL, FBX, …):
/// polygons are triangulated, points and lines dropped, node transforms applied. Materials
/// come from the file (see MaterialFromFile in assimp_material.cpp for the mapping). Throws
/// MeshFileError for a missing, unreadable, empty or malformed file, a file with no
/// triangles, or non-finite coordinates. A file whose every mesh is excluded is not an
/// error: the result is empty and meshesExcluded says why.
///
/// Hardening: the import runs in a child process (fork; the triangles come back
/// through a memfd) whose address space is limited to the ImportBudget's memory, so that
/// an importer crash, assertion or allocation bomb becomes a MeshFileError ("the importer
/// crashed (signal 11)") instead of taking the renderer down. Assimp opens regular files
/// only (a FIFO named by an mtllib or a glTF buffer is refused, not waited on), its
/// assertions become errors, glTF node graphs are checked for cycles, depth and expansion
/// before Assimp sees them, and the budget is checked while instances are expanded.
/// LIGHTMESH_IMPORT_IN_PROCESS=1 imports in this process (for debugging and fuzzing).
LoadedMesh LoadMeshFile(const std::string& path, const MeshLoadOptions& options = {});

/// LoadMeshFile in this process, without the child: what the fuzzer drives (its coverage
/// is only seen in-process) and what the child runs.
LoadedMesh ImportMeshInProcess(const std::string& path, const MeshLoadOptions& options,
                               const ImportBudget& budget);

/// Glob match of the whole `text` against `pattern` with `*` and `?` (no escapes).
bool GlobMatch(std::string_view pattern, std::string_view text);

}  // namespace lm
