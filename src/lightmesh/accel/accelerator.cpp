#include "lightmesh/accel/accelerator.h"

#include "lightmesh/accel/brute_force.h"
#include "lightmesh/accel/grid.h"
#ifdef LIGHTMESH_HAS_EMBREE
#include "lightmesh/accel/embree_accel.h"
#endif
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/util/error.h"

#include <algorithm>

namespace lm {

void KeepOverlapping(const TriangleMesh& mesh, const Bounds3& box, std::vector<uint32_t>& ids,
                     std::vector<uint32_t>* out, bool exact) {
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    const double c[3] = {0.5 * (double(box.lo.x) + box.hi.x), 0.5 * (double(box.lo.y) + box.hi.y),
                         0.5 * (double(box.lo.z) + box.hi.z)};
    const double h[3] = {0.5 * (double(box.hi.x) - box.lo.x), 0.5 * (double(box.hi.y) - box.lo.y),
                         0.5 * (double(box.hi.z) - box.lo.z)};
    for (uint32_t id : ids) {
        const Vec3 &p0 = mesh.Vertex(id, 0), &p1 = mesh.Vertex(id, 1), &p2 = mesh.Vertex(id, 2);
        const Vec3 lo = Min(p0, Min(p1, p2)), hi = Max(p0, Max(p1, p2));
        if (!(lo.x <= box.hi.x && hi.x >= box.lo.x && lo.y <= box.hi.y && hi.y >= box.lo.y &&
              lo.z <= box.hi.z && hi.z >= box.lo.z))
            continue;
        if (!exact || TriangleOverlapsBox(p0, p1, p2, c, h)) out->push_back(id);
    }
}

std::vector<std::string> AcceleratorNames() { return {"brute", "grid", "embree"}; }

std::unique_ptr<Accelerator> CreateAccelerator(std::string_view name, const TriangleMesh& mesh,
                                               const AccelOptions& options) {
    if (name == "brute") return std::make_unique<BruteForceAccel>(mesh);
    if (name == "grid") return std::make_unique<NestedGridAccel>(mesh, options);
    if (name == "embree") {
#ifdef LIGHTMESH_HAS_EMBREE
        return std::make_unique<EmbreeAccel>(mesh);
#else
        ThrowError("--accel embree: this build has no Embree back-end (install libembree-dev "
                   "and configure with -DLIGHTMESH_ENABLE_EMBREE=ON)");
#endif
    }
    ThrowError("unknown ray-query back-end \"%.*s\" (choose brute, grid or embree)",
               static_cast<int>(name.size()), name.data());
}

}  // namespace lm
