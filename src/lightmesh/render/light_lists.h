// light_lists.h -- per cell of a grid over the scene, the lights that can reach it (their
// "range" spheres meet the cell): shading a point looks at those lights only, so with many
// lights of limited range a point's cost follows the lights near it, not the scene's count.
// Shared by every shadow method: a light the list leaves out is not needed at the point, so
// no method is asked for it.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "lightmesh/math/bounds.h"
#include "lightmesh/scene/scene.h"

namespace lm {

class LightLists {
  public:
    LightLists() = default;
    /// Lists over `box` (the scene's bounds) for the lights with a finite range; none at
    /// all (Active() false) when no light has one.
    LightLists(const std::vector<PointLight>& lights, const Bounds3& box);

    /// Whether any light has a finite range (else every light is every point's).
    bool Active() const { return active_; }
    /// The lights without a range: every point's, in ascending order.
    std::span<const uint32_t> Everywhere() const { return everywhere_; }
    /// The lights with a range whose sphere may hold p (a superset of those that do), in
    /// ascending order; p outside the grid: every light with a range.
    std::span<const uint32_t> Near(const Vec3& p) const;

    /// Cells along each axis, entries over all cells, bytes of the lists.
    int CellsX() const { return nx_; }
    int CellsY() const { return ny_; }
    int CellsZ() const { return nz_; }
    uint64_t Entries() const { return ids_.size(); }
    uint64_t Bytes() const { return (ids_.size() + start_.size()) * sizeof(uint32_t) + everywhere_.size() * sizeof(uint32_t); }

  private:
    bool active_ = false;
    Bounds3 box_;
    Vec3 inv_;  // cells per unit along each axis
    int nx_ = 0, ny_ = 0, nz_ = 0;
    std::vector<uint32_t> start_;  // CSR: cell c's lights are ids_[start_[c] .. start_[c + 1])
    std::vector<uint32_t> ids_;
    std::vector<uint32_t> everywhere_, ranged_;
};

}  // namespace lm
