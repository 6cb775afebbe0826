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
    // asked. The point's list is split by group (a group's lights are in the scene's order,
    // so each group's part is ascending too).
    void Visibility(const ShadingPoint& sp, LightIndices lights, float* vis, RenderCounters& counters) const override {
        const SplitHold hold(groups_.size());
        Split& s = *hold;
        s.Make(&lights, 1, group_, local_);
        for (const uint32_t g : s.touched) {
            const uint32_t from = s.start[g], n = s.end[g] - from;
            meshes_[g]->Visibility(sp, LightIndices(s.local.data() + from, n), s.v.data() + from, counters);
            for (uint32_t e = from; e < from + n; ++e) vis[s.slot[e]] = s.v[e];
        }
    }

    // Group by group, the points that need one of its lights, as one block.
    void VisibilityMany(const ShadingPoint* sps, const LightIndices* lights, float* const* vis, size_t count,
                        RenderCounters& counters) const override {
        const SplitHold hold(groups_.size());
        Split& s = *hold;
        s.Make(lights, count, group_, local_);
        std::vector<ShadingPoint>& points = s.points;
        std::vector<LightIndices>& ids = s.ids;
        std::vector<float*>& out = s.out;
        for (const uint32_t g : s.touched) {
            points.clear(), ids.clear(), out.clear();
            // The group's entries, point after point: a run per point.
            for (uint32_t e = s.start[g], end = s.end[g]; e < end;) {
                const uint32_t p = s.point[e];
                uint32_t f = e;
                while (f < end && s.point[f] == p) ++f;
                points.push_back(sps[p]);
                ids.emplace_back(s.local.data() + e, f - e);
                out.push_back(s.v.data() + e);
                e = f;
            }
            meshes_[g]->VisibilityMany(points.data(), ids.data(), out.data(), points.size(), counters);
            for (uint32_t e = s.start[g]; e < s.end[g]; ++e) vis[s.point[e]][s.slot[e]] = s.v[e];
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
    // The entries (point, light) of a block's lists, sorted by group (a counting sort, so
    // each group's entries keep the points' order and each point's list order): entries
    // start[g] .. end[g] - 1 are group g's, with the point, the light's place in the
    // point's list (slot), its index in the group (local) and room for its value (v).
    // touched: the groups with an entry, ascending. Per thread, kept between calls; the work
    // follows the entries and the groups touched, never the scene's lights.
    struct Split {
        std::vector<uint32_t> count, start, end, touched, point, slot, local;
        std::vector<float> v;
        // VisibilityMany's block of one group.
        std::vector<ShadingPoint> points;
        std::vector<LightIndices> ids;
        std::vector<float*> out;
        bool inUse = false;
        void Make(const LightIndices* lists, size_t points, const std::vector<uint32_t>& group,
                  const std::vector<uint32_t>& localOf) {
            touched.clear();
            size_t total = 0;
            for (size_t i = 0; i < points; ++i) {
                total += lists[i].size();
                for (const uint32_t l : lists[i])
                    if (count[group[l]]++ == 0) touched.push_back(group[l]);
            }
            std::sort(touched.begin(), touched.end());
            uint32_t at = 0;
            for (const uint32_t g : touched) {
                start[g] = at;
                at += count[g];
                count[g] = start[g];  // from here: the next free entry of g
            }
            point.resize(total), slot.resize(total), local.resize(total), v.resize(total);
            for (size_t i = 0; i < points; ++i)
                for (size_t k = 0; k < lists[i].size(); ++k) {
                    const uint32_t l = lists[i][k], e = count[group[l]]++;
                    point[e] = static_cast<uint32_t>(i), slot[e] = static_cast<uint32_t>(k), local[e] = localOf[l];
                }
            for (const uint32_t g : touched) {
                end[g] = count[g];
                count[g] = 0;
            }
        }
    };

    // The thread's Split while a call holds it (a nested call, should a wait in one steal
    // work, gets one of its own).
    class SplitHold {
      public:
        explicit SplitHold(size_t groups) : s_(mine().inUse ? fresh_ : mine()) {
            s_.inUse = true;
            if (s_.count.size() < groups) s_.count.assign(groups, 0), s_.start.assign(groups, 0), s_.end.assign(groups, 0);
        }
        ~SplitHold() { s_.inUse = false; }
        SplitHold(const SplitHold&) = delete;
        SplitHold& operator=(const SplitHold&) = delete;
        Split& operator*() const { return s_; }

      private:
        static Split& mine() {
            thread_local Split s;
            return s;
        }
        Split fresh_;
        Split& s_;
    };

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
