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
    const CutoutMaterial& m = materials_[entry_[prim] - 1u];
    const auto& t = mesh.triangles[prim];
    const TexCoord &t0 = mesh.uvs[t[0]], &t1 = mesh.uvs[t[1]], &t2 = mesh.uvs[t[2]];
    const float b0 = 1.0f - b1 - b2;
    const float u = t0.u * b0 + t1.u * b1 + t2.u * b2;
    const float v = t0.v * b0 + t1.v * b1 + t2.v * b2;
    const float alpha = m.fromRed ? m.image->Sample(u, v, 0, m.wrapU, m.wrapV).r : m.image->Alpha(u, v, m.wrapU, m.wrapV);
    return alpha * m.scale >= m.cutoff;
}

}  // namespace lm
