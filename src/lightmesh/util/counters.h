// counters.h -- what a render did, counted per thread and summed at the end.
#pragma once

#include <cstdint>

namespace lm {

/// Work counters. Each render task owns one and they are added up once the image is done,
/// so counting costs no synchronisation on the hot path and the sums do not depend on
/// the thread count.
struct RenderCounters {
    uint64_t cameraRays = 0;      ///< primary rays (aa² per pixel)
    uint64_t reflectionRays = 0;  ///< mirror rays
    uint64_t shadowRays = 0;      ///< shadow rays from shading points (RT, LMM fallback)
    uint64_t shadingPoints = 0;   ///< hits that were shaded
    // Light mesh method (paper §2-4):
    uint64_t interpolations = 0;   ///< shading points whose visibility came from nodes
    uint64_t nodesUsed = 0;        ///< sum of m over those points
    uint64_t candidates = 0;       ///< nodes within r and in front of the surface
    uint64_t localSegments = 0;    ///< local-visibility segments node→P traced
    uint64_t fallbacks = 0;        ///< points with m = 0 that used a shadow ray
    uint64_t uniformCellPoints = 0;  ///< points answered by their cell's summary (all nodes agree)
    uint64_t planarCellPoints = 0;   ///< points whose cell's geometry is one plane: no segment
    uint64_t culledSegments = 0;     ///< local-visibility segments decided without a ray by a point's blockers
    uint64_t patchSegments = 0;      ///< … and without a ray by a node that sees a whole cell patch
    uint64_t penumbraLights = 0;     ///< (point, light) pairs whose radius followed the light's size
    uint64_t penumbraKernel = 0;     ///< … of them answered by the nodes' kernel
    uint64_t penumbraSampled = 0;    ///< … by rays to the light's disc (the rest: the lattice and P's ray)

    RenderCounters& operator+=(const RenderCounters& o) {
        cameraRays += o.cameraRays;
        reflectionRays += o.reflectionRays;
        shadowRays += o.shadowRays;
        shadingPoints += o.shadingPoints;
        interpolations += o.interpolations;
        nodesUsed += o.nodesUsed;
        candidates += o.candidates;
        localSegments += o.localSegments;
        fallbacks += o.fallbacks;
        uniformCellPoints += o.uniformCellPoints;
        planarCellPoints += o.planarCellPoints;
        culledSegments += o.culledSegments;
        patchSegments += o.patchSegments;
        penumbraLights += o.penumbraLights;
        penumbraKernel += o.penumbraKernel;
        penumbraSampled += o.penumbraSampled;
        return *this;
    }
};

}  // namespace lm
