#include "lightmesh/render/light_lists.h"

#include <algorithm>
#include <cmath>

#include "lightmesh/util/error.h"

namespace lm {

LightLists::LightLists(const std::vector<PointLight>& lights, const Bounds3& box) {
    std::vector<float> ranges;
    for (uint32_t i = 0; i < lights.size(); ++i) {
        if (std::isfinite(lights[i].range)) {
            ranged_.push_back(i);
            ranges.push_back(lights[i].range);
        } else {
            everywhere_.push_back(i);
        }
    }
    if (ranged_.empty() || box.IsEmpty()) {
        everywhere_.clear();
        ranged_.clear();
        return;
    }
    active_ = true;
    // The box grown by 1 % of its longest side (shading origins sit a hair off their
    // surfaces); cells of about half the median range (a light's sphere then meets about
    // 5³ cells), at most 64 along the longest side and at least one.
    const float longest = std::max(box.MaxExtent(), 1e-20f);
    const Vec3 grow(0.01f * longest);
    box_ = Bounds3(box.lo - grow, box.hi + grow);
    std::nth_element(ranges.begin(), ranges.begin() + static_cast<std::ptrdiff_t>(ranges.size() / 2), ranges.end());
    const float side = std::max(ranges[ranges.size() / 2] * 0.5f, box_.MaxExtent() / 64.0f);
    const Vec3 d = box_.Diagonal();
    auto count = [&](float e) { return std::clamp(static_cast<int>(std::ceil(e / side)), 1, 64); };
    nx_ = count(d.x), ny_ = count(d.y), nz_ = count(d.z);
    inv_ = Vec3(static_cast<float>(nx_) / std::max(d.x, 1e-30f), static_cast<float>(ny_) / std::max(d.y, 1e-30f),
                static_cast<float>(nz_) / std::max(d.z, 1e-30f));
    const size_t cells = static_cast<size_t>(nx_) * ny_ * nz_;
    auto cellLo = [&](int i, int j, int k) {
        return box_.lo + Vec3(static_cast<float>(i) * d.x / static_cast<float>(nx_), static_cast<float>(j) * d.y / static_cast<float>(ny_),
                              static_cast<float>(k) * d.z / static_cast<float>(nz_));
    };
    // Light by light, the cells its sphere meets (the squared distance from its centre to
    // the cell's box, with a relative margin so the lists err on the side of holding it),
    // counted, then written (CSR); within a cell in ascending light order.
    std::vector<std::vector<uint32_t>> perCell(cells);
    for (uint32_t id : ranged_) {
        const PointLight& l = lights[id];
        const float r = l.range * (1.0f + 1e-4f) + 1e-6f * longest;
        auto index = [&](float v, float lo, float inv, int n) {
            return std::clamp(static_cast<int>(std::floor((v - lo) * inv)), 0, n - 1);
        };
        const int i0 = index(l.position.x - r, box_.lo.x, inv_.x, nx_), i1 = index(l.position.x + r, box_.lo.x, inv_.x, nx_);
        const int j0 = index(l.position.y - r, box_.lo.y, inv_.y, ny_), j1 = index(l.position.y + r, box_.lo.y, inv_.y, ny_);
        const int k0 = index(l.position.z - r, box_.lo.z, inv_.z, nz_), k1 = index(l.position.z + r, box_.lo.z, inv_.z, nz_);
        // The cells' boxes one cell wider than their index range says (rounding of the
        // index arithmetic never drops a light a point of the cell could see).
        for (int k = k0; k <= k1; ++k)
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) {
                    const Vec3 lo = cellLo(i, j, k), hi = cellLo(i + 1, j + 1, k + 1);
                    const Vec3 q = Max(lo, Min(l.position, hi));
                    if (LengthSquared(q - l.position) > r * r) continue;
                    perCell[(static_cast<size_t>(k) * ny_ + j) * nx_ + i].push_back(id);
                }
    }
    start_.resize(cells + 1);
    size_t total = 0;
    for (size_t c = 0; c < cells; ++c) {
        start_[c] = static_cast<uint32_t>(total);
        total += perCell[c].size();
        if (total > UINT32_MAX) ThrowError("light lists: more than 2^32 (cell, light) entries");
    }
    start_[cells] = static_cast<uint32_t>(total);
    ids_.reserve(total);
    for (const auto& c : perCell) ids_.insert(ids_.end(), c.begin(), c.end());
}

std::span<const uint32_t> LightLists::Near(const Vec3& p) const {
    const float fx = (p.x - box_.lo.x) * inv_.x, fy = (p.y - box_.lo.y) * inv_.y, fz = (p.z - box_.lo.z) * inv_.z;
    if (!(fx >= 0 && fy >= 0 && fz >= 0 && fx < static_cast<float>(nx_) && fy < static_cast<float>(ny_) &&
          fz < static_cast<float>(nz_)))
        return ranged_;
    const size_t c = (static_cast<size_t>(fz) * ny_ + static_cast<size_t>(fy)) * nx_ + static_cast<size_t>(fx);
    return {ids_.data() + start_[c], ids_.data() + start_[c + 1]};
}

}  // namespace lm
