#include "lightmesh/shadow/light_mesh.h"

#include <atomic>
#include <cmath>
#include <type_traits>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

LightMeshLattice LightMeshLattice::Make(const Bounds3& bounds, int cc, float ki) {
    if (cc < 1 || cc > 4096) ThrowError("light mesh: CC must be between 1 and 4096, got %d", cc);
    if (!(ki > 0 && ki <= 16)) ThrowError("light mesh: kI must be in (0, 16], got %g", ki);
    const float extent = bounds.MaxExtent();
    if (bounds.IsEmpty() || !(extent > 0) || !std::isfinite(extent))
        ThrowError("light mesh: the scene has no extent");
    LightMeshLattice l;
    l.h = extent / static_cast<float>(cc);
    l.r = ki * l.h;
    const int pad = static_cast<int>(std::ceil(ki));
    l.origin = bounds.lo - Vec3(static_cast<float>(pad) * l.h);
    const Vec3 d = bounds.Diagonal();
    auto count = [&](float side) {
        // Cells across this side; the longest side has exactly CC (guard against rounding).
        const int cells = side >= extent ? cc : static_cast<int>(std::ceil(side / l.h - 1e-4f));
        return std::max(cells, 0) + 2 * pad + 1;
    };
    l.nx = count(d.x);
    l.ny = count(d.y);
    l.nz = count(d.z);
    return l;
}

int LightMeshBytesPerNode(size_t lights) {
    const size_t bits = lights + 2;  // visibility bits + initialised + inside
    return bits <= 8 ? 1 : bits <= 16 ? 2 : bits <= 32 ? 4 : 8;
}

std::string LightMeshVariant::PaperName() const {
    if (enumeration == SphereEnumeration::Cube && local == LocalVisibility::Object) return "Grid";
    return "Grid/Нет (cube loop, no local-visibility test)";
}

std::string LightMeshVariant::Name() const {
    return local == LocalVisibility::Object ? "grid" : "grid-none";
}

std::vector<std::string> LightMeshVariantNames() { return {"grid", "grid-none"}; }

LightMeshVariant ParseLightMeshVariant(std::string_view name) {
    if (name.empty() || name == "grid" || name == "Grid") return {SphereEnumeration::Cube, LocalVisibility::Object};
    if (name == "grid-none") return {SphereEnumeration::Cube, LocalVisibility::None};
    ThrowError("unknown light-mesh variant \"%.*s\" (choose grid or grid-none)",
               static_cast<int>(name.size()), name.data());
}

namespace {

/// The light mesh with node words of type Word (uint8_t for up to 6 lights).
///
/// Node word layout: bits 0 … nL-1 are V(L_i, x) (paper §2: S = ⟨f, v_1…v_nL, i⟩), the top
/// bit is f ("initialised"), the bit below it i ("inside a solid", used by the СТ variant).
/// A node is evaluated the first time a sphere needs it. Several threads may evaluate the
/// same node at once: each computes the same value (it depends only on the node), and a
/// compare-and-swap from 0 lets exactly one of them store it and count it, so no lock is
/// taken and the result never depends on the thread that won.
template <typename Word>
class LightMesh final : public LightMeshShadows {
    static constexpr Word kInit = Word(1) << (sizeof(Word) * 8 - 1);
    static constexpr Word kVisMask = Word(kInit >> 1) - 1;

  public:
    LightMesh(const Scene& scene, const Accelerator& accel, const LightMeshLattice& lattice,
              const LightMeshVariant& variant)
        : scene_(scene), accel_(accel), lattice_(lattice), variant_(variant),
          nodes_(new std::atomic<Word>[lattice.NodeCount()]) {
        static_assert(std::atomic<Word>::is_always_lock_free);
        for (uint64_t i = 0; i < lattice.NodeCount(); ++i) nodes_[i].store(0, std::memory_order_relaxed);
    }

    const LightMeshLattice& Lattice() const override { return lattice_; }
    const LightMeshVariant& Variant() const override { return variant_; }
    int BytesPerNode() const override { return sizeof(Word); }
    uint64_t NodesEvaluated() const override { return evaluated_.load(); }
    bool IsEvaluated(uint64_t index) const override {
        return (nodes_[index].load(std::memory_order_acquire) & kInit) != 0;
    }
    uint64_t NodeVisibility(uint64_t index) const override {
        return Evaluate(index, lattice_.NodeAt(index)) & kVisMask;
    }

