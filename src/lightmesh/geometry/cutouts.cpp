// cutouts.cpp -- the alpha test every ray query applies (cutouts.h).
#include "lightmesh/geometry/cutouts.h"

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/util/error.h"

namespace lm {

CutoutMask::CutoutMask(const std::vector<int32_t>& materialOf, std::vector<CutoutMaterial> materials)
    : materials_(std::move(materials)) {
    if (materials_.size() >= UINT16_MAX) ThrowError("%zu cut-out materials: at most %u", materials_.size(), UINT16_MAX - 1);
    entry_.resize(materialOf.size());
    for (size_t i = 0; i < materialOf.size(); ++i) {
        const int32_t m = materialOf[i];
        if (m >= 0 && static_cast<size_t>(m) < materials_.size() && materials_[static_cast<size_t>(m)].image) {
            entry_[i] = static_cast<uint16_t>(m + 1);
            ++count_;
        }
    }
}

bool CutoutMask::Solid(const TriangleMesh& mesh, uint32_t prim, float b1, float b2) const {
    if (prim >= entry_.size() || entry_[prim] == 0 || mesh.uvs.empty()) return true;
    const auto& t = mesh.triangles[prim];
    return SolidAt(materials_[entry_[prim] - 1u], mesh.uvs[t[0]], mesh.uvs[t[1]], mesh.uvs[t[2]], b1, b2);
}

}  // namespace lm
