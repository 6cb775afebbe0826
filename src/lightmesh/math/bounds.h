// bounds.h -- axis-aligned bounding boxes.
#pragma once

#include "lightmesh/math/vec.h"

namespace lm {

/// An axis-aligned box; the default-constructed box is empty (lo > hi).
struct Bounds3 {
    Vec3 lo{Infinity, Infinity, Infinity};
    Vec3 hi{-Infinity, -Infinity, -Infinity};

    constexpr Bounds3() = default;
    constexpr Bounds3(const Vec3& a, const Vec3& b) : lo(Min(a, b)), hi(Max(a, b)) {}

    constexpr bool IsEmpty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    constexpr Vec3 Diagonal() const { return hi - lo; }
    constexpr Vec3 Center() const { return (lo + hi) * 0.5f; }
    constexpr void Extend(const Vec3& p) { lo = Min(lo, p); hi = Max(hi, p); }
    constexpr void Extend(const Bounds3& b) { lo = Min(lo, b.lo); hi = Max(hi, b.hi); }
    constexpr bool Contains(const Vec3& p) const {
        return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z &&
               p.z <= hi.z;
    }
    /// Length of the longest side.
    constexpr float MaxExtent() const { return IsEmpty() ? 0.0f : MaxComponent(Diagonal()); }
};

}  // namespace lm
