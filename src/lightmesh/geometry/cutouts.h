// cutouts.h -- alpha cut-outs: which points of a triangle are surface and which are holes
// (foliage cards, fences), the one test every ray query of every back-end and shadow
// method applies to a hit, so that they all agree on where a cut-out surface is.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/texture/texture.h"

namespace lm {


/// How a material cuts its surface: a point is solid where scale × its alpha (the image's
/// alpha channel, or its red channel for a grey opacity map without one; bytes / 255, not
/// sRGB-decoded) is at least `cutoff`.
struct CutoutMaterial {
    std::shared_ptr<const Texture> image;
    float cutoff = 0.5f;
    float scale = 1.0f;
    TextureWrap wrapU = TextureWrap::Repeat, wrapV = TextureWrap::Repeat;
    bool fromRed = false;  ///< the opacity is the image's red channel (a grey map_d)

    /// What every point of a texel cell is, one byte per cell of the full image (the cell
    /// whose lower-left corner is texel (x, y) and the others (x + 1, y), (x, y + 1),
    /// (x + 1, y + 1), taken modulo the size): kCellSolid when all four corners are solid
    /// with a margin, kCellHole when all four are holes with a margin (a bilinear value lies
    /// between its corners, and the margin covers its rounding), 0 when SolidAt must
    /// compute it. Built by CutoutMask; empty: always computed.
    std::vector<uint8_t> cells;
    static constexpr uint8_t kCellSolid = 1, kCellHole = 2;
    /// Fills `cells` from the image (w × h bytes).
    void ClassifyCells();
};

/// The cut-out triangles of a mesh and their materials. Held by the mesh it was built for
/// (TriangleMesh::cutouts), which every back-end and shadow method sees; a mesh without
/// cut-outs holds none and pays one null test per candidate hit. With instances
/// (geometry/instances.h), ids past the flat triangles are answered by the instance's
/// prototype's own mask (its local id; the barycentrics swapped under a mirroring
/// transform), so every caller asks by the mesh's ids alike, instanced or flattened.
class CutoutMask {
  public:
    /// `materialOf[prim]` is an index into `materials` for a cut-out triangle, -1 for an
    /// opaque one (one entry per flat triangle of the mesh); `instances`: the mesh's, whose
    /// prototypes carry their own masks (or null).
    CutoutMask(const std::vector<int32_t>& materialOf, std::vector<CutoutMaterial> materials,
               std::shared_ptr<const InstancedMeshes> instances = nullptr);

    /// Whether triangle `prim` is a cut-out one (its hits need Solid).
    bool IsCutout(uint32_t prim) const {
        return prim < entry_.size() ? entry_[prim] != 0 : instances_ && InstancedMaterial(prim);
    }
    /// Whether the point of triangle `prim` at barycentrics (b1, b2) is surface (true) or a
    /// hole: the material's opacity at the point's texture coordinates, bilinear on the full
    /// image (Texture::Alpha). True for opaque triangles. The same answer for every caller.
    bool Solid(const TriangleMesh& mesh, uint32_t prim, float b1, float b2) const;
    /// The number of cut-out triangles (instanced ones included).
    size_t Count() const { return count_; }
    /// Bytes of the materials' cell tables (CutoutMaterial::cells).
    size_t Bytes() const {
        size_t n = 0;
        for (const CutoutMaterial& m : materials_) n += m.cells.size();
        return n;
    }

    /// Solid's parts, for a caller that tests many points of one triangle (the soft
    /// shadows' directions): the triangle's material (null: opaque), its vertices' texture
    /// coordinates, and the test at barycentrics (b1, b2), Solid's arithmetic exactly.
    const CutoutMaterial* MaterialOf(uint32_t prim) const {
        if (prim >= entry_.size()) return instances_ ? InstancedMaterial(prim) : nullptr;
        return entry_[prim] ? &materials_[entry_[prim] - 1u] : nullptr;
    }
    static bool SolidAt(const CutoutMaterial& m, const TexCoord& t0, const TexCoord& t1, const TexCoord& t2, float b1,
                        float b2) {
        const float b0 = 1.0f - b1 - b2;
        const float u = t0.u * b0 + t1.u * b1 + t2.u * b2;
        const float v = t0.v * b0 + t1.v * b1 + t2.v * b2;
        return SolidUV(m, u, v);
    }
    /// SolidAt at the point's texture coordinates (u, v).
    static bool SolidUV(const CutoutMaterial& m, float u, float v) {
        const Texture::TexelCell c = m.image->CellAt(u, v, m.wrapU, m.wrapV);
        if (!m.cells.empty()) {
            // A cell whose corners all agree, with the four corners the lookup reads (not an
            // edge of a clamped or mirrored image, where the neighbour is not the next texel):
            // one byte instead of four texels. The answer is the computed one.
            const int w = m.image->Width(), h = m.image->Height();
            if (c.xb == (c.xa + 1 == w ? 0 : c.xa + 1) && c.yb == (c.ya + 1 == h ? 0 : c.ya + 1))
                if (const uint8_t k = m.cells[static_cast<size_t>(c.ya) * static_cast<size_t>(w) + static_cast<size_t>(c.xa)])
                    return k == CutoutMaterial::kCellSolid;
        }
        return m.image->OpacityOf(c, m.fromRed ? 0 : 3) * m.scale >= m.cutoff;
    }

  private:
    const CutoutMaterial* InstancedMaterial(uint32_t prim) const;
    std::vector<uint16_t> entry_;  // per triangle: 1 + index into materials_, 0 opaque
    std::vector<CutoutMaterial> materials_;
    size_t count_ = 0;
    std::shared_ptr<const InstancedMeshes> instances_;
};

}  // namespace lm
