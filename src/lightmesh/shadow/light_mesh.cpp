#include "lightmesh/shadow/light_mesh.h"

#include <atomic>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
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

namespace {

struct VariantName {
    const char* name;
    const char* paper;
    const char* ascii;  // the paper's name transliterated
    SphereEnumeration enumeration;
    LocalVisibility local;
};

const VariantName kVariants[] = {
    {"grid", "Grid", "Grid", SphereEnumeration::Cube, LocalVisibility::Object},
    {"templates", "Ш", "sh", SphereEnumeration::Templates, LocalVisibility::Object},
    {"reduced", "У", "u", SphereEnumeration::Templates, LocalVisibility::Reduced},
    {"none", "Нет", "net", SphereEnumeration::Templates, LocalVisibility::None},
    {"inside", "СТ", "st", SphereEnumeration::Templates, LocalVisibility::Inside},
    {"object", "ОТ", "ot", SphereEnumeration::Templates, LocalVisibility::Object},
    {"grid-none", "Grid+Нет", "grid-net", SphereEnumeration::Cube, LocalVisibility::None},
    {"consensus", "ОТ+consensus", "ot-consensus", SphereEnumeration::Templates, LocalVisibility::Consensus},
};

}  // namespace

std::vector<std::string> LightMeshVariantNames() {
    std::vector<std::string> names;
    for (const VariantName& v : kVariants) names.push_back(v.name);
    return names;
}

LightMeshVariant ParseLightMeshVariant(std::string_view name) {
    if (name.empty()) name = kDefaultLightMeshVariant;
    for (const VariantName& v : kVariants)
        if (name == v.name || name == v.paper || name == v.ascii)
            return {v.enumeration, v.local, v.name, v.paper};
    ThrowError("unknown light-mesh variant \"%.*s\" (choose grid, templates, reduced, none, inside, "
               "object or grid-none; or the paper's Grid, Ш, У, Нет, СТ, ОТ)",
               static_cast<int>(name.size()), name.data());
}

namespace {

/// A template entry converted for one lattice: the node's offset from LM0 as lattice
/// coordinates, as floats (for the vector from P) and as a linear index offset.
struct TemplateEntry {
    int di, dj, dk;
    Vec3 offset;
    int64_t linear;
};

/// The light mesh with node words of type Word (uint8_t for up to 6 lights).
///
/// Node word layout: bits 0 … nL-1 are V(L_i, x) (paper §4: S = ⟨f, v_1…v_nL, i⟩), the top
/// bit is f ("initialised"), the bit below it i ("inside a solid", СТ only).
/// A node is evaluated the first time a sphere needs it. Several threads may evaluate the
/// same node at once: each computes the same value (it depends only on the node), and a
/// compare-and-swap from 0 lets exactly one of them store it and count it, so no lock is
/// taken and the result never depends on the thread that won.
template <typename Word>
class LightMesh final : public LightMeshShadows {
    static constexpr Word kInit = Word(1) << (sizeof(Word) * 8 - 1);
    static constexpr Word kInside = kInit >> 1;
    static constexpr Word kVisMask = kInside - 1;

  public:
    LightMesh(const Scene& scene, const Accelerator& accel, const LightMeshLattice& lattice,
              const LightMeshVariant& variant, TemplateLoad templates)
        : scene_(scene), accel_(accel), lattice_(lattice), variant_(variant),
          templates_(std::move(templates)), nodes_(new std::atomic<Word>[lattice.NodeCount()]) {
        static_assert(std::atomic<Word>::is_always_lock_free);
        for (uint64_t i = 0; i < lattice.NodeCount(); ++i) nodes_[i].store(0, std::memory_order_relaxed);
        if (variant_.enumeration == SphereEnumeration::Templates) ConvertTemplates();
        sceneBox_ = scene.mesh.Bounds();
    }

    const LightMeshLattice& Lattice() const override { return lattice_; }
    const LightMeshVariant& Variant() const override { return variant_; }
    const TemplateLoad& Templates() const override { return templates_; }
    int BytesPerNode() const override { return sizeof(Word); }
    uint64_t NodesEvaluated() const override { return evaluated_.load(); }
    bool IsEvaluated(uint64_t index) const override {
        return (nodes_[index].load(std::memory_order_acquire) & kInit) != 0;
    }
    uint64_t NodeVisibility(uint64_t index) const override { return NodeWord(index) & kVisMask; }
    bool NodeInside(uint64_t index) const override { return (NodeWord(index) & kInside) != 0; }

