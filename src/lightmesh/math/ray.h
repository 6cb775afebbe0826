// ray.h -- rays and segments.
#pragma once

#include "lightmesh/math/vec.h"

namespace lm {

/// The points o + t·d for t in [tMin, tMax]. d need not be unit length: a segment from
/// a to b is Ray{a, b - a, 0, 1}. Ray queries consider hits with tMin < t < tMax.
struct Ray {
    Vec3 o;
    Vec3 d;
    float tMin = 0.0f;
    float tMax = Infinity;

    constexpr Vec3 At(float t) const { return o + d * t; }
};

/// The segment from a to b as a ray with t in (0, 1).
constexpr Ray Segment(const Vec3& a, const Vec3& b) { return Ray{a, b - a, 0.0f, 1.0f}; }

}  // namespace lm
