// penumbra_classifier.cpp -- see the header.
#include "lightmesh/render/penumbra_classifier.h"

#include <algorithm>
#include <cmath>

namespace lm {

LightCone::LightCone(const Vec3& o, const Vec3& center, float r) : origin(o), oc(center - o), radius(r) {
    const float d2 = LengthSquared(oc), r2 = radius * radius;
    inside = d2 <= r2;
    d = std::sqrt(d2);
    s = inside ? 0.0f : std::sqrt(d2 - r2);
}

bool ConeHolds(const Vec3& origin, const Vec3& center, float radius, const Vec3& x, float slop) {
    return LightCone(origin, center, radius).Holds(x, slop);
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
