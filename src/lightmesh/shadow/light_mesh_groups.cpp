#include "lightmesh/shadow/light_mesh_groups.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace {

// 10 bits of each coordinate interleaved (z, y, x from the top).
uint32_t Morton3(uint32_t x, uint32_t y, uint32_t z) {
    auto spread = [](uint32_t v) {
        v &= 0x3FF;
        v = (v | (v << 16)) & 0x030000FF;
        v = (v | (v << 8)) & 0x0300F00F;
        v = (v | (v << 4)) & 0x030C30C3;
        v = (v | (v << 2)) & 0x09249249;
        return v;
    };
    return spread(x) | (spread(y) << 1) | (spread(z) << 2);
}

class LightMeshGroups final : public LightMeshShadows {
  public:
    LightMeshGroups(const Scene& scene, std::vector<std::vector<uint32_t>> groups,
                    std::vector<std::unique_ptr<LightMeshShadows>> meshes)
        : scene_(scene), groups_(std::move(groups)), meshes_(std::move(meshes)), group_(scene.lights.size()),
          local_(scene.lights.size()) {
        for (size_t g = 0; g < groups_.size(); ++g)
            for (size_t k = 0; k < groups_[g].size(); ++k) {
                group_[groups_[g][k]] = static_cast<uint32_t>(g);
                local_[groups_[g][k]] = static_cast<uint32_t>(k);
            }
    }

    // Each group that holds a light the point needs answers its lights; the others are not
    // asked.
    void Visibility(const ShadingPoint& sp, const bool* needed, float* vis, RenderCounters& counters) const override {
        bool need[kMaxLightsPerWord];
        float v[kMaxLightsPerWord];
        for (size_t g = 0; g < groups_.size(); ++g) {
            const std::vector<uint32_t>& ids = groups_[g];
            bool any = false;
            for (size_t k = 0; k < ids.size(); ++k) any |= (need[k] = needed[ids[k]]);
            if (!any) continue;
            std::fill(v, v + ids.size(), 0.0f);
            meshes_[g]->Visibility(sp, need, v, counters);
            for (size_t k = 0; k < ids.size(); ++k)
                if (need[k]) vis[ids[k]] = v[k];
        }
    }

    // Group by group, the points that need one of its lights, as one block.
    void VisibilityMany(const ShadingPoint* sps, size_t count, size_t lights, const bool* needed, float* vis,
                        RenderCounters& counters) const override {
        thread_local std::vector<ShadingPoint> points;
        thread_local std::vector<size_t> which;
        thread_local std::vector<uint8_t> need;  // bools (vector<bool> has no data())
        thread_local std::vector<float> v;
        for (size_t g = 0; g < groups_.size(); ++g) {
            const std::vector<uint32_t>& ids = groups_[g];
            const size_t n = ids.size();
            points.clear(), which.clear(), need.clear();
            for (size_t i = 0; i < count; ++i) {
                const bool* pn = needed + i * lights;
                const size_t at = need.size();
                bool any = false;
                for (size_t k = 0; k < n; ++k) {
                    need.push_back(pn[ids[k]]);
                    any |= pn[ids[k]];
                }
                if (!any) {
                    need.resize(at);
                    continue;
                }
                points.push_back(sps[i]);
                which.push_back(i);
            }
            if (points.empty()) continue;
            v.assign(points.size() * n, 0.0f);
            meshes_[g]->VisibilityMany(points.data(), points.size(), n, reinterpret_cast<const bool*>(need.data()),
                                       v.data(), counters);
            for (size_t j = 0; j < points.size(); ++j)
                for (size_t k = 0; k < n; ++k)
                    if (need[j * n + k]) vis[which[j] * lights + ids[k]] = v[j * n + k];
        }
    }

    const LightMeshLattice& Lattice() const override { return meshes_.front()->Lattice(); }
    const LightMeshVariant& Variant() const override { return meshes_.front()->Variant(); }
    const TemplateLoad& Templates() const override { return meshes_.front()->Templates(); }
    int BytesPerNode() const override {
        int bytes = 0;
        for (const auto& m : meshes_) bytes += m->BytesPerNode();
        return bytes;
    }
    // Node words evaluated, summed over the groups (a node evaluated for two groups counts
    // twice: its rays went to two groups' lights).
    uint64_t NodesEvaluated() const override {
        uint64_t n = 0;
        for (const auto& m : meshes_) n += m->NodesEvaluated();
        return n;
    }
    bool IsEvaluated(uint64_t index) const override {
        for (const auto& m : meshes_)
            if (m->IsEvaluated(index)) return true;
        return false;
    }
    // Bits of the scene's first 64 lights.
    uint64_t NodeVisibility(uint64_t index) const override {
        uint64_t bits = 0;
        for (size_t l = 0; l < std::min<size_t>(64, group_.size()); ++l)
            bits |= ((meshes_[group_[l]]->NodeVisibility(index) >> local_[l]) & 1) << l;
        return bits;
    }
    bool NodeInside(uint64_t index) const override { return meshes_.front()->NodeInside(index); }
    float NodeBlockerParameter(uint64_t index, size_t light) const override {
        if (light >= group_.size()) return 0.0f;
        return meshes_[group_[light]]->NodeBlockerParameter(index, local_[light]);
    }

