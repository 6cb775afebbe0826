// penumbra_classifier.cpp -- see the header.
#include "lightmesh/render/penumbra_classifier.h"

#include <algorithm>
#include <cmath>

namespace lm {

bool ConeHolds(const Vec3& origin, const Vec3& center, float radius, const Vec3& x, float slop) {
    const Vec3 oc = center - origin, ox = x - origin;
    const float d2 = LengthSquared(oc), r2 = radius * radius;
    if (d2 <= r2) return false;  // inside the light: it sees all of it
    const float d = std::sqrt(d2);
    const float t = Dot(ox, oc) / d;  // along the axis
    if (t <= 0 || t >= d) return false;
    const float rho2 = std::max(0.0f, LengthSquared(ox) - t * t);
    const float cone = t * radius / std::sqrt(d2 - r2) + slop;
    return rho2 <= cone * cone;
}

float PenumbraReach(const Vec3& origin, const Vec3& n, const Vec3& center, float radius, float b, float footprint,
                    float cap) {
    const Vec3 oc = center - origin;
    const float d = Length(oc);
    if (!(d > 0) || !(footprint > 0)) return cap;
    const float w = radius * b / std::max(d - b, 1e-4f * d);
    const float cosL = std::max(0.2f, std::abs(Dot(n, oc)) / d);
    return std::min(cap, w / cosL / footprint + 2.0f);
}

}  // namespace lm
