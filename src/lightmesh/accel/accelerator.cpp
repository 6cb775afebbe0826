#include "lightmesh/accel/accelerator.h"

#include "lightmesh/accel/brute_force.h"
#include "lightmesh/accel/grid.h"
#ifdef LIGHTMESH_HAS_EMBREE
#include "lightmesh/accel/embree_accel.h"
#endif
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"


namespace lm {

void Accelerator::IntersectMany(const Ray* rays, size_t count, Hit* hits) const {
    for (size_t i = 0; i < count; ++i) {
        hits[i] = Hit{};
        Intersect(rays[i], &hits[i]);
    }
}

void Accelerator::OccludedMany(const Ray* rays, size_t count, bool* occluded) const {
    for (size_t i = 0; i < count; ++i) occluded[i] = Occluded(rays[i]);
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
        ThrowSettingError("accel", "--accel embree: this build has no Embree back-end (install libembree-dev "
                   "and configure with -DLIGHTMESH_ENABLE_EMBREE=ON)");
#endif
    }
    ThrowSettingError("accel", "unknown ray-query back-end \"%.*s\" (choose brute, grid or embree)",
               static_cast<int>(name.size()), name.data());
}

}  // namespace lm