    void Visibility(const ShadingPoint& sp, const bool* needed, float* vis,
                    RenderCounters& counters) const override {
        Accumulator acc;
        if (variant_.enumeration == SphereEnumeration::Templates && TemplateWalk(sp, acc, counters)) {
        } else {
            CubeWalk(sp, acc, counters);
        }
        const size_t nLights = scene_.lights.size();
        if (acc.m == 0) {
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
        counters.nodesUsed += acc.m;
        // A true division, so that m visible nodes out of m give exactly 1 (as RT does).
        for (size_t l = 0; l < nLights; ++l)
            vis[l] = static_cast<float>(acc.visible[l]) / static_cast<float>(acc.m);
    }

    ShadowFigures Figures() const override {
        const uint64_t total = lattice_.NodeCount(), done = evaluated_.load();
        ShadowFigures f = {
            {"variant", variant_.name + " (" + variant_.paperName + ")"},
            {"mesh", StringPrintf("%dx%dx%d nodes", lattice_.nx, lattice_.ny, lattice_.nz)},
            {"h", StringPrintf("%g", lattice_.h)},
            {"r", StringPrintf("%g", lattice_.r)},
            {"node storage", FormatBytes(total * sizeof(Word)) + StringPrintf(" (%d byte(s) per node)", int(sizeof(Word)))},
            {"nodes evaluated", StringPrintf("%llu (%.2f%% of %llu)", static_cast<unsigned long long>(done),
                                             100.0 * static_cast<double>(done) / static_cast<double>(total),
                                             static_cast<unsigned long long>(total))},
            {"node segments", StringPrintf("%llu", static_cast<unsigned long long>(done * SegmentsPerNode()))},
        };
        if (variant_.enumeration == SphereEnumeration::Templates) {
            const TemplateLoad& t = templates_;
            f.push_back({"templates", StringPrintf("ns %d, %d sub-positions, %zu entries, %s in %.1f ms%s%s",
                                                   t.templates.ns, t.templates.SubPositionCount(),
                                                   t.templates.offsets.size(),
                                                   t.loaded ? "loaded" : (t.written ? "built and cached" : "built"),
                                                   t.seconds * 1e3, t.path.empty() ? "" : " from/at ",
                                                   t.path.c_str())});
        }
        return f;
    }

  private:
    struct Accumulator {
        uint32_t m = 0;
        uint32_t visible[64] = {};
    };

    // Segments traced when a node is evaluated: one per light, plus, for СТ, the extra
    // segments that complete its vote of three (see EvaluateNode).
    size_t SegmentsPerNode() const {
        const size_t n = scene_.lights.size();
        return variant_.local == LocalVisibility::Inside && n < 3 ? 3 : n;
    }

    Word NodeWord(uint64_t index) const {
        const uint64_t i = index % lattice_.nx, j = (index / lattice_.nx) % lattice_.ny,
                       k = index / (static_cast<uint64_t>(lattice_.nx) * lattice_.ny);
        return Evaluate(index, lattice_.Node(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k)));
    }

    // Adds node x to the interpolation set.
    void Use(Accumulator& acc, Word w) const {
        ++acc.m;
        for (size_t l = 0; l < scene_.lights.size(); ++l) acc.visible[l] += (w >> l) & 1;
    }

    // The local-visibility segment from a node to P (paper §1.4): it must be unblocked.
    bool SeesPoint(const Vec3& x, const ShadingPoint& sp, RenderCounters& counters) const {
        ++counters.localSegments;
        return !accel_.Occluded(Segment(x, sp.origin));
    }

    // A candidate that passed the sphere and surface tests, for the variants that decide
    // node by node (all but У).
    void Candidate(const Vec3& x, uint64_t index, const ShadingPoint& sp, Accumulator& acc,
                   RenderCounters& counters) const {
        ++counters.candidates;
        switch (variant_.local) {
            case LocalVisibility::Object:
            case LocalVisibility::Reduced:    // only on the cube loop's fallback path: test all
            case LocalVisibility::Consensus:
                if (!SeesPoint(x, sp, counters)) return;
                break;
            case LocalVisibility::Inside: {
                const Word w = Evaluate(index, x);
                if (!(w & kInside)) Use(acc, w);
                return;
            }
            default: break;
        }
        Use(acc, Evaluate(index, x));
    }

