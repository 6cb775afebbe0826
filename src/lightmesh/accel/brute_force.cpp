#include "lightmesh/accel/brute_force.h"

#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/util/error.h"

namespace lm {

bool BruteForceAccel::Intersect(const Ray& ray, Hit* hit) const {
    Ray r = ray;
    bool found = false;
    TriangleHit th;
    const CutoutMask* cut = mesh_.cutouts.get();
    for (uint32_t i = 0; i < mesh_.triangles.size(); ++i) {
        if (IntersectTriangle(r, mesh_.Vertex(i, 0), mesh_.Vertex(i, 1), mesh_.Vertex(i, 2), &th) &&
            (!cut || cut->Solid(mesh_, i, th.b1, th.b2))) {
            r.tMax = th.t;  // only closer hits from now on; ties keep the lower id
            *hit = Hit{th.t, i, th.b1, th.b2};
            found = true;
        }
    }
    return found;
}

bool BruteForceAccel::Occluded(const Ray& ray) const {
    TriangleHit th;
    const CutoutMask* cut = mesh_.cutouts.get();
    for (uint32_t i = 0; i < mesh_.triangles.size(); ++i)
        if (IntersectTriangle(ray, mesh_.Vertex(i, 0), mesh_.Vertex(i, 1), mesh_.Vertex(i, 2), &th) &&
            (!cut || cut->Solid(mesh_, i, th.b1, th.b2)))
            return true;
    return false;
}

int BruteForceAccel::CountCrossings(const Ray& ray) const { return lm::CountCrossings(mesh_, ray); }

AccelFigures BruteForceAccel::Figures() const {
    return {{"triangles", StringPrintf("%zu", mesh_.triangles.size())},
            {"bytes per triangle", "0"}};
}

}  // namespace lm
