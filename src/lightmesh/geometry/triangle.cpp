#include "lightmesh/geometry/triangle.h"

#include <algorithm>
#include <cmath>

namespace lm {

bool IntersectTriangle(const Ray& ray, const Vec3& p0, const Vec3& p1, const Vec3& p2,
                       TriangleHit* hit) {
    const float p[9] = {p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, p2.x, p2.y, p2.z};
    return detail::IntersectPrepared(detail::PreparedRay(ray), p, hit);
}

bool TriangleOverlapsBox(const Vec3& p0, const Vec3& p1, const Vec3& p2, const double c[3], const double h[3]) {
    double v[3][3];
    for (int a = 0; a < 3; ++a) {
        v[0][a] = double(p0[a]) - c[a];
        v[1][a] = double(p1[a]) - c[a];
        v[2][a] = double(p2[a]) - c[a];
    }
    // Box normals: the bounding boxes overlap.
    for (int a = 0; a < 3; ++a) {
        double lo = std::min({v[0][a], v[1][a], v[2][a]});
        double hi = std::max({v[0][a], v[1][a], v[2][a]});
        if (lo > h[a] || hi < -h[a]) return false;
    }
    double e[3][3];
    for (int a = 0; a < 3; ++a) {
        e[0][a] = v[1][a] - v[0][a];
        e[1][a] = v[2][a] - v[1][a];
        e[2][a] = v[0][a] - v[2][a];
    }
    // Triangle normal: the plane passes through the box.
    {
        double n[3] = {e[0][1] * e[1][2] - e[0][2] * e[1][1], e[0][2] * e[1][0] - e[0][0] * e[1][2],
                       e[0][0] * e[1][1] - e[0][1] * e[1][0]};
        double d = n[0] * v[0][0] + n[1] * v[0][1] + n[2] * v[0][2];
        double r = h[0] * std::abs(n[0]) + h[1] * std::abs(n[1]) + h[2] * std::abs(n[2]);
        if (std::abs(d) > r) return false;
    }
    // Edge × axis.
    for (int i = 0; i < 3; ++i) {
        for (int a = 0; a < 3; ++a) {
            // axis = e_i × unit(a)
            const int b = (a + 1) % 3, c2 = (a + 2) % 3;
            double ax[3];
            ax[a] = 0;
            ax[b] = e[i][c2];
            ax[c2] = -e[i][b];
            double p0 = ax[b] * v[0][b] + ax[c2] * v[0][c2];
            double p1 = ax[b] * v[1][b] + ax[c2] * v[1][c2];
            double p2 = ax[b] * v[2][b] + ax[c2] * v[2][c2];
            double r = h[b] * std::abs(ax[b]) + h[c2] * std::abs(ax[c2]);
            if (std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r) return false;
        }
    }
    return true;
}

}  // namespace lm