    // The paper's "Grid" enumeration (§3.1 pseudocode): the cube of nodes around the
    // sphere, each tested against r. Also the fallback of the templates near the lattice's
    // border, where a template would reach outside it.
    void CubeWalk(const ShadingPoint& sp, Accumulator& acc, RenderCounters& counters) const {
        const LightMeshLattice& L = lattice_;
        const float r2 = L.r * L.r;
        auto lo = [&](float p, float o, int n) {
            return std::clamp(static_cast<int>(std::ceil((p - L.r - o) / L.h)), 0, n - 1);
        };
        auto hi = [&](float p, float o, int n) {
            return std::clamp(static_cast<int>(std::floor((p + L.r - o) / L.h)), 0, n - 1);
        };
        const int i0 = lo(sp.p.x, L.origin.x, L.nx), i1 = hi(sp.p.x, L.origin.x, L.nx);
        const int j0 = lo(sp.p.y, L.origin.y, L.ny), j1 = hi(sp.p.y, L.origin.y, L.ny);
        const int k0 = lo(sp.p.z, L.origin.z, L.nz), k1 = hi(sp.p.z, L.origin.z, L.nz);
        for (int k = k0; k <= k1; ++k)
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) {
                    const Vec3 x = L.Node(i, j, k);
                    const Vec3 d = x - sp.p;
                    if (LengthSquared(d) > r2) continue;
                    if (Dot(sp.n, d) <= 0) continue;  // behind the surface: (n(P), x - P) <= 0
                    Candidate(x, L.Index(i, j, k), sp, acc, counters);
                }
    }

    // Templates (§3.1): snap P to the nearest sub-position of its cell and walk that
    // sub-position's list; no distance tests. Returns false (and does nothing) when the
    // template would reach outside the lattice, which only happens for points on or
    // outside the far faces of the scene's box; the cube loop takes those.
    bool TemplateWalk(const ShadingPoint& sp, Accumulator& acc, RenderCounters& counters) const {
        const LightMeshLattice& L = lattice_;
        const Vec3 q = (sp.p - L.origin) * invH_;
        const int ci = static_cast<int>(std::floor(q.x)), cj = static_cast<int>(std::floor(q.y)),
                  ck = static_cast<int>(std::floor(q.z));
        if (ci + minOffset_ < 0 || cj + minOffset_ < 0 || ck + minOffset_ < 0 || ci + maxOffset_ >= L.nx ||
            cj + maxOffset_ >= L.ny || ck + maxOffset_ >= L.nz)
            return false;
        const Vec3 frac = q - Vec3(static_cast<float>(ci), static_cast<float>(cj), static_cast<float>(ck));
        const int ns = templates_.templates.ns;
        auto snap = [ns](float f) { return std::clamp(static_cast<int>(std::lround(f * static_cast<float>(ns))), 0, ns); };
        const int s = templates_.templates.SubPosition(snap(frac.x), snap(frac.y), snap(frac.z));
        const uint32_t begin = templates_.templates.begin[s], end = templates_.templates.begin[s + 1];
        const uint32_t innerBegin = begin + templates_.templates.boundaryCount[s];
        const int64_t base = static_cast<int64_t>(L.Index(ci, cj, ck));
        // (n(P), x - P) with x - P = (offset - frac)·h; h > 0 does not change the sign.
        auto front = [&](const TemplateEntry& e) { return Dot(sp.n, e.offset - frac) > 0; };
        auto node = [&](const TemplateEntry& e) { return L.Node(ci + e.di, cj + e.dj, ck + e.dk); };

        if (variant_.local == LocalVisibility::Consensus) {
            ConsensusWalk(sp, begin, end, base, ci, cj, ck, frac, acc, counters);
            return true;
        }
        if (variant_.local != LocalVisibility::Reduced) {
            for (uint32_t t = begin; t < end; ++t) {
                const TemplateEntry& e = entries_[t];
                if (!front(e)) continue;
                Candidate(node(e), static_cast<uint64_t>(base + e.linear), sp, acc, counters);
            }
            return true;
        }
        // У (§3.2): test the boundary nodes first; if all of them see P, take the inner
        // nodes without testing them, otherwise test the inner nodes too.
        bool allSee = true;
        for (uint32_t t = begin; t < innerBegin; ++t) {
            const TemplateEntry& e = entries_[t];
            if (!front(e)) continue;
            ++counters.candidates;
            const Vec3 x = node(e);
            if (SeesPoint(x, sp, counters)) Use(acc, Evaluate(static_cast<uint64_t>(base + e.linear), x));
            else allSee = false;
        }
        for (uint32_t t = innerBegin; t < end; ++t) {
            const TemplateEntry& e = entries_[t];
            if (!front(e)) continue;
            ++counters.candidates;
            const Vec3 x = node(e);
            if (allSee || SeesPoint(x, sp, counters)) Use(acc, Evaluate(static_cast<uint64_t>(base + e.linear), x));
        }
        return true;
    }

