// light_mesh.cpp -- the light mesh method's entry points (paper §2-4): the lattice, the
// variants' names, LightMesh's construction, node evaluation and figures, its --stats lines
// and the factory; the class and its other parts are light_mesh_impl.h and the headers it
// names. A little over 500 lines as one concept: what builds and reports one light mesh.
#include "lightmesh/shadow/light_mesh.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <new>
#include <tuple>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

#include <immintrin.h>

#include "lightmesh/geometry/triangle.h"
#include "lightmesh/math/simd.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/shadow/light_mesh_cells.h"
#include "lightmesh/shadow/light_mesh_impl.h"
#include "lightmesh/shadow/light_mesh_groups.h"
#include "lightmesh/shadow/light_mesh_kernels.h"
#include "lightmesh/shadow/light_mesh_patches.h"
#include "lightmesh/shadow/light_mesh_penumbra.h"
#include "lightmesh/shadow/light_mesh_walks.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/huge_pages.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/parallel.h"
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
    // A template reaches floor(kI) + 1 nodes beyond its cell: one more than the padding
    // when kI is a whole number (see count below).
    const int farPad = std::max(pad, static_cast<int>(std::floor(ki)) + 1);
    l.origin = bounds.lo - Vec3(static_cast<float>(pad) * l.h);
    const Vec3 d = bounds.Diagonal();
    auto count = [&](float side) {
        // Cells across this side; the longest side has exactly CC (guard against rounding).
        // At the far end, room for the templates of points on the box's far face: one
        // that lies on a lattice plane (always on the longest axis, whose side is CC
        // steps; on the others when the side is a whole number of steps) is in cell pad +
        // cells, whose templates reach floor(kI) + 1 nodes beyond it. Without that node
        // (whole-number kI) its points took the cube loop (a closed room's far wall: a
        // quarter of its points, 1.7× RT's time at 1024×768).
        const int cells = side >= extent ? cc : static_cast<int>(std::ceil(side / l.h - 1e-4f));
        return std::max(cells, 0) + pad + farPad + 1;
    };
    l.nx = count(d.x);
    l.ny = count(d.y);
    l.nz = count(d.z);
    return l;
}

int LightMeshBytesPerNode(size_t lights) {
    if (lights > kMaxLightsPerWord) {  // groups (LightGroups' sizes), a word each
        const size_t groups = (lights + kMaxLightsPerWord - 1) / kMaxLightsPerWord;
        int bytes = 0;
        for (size_t g = 0; g < groups; ++g) bytes += LightMeshBytesPerNode(lights / groups + (g < lights % groups ? 1 : 0));
        return bytes;
    }
    const size_t bits = lights + 2;  // visibility bits + initialised + inside
    return bits <= 8 ? 1 : bits <= 16 ? 2 : bits <= 32 ? 4 : 8;
}

