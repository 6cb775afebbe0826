// triangle.h -- the watertight ray/triangle test every back-end of ours shares.
#pragma once

#include <utility>

#include "lightmesh/math/ray.h"

namespace lm {

/// Where a ray meets a triangle: parameter t along the ray and barycentric coordinates
/// (b0, b1, b2) of the hit point with respect to (p0, p1, p2).
struct TriangleHit {
    float t;
    float b0, b1, b2;
};

namespace detail {
/// The ray in the watertight test's frame (Woop, Benthin & Wald 2013, §3): the axis
/// permutation and shear, computed once per ray, so that back-ends testing many triangles
/// against one ray (the nested grid) pay the three divisions once.
struct PreparedRay {
    int kx, ky, kz;
    float sx, sy, sz;
    Vec3 o;
    float tMin, tMax;
    bool valid;  // false for a zero direction: nothing is ever hit

    explicit PreparedRay(const Ray& ray) : o(ray.o), tMin(ray.tMin), tMax(ray.tMax) {
        const Vec3& d = ray.d;
        kz = MaxDimension(Abs(d));
        valid = d[kz] != 0;
        kx = kz + 1 == 3 ? 0 : kz + 1;
        ky = kx + 1 == 3 ? 0 : kx + 1;
        if (d[kz] < 0) std::swap(kx, ky);
        sx = valid ? d[kx] / d[kz] : 0.0f;
        sy = valid ? d[ky] / d[kz] : 0.0f;
        sz = valid ? 1.0f / d[kz] : 0.0f;
    }
};

template <typename T>
inline bool OwnsEdge(T ex, T ey) {
    return ey > 0 || (ey == 0 && ex > 0);
}

template <typename T>
inline bool EdgeTest(T ax, T ay, T bx, T by, T cx, T cy, T* u, T* v, T* w, T* sign) {
    *u = cx * by - cy * bx;
    *v = ax * cy - ay * cx;
    *w = bx * ay - by * ax;
    if ((*u < 0 || *v < 0 || *w < 0) && (*u > 0 || *v > 0 || *w > 0)) return false;
    T det = *u + *v + *w;
    if (det == 0) return false;
    *sign = det > 0 ? T(1) : T(-1);
    if (*u == 0 && !OwnsEdge(*sign * (bx - cx), *sign * (by - cy))) return false;
    if (*v == 0 && !OwnsEdge(*sign * (cx - ax), *sign * (cy - ay))) return false;
    if (*w == 0 && !OwnsEdge(*sign * (ax - bx), *sign * (ay - by))) return false;
    return true;
}

/// IntersectTriangle(ray, p0, p1, p2, hit) for the ray `r` was prepared from, with r.tMin
/// and r.tMax as the range; p points at the 9 floats p0, p1, p2. IntersectTriangle is this
/// function, so every back-end of ours answers bit for bit alike.
[[gnu::always_inline]] inline bool IntersectPrepared(const PreparedRay& r, const float* p,
                                                     TriangleHit* hit) {
    if (!r.valid) return false;
    const int kx = r.kx, ky = r.ky, kz = r.kz;
    // a = p0 - o etc., only the components the test reads.
    const float o[3] = {r.o.x, r.o.y, r.o.z};
    const float aX = p[kx] - o[kx], aY = p[ky] - o[ky], aZ = p[kz] - o[kz];
    const float bX = p[3 + kx] - o[kx], bY = p[3 + ky] - o[ky], bZ = p[3 + kz] - o[kz];
    const float cX = p[6 + kx] - o[kx], cY = p[6 + ky] - o[ky], cZ = p[6 + kz] - o[kz];
    const float ax = aX - r.sx * aZ, ay = aY - r.sy * aZ;
    const float bx = bX - r.sx * bZ, by = bY - r.sy * bZ;
    const float cx = cX - r.sx * cZ, cy = cY - r.sy * cZ;

    float u, v, w, sign;
    float cu = cx * by - cy * bx, cv = ax * cy - ay * cx, cw = bx * ay - by * ax;
    // Most tested triangles are missed: reject them with one branch (bitwise |, &: the same
    // truth values as EdgeTest's short-circuit ||, &&, NaN included, without its branches).
    const bool anyNeg = (cu < 0) | (cv < 0) | (cw < 0);
    const bool anyPos = (cu > 0) | (cv > 0) | (cw > 0);
    const bool anyZero = (cu == 0) | (cv == 0) | (cw == 0);
    if (anyNeg & anyPos & !anyZero) return false;
    if (anyZero) {
        double du, dv, dw, dsign;
        if (!EdgeTest<double>(ax, ay, bx, by, cx, cy, &du, &dv, &dw, &dsign)) return false;
        u = static_cast<float>(du * dsign);
        v = static_cast<float>(dv * dsign);
        w = static_cast<float>(dw * dsign);
        sign = static_cast<float>(dsign);
    } else {
        // Inlined EdgeTest<float> on the products already computed (same values).
        u = cu;
        v = cv;
        w = cw;
        const float d0 = u + v + w;
        if (d0 == 0) return false;
        sign = d0 > 0 ? 1.0f : -1.0f;
        u *= sign;
        v *= sign;
        w *= sign;
    }
    (void)sign;
    const float det = u + v + w;
    if (!(det > 0)) return false;

    const float az = r.sz * aZ, bz = r.sz * bZ, cz = r.sz * cZ;
    const float t = (u * az + v * bz + w * cz) / det;
    if (!(t > r.tMin && t < r.tMax)) return false;
    hit->t = t;
    const float inv = 1.0f / det;
    hit->b0 = u * inv;
    hit->b1 = v * inv;
    hit->b2 = w * inv;
    return true;
}
}  // namespace detail

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

/// The cross product of the edges scaled by the triangle's own size (the power of two of
/// its largest edge component, so the scaling is exact and a collinear triangle stays
/// exactly flat), so it neither underflows nor overflows whatever the scale: zero only for
/// a flat triangle (collinear or repeated vertices). Degeneracy is decided on it
/// (CleanMesh; a box at 1e-17 scale, whose squared cross product underflows in float, is
/// not "zero area").
inline Vec3 ScaledTriangleNormal(const Vec3& p0, const Vec3& p1, const Vec3& p2) {
    const Vec3 e1 = p1 - p0, e2 = p2 - p0;
    const float s = std::max(MaxComponent(Abs(e1)), MaxComponent(Abs(e2)));
    if (!(s > 0) || !std::isfinite(s)) return Vec3(0.0f);
    int exponent = 0;
    std::frexp(s, &exponent);
    const float scale = std::ldexp(1.0f, -exponent);
    return Cross(e1 * scale, e2 * scale);
}

/// The unit normal (Normalize(TriangleNormal), bit for bit, for every triangle whose cross
/// product squares within float's range; from ScaledTriangleNormal for tiny or huge ones).
inline Vec3 UnitTriangleNormal(const Vec3& p0, const Vec3& p1, const Vec3& p2) {
    const Vec3 n = TriangleNormal(p0, p1, p2);
    const float l2 = LengthSquared(n);
    if (l2 > 1e-36f && l2 < 1e36f) return Normalize(n);
    return Normalize(ScaledTriangleNormal(p0, p1, p2));
}

/// How far rays leaving a point of the triangle start off its surface, along the normal
/// (the shading point's origin). The rounding errors of a hit point and of the
/// intersection test's t both scale with the magnitude of the coordinates involved, so the
/// offset is a few dozen ulps of the triangle's largest coordinate (a flat bound, unlike
/// pbrt-v4's per-axis one, which is zero for a floor at y = 0 and needs a matching
/// conservative t test). The light mesh's cell patches rely on it being the triangle's.
inline float SurfaceOffset(const Vec3& p0, const Vec3& p1, const Vec3& p2) {
    const float magnitude = std::max({MaxComponent(Abs(p0)), MaxComponent(Abs(p1)), MaxComponent(Abs(p2))});
    return magnitude * 4e-6f + 1e-30f;
}

/// Triangle/box overlap by the separating-axis theorem (Akenine-Möller, "Fast 3D
/// Triangle-Box Overlap Testing", JGT 2001): 3 box normals, the triangle's normal and the 9
/// edge cross products, in double; touching counts as overlapping. Everything that depends
/// on the triangle and the boxes' half sizes `h` only (the 13 axes, the vertices'
/// projections on them, the boxes' radii) is computed once, so a box then costs 13
/// projections of its centre: the nested grid tests one triangle against every cell of its
/// bounding box with it.
class TriangleBoxOverlap {
  public:
    TriangleBoxOverlap(const Vec3& p0, const Vec3& p1, const Vec3& p2, const double h[3]);
    /// Whether the triangle meets the box of centre `c` and the half sizes given.
    bool Overlaps(const double c[3]) const;

  private:
    struct Axis {
        double a[3];      // the axis
        double lo, hi;    // the vertices' projections on it: min and max
        double r;         // the box's radius along it
    };
    Axis axes_[10];  // the triangle's normal, then the 9 edge × box-axis products
    int count_ = 0;  // the edge axes that are not zero
    double lo_[3], hi_[3], h_[3];
};

/// One-shot TriangleBoxOverlap: the box is given by its centre `c` and half sizes `h`.
bool TriangleOverlapsBox(const Vec3& p0, const Vec3& p1, const Vec3& p2, const double c[3],
                         const double h[3]);

}  // namespace lm