    // Consensus (ours, exact): ОТ keeps the candidates that see P and averages their bits.
    // If every candidate carries the same bits, the average over any non-empty subset is
    // those bits, so it is enough to find one candidate that sees P; only if none does
    // (m = 0) does the result change to the fallback, exactly as with ОТ. Where the
    // candidates disagree (penumbrae, edges of objects) every segment is traced as in ОТ.
    // The image is identical to ОТ's; only the mean m in --stats differs.
    void ConsensusWalk(const ShadingPoint& sp, uint32_t begin, uint32_t end, int64_t base, int ci, int cj,
                       int ck, const Vec3& frac, Accumulator& acc, RenderCounters& counters) const {
        struct Candidate {
            uint32_t entry;
            Word word;
        };
        Candidate buffer[512];
        std::vector<Candidate> heap;
        Candidate* list = buffer;
        if (end - begin > 512) {
            heap.resize(end - begin);
            list = heap.data();
        }
        uint32_t n = 0;
        bool agree = true;
        const LightMeshLattice& L = lattice_;
        for (uint32_t t = begin; t < end; ++t) {
            const TemplateEntry& e = entries_[t];
            if (!(Dot(sp.n, e.offset - frac) > 0)) continue;
            ++counters.candidates;
            const Word w = Evaluate(static_cast<uint64_t>(base + e.linear), L.Node(ci + e.di, cj + e.dj, ck + e.dk));
            if (n > 0 && ((w ^ list[0].word) & kVisMask)) agree = false;
            list[n++] = {t, w};
        }
        for (uint32_t c = 0; c < n; ++c) {
            const TemplateEntry& e = entries_[list[c].entry];
            if (!SeesPoint(L.Node(ci + e.di, cj + e.dj, ck + e.dk), sp, counters)) continue;
            Use(acc, list[c].word);
            if (agree) return;
        }
    }

    void ConvertTemplates() {
        const SphereTemplates& t = templates_.templates;
        invH_ = 1.0f / lattice_.h;
        entries_.reserve(t.offsets.size());
        // The offsets' range: -floor(kI) … floor(kI) + 1, inside the lattice's ceil(kI)
        // cells of padding for every P in the scene's box.
        for (const auto& o : t.offsets)
            for (int8_t v : o) {
                minOffset_ = std::min<int>(minOffset_, v);
                maxOffset_ = std::max<int>(maxOffset_, v);
            }
        for (const auto& o : t.offsets)
            entries_.push_back({o[0], o[1], o[2], Vec3(o[0], o[1], o[2]),
                                o[0] + static_cast<int64_t>(lattice_.nx) *
                                           (o[1] + static_cast<int64_t>(lattice_.ny) * o[2])});
    }

    // The node's word, computing it on first use: one shadow ray to each light; for СТ
    // also the inside flag.
    Word Evaluate(uint64_t index, const Vec3& x) const {
        const Word w = nodes_[index].load(std::memory_order_acquire);
        if (w & kInit) return w;
        const Word value = variant_.local == LocalVisibility::Inside ? EvaluateWithInside(x) : EvaluateVisibility(x);
        Word expected = 0;
        if (nodes_[index].compare_exchange_strong(expected, value, std::memory_order_acq_rel))
            evaluated_.fetch_add(1, std::memory_order_relaxed);
        return value;
    }

    Word EvaluateVisibility(const Vec3& x) const {
        Word value = kInit;
        for (size_t l = 0; l < scene_.lights.size(); ++l)
            if (LightVisible(accel_, x, scene_.lights[l].position)) value |= Word(1) << l;
        return value;
    }

