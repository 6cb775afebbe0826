#include "lightmesh/accel/accelerator.h"

#include "lightmesh/accel/brute_force.h"
#include "lightmesh/accel/grid.h"
#ifdef LIGHTMESH_HAS_EMBREE
#include "lightmesh/accel/embree_accel.h"
#endif
#include "lightmesh/geometry/instances.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"


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

namespace {

/// A back-end that reads triangles as one array (brute force, the nested grid) over a mesh
/// with instances: it is built over a world-space copy of its own (FlattenInstances keeps
/// every id), whose memory Figures reports.
class FlattenedAccel final : public Accelerator {
  public:
    FlattenedAccel(const TriangleMesh& mesh, std::string_view name, const AccelOptions& options)
        : flat_(Flattened(mesh)), instances_(mesh.instances->Instances().size()) {
        if (name == "brute") inner_ = std::make_unique<BruteForceAccel>(flat_);
        else inner_ = std::make_unique<NestedGridAccel>(flat_, options);
    }
    std::string_view Name() const override { return inner_->Name(); }
    bool Intersect(const Ray& ray, Hit* hit) const override { return inner_->Intersect(ray, hit); }
    bool Occluded(const Ray& ray) const override { return inner_->Occluded(ray); }
    void IntersectMany(const Ray* rays, size_t count, Hit* hits) const override { inner_->IntersectMany(rays, count, hits); }
    void OccludedMany(const Ray* rays, size_t count, bool* occluded) const override {
        inner_->OccludedMany(rays, count, occluded);
    }
    int CountCrossings(const Ray& ray) const override { return inner_->CountCrossings(ray); }
    AccelFigures Figures() const override {
        AccelFigures f = inner_->Figures();
        const double bytes = static_cast<double>(flat_.positions.size() * sizeof(Vec3) + flat_.normals.size() * sizeof(Vec3) +
                                                 flat_.uvs.size() * sizeof(TexCoord) +
                                                 flat_.triangles.size() * (3 * sizeof(uint32_t) + sizeof(uint32_t)));
        f.insert(f.begin(), {"flattened copy", StringPrintf("%s triangles (%s instances expanded), %.1f MB",
                                                            FormatCount(flat_.TriangleCount()).c_str(),
                                                            FormatCount(instances_).c_str(), bytes / 1e6)});
        return f;
    }

  private:
    TriangleMesh flat_;
    size_t instances_;
    std::unique_ptr<Accelerator> inner_;
};

}  // namespace

std::vector<std::string> AcceleratorNames() { return {"brute", "grid", "embree"}; }

std::unique_ptr<Accelerator> CreateAccelerator(std::string_view name, const TriangleMesh& mesh,
                                               const AccelOptions& options) {
    if ((name == "brute" || name == "grid") && mesh.instances) return std::make_unique<FlattenedAccel>(mesh, name, options);
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
