// penumbra_classifier.h -- which camera hits are in a light's penumbra, found from one
// shadow ray per hit and light (the "probe", to the light's centre) and shared between
// neighbouring pixels: the soft default's classifier (render/soft_frame.h).
//
// A hit outside every penumbra of a light sees all of it or none of it, and its probe says
// which. A penumbra lies around each edge of the probes' hard shadow: where two neighbouring
// samples of one surface disagree, the blocked one's probe meets the occluder near its
// silhouette, at a point x. Every receiver point whose cone to the light's sphere contains x
// (it sees x against the light) is in that silhouette's penumbra or umbra: the penumbra
// wedge of the silhouette through x (Laine et al. 2005, "Soft shadow volumes for ray
// tracing"), with the silhouette found by the probes instead of from the mesh's edges.
// Points near a seed in the image are tested against its x; those whose cone holds one are
// sampled, the others keep their probe. The width of the penumbra in the image follows
// from the blocker's distance b (R·b/(d − b) on a plane facing the light, Mehta et al.
// 2012), which bounds how far from the seed to look.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "lightmesh/math/vec.h"

namespace lm {

/// A point of an occluder's silhouette, seen from a pair of neighbouring samples whose
/// probes disagree.
struct SilhouettePoint {
    Vec3 x;              ///< where the blocked sample's probe meets the occluder
    float slop = 0;      ///< world distance around x that the pixel grid leaves uncertain
    int sx = 0, sy = 0;  ///< the seed's sample in the frame
    float reach = 0;     ///< samples from the seed within which a cone may hold x
};

/// Whether the cone from `origin` to the sphere (centre, radius R) holds x, widened by
/// `slop` (world units at x): x lies between the origin and the light and within the cone's
/// radius there, so an occluder's silhouette through x crosses the light as the origin sees
/// it. The cone's radius at distance t along its axis is t·tanθ, sin θ = R/d.
bool ConeHolds(const Vec3& origin, const Vec3& center, float radius, const Vec3& x, float slop);

/// ConeHolds's cone from one point to one light, its quantities computed once for the many
/// silhouette points tested against it (the marks test every point within reach): the same
/// arithmetic, so the same answers bit for bit.
struct LightCone {
    LightCone() = default;
    LightCone(const Vec3& origin, const Vec3& center, float radius);
    bool Holds(const Vec3& x, float slop) const {
        if (inside) return false;  // inside the light: it sees all of it
        const Vec3 ox = x - origin;
        const float t = Dot(ox, oc) / d;  // along the axis
        if (t <= 0 || t >= d) return false;
        const float rho2 = std::max(0.0f, LengthSquared(ox) - t * t);
        const float cone = t * radius / s + slop;
        return rho2 <= cone * cone;
    }
    Vec3 origin, oc;        ///< the point, and the light's centre from it
    float radius = 0, d = 0, s = 0;  ///< R, |oc|, √(d² − R²)
    bool inside = false;    ///< d ≤ R
};

/// The penumbra's half width in samples around a silhouette point x at distance b from a
/// receiver point `origin` (normal n) lit by the sphere (centre, radius): R·b/(d − b) on a
/// plane facing the light, stretched by 1/cos on the receiver (at most 5×), over the
/// receiver's footprint (the world size of a sample there), plus the slop's samples.
/// Returns at most `cap`.
float PenumbraReach(const Vec3& origin, const Vec3& n, const Vec3& center, float radius, float b,
                    float footprint, float cap);

}  // namespace lm