    // СТ (§4): a node is inside a solid when a segment from it to a point outside every
    // object crosses the surface an odd number of times. The paper starts that segment at
    // the shading point that first needs the node; that makes the flag depend on which
    // point (and so which thread) came first wherever meshes are not closed. We vote
    // instead over three segments that depend on the node alone: to the first three
    // lights (outside every object: the loader checks), completed, with fewer lights, by
    // the shortest axis-aligned segments out of the scene's box. The light segments also
    // give the visibility bits (no crossing = visible), so with three or more lights the
    // flag costs no extra segment; on closed meshes all three votes agree.
    Word EvaluateWithInside(const Vec3& x) const {
        Word value = kInit;
        int odd = 0, votes = 0;
        const size_t nLights = scene_.lights.size();
        for (size_t l = 0; l < nLights; ++l) {
            const Vec3& light = scene_.lights[l].position;
            if (votes < 3) {
                const int crossings = accel_.CountCrossings(Ray{x, light - x, 0.0f, 1.0f - 1e-5f});
                if (crossings == 0) value |= Word(1) << l;
                odd += crossings & 1;
                ++votes;
            } else if (LightVisible(accel_, x, light)) {
                value |= Word(1) << l;
            }
        }
        if (votes < 3) {
            // Distances to the six faces of the box grown by one step, nearest first.
            const float margin = lattice_.h;
            std::pair<float, Vec3> exits[6] = {
                {x.x - sceneBox_.lo.x, Vec3(sceneBox_.lo.x - margin, x.y, x.z)},
                {sceneBox_.hi.x - x.x, Vec3(sceneBox_.hi.x + margin, x.y, x.z)},
                {x.y - sceneBox_.lo.y, Vec3(x.x, sceneBox_.lo.y - margin, x.z)},
                {sceneBox_.hi.y - x.y, Vec3(x.x, sceneBox_.hi.y + margin, x.z)},
                {x.z - sceneBox_.lo.z, Vec3(x.x, x.y, sceneBox_.lo.z - margin)},
                {sceneBox_.hi.z - x.z, Vec3(x.x, x.y, sceneBox_.hi.z + margin)},
            };
            std::stable_sort(std::begin(exits), std::end(exits),
                             [](const auto& a, const auto& b) { return a.first < b.first; });
            for (int e = 0; votes < 3; ++e, ++votes) odd += accel_.CountCrossings(Segment(x, exits[e].second)) & 1;
        }
        if (odd >= 2) value |= kInside;
        return value;
    }

    const Scene& scene_;
    const Accelerator& accel_;
    const LightMeshLattice lattice_;
    const LightMeshVariant variant_;
    const TemplateLoad templates_;
    std::vector<TemplateEntry> entries_;
    int minOffset_ = 0, maxOffset_ = 0;
    float invH_ = 0;
    Bounds3 sceneBox_;
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
    const int ns = options.ns == 0 ? kDefaultTemplateSubsteps : options.ns;
    if (ns < 1 || ns > 64) ThrowError("light mesh: ns must be between 1 and 64, got %d", ns);
    const int bytes = LightMeshBytesPerNode(nLights);
    const uint64_t need = lattice.NodeCount() * static_cast<uint64_t>(bytes);
    const uint64_t physical = PhysicalMemoryBytes();
    if (physical && need > physical / 2)
        ThrowError("light mesh %dx%dx%d (CC %d, kI %g) needs %s of node storage, more than half of "
                   "this machine's %s: lower --cc",
                   lattice.nx, lattice.ny, lattice.nz, options.cc, options.ki,
                   FormatBytes(need).c_str(), FormatBytes(physical).c_str());
    if (variant.local == LocalVisibility::Inside) {
        const EdgeReport edges = AnalyzeEdges(scene.mesh);
        if (!edges.Closed())
            LogWarning(StringPrintf("%s: %zu open and %zu non-manifold edges: the inside test (СТ) assumes "
                                    "closed solids and may misjudge nodes near them",
                                    scene.name.c_str(), edges.open, edges.nonManifold));
    }
    TemplateLoad templates;
    if (variant.enumeration == SphereEnumeration::Templates) {
        templates = LoadOrBuildSphereTemplates(ns, options.ki, options.templateDir);
        if (!templates.note.empty()) LogWarning("templates: " + templates.note);
    }
    switch (bytes) {
        case 1: return std::make_unique<LightMesh<uint8_t>>(scene, accel, lattice, variant, std::move(templates));
        case 2: return std::make_unique<LightMesh<uint16_t>>(scene, accel, lattice, variant, std::move(templates));
        case 4: return std::make_unique<LightMesh<uint32_t>>(scene, accel, lattice, variant, std::move(templates));
        default: return std::make_unique<LightMesh<uint64_t>>(scene, accel, lattice, variant, std::move(templates));
    }
}

}  // namespace lm
