// accelerator.h -- the ray-query interface every back-end implements, and its factory.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/math/ray.h"
#include "lightmesh/settings/accel_options.h"

namespace lm {

/// Closest hit of a ray: parameter t, primitive id (index into TriangleMesh::triangles)
/// and barycentrics (b1, b2) of the hit point for vertices 1 and 2 (b0 = 1 - b1 - b2).
struct Hit {
    float t = Infinity;
    uint32_t prim = UINT32_MAX;
    float b1 = 0, b2 = 0;
};

/// Named figures about a built back-end, for `lightmesh info` and `--stats`.
using AccelFigures = std::vector<std::pair<std::string, std::string>>;

/// Ray-scene queries over a fixed TriangleMesh. All queries are const and thread-safe.
/// A hit counts when ray.tMin < t < ray.tMax.
class Accelerator {
  public:
    virtual ~Accelerator() = default;

    /// The name it was created by: "brute", "grid" or "embree".
    virtual std::string_view Name() const = 0;

    /// Closest hit along the ray; false if none.
    virtual bool Intersect(const Ray& ray, Hit* hit) const = 0;

    /// True if any triangle is hit (shadow rays and local-visibility segments).
    virtual bool Occluded(const Ray& ray) const = 0;

    /// Intersect for each of `count` rays, into hits[0 … count-1]; a ray without a hit gets
    /// Hit{} (t = ∞, prim = UINT32_MAX). For coherent rays (a tile's camera rays), which a
    /// back-end may trace as a packet: each ray must get the hit Intersect gives it, whatever
    /// its companions (AccelBatch tests). The default, which brute force keeps, is Intersect
    /// ray by ray.
    virtual void IntersectMany(const Ray* rays, size_t count, Hit* hits) const;

    /// Occluded for each of `count` rays, into occluded[0 … count-1]: for a few rays at
    /// once that share an end or a target (a point's rays to a light's disc, the light
    /// mesh's segments from nodes to a point), which a back-end may trace as a packet. Each
    /// ray must get the answer Occluded gives it, whatever its companions
    /// (AccelBatch tests hold every back-end to it). The default, which brute force keeps,
    /// is Occluded ray by ray.
    virtual void OccludedMany(const Ray* rays, size_t count, bool* occluded) const;

    /// The number of surface crossings along the ray: each triangle hit counts once, and
    /// a ray through a shared edge or vertex of a closed mesh counts one crossing (the
    /// tie-breaking rule of IntersectTriangle). Parity gives inside/outside (paper §4).
    virtual int CountCrossings(const Ray& ray) const = 0;

    /// Build figures: cells, empty cells, triangles per cell, depth, bytes, build time.
    virtual AccelFigures Figures() const = 0;
};

/// The back-end names CreateAccelerator accepts, in the order of the help text.
std::vector<std::string> AcceleratorNames();

/// Builds the back-end called `name` over `mesh` (which must outlive it). Throws Error
/// naming the valid choices for an unknown name, or when a back-end was not compiled in.
std::unique_ptr<Accelerator> CreateAccelerator(std::string_view name, const TriangleMesh& mesh,
                                               const AccelOptions& options = {});

}  // namespace lm