int LightMeshStorageBytesPerNode(size_t lights, float lightRadius) {
    return LightMeshBytesPerNode(lights) + (lightRadius > 0 ? 2 * static_cast<int>(lights) : 0);
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

void LightMeshShadows::VisibilityOfMasks(const ShadingPoint* sps, const uint64_t* needed, LightValues* vis,
                                         size_t count, RenderCounters& counters) const {
    std::vector<std::vector<uint32_t>> ids(count);
    std::vector<LightIndices> lists(count);
    std::vector<std::vector<float>> values(count);
    std::vector<float*> out(count);
    for (size_t i = 0; i < count; ++i) {
        for (uint64_t m = needed[i]; m; m &= m - 1) ids[i].push_back(static_cast<uint32_t>(__builtin_ctzll(m)));
        lists[i] = ids[i];
        values[i].resize(ids[i].size());
        out[i] = values[i].data();
    }
    VisibilityMany(sps, lists.data(), out.data(), count, counters);
    for (size_t i = 0; i < count; ++i)
        for (size_t k = 0; k < ids[i].size(); ++k) vis[i][ids[i][k]] = values[i][k];
}

StatsLines LightMeshShadows::CounterLines(const RenderCounters& counters) const {
    const auto n = [&counters](LightMeshCount k) { return Count(counters, k); };
    const uint64_t interpolations = n(LightMeshCount::kInterpolations), fallbacks = n(LightMeshCount::kFallbacks);
    StatsLines lines;
    if (interpolations + fallbacks == 0) return lines;
    const double points = static_cast<double>(interpolations + fallbacks);
    lines.push_back(
        {"lmm", StringPrintf("interpolated points %s, mean m %.1f, candidates per point %.1f, "
                             "local-visibility segments %s, fallbacks %s (%.2f%%)",
                             FormatCount(interpolations).c_str(),
                             interpolations ? static_cast<double>(n(LightMeshCount::kNodesUsed)) /
                                                  static_cast<double>(interpolations)
                                            : 0.0,
                             static_cast<double>(n(LightMeshCount::kCandidates)) / points,
                             FormatCount(n(LightMeshCount::kLocalSegments)).c_str(), FormatCount(fallbacks).c_str(),
                             100.0 * static_cast<double>(fallbacks) / points)});
    const uint64_t uniform = n(LightMeshCount::kUniformCellPoints), planar = n(LightMeshCount::kPlanarCellPoints);
    const uint64_t culled = n(LightMeshCount::kCulledSegments), patch = n(LightMeshCount::kPatchSegments);
    if (uniform + planar > 0)
        lines.push_back(
            {"cells", StringPrintf("points answered by their cell's summary %s (%.1f%%), in planar cells %s (%.1f%%), "
                                   "segments decided without a ray %s (%s by the point's blockers, %s by a node that "
                                   "sees the whole cell patch), points without a cell patch (too few camera rays for "
                                   "its front triangles) %s; mean m counts the other points only",
                                   FormatCount(uniform).c_str(), 100.0 * static_cast<double>(uniform) / points,
                                   FormatCount(planar).c_str(), 100.0 * static_cast<double>(planar) / points,
                                   FormatCount(culled + patch).c_str(), FormatCount(culled).c_str(),
                                   FormatCount(patch).c_str(), FormatCount(n(LightMeshCount::kPatchesNotPaying)).c_str())});
    const uint64_t penumbra = n(LightMeshCount::kPenumbraLights);
    if (penumbra > 0)
        lines.push_back(
            {"penumbra", StringPrintf("(point, light) pairs whose width followed the light radius %s (%.1f%% of "
                                      "points): %s by the nodes' kernel, %s by rays to the light's disc, the rest by "
                                      "the lattice and P's own ray",
                                      FormatCount(penumbra).c_str(), 100.0 * static_cast<double>(penumbra) / points,
                                      FormatCount(n(LightMeshCount::kPenumbraKernel)).c_str(),
                                      FormatCount(n(LightMeshCount::kPenumbraSampled)).c_str())});
    const uint64_t thin = n(LightMeshCount::kThinChecks);
    if (thin > 0)
        lines.push_back({"thin", StringPrintf("(point, light) pairs where P's own ray checked the nodes' answer %s, of "
                                              "them %s where it disagreed (an occluder or gap thinner than h: the "
                                              "light's disc decided)",
                                              FormatCount(thin).c_str(), FormatCount(n(LightMeshCount::kThinFound)).c_str())});
    return lines;
}

LightMeshVariant ParseLightMeshVariant(std::string_view name) {
    if (name.empty()) name = kDefaultLightMeshVariant;
    for (const VariantName& v : kVariants)
        if (name == v.name || name == v.paper || name == v.ascii)
            return {v.enumeration, v.local, v.name, v.paper};
    // The name as given, NUL bytes included (Error shows them as <U+0000>; "%s" cut there).
    std::string names;
    for (size_t i = 0; i < std::size(kVariants); ++i)
        names += (i == 0 ? "" : (i + 1 == std::size(kVariants) ? " or " : ", ")) + std::string(kVariants[i].name);
    throw SettingError("variant", "unknown light-mesh variant \"" + std::string(name) + "\" (choose " + names +
                                      "; or the paper's Grid, Ш, У, Нет, СТ, ОТ)");
}

namespace {

template <typename Word>
LightMesh<Word>::LightMesh(const Scene& scene, const Accelerator& accel, const LightMeshLattice& lattice,
                           const LightMeshVariant& variant, TemplateLoad templates, const LightMeshOptions& options,
                           std::vector<PointLight> lights, const std::shared_ptr<void>& sharedTables)
    : scene_(scene),
      lights_(std::move(lights)),
      accel_(accel),
      lattice_(lattice),
      variant_(variant),
      templates_(std::move(templates)),
      frontMasks_(ChooseFrontFunction(options.simdWidth)),
      cull_(ChooseCullFunction(options.simdWidth)),
      findBlockers_(ChooseFindBlockersFunction(options.simdWidth)),
      patchSees_(ChoosePatchSeesFunction(options.simdWidth)),
      sideNodes_(ChooseSideNodesFunction(options.simdWidth)),
      filterNear_(ChooseFilterNearFunction(options.simdWidth)),
      nearCodes_(ChooseNearCodesFunction(options.simdWidth)),
      sumFront_(ChooseSumFrontFunction(options.simdWidth, static_cast<int>(sizeof(Word)))),
      minority_(ChooseMinorityFunction(options.simdWidth, static_cast<int>(sizeof(Word)))),
      nodes_(ZeroedArray<Word>(lattice.NodeCount() + kNodePadding)),
      lightRadius_(options.lightRadius),
      tables_(TakeTables(sharedTables)) {
    if (lightRadius_ > 0)
        thinCheck_ = options.thinCheck == "all" ? ThinCheck::kAll
                     : options.thinCheck == "lit" ? ThinCheck::kLit
                                                  : ThinCheck::kOff;
    const std::string& cellSummaries = options.cellSummaries;
    // The blocker distances on huge pages only for a few lights: with many, a node's record
    // is a cache line or more and evaluated nodes are a few per cent of the lattice, so
    // 2 MiB pages zeroed whole on first touch cost more than they save (hall-lights, 256
    // lights in 5 groups: render 0.904 -> 0.776 s, peak 199 -> 102 MiB; one light unchanged).
    if (lightRadius_ > 0)
        blockerT_ = ZeroedArray<uint16_t>(lattice.NodeCount() * lights_.size(), /*huge=*/lights_.size() < 32);
    for (const PointLight& l : lights_) ranged_ = ranged_ || std::isfinite(l.range);
    if (variant_.enumeration == SphereEnumeration::Templates) ConvertTemplates();
    // Its patches and cells read triangles as one array (the caller flattens instances).
    if (scene.mesh.instances) ThrowError("the light mesh needs a scene whose instances are flattened");
    sceneBox_ = scene.mesh.Bounds();
    // Tolerances at the lattice's scale. delta: how far from a plane a vertex may lie and
    // still count as on it (a few float ulps of the largest coordinate); eps: how far a
    // triangle's unit normal may turn from the plane's. A node closer to P's plane than
    // frontEps_ steps (their effect over the sphere, twice over) is on the surface, not
    // in front of it: its visibility there is decided by rounding.
    const Vec3 far = lattice_.Node(lattice_.nx - 1, lattice_.ny - 1, lattice_.nz - 1);
    const float magnitude = std::max(MaxComponent(Abs(lattice_.origin)), MaxComponent(Abs(far)));
    planeDelta_ = PlaneDelta(magnitude);
    frontEps_ = (4 * planeDelta_ + 2 * kPlaneEps * (lattice_.r + 2 * lattice_.h)) / lattice_.h;
    reachMargin_ = 1e-3f * lattice_.h + 1e-5f * magnitude;
    cullMargin_ = CullMargin(planeDelta_);
    // A point's segments end at nodes within r of its snapped sub-position.
    pointReach_ = lattice_.r + 0.87f * lattice_.h / static_cast<float>(std::max(templates_.templates.ns, 1)) + reachMargin_;
    planeSlab_ = pointReach_ + 4 * planeDelta_;
    // (Not with alpha cut-outs: the summaries' exact segment tests read the triangles
    // themselves; without them every segment goes through the back-end, which honours the
    // holes. The images are the summaries' own otherwise: only the time differs.)
    summaries_ = !scene.mesh.cutouts && variant_.enumeration == SphereEnumeration::Templates &&
                 (variant_.local == LocalVisibility::Consensus
                      ? cellSummaries != "off"
                      : cellSummaries == "on" && (variant_.local == LocalVisibility::None ||
                                                  variant_.local == LocalVisibility::Inside));
    camera_ = scene.camera.position;
    if (summaries_ && cellSummaries == "auto" && options.rayAngle > 0) {
        const float reach = lattice_.h / (options.rayAngle * std::sqrt(kMinRaysPerCell));
        summaryReach2_ = reach * reach;
        patchRayAngle2_ = options.rayAngle * options.rayAngle;
    }
    if (summaries_) {
        bricksX_ = static_cast<uint64_t>(lattice.nx + kBrick - 1) / kBrick;
        bricksY_ = static_cast<uint64_t>(lattice.ny + kBrick - 1) / kBrick;
        const uint64_t bricksZ = static_cast<uint64_t>(lattice.nz + kBrick - 1) / kBrick;
        bricks_ = ZeroedArray<SummaryBrick*>(bricksX_ * bricksY_ * bricksZ);
        if (tables_->built) {
            // Another group's tables (the same geometry, lattice and options).
            binPairs_ = tables_->binPairs;
            if (!tables_->binned) summaries_ = false, summariesOff_ = true;
        } else {
            const TriangleMesh& mesh = scene.mesh;
            planes_.resize(mesh.triangles.size());
            magnitudes_.resize(mesh.triangles.size());
            ParallelFor(size_t(0), planes_.size(), [&](size_t t) {
                const uint32_t id = static_cast<uint32_t>(t);
                const Vec3 &a = mesh.Vertex(id, 0), &b = mesh.Vertex(id, 1), &c = mesh.Vertex(id, 2);
                double n[3];
                UnitNormal(mesh, id, n);  // zero for a degenerate triangle: never culled
                TrianglePlane& pl = planes_[t];
                pl.n = Vec3(static_cast<float>(n[0]), static_cast<float>(n[1]), static_cast<float>(n[2]));
                pl.d = Dot(pl.n, a);
                pl.lo = Min(a, Min(b, c)) - Vec3(cullMargin_);
                pl.hi = Max(a, Max(b, c)) + Vec3(cullMargin_);
                magnitudes_[t] = std::max({MaxComponent(Abs(a)), MaxComponent(Abs(b)), MaxComponent(Abs(c))});
            });
        }
        if (!tables_->built && !BinTrianglesByBrick(bricksZ)) {
            // Images are the same without summaries; only the time differs.
            summaries_ = false;
            summariesOff_ = true;
            planes_ = {};
            magnitudes_ = {};
            LogWarning(StringPrintf("%s: light mesh: cell summaries off: the triangles' boxes reach %llu "
                                    "(triangle, brick) pairs, more than the budget of %llu",
                                    scene.name.c_str(), static_cast<unsigned long long>(binPairs_),
                                    static_cast<unsigned long long>(BinBudget())));
        }
    }
    if (summaries_ || summariesOff_) {
        tables_->built = true;
        tables_->binned = summaries_;
        tables_->binPairs = binPairs_;
    }
    patches_ = summaries_ && patchesFit_ && variant_.local == LocalVisibility::Consensus;
}

template <typename Word>
inline void LightMesh<Word>::Visibility(const ShadingPoint& sp, LightIndices lights, float* vis,
                                        RenderCounters& counters) const {
    const Word needed = NeededMask(lights);
    LightValues local;
    const uint64_t ownRays = Interpolate(sp, needed, local, counters);
    if (thinCheck_ != ThinCheck::kOff) CheckThin(sp, needed, ownRays, local, counters);
    for (size_t k = 0; k < lights.size(); ++k) vis[k] = local[lights[k]];
}

template <typename Word>
inline void LightMesh<Word>::CheckThin(const ShadingPoint& sp, Word needed, uint64_t ownRays, float* vis,
                                       RenderCounters& counters) const {
    // P's own rays to the lights the nodes decided alone, traced together.
    const uint64_t checked = ThinChecked(needed, ownRays, vis);
    if (!checked) return;
    ApplyThinCheck(sp, checked, LightsVisible(accel_, sp.origin, lights_, checked), vis, counters);
}

template <typename Word>
inline uint64_t LightMesh<Word>::ThinChecked(Word needed, uint64_t ownRays, const float* vis) const {
    uint64_t checked = 0;
    for (uint64_t m = static_cast<uint64_t>(needed) & ~ownRays; m; m &= m - 1) {
        const int l = __builtin_ctzll(m);
        if (vis[l] == 1.0f || (thinCheck_ == ThinCheck::kAll && vis[l] == 0.0f)) checked |= uint64_t(1) << l;
    }
    return checked;
}

template <typename Word>
inline void LightMesh<Word>::ApplyThinCheck(const ShadingPoint& sp, uint64_t checked, uint64_t visible, float* vis,
                                            RenderCounters& counters) const {
    for (; checked; checked &= checked - 1) {
        const int l = __builtin_ctzll(checked);
        const bool lit = vis[l] == 1.0f;
        const Vec3& light = lights_[static_cast<size_t>(l)].position;
        ++Count(counters, LightMeshCount::kThinChecks);
        ++counters.shadowRays;
        if ((((visible >> l) & 1) != 0) == lit) continue;
        ++Count(counters, LightMeshCount::kThinFound);
        int rays = 0;
        vis[l] = DiscLightVisibility(accel_, sp.origin, light, lightRadius_, kNarrowPerRing,
                                     AreaLightSeed(sp, static_cast<uint32_t>(l)), &rays);
        counters.shadowRays += static_cast<uint64_t>(rays);
    }
}

template <typename Word>
inline void LightMesh<Word>::VisibilityMany(const ShadingPoint* sps, const LightIndices* lights, float* const* vis,
                                            size_t count, RenderCounters& counters) const {
    constexpr size_t kChunk = 64;
    thread_local std::unique_ptr<LightValues[]> local(new LightValues[kChunk]);  // 16 KiB, by point and light
    uint64_t needed[kChunk];
    for (size_t first = 0; first < count; first += kChunk) {
        const size_t n = std::min(kChunk, count - first);
        for (size_t i = 0; i < n; ++i) needed[i] = NeededMask(lights[first + i]);
        VisibilityOfMasks(sps + first, needed, local.get(), n, counters);
        for (size_t i = 0; i < n; ++i) {
            const LightIndices ids = lights[first + i];
            for (size_t k = 0; k < ids.size(); ++k) vis[first + i][k] = local[i][ids[k]];
        }
    }
}

template <typename Word>
inline void LightMesh<Word>::VisibilityOfMasks(const ShadingPoint* sps, const uint64_t* needed, LightValues* vis,
                                               size_t count, RenderCounters& counters) const {
    // Without a light radius there is nothing to batch: point by point.
    if (lightRadius_ == 0) {
        for (size_t i = 0; i < count; ++i) {
            const uint64_t ownRays = Interpolate(sps[i], static_cast<Word>(needed[i]), vis[i], counters);
            if (thinCheck_ != ThinCheck::kOff) CheckThin(sps[i], static_cast<Word>(needed[i]), ownRays, vis[i], counters);
        }
        return;
    }
    // Every point's walk first, its narrow penumbrae's discs queued; then the discs, the
    // rings of several points to one light together; then the thin check's rays light by
    // light, as hard shadows trace theirs. Measured: see the README's penumbra benchmark.
    constexpr size_t kChunk = 64;
    thread_local DiscQueue queue;
    struct Restore {
        DiscQueue* previous;
        ~Restore() { ThreadDiscQueue() = previous; }
    } restore{ThreadDiscQueue()};
    for (size_t first = 0; first < count; first += kChunk) {
        const size_t n = std::min(kChunk, count - first);
        uint64_t checked[kChunk], visible[kChunk];
        queue.entries.clear();
        ThreadDiscQueue() = &queue;
        for (size_t i = 0; i < n; ++i) {
            const size_t p = first + i;
            queue.point = i;
            const Word mask = static_cast<Word>(needed[p]);
            const uint64_t ownRays = Interpolate(sps[p], mask, vis[p], counters);
            checked[i] = thinCheck_ == ThinCheck::kOff ? 0 : ThinChecked(mask, ownRays, vis[p]);
        }
        ThreadDiscQueue() = restore.previous;
        TraceDiscs(queue, vis + first, counters);
        if (thinCheck_ == ThinCheck::kOff) continue;
        // (ApplyThinCheck counts the rays, one per checked light, as CheckThin does.)
        LightsVisibleMany(accel_, sps + first, n, lights_, checked, visible);
        for (size_t i = 0; i < n; ++i)
            if (checked[i]) ApplyThinCheck(sps[first + i], checked[i], visible[i], vis[first + i], counters);
    }
}

template <typename Word>
inline void LightMesh<Word>::TraceDiscs(const DiscQueue& queue, LightValues* vis, RenderCounters& counters) const {
    // Per light, the outer rings of kGroup queued points in one packet, then the inner
    // rings of those the outer ring left undecided, likewise. Each ray's answer is the one
    // it gets alone, so every value is DiscLightVisibility's.
    constexpr size_t kGroup = 4, kMaxRays = kGroup * kNarrowPerRing;
    thread_local std::vector<int> outer;
    thread_local std::vector<size_t> pending, undecided;
    outer.assign(queue.entries.size(), 0);
    Ray rays[kMaxRays];
    bool blocked[kMaxRays];
    // Traces the given ring of the entries `ids` (of one light), kGroup at a time, and hands
    // each entry's count of visible rays to `use`.
    auto trace = [&](const std::vector<size_t>& ids, bool inner, auto&& use) {
        for (size_t g = 0; g < ids.size(); g += kGroup) {
            const size_t n = std::min(kGroup, ids.size() - g);
            for (size_t k = 0; k < n; ++k) {
                const DiscRings& rings = queue.entries[ids[g + k]].rings;
                if (inner) rings.InnerRays(rays + k * kNarrowPerRing);
                else rings.OuterRays(rays + k * kNarrowPerRing);
            }
            accel_.OccludedMany(rays, n * kNarrowPerRing, blocked);
            counters.shadowRays += n * kNarrowPerRing;
            for (size_t k = 0; k < n; ++k) {
                int visible = 0;
                for (int r = 0; r < kNarrowPerRing; ++r) visible += !blocked[k * kNarrowPerRing + static_cast<size_t>(r)];
                use(ids[g + k], visible);
            }
        }
    };
    uint64_t queued = 0;  // the lights of the entries
    for (const auto& entry : queue.entries) queued |= uint64_t(1) << entry.light;
    for (; queued; queued &= queued - 1) {
        const size_t l = static_cast<size_t>(__builtin_ctzll(queued));
        pending.clear();
        for (size_t e = 0; e < queue.entries.size(); ++e) {
            const auto& entry = queue.entries[e];
            if (entry.light != l) continue;
            if (entry.rings.Inside()) vis[entry.point][l] = 1.0f;
            else pending.push_back(e);
        }
        if (pending.empty()) continue;
        undecided.clear();
        trace(pending, false, [&](size_t e, int visible) {
            const auto& entry = queue.entries[e];
            outer[e] = visible;
            if (entry.rings.OuterDecides(visible)) vis[entry.point][l] = entry.rings.Value(visible, 0);
            else undecided.push_back(e);
        });
        trace(undecided, true, [&](size_t e, int visible) {
            const auto& entry = queue.entries[e];
            vis[entry.point][l] = entry.rings.Value(outer[e], visible);
        });
    }
}

template <typename Word>
inline uint64_t LightMesh<Word>::Interpolate(const ShadingPoint& sp, Word neededMask, float* vis,
                                             RenderCounters& counters) const {
    Accumulator acc(lights_.size());
    // The lights needed, one bit each (at most 62 in a word).
    auto each = [needed = static_cast<uint64_t>(neededMask)](auto&& f) {
        for (uint64_t m = needed; m; m &= m - 1) f(static_cast<size_t>(__builtin_ctzll(m)));
    };
    if (variant_.enumeration == SphereEnumeration::Templates) {
        Word uniform = 0;
        if (!TemplateWalk(sp, neededMask, acc, counters, &uniform)) {
            CubeWalk(sp, neededMask, acc, counters);
        } else if (uniform) {
            // For every light needed, every node the point may use carries this bit, and
            // the set is not empty.
            ++Count(counters, LightMeshCount::kInterpolations);
            ++Count(counters, LightMeshCount::kUniformCellPoints);
            each([&](size_t l) { vis[l] = static_cast<float>((uniform >> l) & 1); });
            return 0;
        }
    } else {
        CubeWalk(sp, neededMask, acc, counters);
    }
    if (acc.weighted) {
        ++Count(counters, LightMeshCount::kInterpolations);
        Count(counters, LightMeshCount::kNodesUsed) += acc.m;
        each([&](size_t l) { vis[l] = acc.vis[l]; });
        return acc.ownRays;
    }
    if (acc.m == 0) {
        // No node left (a crevice, or a sphere cut off by occluders): one shadow ray
        // per light, as RT would (the paper is silent on this case).
        ++Count(counters, LightMeshCount::kFallbacks);
        each([&](size_t l) {
            ++counters.shadowRays;
            vis[l] = LightVisible(accel_, sp.origin, lights_[l].position) ? 1.0f : 0.0f;
        });
        return ~uint64_t(0);  // every light from P's own ray
    }
    acc.Flush();
    ++Count(counters, LightMeshCount::kInterpolations);
    Count(counters, LightMeshCount::kNodesUsed) += acc.m;
    // A true division, so that m visible nodes out of m give exactly 1 (as RT does).
    each([&](size_t l) { vis[l] = static_cast<float>(acc.visible[l]) / static_cast<float>(acc.m); });
    return 0;
}

template <typename Word>
inline ShadowFigures LightMesh<Word>::Figures() const {
    const uint64_t total = lattice_.NodeCount(), done = evaluated_.load();
    const uint64_t cellsDone = summarized_.load(), planar = planarCells_.load(),
                   uniform = uniformCells_.load();
    ShadowFigures f = {
        {"variant", variant_.name + " (" + variant_.paperName + ")"},
        {"mesh", StringPrintf("%dx%dx%d nodes", lattice_.nx, lattice_.ny, lattice_.nz)},
        {"h", StringPrintf("%g", lattice_.h)},
        {"r", StringPrintf("%g", lattice_.r)},
        {"node storage", FormatBytes(total * BytesPerNode()) +
                             (lightRadius_ > 0
                                  ? StringPrintf(" (%d byte(s) per node: %d of visibility, 2 per light of blocker distance)",
                                                 BytesPerNode(), int(sizeof(Word)))
                                  : StringPrintf(" (%d byte(s) per node)", int(sizeof(Word))))},
        {"nodes evaluated", StringPrintf("%llu (%.2f%% of %llu)", static_cast<unsigned long long>(done),
                                         100.0 * static_cast<double>(done) / static_cast<double>(total),
                                         static_cast<unsigned long long>(total))},
        {"node segments", StringPrintf("%llu", static_cast<unsigned long long>(done * SegmentsPerNode()))},
    };
    if (lightRadius_ > 0)
        f.push_back({"penumbrae", StringPrintf("light radius %g: the radius follows the light's size, at most r", lightRadius_)});
    if (summariesOff_)
        f.push_back({"cell summaries", StringPrintf("off (%llu triangle-brick pairs, over the budget)",
                                                    static_cast<unsigned long long>(binPairs_))});
    if (summaries_)
        f.push_back({"cell summaries",
                     StringPrintf("%llu cells (%llu uniform, %llu planar), %s", static_cast<unsigned long long>(cellsDone),
                                  static_cast<unsigned long long>(uniform), static_cast<unsigned long long>(planar),
                                  FormatBytes(SummaryBytes()).c_str())});
    if (variant_.enumeration == SphereEnumeration::Templates) {
        const TemplateLoad& t = templates_;
        f.push_back({"templates", StringPrintf("ns %d, %s sub-positions, %s entries, %s in %.1f ms%s%s",
                                               t.templates.ns, FormatCount(t.templates.SubPositionCount()).c_str(),
                                               FormatCount(t.templates.offsets.size()).c_str(),
                                               t.loaded ? "loaded" : (t.written ? "built and cached" : "built"),
                                               t.seconds * 1e3,
                                               t.path.empty() ? "" : (t.loaded ? " from " : " at "),
                                               t.path.c_str())});
    }
    return f;
}

template <typename Word>
inline void LightMesh<Word>::ConvertTemplates() {
    const SphereTemplates& t = templates_.templates;
    invH_ = 1.0f / lattice_.h;
    // The offsets' range: -floor(kI) … floor(kI) + 1, inside the lattice's ceil(kI)
    // cells of padding for every P in the scene's box.
    for (const auto& o : t.offsets)
        for (int8_t v : o) {
            minOffset_ = std::min<int>(minOffset_, v);
            maxOffset_ = std::max<int>(maxOffset_, v);
        }
    auto linear = [&](int di, int dj, int dk) {
        return di + static_cast<int64_t>(lattice_.nx) * (dj + static_cast<int64_t>(lattice_.ny) * dk);
    };
    // |linear| <= 17·(nx·ny + nx + 1) at kI 16: below 2^31 up to about 11,000 nodes a
    // side, far past CC's 4096.
    const int64_t reach = std::max(-minOffset_, maxOffset_);
    if (linear(reach, reach, reach) > std::numeric_limits<int32_t>::max())
        ThrowSettingError("cc", "light mesh %dx%dx%d: too many nodes for the templates' 32-bit offsets: lower CC", lattice_.nx,
                   lattice_.ny, lattice_.nz);
    const int cubeSide = maxOffset_ - minOffset_ + 1;
    if (cubeSide > kMaxCubeSide)  // (an internal error: the templates' parser checks the offsets)
        ThrowError("light mesh: sphere templates with offsets %d .. %d: more than kI <= 16 allows", minOffset_, maxOffset_);
    cubeSide_ = cubeSide;
    const uint64_t cubeNodes = static_cast<uint64_t>(cubeSide) * cubeSide * cubeSide;
    cubeWords_ = static_cast<uint32_t>(std::min<uint64_t>((cubeNodes + 63) / 64, kCubeWords));
    const bool cubeFits = cubeNodes <= 64 * kCubeWords;
    auto pack = [&](uint32_t from, uint32_t to) {
        for (uint32_t first = from; first < to; first += 8) {
            FrontBlock b{};
            for (uint32_t k = 0; k < 8; ++k) {
                const bool real = first + k < to;
                const std::array<int8_t, 3> o = real ? t.offsets[first + k] : std::array<int8_t, 3>{};
                b.ox[k] = o[0];
                b.oy[k] = o[1];
                b.oz[k] = o[2];
                b.linear[k] = static_cast<int32_t>(linear(o[0], o[1], o[2]));
                b.lanes |= static_cast<uint8_t>(real ? 1u << k : 0u);
            }
            frontBlocks_.push_back(b);
        }
    };
    size_t blocks = 0;
    for (size_t sp = 0; sp + 1 < t.begin.size(); ++sp)
        blocks += (t.boundaryCount[sp] + 7) / 8 + (t.begin[sp + 1] - t.begin[sp] - t.boundaryCount[sp] + 7) / 8;
    frontBlocks_.reserve(blocks);
    for (size_t sp = 0; sp + 1 < t.begin.size(); ++sp) {
        FrontRuns runs;
        runs.begin = static_cast<uint32_t>(frontBlocks_.size());
        pack(t.begin[sp], t.begin[sp] + t.boundaryCount[sp]);
        runs.inner = static_cast<uint32_t>(frontBlocks_.size());
        pack(t.begin[sp] + t.boundaryCount[sp], t.begin[sp + 1]);
        runs.end = static_cast<uint32_t>(frontBlocks_.size());
        frontRuns_.push_back(runs);
    }
    // The union of all sub-positions' sets: every node a point of a cell may use, in
    // memory order (the cell summaries read them all): marked in the offsets' cube,
    // then read back z, y, x.
    std::vector<std::array<int8_t, 3>> all;
    std::vector<bool> present(cubeNodes);
    for (const auto& o : t.offsets) present[CubeIndex(o[0], o[1], o[2])] = true;
    for (int z = 0, e = 0; z < cubeSide; ++z)
        for (int y = 0; y < cubeSide; ++y)
            for (int x = 0; x < cubeSide; ++x, ++e)
                if (present[e]) all.push_back({static_cast<int8_t>(x + minOffset_), static_cast<int8_t>(y + minOffset_),
                                               static_cast<int8_t>(z + minOffset_)});
    for (const auto& o : all) {
        cellNodes_.push_back(linear(o[0], o[1], o[2]));
        cellOx_.push_back(o[0]);
        cellOy_.push_back(o[1]);
        cellOz_.push_back(o[2]);
    }
    patchesFit_ = cubeFits;
}

template <typename Word>
inline Word LightMesh<Word>::EvaluateVisibility(const Vec3& x, uint64_t index) const {
    Word value = kInit;
    const size_t nLights = lights_.size();
    // Lights with a range: no ray (bit 0) to those that end short of every point that may use
    // the node (points within pointReach_ of it; a step more for the cube loop's). Those
    // points do not need the light, and formula (2) reads only the lights a point needs.
    const uint64_t all = nLights >= 64 ? ~uint64_t(0) : (uint64_t(1) << nLights) - 1;
    uint64_t inRange = all;
    if (ranged_)
        for (size_t l = 0; l < nLights; ++l) {
            const float reach = lights_[l].range + pointReach_ + lattice_.h;
            if (LengthSquared(lights_[l].position - x) > reach * reach) inRange &= ~(uint64_t(1) << l);
        }
    if (lightRadius_ > 0) {
        // Penumbra mode: the same segment, but the nearest blocker's distance too, as
        // its parameter t along x → light in 16 bits (0: no blocker). The stores are
        // relaxed: they happen before the word's publication (release), and racing
        // threads store the same values.
        for (size_t l = 0; l < nLights; ++l) {
            if (!((inRange >> l) & 1)) continue;
            const Vec3& light = lights_[l].position;
            Hit hit;
            if (!accel_.Intersect(LightSegment(x, light), &hit)) {
                value |= Word(1) << l;
                continue;
            }
            const float q = std::clamp(std::round(hit.t * 65535.0f), 1.0f, 65535.0f);
            blockerT_[index * nLights + l].store(static_cast<uint16_t>(q), std::memory_order_relaxed);
        }
        return value;
    }
    // With many lights a node's rays go out together, as RT's from a point do (LightsVisible:
    // Embree's packets, each ray the answer it gets alone): castle with 20 and 40 lights,
    // the default 3 % and 7 % faster; with 4 to 12 lights no gain was measurable.
    if (nLights >= kPacketLights)
        return value | static_cast<Word>(LightsVisible(accel_, x, lights_, inRange));
    for (size_t l = 0; l < nLights; ++l)
        if (((inRange >> l) & 1) && LightVisible(accel_, x, lights_[l].position)) value |= Word(1) << l;
    return value;
}

// СТ (§4): a node is inside a solid when a segment from it to a point outside every
// object crosses the surface an odd number of times. The paper starts that segment at
// the shading point that first needs the node; that makes the flag depend on which
// point (and so which thread) came first wherever meshes are not closed. We vote
// instead over three segments that depend on the node alone: to the first three
// lights (outside every object: the loader checks, except in a closed room with the
// camera, see CheckLightsOutsideSolids), completed, with fewer lights, by the shortest
// axis-aligned segments out of the scene's box. The light segments also
// give the visibility bits (no crossing = visible), so with three or more lights the
// flag costs no extra segment; on closed meshes all three votes agree.
template <typename Word>
inline Word LightMesh<Word>::EvaluateWithInside(const Vec3& x) const {
    Word value = kInit;
    int odd = 0, votes = 0;
    const size_t nLights = lights_.size();
    for (size_t l = 0; l < nLights; ++l) {
        const Vec3& light = lights_[l].position;
        if (votes < 3) {
            const int crossings = accel_.CountCrossings(LightSegment(x, light));
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

}  // namespace

std::unique_ptr<LightMeshShadows> CreateLightMeshShadows(const Scene& scene, const Accelerator& accel,
                                                         const LightMeshOptions& options) {
    const LightMeshVariant variant = ParseLightMeshVariant(options.variant);
    const LightMeshLattice lattice = LightMeshLattice::Make(scene.mesh.Bounds(), options.cc, options.ki);
    const size_t nLights = scene.lights.size();
    const int ns = options.ns == 0 ? kDefaultTemplateSubsteps : options.ns;
    if (ns < 1 || ns > 64) ThrowSettingError("ns", "light mesh: ns must be between 1 and 64, got %d", ns);
    if (!(options.lightRadius >= 0) || !std::isfinite(options.lightRadius))
        ThrowSettingError("light_radius", "light mesh: the light radius must be finite and >= 0, got %g", options.lightRadius);
    if (options.lightRadius > 0 && variant.local != LocalVisibility::Consensus)
        ThrowSettingError("light_radius", "light mesh: a light radius (contact-hardening penumbrae) needs the consensus variant (the "
                   "default), not %s",
                   variant.name.c_str());
    // More lights than a word holds: groups of them, each a light mesh of its own
    // (LightMeshGroups); the storage per node is the groups' together.
    const std::vector<std::vector<uint32_t>> groups = LightGroups(scene.lights, kMaxLightsPerWord);
    uint64_t bytesPerNode = 0;
    for (const auto& g : groups) bytesPerNode += static_cast<uint64_t>(LightMeshStorageBytesPerNode(g.size(), options.lightRadius));
    // Node words. (Cell summaries add a pointer per 4³ cells, zero pages until used, and
    // their records, about 32 bytes per cell used, lazily like the nodes.)
    const uint64_t need = lattice.NodeCount() * static_cast<uint64_t>(bytesPerNode);
    const uint64_t physical = PhysicalMemoryBytes();
    if (physical && need > physical / 2)
        // A SettingError: NamingOrigins puts where CC was given in front ("--cc", "scene.json
        // /render/cc", "m.json /cc/1"), which "lower --cc" used to assume.
        ThrowSettingError("cc", "light mesh %dx%dx%d (CC %d, kI %g) needs %s of node storage%s, more than half of "
                   "this machine's %s: lower CC",
                   lattice.nx, lattice.ny, lattice.nz, options.cc, options.ki, FormatBytes(need).c_str(),
                   options.lightRadius > 0 || groups.size() > 1
                       ? StringPrintf(" (%llu bytes per node%s%s)", static_cast<unsigned long long>(bytesPerNode),
                                      groups.size() > 1 ? StringPrintf(" for %zu lights in %zu groups", nLights, groups.size()).c_str() : "",
                                      options.lightRadius > 0 ? " with the blocker distances of the light radius" : "")
                             .c_str()
                       : "",
                   FormatBytes(physical).c_str());
    if (variant.local == LocalVisibility::Inside) {
        const EdgeReport edges = AnalyzeEdges(scene.mesh);
        if (!edges.Closed())
            LogWarning(StringPrintf("%s: %zu open and %zu non-manifold edges: the inside test (СТ) assumes "
                                    "closed solids and may misjudge nodes near them",
                                    scene.name.c_str(), edges.open, edges.nonManifold));
    }
    TemplateLoad templates;
    if (variant.enumeration == SphereEnumeration::Templates) {
        // The templates and the light mesh's copy of them for its kernels (a FrontBlock of
        // 64 bytes per 8 entries): refused before either is made when they would not fit.
        CheckSphereTemplateBudget(ns, options.ki, 3 + sizeof(FrontBlock) / 8, "light mesh: sphere templates");
        templates = LoadOrBuildSphereTemplates(ns, options.ki, options.templateDir);
        if (!templates.note.empty()) LogWarning("templates: " + templates.note);
    }
    if (options.thinCheck != "off" && options.thinCheck != "lit" && options.thinCheck != "all")
        ThrowSettingError("thin_check", "thin check \"%s\": choose off, lit or all", options.thinCheck.c_str());
    const std::string& summaries = options.cellSummaries;
    if (summaries != "auto" && summaries != "on" && summaries != "off")
        ThrowSettingError("cell_summaries", "cell summaries \"%s\": choose auto, on or off", summaries.c_str());
    if (options.simdWidth != 0 && options.simdWidth != 1 && options.simdWidth != 4 && options.simdWidth != 8)
        ThrowError("light mesh: SIMD width %d: choose 0, 1, 4 or 8", options.simdWidth);
    if (groups.size() == 1)
        return CreateLightMeshForLights(scene, accel, lattice, variant, std::move(templates), options, scene.lights);
    std::vector<std::unique_ptr<LightMeshShadows>> meshes;
    std::shared_ptr<void> tables;  // the geometry's tables, built by the first group, shared
    for (const auto& g : groups) {
        std::vector<PointLight> lights;
        for (uint32_t id : g) lights.push_back(scene.lights[id]);
        meshes.push_back(CreateLightMeshForLights(scene, accel, lattice, variant, templates, options, std::move(lights), &tables));
    }
    return CreateLightMeshGroups(scene, groups, std::move(meshes));
}

std::unique_ptr<LightMeshShadows> CreateLightMeshForLights(const Scene& scene, const Accelerator& accel,
                                                           const LightMeshLattice& lattice, const LightMeshVariant& variant,
                                                           TemplateLoad templates, const LightMeshOptions& options,
                                                           std::vector<PointLight> lights, std::shared_ptr<void>* tables) {
    // Tables are shared between meshes of one word type only (every group's words are 8
    // bytes: 31 lights or more each).
    auto make = [&]<typename Word>(Word) -> std::unique_ptr<LightMeshShadows> {
        auto mesh = std::make_unique<LightMesh<Word>>(scene, accel, lattice, variant, std::move(templates), options,
                                                      std::move(lights), tables ? *tables : nullptr);
        if (tables) *tables = mesh->SharedTables();
        return mesh;
    };
    switch (LightMeshBytesPerNode(lights.size())) {
        case 1: return make(uint8_t{});
        case 2: return make(uint16_t{});
        case 4: return make(uint32_t{});
        default: return make(uint64_t{});
    }
}

}  // namespace lm