    void Visibility(const ShadingPoint& sp, const bool* needed, float* vis,
                    RenderCounters& counters) const override {
        const size_t nLights = scene_.lights.size();
        uint32_t visibleCount[64] = {};
        uint32_t m = 0;
        const LightMeshLattice& L = lattice_;
        const float r2 = L.r * L.r;
        // Cube loop over the nodes whose cube around the sphere contains (paper §3.1, the
        // "Grid" pseudocode): index ranges clamped to the lattice.
        auto lo = [&](float p, float o, int n) {
            return std::clamp(static_cast<int>(std::ceil((p - L.r - o) / L.h)), 0, n - 1);
        };
        auto hi = [&](float p, float o, int n) {
            return std::clamp(static_cast<int>(std::floor((p + L.r - o) / L.h)), 0, n - 1);
        };
        const int i0 = lo(sp.p.x, L.origin.x, L.nx), i1 = hi(sp.p.x, L.origin.x, L.nx);
        const int j0 = lo(sp.p.y, L.origin.y, L.ny), j1 = hi(sp.p.y, L.origin.y, L.ny);
        const int k0 = lo(sp.p.z, L.origin.z, L.nz), k1 = hi(sp.p.z, L.origin.z, L.nz);
        for (int k = k0; k <= k1; ++k) {
            for (int j = j0; j <= j1; ++j) {
                for (int i = i0; i <= i1; ++i) {
                    const Vec3 x = L.Node(i, j, k);
                    const Vec3 d = x - sp.p;
                    if (LengthSquared(d) > r2) continue;
                    // Nodes behind the surface: (n(P), x - P) <= 0 (paper §1).
                    if (Dot(sp.n, d) <= 0) continue;
                    ++counters.candidates;
                    if (variant_.local == LocalVisibility::Object) {
                        // ОТ: the node must see P, or light leaks through walls (§1.4).
                        ++counters.localSegments;
                        if (accel_.Occluded(Segment(x, sp.origin))) continue;
                    }
                    const Word w = Evaluate(L.Index(i, j, k), x);
                    ++m;
                    for (size_t l = 0; l < nLights; ++l) visibleCount[l] += (w >> l) & 1;
                }
            }
        }
        if (m == 0) {
            // No node left (a crevice, or a sphere cut off by occluders): one shadow ray
            // per light, as RT would (the paper is silent on this case).
            ++counters.fallbacks;
            for (size_t l = 0; l < nLights; ++l) {
                if (!needed[l]) continue;
                ++counters.shadowRays;
                vis[l] = LightVisible(accel_, sp.origin, scene_.lights[l].position) ? 1.0f : 0.0f;
            }
            return;
        }
        ++counters.interpolations;
        counters.nodesUsed += m;
        // A true division, so that m visible nodes out of m give exactly 1 (as RT does).
        for (size_t l = 0; l < nLights; ++l)
            vis[l] = static_cast<float>(visibleCount[l]) / static_cast<float>(m);
    }

    ShadowFigures Figures() const override {
        const uint64_t total = lattice_.NodeCount(), done = evaluated_.load();
        return {
            {"variant", variant_.Name() + " (" + variant_.PaperName() + ")"},
            {"mesh", StringPrintf("%dx%dx%d nodes", lattice_.nx, lattice_.ny, lattice_.nz)},
            {"h", StringPrintf("%g", lattice_.h)},
            {"r", StringPrintf("%g", lattice_.r)},
            {"node storage", FormatBytes(total * sizeof(Word))},
            {"nodes evaluated", StringPrintf("%llu (%.2f%% of %llu)", static_cast<unsigned long long>(done),
                                             100.0 * static_cast<double>(done) / static_cast<double>(total),
                                             static_cast<unsigned long long>(total))},
            {"node shadow rays",
             StringPrintf("%llu", static_cast<unsigned long long>(done * scene_.lights.size()))},
        };
    }

  private:
    // The node's word, computing it on first use: one shadow ray to each light.
    Word Evaluate(uint64_t index, const Vec3& x) const {
        Word w = nodes_[index].load(std::memory_order_acquire);
        if (w & kInit) return w;
        Word value = kInit;
        for (size_t l = 0; l < scene_.lights.size(); ++l)
            if (LightVisible(accel_, x, scene_.lights[l].position)) value |= Word(1) << l;
        Word expected = 0;
        if (nodes_[index].compare_exchange_strong(expected, value, std::memory_order_acq_rel))
            evaluated_.fetch_add(1, std::memory_order_relaxed);
        return value;
    }

    const Scene& scene_;
    const Accelerator& accel_;
    const LightMeshLattice lattice_;
    const LightMeshVariant variant_;
    std::unique_ptr<std::atomic<Word>[]> nodes_;
    mutable std::atomic<uint64_t> evaluated_{0};
};

}  // namespace

std::unique_ptr<LightMeshShadows> CreateLightMeshShadows(const Scene& scene, const Accelerator& accel,
                                                         const LightMeshOptions& options) {
    const LightMeshVariant variant = ParseLightMeshVariant(options.variant);
    const LightMeshLattice lattice = LightMeshLattice::Make(scene.mesh.Bounds(), options.cc, options.ki);
    const size_t nLights = scene.lights.size();
    if (nLights > 62) ThrowError("light mesh: %zu lights; at most 62 are supported", nLights);
    const int bytes = LightMeshBytesPerNode(nLights);
    const uint64_t need = lattice.NodeCount() * static_cast<uint64_t>(bytes);
    const uint64_t physical = PhysicalMemoryBytes();
    if (physical && need > physical / 2)
        ThrowError("light mesh %dx%dx%d (CC %d, kI %g) needs %s of node storage, more than half of "
                   "this machine's %s: lower --cc",
                   lattice.nx, lattice.ny, lattice.nz, options.cc, options.ki,
                   FormatBytes(need).c_str(), FormatBytes(physical).c_str());
    switch (bytes) {
        case 1: return std::make_unique<LightMesh<uint8_t>>(scene, accel, lattice, variant);
        case 2: return std::make_unique<LightMesh<uint16_t>>(scene, accel, lattice, variant);
        case 4: return std::make_unique<LightMesh<uint32_t>>(scene, accel, lattice, variant);
        default: return std::make_unique<LightMesh<uint64_t>>(scene, accel, lattice, variant);
    }
}

}  // namespace lm
