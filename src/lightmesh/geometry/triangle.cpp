#include "lightmesh/geometry/triangle.h"

namespace lm {

bool IntersectTriangle(const Ray& ray, const Vec3& p0, const Vec3& p1, const Vec3& p2,
                       TriangleHit* hit) {
    const float p[9] = {p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, p2.x, p2.y, p2.z};
    return detail::IntersectPrepared(detail::PreparedRay(ray), p, hit);
}

}  // namespace lm
