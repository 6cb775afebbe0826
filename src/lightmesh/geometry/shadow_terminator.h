// shadow_terminator.h -- where rays leaving a smooth-shaded point start: the point lifted to
// the tangent planes of its triangle's vertex normals (J. Hanika, "Hacking the Shadow
// Terminator", Ray Tracing Gems II, chapter 4, 2021).
//
// A low-poly mesh with interpolated normals is shaded as the smooth surface the normals
// describe, but its rays leave the flat facets. Near the terminator a facet can face away
// from a light its shading normal faces: a ray from the facet runs into the mesh, and the
// lit side ends along the facets' edges in a jagged dark line. Lifted to the vertices'
// tangent planes, the point sits on (about) the smooth surface, and its rays leave the mesh.
#pragma once

#include <cmath>

#include "lightmesh/math/vec.h"

namespace lm {

/// The point `p` of a triangle, with barycentrics `b` of its corners `corner`, lifted to the
/// tangent planes of the corners' shading normals `normal` (any length, zero for none) turned
/// by `side` (1 or -1) to the side rays leave: for each corner, p projected onto the plane
/// through the corner with its normal when p lies below that plane (else p itself), and the
/// barycentric mean of the three. p moves only along the normals, by at most the triangle's
/// size. Where p lies above every plane (a concave part of the mesh, or a flat one), it stays
/// where it is. Projections through |n|² rather than unit normals: no square roots per hit.
inline Vec3 LiftToShadingPlanes(const Vec3& p, const float b[3], const Vec3 corner[3], const Vec3 normal[3],
                                float side = 1.0f) {
    Vec3 lifted = p;
    for (int k = 0; k < 3; ++k) {
        const float below = side * Dot(p - corner[k], normal[k]), n2 = LengthSquared(normal[k]);
        if (below < 0 && n2 > 0 && std::isfinite(n2)) lifted -= normal[k] * (side * b[k] * below / n2);
    }
    return lifted;
}

}  // namespace lm
