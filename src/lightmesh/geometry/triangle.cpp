#include "lightmesh/geometry/triangle.h"

#include <algorithm>
#include <cmath>

namespace lm {

bool IntersectTriangle(const Ray& ray, const Vec3& p0, const Vec3& p1, const Vec3& p2,
                       TriangleHit* hit) {
    const float p[9] = {p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, p2.x, p2.y, p2.z};
    return detail::IntersectPrepared(detail::PreparedRay(ray), p, hit);
}

TriangleBoxOverlap::TriangleBoxOverlap(const Vec3& p0, const Vec3& p1, const Vec3& p2, const double h[3]) {
    const double v[3][3] = {{p0.x, p0.y, p0.z}, {p1.x, p1.y, p1.z}, {p2.x, p2.y, p2.z}};
    for (int a = 0; a < 3; ++a) {
        lo_[a] = std::min({v[0][a], v[1][a], v[2][a]});
        hi_[a] = std::max({v[0][a], v[1][a], v[2][a]});
        h_[a] = h[a];
    }
    double e[3][3];
    for (int a = 0; a < 3; ++a) {
        e[0][a] = v[1][a] - v[0][a];
        e[1][a] = v[2][a] - v[1][a];
        e[2][a] = v[0][a] - v[2][a];
    }
    auto add = [&](double x, double y, double z) {
        Axis& ax = axes_[count_++];
        ax.a[0] = x;
        ax.a[1] = y;
        ax.a[2] = z;
        const double q0 = x * v[0][0] + y * v[0][1] + z * v[0][2];
        const double q1 = x * v[1][0] + y * v[1][1] + z * v[1][2];
        const double q2 = x * v[2][0] + y * v[2][1] + z * v[2][2];
        ax.lo = std::min({q0, q1, q2});
        ax.hi = std::max({q0, q1, q2});
        ax.r = h[0] * std::abs(x) + h[1] * std::abs(y) + h[2] * std::abs(z);
    };
    // The triangle's normal: the plane passes through the box.
    add(e[0][1] * e[1][2] - e[0][2] * e[1][1], e[0][2] * e[1][0] - e[0][0] * e[1][2],
        e[0][0] * e[1][1] - e[0][1] * e[1][0]);
    // Edge × box axis a: (0, -e_z, e_y), (e_z, 0, -e_x), (-e_y, e_x, 0). A zero axis
    // separates nothing and is left out.
    for (int i = 0; i < 3; ++i) {
        const double x = e[i][0], y = e[i][1], z = e[i][2];
        if (y != 0 || z != 0) add(0, -z, y);
        if (x != 0 || z != 0) add(z, 0, -x);
        if (x != 0 || y != 0) add(-y, x, 0);
    }
}

bool TriangleBoxOverlap::Overlaps(const double c[3]) const {
    // Box normals: the bounding boxes overlap.
    for (int a = 0; a < 3; ++a)
        if (lo_[a] - c[a] > h_[a] || hi_[a] - c[a] < -h_[a]) return false;
    for (int k = 0; k < count_; ++k) {
        const Axis& ax = axes_[k];
        const double pc = ax.a[0] * c[0] + ax.a[1] * c[1] + ax.a[2] * c[2];
        if (ax.lo - pc > ax.r || ax.hi - pc < -ax.r) return false;
    }
    return true;
}

bool TriangleOverlapsBox(const Vec3& p0, const Vec3& p1, const Vec3& p2, const double c[3], const double h[3]) {
    return TriangleBoxOverlap(p0, p1, p2, h).Overlaps(c);
}

}  // namespace lm
