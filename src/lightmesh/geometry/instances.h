// instances.h -- meshes imported once and placed many times: prototypes (each a mesh in its
// own space) and instances (a prototype and an affine transform), the second level of a
// TriangleMesh (mesh.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lightmesh/geometry/affine.h"
#include "lightmesh/geometry/mesh.h"
#include "lightmesh/math/bounds.h"

namespace lm {

/// One placement of a prototype.
struct MeshInstance {
    uint32_t prototype = 0;
    /// The id of its first triangle among the instanced ones: its triangle k has the global
    /// id TriangleMesh::triangles.size() + first + k.
    uint32_t first = 0;
    Affine toWorld;
    /// The box of its triangles' vertices in world space (exact: the vertices transformed).
    Bounds3 bounds;
};

/// The instanced triangles of a TriangleMesh. A triangle's world-space corners are its
/// prototype's vertices through Affine::ApplyPoint, in the order TransformMesh gives them
/// (a mirroring transform swaps corners 1 and 2), and its shading normals are transformed
/// as TransformMesh does: the instanced triangles read, bit for bit, as FlattenInstances
/// writes them.
class InstancedMeshes {
  public:
    /// Adds a prototype (in its own space, cleaned, its material ids the scene's); returns
    /// its index.
    uint32_t AddPrototype(TriangleMesh mesh);
    /// Places prototype `p` by `toWorld` (invertible, finite; the caller checks).
    void AddInstance(uint32_t p, const Affine& toWorld);

    const std::vector<TriangleMesh>& Prototypes() const { return prototypes_; }
    const std::vector<MeshInstance>& Instances() const { return instances_; }
    /// The triangles the instances stand for.
    size_t TriangleCount() const { return count_; }
    Bounds3 Bounds() const { return bounds_; }
    /// The instance holding instanced triangle `id` (0-based among the instanced ones).
    size_t Locate(uint32_t id) const;

    /// World-space corners, shading normals and texture coordinates of instanced triangle
    /// `id`; Normals and TexCoords return false when the prototypes carry none.
    void Corners(uint32_t id, Vec3 p[3]) const;
    bool Normals(uint32_t id, Vec3 n[3]) const;
    bool TexCoords(uint32_t id, TexCoord t[3]) const;
    uint32_t Material(uint32_t id) const;

    /// Bytes of the prototypes and the instance table.
    size_t Bytes() const;
    /// Bytes the instanced triangles take flattened (FlattenInstances): each instance's
    /// vertices, shading normals and texture coordinates as its prototype has them, and 16
    /// bytes a triangle (indices, material id).
    uint64_t FlattenedBytes() const;

    /// Makes the shared vertex attributes agree as TriangleMesh::Append would leave them:
    /// shading normals kept only if `flat` and every prototype have them (otherwise dropped
    /// everywhere), texture coordinates everywhere ((0, 0) where a mesh had none) if any has
    /// them. Called once every prototype is added.
    void HarmoniseAttributes(TriangleMesh* flat);

  private:
    std::vector<TriangleMesh> prototypes_;
    std::vector<MeshInstance> instances_;
    std::vector<Bounds3> protoBounds_;
    size_t count_ = 0;
    Bounds3 bounds_;
};

/// Why `triangles` copied triangles (flattened instances, a file's references copied) do
/// not fit, or "" when they do: at the pipeline's kPipelineBytesPerTriangle each (or their
/// own `bytes`, if more) against half the memory this process may use (PhysicalMemoryBytes):
/// "would take about 23.8 GiB (128 B a triangle through the pipeline), more than half of
/// the 256.0 MiB this process may use (LIGHTMESH_MEMORY_LIMIT)".
std::string CopiesOverBudget(uint64_t triangles, uint64_t bytes = 0);

/// Replaces mesh->instances by their triangles in world space, appended in id order (so
/// every id keeps its triangle): what the back-ends and shadow methods that read triangles
/// as one array get. Throws Error, before allocating, when the flattened triangles would
/// take more than half the memory this process may use (CopiesOverBudget); the message
/// starts with `who` ("scene.json: --shadows lmm: ") when given.
void FlattenInstances(TriangleMesh* mesh, const std::string& who = "");

/// FlattenInstances's check alone: throws its Error if `mesh`'s instances would not fit
/// flattened, without flattening them (a caller that knows the scene and the option checks
/// before a back-end flattens them out of its sight).
void CheckFlatteningFits(const TriangleMesh& mesh, const std::string& who);

/// A copy of `mesh` with its instances flattened.
TriangleMesh Flattened(const TriangleMesh& mesh);

}  // namespace lm