    // The first group's figures, with the storage and the nodes for all groups (its cell
    // summaries are the first group's: each group keeps its own).
    ShadowFigures Figures() const override {
        ShadowFigures f = meshes_.front()->Figures();
        const uint64_t total = Lattice().NodeCount();
        uint64_t evaluated = 0, segments = 0;
        for (size_t g = 0; g < meshes_.size(); ++g) {
            evaluated += meshes_[g]->NodesEvaluated();
            segments += meshes_[g]->NodesEvaluated() * groups_[g].size();
        }
        for (auto& [name, value] : f) {
            if (name == "node storage")
                value = StringPrintf("%s at most (%d bytes per node: %zu lights in %zu groups of up to %zu, a word each%s); "
                                     "%s touched",
                                     FormatBytes(total * static_cast<uint64_t>(BytesPerNode())).c_str(), BytesPerNode(),
                                     scene_.lights.size(), groups_.size(), kMaxLightsPerWord,
                                     meshes_.front()->BytesPerNode() > 8 ? ", and the blocker distances" : "",
                                     FormatBytes(TouchedBytes()).c_str());
            else if (name == "nodes evaluated")
                value = StringPrintf("%llu node words (%.2f%% of %llu nodes × %zu groups)",
                                     static_cast<unsigned long long>(evaluated),
                                     100.0 * static_cast<double>(evaluated) / static_cast<double>(total * meshes_.size()),
                                     static_cast<unsigned long long>(total), meshes_.size());
            else if (name == "node segments")
                value = StringPrintf("%llu at most (lights beyond their range get none)", static_cast<unsigned long long>(segments));
            else if (name == "cell summaries")
                value = "first group: " + value;
        }
        return f;
    }

  private:
    // A node word is written where a group evaluated it: its pages are touched then.
    uint64_t TouchedBytes() const {
        uint64_t bytes = 0;
        for (const auto& m : meshes_) bytes += m->NodesEvaluated() * static_cast<uint64_t>(m->BytesPerNode());
        return bytes;
    }

    const Scene& scene_;
    const std::vector<std::vector<uint32_t>> groups_;
    const std::vector<std::unique_ptr<LightMeshShadows>> meshes_;
    std::vector<uint32_t> group_, local_;  // per scene light: its group, its place there
};

}  // namespace

std::vector<std::vector<uint32_t>> LightGroups(const std::vector<PointLight>& lights, size_t perGroup) {
    const size_t n = lights.size();
    std::vector<uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    if (n <= perGroup) return {order};
    Bounds3 box;
    for (const PointLight& l : lights) box.Extend(l.position);
    const Vec3 ext = box.Diagonal();
    auto cell = [](float v, float lo, float e) {
        return e > 0 ? static_cast<uint32_t>(std::clamp((v - lo) / e * 1023.0f, 0.0f, 1023.0f)) : 0u;
    };
    std::vector<uint32_t> code(n);
    for (size_t i = 0; i < n; ++i) {
        const Vec3& p = lights[i].position;
        code[i] = Morton3(cell(p.x, box.lo.x, ext.x), cell(p.y, box.lo.y, ext.y), cell(p.z, box.lo.z, ext.z));
    }
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return code[a] < code[b]; });
    const size_t groups = (n + perGroup - 1) / perGroup;
    std::vector<std::vector<uint32_t>> out(groups);
    for (size_t g = 0, at = 0; g < groups; ++g) {
        const size_t size = n / groups + (g < n % groups ? 1 : 0);
        out[g].assign(order.begin() + static_cast<std::ptrdiff_t>(at), order.begin() + static_cast<std::ptrdiff_t>(at + size));
        std::sort(out[g].begin(), out[g].end());
        at += size;
    }
    return out;
}

std::unique_ptr<LightMeshShadows> CreateLightMeshGroups(const Scene& scene, std::vector<std::vector<uint32_t>> groups,
                                                        std::vector<std::unique_ptr<LightMeshShadows>> meshes) {
    return std::make_unique<LightMeshGroups>(scene, std::move(groups), std::move(meshes));
}

}  // namespace lm
