// light_mesh_counters.h -- the light mesh's own counts (paper §2-4), kept in the shadow
// method's slots of RenderCounters (RenderCounters::method).
#pragma once

#include <cstddef>
#include <cstdint>

#include "lightmesh/util/counters.h"

namespace lm {

/// What the light mesh counts: each value is its slot of RenderCounters::method.
enum class LightMeshCount : size_t {
    kInterpolations,     ///< shading points whose visibility came from nodes
    kNodesUsed,          ///< sum of m over those points
    kCandidates,         ///< nodes within r and in front of the surface
    kLocalSegments,      ///< local-visibility segments node→P traced
    kFallbacks,          ///< points with m = 0 that used a shadow ray
    kUniformCellPoints,  ///< points answered by their cell's summary (all nodes agree)
    kPlanarCellPoints,   ///< points whose cell's geometry is one plane: no segment
    kCulledSegments,     ///< local-visibility segments decided without a ray by a point's blockers
    kPatchSegments,      ///< … and without a ray by a node that sees a whole cell patch
    kPenumbraLights,     ///< (point, light) pairs whose radius followed the light's size
    kPenumbraKernel,     ///< … of them answered by the nodes' kernel
    kPenumbraSampled,    ///< … by rays to the light's disc (the rest: the lattice and P's ray)
    kThinChecks,         ///< (point, light) pairs where P's own ray checked the nodes' answer
    kThinFound,          ///< … of them where it disagreed (an occluder or gap thinner than h)
    kPatchesNotPaying,   ///< points whose cell patch was not built: too few camera rays for its front triangles
    kNumber,             ///< how many there are (not a count)
};
static_assert(static_cast<size_t>(LightMeshCount::kNumber) <= kMethodCounterSlots,
              "the light mesh's counts must fit in RenderCounters::method");

/// The light mesh's count `k` in `c`: `++Count(counters, LightMeshCount::kCandidates)`.
inline uint64_t& Count(RenderCounters& c, LightMeshCount k) { return c.method[static_cast<size_t>(k)]; }
inline uint64_t Count(const RenderCounters& c, LightMeshCount k) { return c.method[static_cast<size_t>(k)]; }

}  // namespace lm
