// triangle.h -- the watertight ray/triangle test every back-end of ours shares.
#pragma once

#include "lightmesh/math/ray.h"

namespace lm {

/// Where a ray meets a triangle: parameter t along the ray and barycentric coordinates
/// (b0, b1, b2) of the hit point with respect to (p0, p1, p2).
struct TriangleHit {
    float t;
    float b0, b1, b2;
};

/// Watertight ray/triangle intersection (Woop, Benthin & Wald, "Watertight Ray/Triangle
/// Intersection", JCGT 2013), with a tie-breaking rule on edges and vertices.
///
/// Reports a hit with ray.tMin < t < ray.tMax. Both windings are hit (scenes are not
/// assumed to be consistently oriented); degenerate triangles and rays lying in the
/// triangle's plane never hit.
///
/// Tie-breaking: a ray through an edge shared by two triangles hits exactly one of them,
/// and a ray through a vertex surrounded by a fan of triangles hits exactly one of the fan.
/// Woop et al.'s edge functions of a shared edge are exact negations of each other in the
/// two triangles (same products, opposite order), so an edge function that is exactly zero
/// is zero in both; we then accept it only in the triangle for which the edge, oriented
/// with the interior on its left in the ray's 2D frame, points "up" (y > 0, or y == 0 and
/// x > 0): the rasteriser's top-left rule. This is what makes crossing counts (parity tests
/// for inside/outside, paper §4) robust on closed meshes. Requires no FMA contraction
/// (the library is built with -ffp-contract=off).
bool IntersectTriangle(const Ray& ray, const Vec3& p0, const Vec3& p1, const Vec3& p2,
                       TriangleHit* hit);

/// Geometric normal (p1 - p0) × (p2 - p0), not normalised; zero for a degenerate triangle.
inline Vec3 TriangleNormal(const Vec3& p0, const Vec3& p1, const Vec3& p2) {
    return Cross(p1 - p0, p2 - p0);
}

}  // namespace lm
