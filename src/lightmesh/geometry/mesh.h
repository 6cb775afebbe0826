// mesh.h -- the scene's triangles in world space, as one indexed mesh.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/math/bounds.h"
#include "lightmesh/math/ray.h"

namespace lm {

class CutoutMask;
class InstancedMeshes;

/// Texture coordinates of a vertex (glTF's convention: v grows downwards in the image).
struct TexCoord {
    float u = 0, v = 0;
};

/// All triangles of a scene in world space, in two levels: `triangles` (the flat ones), and
/// optionally `instances` (meshes placed many times, geometry/instances.h). A primitive id
/// below triangles.size() is an index into `triangles`; the instanced triangles follow, in
/// the order of their instances. The accessors below (Corners, ShadingNormals, UvsOf,
/// MaterialOf) read either kind; code that reads the arrays directly sees the flat ones
/// only, and is given a mesh whose instances were flattened (FlattenInstances).
struct TriangleMesh {
    std::vector<Vec3> positions;
    /// Optional per-vertex shading normals (empty, or one per position).
    std::vector<Vec3> normals;
    /// Optional per-vertex texture coordinates: empty when no textured material uses them
    /// (untextured scenes carry none), else one per position (0, 0 where a mesh had none).
    std::vector<TexCoord> uvs;
    std::vector<std::array<uint32_t, 3>> triangles;
    /// Material index per triangle (same length as `triangles`).
    std::vector<uint32_t> materialIds;
    /// The alpha cut-outs of the triangles (geometry/cutouts.h), built last by the scene
    /// loader; null when no triangle is cut out. Every ray query applies its Solid test to a
    /// hit of a cut-out triangle. (Append keeps it; triangles beyond those it was built for
    /// are opaque.)
    std::shared_ptr<const CutoutMask> cutouts;
    /// Instanced triangles (null: none). A prototype's cut-outs are its own `cutouts`, which
    /// the mesh's mask answers for its instances' ids.
    std::shared_ptr<const InstancedMeshes> instances;

    /// The flat triangles (`triangles`).
    size_t TriangleCount() const { return triangles.size(); }
    /// Every triangle: the flat ones and those the instances stand for.
    size_t PrimCount() const;
    /// The box of every triangle, instanced ones included.
    Bounds3 Bounds() const;
    /// Vertex k of a flat triangle.
    const Vec3& Vertex(uint32_t prim, int k) const { return positions[triangles[prim][k]]; }

    /// The world-space corners of any triangle, flat or instanced.
    void Corners(uint32_t prim, Vec3 p[3]) const {
        if (prim < triangles.size()) {
            for (int k = 0; k < 3; ++k) p[k] = positions[triangles[prim][k]];
            return;
        }
        InstancedCorners(prim, p);
    }
    /// Whether its triangles have shading normals: the flat ones', or, with no flat
    /// triangles yet, the prototypes' (InstancedMeshes::HarmoniseAttributes makes them agree).
    bool HasShadingNormals() const;
    /// Its shading normals (false when the mesh has none).
    bool ShadingNormals(uint32_t prim, Vec3 n[3]) const {
        if (prim >= triangles.size()) return InstancedNormals(prim, n);
        if (normals.empty()) return false;
        for (int k = 0; k < 3; ++k) n[k] = normals[triangles[prim][k]];
        return true;
    }
    /// Its texture coordinates (false when the mesh has none).
    bool UvsOf(uint32_t prim, TexCoord t[3]) const {
        if (prim >= triangles.size()) return InstancedUvs(prim, t);
        if (uvs.empty()) return false;
        for (int k = 0; k < 3; ++k) t[k] = uvs[triangles[prim][k]];
        return true;
    }
    /// Its material index.
    uint32_t MaterialOf(uint32_t prim) const {
        return prim < materialIds.size() ? materialIds[prim] : InstancedMaterial(prim);
    }

    /// Appends another mesh (its material ids offset by `materialOffset`).
    void Append(const TriangleMesh& other, uint32_t materialOffset = 0);

  private:
    void InstancedCorners(uint32_t prim, Vec3 p[3]) const;
    uint32_t InstancedMaterial(uint32_t prim) const;
    bool InstancedNormals(uint32_t prim, Vec3 n[3]) const;
    bool InstancedUvs(uint32_t prim, TexCoord t[3]) const;
};

/// Bytes a triangle costs through the pipeline (mesh, vertices, a back-end's structures):
/// the import's triangle budget and the flattening of instances are checked against it.
inline constexpr uint64_t kPipelineBytesPerTriangle = 128;

/// What CleanMesh removed.
struct CleanReport {
    size_t degenerate = 0;  ///< zero-area triangles (or with a non-finite vertex) dropped
    size_t duplicate = 0;   ///< exact duplicates (same three positions, any order) dropped
};

/// Drops degenerate triangles and exact duplicates (real models have them, and a doubled
/// triangle would count two crossings in an inside/outside parity test).
CleanReport CleanMesh(TriangleMesh* mesh);

/// Topology of the mesh with vertices welded by exact position.
struct EdgeReport {
    size_t edges = 0;        ///< distinct undirected edges
    size_t open = 0;         ///< edges used by exactly one triangle (a hole or a sheet's rim)
    size_t nonManifold = 0;  ///< edges used by more than two triangles
    bool Closed() const { return open == 0 && nonManifold == 0; }
};

/// Counts open and non-manifold edges: the inside-a-solid test (paper §4, "СТ") assumes
/// closed objects and is unreliable where these exist.
EdgeReport AnalyzeEdges(const TriangleMesh& mesh);

/// The triangles that belong to closed parts: edge-connected sets of triangles (vertices
/// welded by exact position) in which every edge is shared by exactly two of them. An open
/// surface (a floor, a sheet, a shape with a hole) is no part of one. Per triangle of the
/// mesh's own (`flat`) and of each instance prototype (`prototypes`), 1 or 0.
struct ClosedParts {
    std::vector<uint8_t> flat;
    std::vector<std::vector<uint8_t>> prototypes;
};
ClosedParts FindClosedParts(const TriangleMesh& mesh);

/// The surfaces the ray crosses, every triangle tested (IntersectTriangle's watertight test
/// and tie-breaks: a closed mesh gives exact inside/outside parity, paper §4). The brute-force
/// back-end's CountCrossings, and the scene checks' light-inside-a-solid test, which needs no
/// back-end for the few rays it traces.
int CountCrossings(const TriangleMesh& mesh, const Ray& ray);
/// The same, counting only the triangles of closed parts (`only`).
int CountCrossings(const TriangleMesh& mesh, const Ray& ray, const ClosedParts& only);

}  // namespace lm
