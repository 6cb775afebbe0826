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
          local_(scene.lights.size()), place_(scene.lights.size()) {
        for (size_t g = 0; g < groups_.size(); ++g)
            for (size_t k = 0; k < groups_[g].size(); ++k) {
                group_[groups_[g][k]] = static_cast<uint32_t>(g);
                local_[groups_[g][k]] = static_cast<uint32_t>(k);
                place_[groups_[g][k]] = static_cast<uint32_t>(g << 6 | k);
            }
    }

    // Each group that holds a light the point needs answers its lights; the others are not
    // asked. As a block of one point.
    void Visibility(const ShadingPoint& sp, LightIndices lights, float* vis, RenderCounters& counters) const override {
        float* out[1] = {vis};
        VisibilityMany(&sp, &lights, out, 1, counters);
    }

    // Group by group, the points that need one of its lights, as one block. One pass over
    // the points' lists makes each point's mask per group (bit: the light's place in the
    // group) and notes where each listed light's value goes; each group answers its points'
    // masks by light (VisibilityOfMasks), and the values go to their places.
    void VisibilityMany(const ShadingPoint* sps, const LightIndices* lights, float* const* vis, size_t count,
                        RenderCounters& counters) const override {
        constexpr size_t kChunk = 64;
        const size_t groups = groups_.size();
        const SplitHold hold(kChunk * groups, (groups + 63) / 64);
        Split& s = *hold;
        uint64_t* touched = s.touched.data();  // the groups some point of the chunk needs
        for (size_t first = 0; first < count; first += kChunk) {
            const size_t n = std::min(kChunk, count - first);
            std::fill(s.masks.begin(), s.masks.begin() + static_cast<std::ptrdiff_t>(n * groups), uint64_t(0));
            for (size_t i = 0; i < n; ++i) {
                const LightIndices ids = lights[first + i];
                uint64_t* masks = s.masks.data() + i * groups;
                uint32_t* slots = s.slots.data() + i * groups * 64;
                // A run of lights of one group (nearby lights: often several in a row) adds
                // to a mask in a register, not through memory.
                uint32_t group = 0;
                uint64_t mask = 0;
                for (size_t k = 0; k < ids.size(); ++k) {
                    const uint32_t where = place_[ids[k]], g = where >> 6, l = where & 63;
                    if (g != group) {
                        masks[group] |= mask;
                        group = g, mask = 0;
                    }
                    mask |= uint64_t(1) << l;
                    slots[where] = static_cast<uint32_t>(k);
                }
                masks[group] |= mask;
            }
            std::fill(s.touched.begin(), s.touched.end(), uint64_t(0));
            for (size_t i = 0; i < n; ++i)
                for (size_t g = 0; g < groups; ++g)
                    if (s.masks[i * groups + g]) touched[g >> 6] |= uint64_t(1) << (g & 63);
            for (size_t word = 0; word < s.touched.size(); ++word)
                for (uint64_t t = touched[word]; t; t &= t - 1) {
                    const size_t g = word * 64 + static_cast<size_t>(__builtin_ctzll(t));
                    size_t m = 0;
                    for (size_t i = 0; i < n; ++i) {
                        const uint64_t mask = s.masks[i * groups + g];
                        if (!mask) continue;
                        s.points[m] = sps[first + i], s.needed[m] = mask, s.which[m] = static_cast<uint32_t>(i);
                        ++m;
                    }
                    meshes_[g]->VisibilityOfMasks(s.points.data(), s.needed.data(), s.values.get(), m, counters);
                    for (size_t j = 0; j < m; ++j) {
                        const size_t i = s.which[j];
                        const uint32_t* slots = s.slots.data() + (i * groups + g) * 64;
                        float* out = vis[first + i];
                        for (uint64_t b = s.needed[j]; b; b &= b - 1) {
                            const int l = __builtin_ctzll(b);
                            out[slots[l]] = s.values[j][l];
                        }
                    }
                }
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
    // VisibilityMany's scratch, per thread, kept between calls (only the entries of the
    // lights listed are touched): per point and group the mask of lights needed and, per
    // light of the group, its place in the point's list (slots); one group's block.
    struct Split {
        std::vector<uint64_t> masks;
        std::vector<uint32_t> slots;
        std::vector<ShadingPoint> points;
        std::vector<uint64_t> needed;
        std::vector<uint32_t> which;
        std::vector<uint64_t> touched;  // a bit per group
        std::unique_ptr<LightMeshShadows::LightValues[]> values;
        size_t room = 0;  // point × group entries
        bool inUse = false;
        void Reserve(size_t entries, size_t groupWords) {
            touched.resize(groupWords);
            if (room >= entries) return;
            room = entries;
            masks.resize(entries), slots.resize(entries * 64);
            constexpr size_t kBlock = 64;
            points.resize(kBlock), needed.resize(kBlock), which.resize(kBlock);
            values.reset(new LightMeshShadows::LightValues[kBlock]);
        }
    };

    // The thread's Split while a call holds it (a nested call, should a wait in one steal
    // work, gets one of its own).
    class SplitHold {
      public:
        SplitHold(size_t entries, size_t groupWords) : s_(mine().inUse ? fresh_ : mine()) {
            s_.inUse = true;
            s_.Reserve(entries, groupWords);
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
    std::vector<uint32_t> place_;          // the two in one: group · 64 + place
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
