#include "lightmesh/geometry/triangle.h"

#include <cmath>
#include <utility>

namespace lm {
namespace {

// The edge (ex, ey) in the ray's 2D frame, oriented with the triangle's interior on its
// left, owns points that lie exactly on it when it points up or exactly right.
template <typename T>
inline bool OwnsEdge(T ex, T ey) {
    return ey > 0 || (ey == 0 && ex > 0);
}

// Edge-function evaluation and the inside test, shared by the float path and the double
// fallback. (ax, ay) etc. are the vertices relative to the ray origin, sheared so the ray
// runs along +z. Returns false on a miss; on a hit fills u, v, w (normalised to be >= 0)
// and the sign of the determinant.
template <typename T>
inline bool EdgeTest(T ax, T ay, T bx, T by, T cx, T cy, T* u, T* v, T* w, T* sign) {
    *u = cx * by - cy * bx;  // edge from C to B (opposite A)
    *v = ax * cy - ay * cx;  // edge from A to C (opposite B)
    *w = bx * ay - by * ax;  // edge from B to A (opposite C)
    if ((*u < 0 || *v < 0 || *w < 0) && (*u > 0 || *v > 0 || *w > 0)) return false;
    T det = *u + *v + *w;
    if (det == 0) return false;
    *sign = det > 0 ? T(1) : T(-1);
    // With u, v, w >= 0 after normalisation, the edge directions (B - C), (C - A), (A - B)
    // times sign have the interior on their left; see the header for the ownership rule.
    if (*u == 0 && !OwnsEdge(*sign * (bx - cx), *sign * (by - cy))) return false;
    if (*v == 0 && !OwnsEdge(*sign * (cx - ax), *sign * (cy - ay))) return false;
    if (*w == 0 && !OwnsEdge(*sign * (ax - bx), *sign * (ay - by))) return false;
    return true;
}

}  // namespace

bool IntersectTriangle(const Ray& ray, const Vec3& p0, const Vec3& p1, const Vec3& p2,
                       TriangleHit* hit) {
    // Permute axes so that z is the ray's dominant direction; swap x and y to keep the
    // winding when the dominant component is negative.
    const Vec3& d = ray.d;
    int kz = MaxDimension(Abs(d));
    if (d[kz] == 0) return false;
    int kx = kz + 1 == 3 ? 0 : kz + 1;
    int ky = kx + 1 == 3 ? 0 : kx + 1;
    if (d[kz] < 0) std::swap(kx, ky);
    const float sx = d[kx] / d[kz];
    const float sy = d[ky] / d[kz];
    const float sz = 1.0f / d[kz];

    const Vec3 a = p0 - ray.o, b = p1 - ray.o, c = p2 - ray.o;
    const float ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
    const float bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
    const float cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];

    float u, v, w, sign;
    float cu = cx * by - cy * bx, cv = ax * cy - ay * cx, cw = bx * ay - by * ax;
    if (cu == 0 || cv == 0 || cw == 0) {
        // Exactly on an edge in float: decide in double, where the products are exact.
        double du, dv, dw, dsign;
        if (!EdgeTest<double>(ax, ay, bx, by, cx, cy, &du, &dv, &dw, &dsign)) return false;
        u = static_cast<float>(du * dsign);
        v = static_cast<float>(dv * dsign);
        w = static_cast<float>(dw * dsign);
        sign = static_cast<float>(dsign);
    } else {
        if (!EdgeTest<float>(ax, ay, bx, by, cx, cy, &u, &v, &w, &sign)) return false;
        u *= sign;
        v *= sign;
        w *= sign;
    }
    const float det = u + v + w;  // > 0 after normalisation
    if (!(det > 0)) return false;

    const float az = sz * a[kz], bz = sz * b[kz], cz = sz * c[kz];
    const float t = (u * az + v * bz + w * cz) / det;
    if (!(t > ray.tMin && t < ray.tMax)) return false;
    hit->t = t;
    const float inv = 1.0f / det;
    hit->b0 = u * inv;
    hit->b1 = v * inv;
    hit->b2 = w * inv;
    return true;
}

}  // namespace lm
