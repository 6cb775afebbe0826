// mesh_loader.h -- mesh files of any format Assimp reads, flattened into one TriangleMesh.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/util/error.h"

namespace lm {

/// An affine transform p ↦ A·p + t: the top three rows of a row-major 4×4 matrix
/// (the fourth row is implicitly 0 0 0 1).
struct Affine {
    float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

    static Affine Scale(const Vec3& s);
    /// Rotation by `degrees` about `axis` (any non-zero length), counter-clockwise when
    /// the axis points at the viewer (right-handed).
    static Affine Rotate(const Vec3& axis, float degrees);
    static Affine Translate(const Vec3& t);

    /// The composition "first b, then this": (a * b)(p) = a(b(p)).
    Affine operator*(const Affine& b) const;
    Vec3 ApplyPoint(const Vec3& p) const;
    Vec3 ApplyVector(const Vec3& v) const;
    /// Determinant of the linear 3×3 part (negative: the transform mirrors).
    float Determinant() const;
};

/// Transforms every position by `t` and every normal by the inverse transpose of its
/// linear part (renormalised). A mirroring transform (determinant < 0) also reverses each
/// triangle's winding, so geometric normals keep pointing the same way relative to the
/// surface. Precondition: t is invertible.
void TransformMesh(TriangleMesh* mesh, const Affine& t);

/// What LoadMeshFile throws. what() is "<path>: <reason>"; the parts are kept so that a
/// scene file can name its JSON path first.
class MeshFileError : public Error {
  public:
    MeshFileError(const std::string& path, const std::string& reason, bool unreadable)
        : Error(path + ": " + reason), path_(path), reason_(reason), unreadable_(unreadable) {}
    const std::string& Path() const { return path_; }
    const std::string& Reason() const { return reason_; }
    /// True when the file could not be read at all (missing, a directory, empty, a format
    /// or content Assimp rejects); false when it was read but holds nothing usable (no
    /// triangles, non-finite coordinates).
    bool Unreadable() const { return unreadable_; }

  private:
    std::string path_, reason_;
    bool unreadable_;
};

struct MeshLoadOptions {
    /// Glob patterns (`*` any run of characters, `?` one character; case-sensitive) matched
    /// against material names: a mesh whose material matches is left out.
    std::vector<std::string> excludeMaterials;
    /// Glob patterns matched against node names (a match excludes the node's whole subtree)
    /// and mesh names.
    std::vector<std::string> excludeNames;
};

struct LoadedMesh {
    /// The file's triangles with the node hierarchy's transforms applied, in the file's
    /// units. Every instance of a shared mesh is expanded. Normals are kept only if every
    /// placed mesh has them.
    TriangleMesh mesh;
    /// The materials the placed meshes use, indexed by mesh.materialIds.
    std::vector<Material> materials;
    size_t meshesPlaced = 0;    ///< mesh instances placed (each node × mesh pair)
    size_t meshesExcluded = 0;  ///< mesh instances left out by the exclude patterns
    /// Per pattern of MeshLoadOptions: whether it excluded anything (to warn about typos).
    std::vector<bool> excludeMaterialsMatched, excludeNamesMatched;
    /// The importer's warnings (e.g. a missing .mtl file), each prefixed with the path.
    std::vector<std::string> warnings;
};

/// Reads a mesh file in any format Assimp knows (OBJ+MTL, glTF 2, PLY, STL, FBX, …):
/// polygons are triangulated, points and lines dropped, node transforms applied. Materials
/// come from the file (see MaterialFromFile in mesh_loader.cpp for the mapping). Throws
/// MeshFileError for a missing, unreadable, empty or malformed file, a file with no
/// triangles, or non-finite coordinates. A file whose every mesh is excluded is not an
/// error: the result is empty and meshesExcluded says why.
LoadedMesh LoadMeshFile(const std::string& path, const MeshLoadOptions& options = {});

/// Glob match of the whole `text` against `pattern` with `*` and `?` (no escapes).
bool GlobMatch(std::string_view pattern, std::string_view text);

}  // namespace lm
