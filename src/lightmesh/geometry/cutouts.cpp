// cutouts.cpp -- the alpha test every ray query applies (cutouts.h).
#include "lightmesh/geometry/cutouts.h"

#include "lightmesh/geometry/instances.h"
#include "lightmesh/geometry/mesh.h"
#include "lightmesh/util/error.h"

namespace lm {

CutoutMask::CutoutMask(const std::vector<int32_t>& materialOf, std::vector<CutoutMaterial> materials,
                       std::shared_ptr<const InstancedMeshes> instances)
    : materials_(std::move(materials)), instances_(std::move(instances)) {
    if (materials_.size() >= UINT16_MAX) ThrowError("%zu cut-out materials: at most %u", materials_.size(), UINT16_MAX - 1);
    entry_.resize(materialOf.size());
    for (size_t i = 0; i < materialOf.size(); ++i) {
        const int32_t m = materialOf[i];
        if (m >= 0 && static_cast<size_t>(m) < materials_.size() && materials_[static_cast<size_t>(m)].image) {
            entry_[i] = static_cast<uint16_t>(m + 1);
            ++count_;
        }
    }
    if (instances_)
        for (const MeshInstance& in : instances_->Instances())
            if (const auto& c = instances_->Prototypes()[in.prototype].cutouts) count_ += c->Count();
}

const CutoutMaterial* CutoutMask::InstancedMaterial(uint32_t prim) const {
    const uint32_t id = prim - static_cast<uint32_t>(entry_.size());
    if (id >= instances_->TriangleCount()) return nullptr;
    const MeshInstance& in = instances_->Instances()[instances_->Locate(id)];
    const auto& cut = instances_->Prototypes()[in.prototype].cutouts;
    return cut ? cut->MaterialOf(id - in.first) : nullptr;
}

bool CutoutMask::Solid(const TriangleMesh& mesh, uint32_t prim, float b1, float b2) const {
    if (prim >= entry_.size() && instances_) {
        // The prototype's triangle, its corners 1 and 2 swapped under a mirroring transform.
        const uint32_t id = prim - static_cast<uint32_t>(entry_.size());
        if (id >= instances_->TriangleCount()) return true;
        const MeshInstance& in = instances_->Instances()[instances_->Locate(id)];
        const TriangleMesh& proto = instances_->Prototypes()[in.prototype];
        if (!proto.cutouts) return true;
        const bool mirrored = in.toWorld.Determinant() < 0;
        return proto.cutouts->Solid(proto, id - in.first, mirrored ? b2 : b1, mirrored ? b1 : b2);
    }
    if (prim >= entry_.size() || entry_[prim] == 0 || mesh.uvs.empty()) return true;
    const auto& t = mesh.triangles[prim];
    return SolidAt(materials_[entry_[prim] - 1u], mesh.uvs[t[0]], mesh.uvs[t[1]], mesh.uvs[t[2]], b1, b2);
}

}  // namespace lm
