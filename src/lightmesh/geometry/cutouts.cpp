// cutouts.cpp -- the alpha test every ray query applies (cutouts.h).
#include "lightmesh/geometry/cutouts.h"

#include <algorithm>
#include <cmath>

#include "lightmesh/geometry/instances.h"
#include "lightmesh/geometry/mesh.h"
#include "lightmesh/util/error.h"

namespace lm {

void CutoutMaterial::ClassifyCells() {
    cells.clear();
    if (!image) return;
    const int w = image->Width(), h = image->Height(), channel = fromRed ? 0 : 3;
    cells.assign(static_cast<size_t>(w) * static_cast<size_t>(h), 0);
    // SolidAt's test is bilinear(corners) · scale ≥ cutoff. The bilinear value lies between
    // the corners' least and greatest values up to a few roundings (relative 1e-6); the
    // margin, 1e-4 of the magnitudes involved, leaves every cell near the cut-off to the
    // computation.
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int x1 = x + 1 == w ? 0 : x + 1, y1 = y + 1 == h ? 0 : y + 1;
            const double a[4] = {image->TexelOpacity(x, y, TextureWrap::Repeat, TextureWrap::Repeat, channel),
                                 image->TexelOpacity(x1, y, TextureWrap::Repeat, TextureWrap::Repeat, channel),
                                 image->TexelOpacity(x, y1, TextureWrap::Repeat, TextureWrap::Repeat, channel),
                                 image->TexelOpacity(x1, y1, TextureWrap::Repeat, TextureWrap::Repeat, channel)};
            double lo = a[0], hi = a[0];
            for (double v : a) lo = std::min(lo, v), hi = std::max(hi, v);
            double sLo = lo * scale, sHi = hi * scale;
            if (sLo > sHi) std::swap(sLo, sHi);
            const double margin = 1e-4 * (std::abs(sLo) + std::abs(sHi) + std::abs(cutoff)) + 1e-12;
            uint8_t& k = cells[static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)];
            if (sLo - margin >= cutoff) k = kCellSolid;
            else if (sHi + margin < cutoff) k = kCellHole;
        }
}

CutoutMask::CutoutMask(const std::vector<int32_t>& materialOf, std::vector<CutoutMaterial> materials,
                       std::shared_ptr<const InstancedMeshes> instances)
    : materials_(std::move(materials)), instances_(std::move(instances)) {
    if (materials_.size() >= UINT16_MAX) ThrowError("%zu cut-out materials: at most %u", materials_.size(), UINT16_MAX - 1);
    for (CutoutMaterial& m : materials_)
        if (m.cells.empty()) m.ClassifyCells();
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
