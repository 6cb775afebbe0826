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
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/shadow/light_mesh_kernels.h"
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

using namespace kernels;

/// Zero-filled storage whose pages the kernel hands out on first touch (AllocateZeroed: on
/// huge pages from 256 KiB to 64 MiB), so a large lattice costs nothing until its nodes
/// are used (lazy, like the nodes themselves). std::atomic of an integer is a
/// standard-layout type whose zero bytes are the value 0.
template <typename T>
using ZeroedPtr = std::unique_ptr<T[], ZeroedDeleter>;
template <typename T>
ZeroedPtr<std::atomic<T>> ZeroedArray(uint64_t count) {
    static_assert(std::atomic<T>::is_always_lock_free && sizeof(std::atomic<T>) == sizeof(T));
    if (count > std::numeric_limits<size_t>::max() / sizeof(T)) throw std::bad_alloc();
    ZeroedDeleter deleter;
    void* p = AllocateZeroed(std::max<uint64_t>(count, 1) * sizeof(T), &deleter);
    return ZeroedPtr<std::atomic<T>>(static_cast<std::atomic<T>*>(p), deleter);
}

// For the arenas' chunks (AllocateLarge).
struct FreeDeleter {
    void operator()(void* p) const { std::free(p); }
};

// The most triangles a cell's reach list keeps (more: every segment of its points goes to
// the back-end). Measured: 1024 instead made the castle no faster and the playground 17 %
// slower (its thin bars fill the reach lists; building a point's front list scans them),
// also with a point's blockers capped at 32 or 64. Again with the cells' own tolerances
// (1024×768, Embree, medians of 2 alternated bench runs): at kI 3, 1024 took the castle's
// segments to Embree from 2.14M to 83k and still made every scene 3–16 % slower (a short
// segment costs Embree less than the front lists, patches and culling over long lists);
// at kI 2, 128 made the garden 7 % faster but the castle 2.5 % slower.
constexpr uint32_t kMaxReach = 256;
// Cell patches keep a bit per node of a cell's neighbourhood cube: up to 64 words (kI up
// to about 7; larger spheres test every segment point by point).
constexpr uint32_t kCubeWords = 64;

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
              const LightMeshVariant& variant, TemplateLoad templates, const LightMeshOptions& options)
        : scene_(scene), accel_(accel), lattice_(lattice), variant_(variant),
          templates_(std::move(templates)), frontMasks_(ChooseFrontFunction(options.simdWidth)),
          cull_(ChooseCullFunction(options.simdWidth)), findBlockers_(ChooseFindBlockersFunction(options.simdWidth)),
          patchSees_(ChoosePatchSeesFunction(options.simdWidth)), sumFront_(ChooseSumFrontFunction(options.simdWidth)),
          nodes_(ZeroedArray<Word>(lattice.NodeCount() + kNodePadding)), lightRadius_(options.lightRadius) {
        const std::string& cellSummaries = options.cellSummaries;
        if (lightRadius_ > 0) blockerT_ = ZeroedArray<uint16_t>(lattice.NodeCount() * scene.lights.size());
        if (variant_.enumeration == SphereEnumeration::Templates) ConvertTemplates();
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
        summaries_ = variant_.enumeration == SphereEnumeration::Templates &&
                     (variant_.local == LocalVisibility::Consensus
                          ? cellSummaries != "off"
                          : cellSummaries == "on" && (variant_.local == LocalVisibility::None ||
                                                      variant_.local == LocalVisibility::Inside));
        if (summaries_) {
            bricksX_ = static_cast<uint64_t>(lattice.nx + kBrick - 1) / kBrick;
            bricksY_ = static_cast<uint64_t>(lattice.ny + kBrick - 1) / kBrick;
            const uint64_t bricksZ = static_cast<uint64_t>(lattice.nz + kBrick - 1) / kBrick;
            bricks_ = ZeroedArray<SummaryBrick*>(bricksX_ * bricksY_ * bricksZ);
            {
                const TriangleMesh& mesh = scene.mesh;
                planes_.resize(mesh.triangles.size());
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
                });
            }
            if (!BinTrianglesByBrick(bricksZ)) {
                // Images are the same without summaries; only the time differs.
                summaries_ = false;
                summariesOff_ = true;
                planes_ = {};
                LogWarning(StringPrintf("%s: light mesh: cell summaries off: the triangles' boxes reach %llu "
                                        "(triangle, brick) pairs, more than the budget of %llu",
                                        scene.name.c_str(), static_cast<unsigned long long>(binPairs_),
                                        static_cast<unsigned long long>(BinBudget())));
            }
        }
        patches_ = summaries_ && patchesFit_ && variant_.local == LocalVisibility::Consensus;
    }

    // The most (triangle, brick) pairs the binning may store: far more than any scene of
    // ordinary triangles needs (the garden: about 8 per triangle), far less than a file of
    // huge overlapping triangles would ask for.
    uint64_t BinBudget() const { return 64 * static_cast<uint64_t>(planes_.size()) + (uint64_t(1) << 22); }

    // Every brick's candidate list: the triangles whose bounding box meets the box of all
    // that its cells' summaries look at (their reach), in triangle order. Built once, in
    // parallel, in two passes (count, fill).
    // False, having stored nothing, when the lists would exceed BinBudget().
    bool BinTrianglesByBrick(uint64_t bricksZ) {
        const LightMeshLattice& L = lattice_;
        const uint64_t nb[3] = {bricksX_, bricksY_, bricksZ};
        const float lo[3] = {static_cast<float>(minOffset_), static_cast<float>(minOffset_), static_cast<float>(minOffset_)};
        const float span = static_cast<float>(kBrick - 1 + maxOffset_);
        const float slack = reachMargin_ / L.h + 0.01f;
        // The bricks [b0, b1] per axis whose reach meets the triangle's box (none if b0 > b1).
        auto range = [&](const TrianglePlane& pl, int axis, int64_t* b0, int64_t* b1) {
            const float tlo = (pl.lo[axis] - L.origin[axis]) / L.h, thi = (pl.hi[axis] - L.origin[axis]) / L.h;
            // brick B covers nodes [kBrick·B + minOffset, kBrick·B + span] (± slack)
            const float f0 = std::ceil((tlo - span - slack) / kBrick), f1 = std::floor((thi - lo[axis] + slack) / kBrick);
            const float maxB = static_cast<float>(nb[axis] - 1);
            *b0 = static_cast<int64_t>(std::clamp(f0, 0.0f, maxB + 1));
            *b1 = static_cast<int64_t>(std::clamp(f1, -1.0f, maxB));
        };
        const uint64_t bricks = bricksX_ * bricksY_ * bricksZ;
        // The pairs first, without visiting them: a hostile file must not make this a hang.
        std::atomic<uint64_t> pairs{0};
        ParallelFor(size_t(0), planes_.size(), [&](size_t t) {
            uint64_t product = 1;
            for (int a = 0; a < 3; ++a) {
                int64_t b0, b1;
                range(planes_[t], a, &b0, &b1);
                product *= static_cast<uint64_t>(std::max<int64_t>(b1 - b0 + 1, 0));
            }
            pairs.fetch_add(product, std::memory_order_relaxed);
        });
        binPairs_ = pairs.load();
        if (binPairs_ > BinBudget()) return false;
        // Count and fill by contiguous runs of triangles, each with its own counts per brick:
        // no atomics (two threads incrementing one array's counters spend most of their
        // time trading its cache lines), and every list comes out in triangle order. Runs
        // are fewer for a lattice with many bricks, so their counts stay within about
        // 16 M entries.
        const uint64_t runs = std::clamp<uint64_t>((uint64_t(1) << 24) / std::max<uint64_t>(bricks, 1), 1,
                                                   std::min<uint64_t>(16, std::max<size_t>(planes_.size() / 4096, 1)));
        const uint64_t perRun = (planes_.size() + runs - 1) / runs;
        // Run r's count in brick b, then its next slot there: at[r·bricks + b].
        std::vector<uint64_t, HugePageAllocator<uint64_t>> at(runs * bricks, 0);
        auto each = [&](size_t t, auto&& visit) {
            int64_t b0[3], b1[3];
            for (int a = 0; a < 3; ++a) range(planes_[t], a, &b0[a], &b1[a]);
            for (int64_t z = b0[2]; z <= b1[2]; ++z)
                for (int64_t y = b0[1]; y <= b1[1]; ++y)
                    for (int64_t x = b0[0]; x <= b1[0]; ++x) visit((static_cast<uint64_t>(z) * bricksY_ + y) * bricksX_ + x);
        };
        auto forRuns = [&](auto&& body) {
            ParallelFor(uint64_t(0), runs, [&](uint64_t r) {
                uint64_t* mine = at.data() + r * bricks;
                const size_t end = std::min<size_t>(planes_.size(), (r + 1) * perRun);
                for (size_t t = r * perRun; t < end; ++t) body(t, mine);
            });
        };
        forRuns([&](size_t t, uint64_t* mine) { each(t, [&](uint64_t b) { ++mine[b]; }); });
        // Brick b's list holds run 0's triangles, then run 1's, …: each run's slots start
        // where the previous run's end.
        brickStart_.assign(bricks + 1, 0);
        uint64_t total = 0;
        for (uint64_t b = 0; b < bricks; ++b) {
            brickStart_[b] = total;
            for (uint64_t r = 0; r < runs; ++r) {
                const uint64_t n = at[r * bricks + b];
                at[r * bricks + b] = total;
                total += n;
            }
        }
        brickStart_[bricks] = total;
        brickTris_.resize(total);
        forRuns([&](size_t t, uint64_t* mine) {
            each(t, [&](uint64_t b) { brickTris_[mine[b]++] = static_cast<uint32_t>(t); });
        });
        return true;
    }

    const LightMeshLattice& Lattice() const override { return lattice_; }
    const LightMeshVariant& Variant() const override { return variant_; }
    const TemplateLoad& Templates() const override { return templates_; }
    int BytesPerNode() const override { return LightMeshStorageBytesPerNode(scene_.lights.size(), lightRadius_); }
    uint64_t NodesEvaluated() const override { return evaluated_.load(); }
    bool IsEvaluated(uint64_t index) const override {
        return (nodes_[index].load(std::memory_order_acquire) & kInit) != 0;
    }
    uint64_t NodeVisibility(uint64_t index) const override { return NodeWord(index) & kVisMask; }
    bool NodeInside(uint64_t index) const override { return (NodeWord(index) & kInside) != 0; }
    float NodeBlockerParameter(uint64_t index, size_t light) const override {
        if (light >= scene_.lights.size()) return 0.0f;
        const Word w = NodeWord(index);
        if (lightRadius_ == 0 || ((w >> light) & 1)) return 0.0f;
        return BlockerParameter(index, light);
    }
    // The stored blocker parameter of an evaluated node whose light is blocked.
    float BlockerParameter(uint64_t index, size_t light) const {
        return static_cast<float>(blockerT_[index * scene_.lights.size() + light].load(std::memory_order_relaxed)) *
               (1.0f / 65535.0f);
    }

    void Visibility(const ShadingPoint& sp, const bool* needed, float* vis,
                    RenderCounters& counters) const override {
        const size_t nLights = scene_.lights.size();
        Accumulator acc(nLights);
        Word neededMask = 0;
        for (size_t l = 0; l < nLights; ++l)
            if (needed[l]) neededMask |= Word(1) << l;
        if (variant_.enumeration == SphereEnumeration::Templates) {
            Word uniform = 0;
            if (!TemplateWalk(sp, neededMask, acc, counters, &uniform)) {
                CubeWalk(sp, neededMask, acc, counters);
            } else if (uniform) {
                // For every light needed, every node the point may use carries this bit, and
                // the set is not empty.
                ++counters.interpolations;
                ++counters.uniformCellPoints;
                for (size_t l = 0; l < nLights; ++l) vis[l] = static_cast<float>((uniform >> l) & 1);
                return;
            }
        } else {
            CubeWalk(sp, neededMask, acc, counters);
        }
        if (acc.weighted) {
            ++counters.interpolations;
            counters.nodesUsed += acc.m;
            for (size_t l = 0; l < nLights; ++l)
                if (needed[l]) vis[l] = acc.vis[l];
            return;
        }
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
        if constexpr (sizeof(Word) == 1) acc.Flush();
        ++counters.interpolations;
        counters.nodesUsed += acc.m;
        // A true division, so that m visible nodes out of m give exactly 1 (as RT does).
        for (size_t l = 0; l < nLights; ++l)
            vis[l] = static_cast<float>(acc.visible[l]) / static_cast<float>(acc.m);
    }

    ShadowFigures Figures() const override {
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
    // A run of FrontBlocks with their front masks: visits the entries in front in the
    // template's order.
    struct FrontRun {
        const FrontBlock* blocks;
        const uint8_t* masks;
        uint32_t count;
        template <typename F>
        void ForEach(F&& f) const {
            for (uint32_t b = 0; b < count; ++b)
                for (unsigned m = masks[b]; m; m &= m - 1) f(blocks[b], __builtin_ctz(m));
        }
        /// Whether f holds for some entry in front, stopping at the first.
        template <typename F>
        bool Any(F&& f) const {
            for (uint32_t b = 0; b < count; ++b)
                for (unsigned m = masks[b]; m; m &= m - 1)
                    if (f(blocks[b], __builtin_ctz(m))) return true;
            return false;
        }
    };

    // ---- Cell summaries (ours, not in the paper; exact) ------------------------------
    //
    // A summary belongs to a mesh cell (the cell whose lower corner is node (ci, cj, ck))
    // and to its main plane Π: the plane of the largest triangle meeting the cell (ties:
    // the lower id, so it does not depend on the lists' order). It is used by the points of
    // the cell that lie on Π (within planeDelta_, normal within kPlaneEps; the planar
    // argument below within the cell's own tolerance delta), which is most points of
    // floors, walls and other flat faces. For each side s of Π:
    //  - uniform_s: every node a point of the cell may use (cellNodes_) that lies on side
    //    s of Π has the same visibility bits bits_s (and, for СТ, the same inside flag).
    //    A point on Π seen from side s uses only such nodes (its front test keeps nodes
    //    more than frontEps_ steps in front of its own plane, which is within the
    //    tolerances of Π), so any non-empty subset averages to exactly bits_s: formula (2)
    //    needs neither the walk nor the node words.
    //  - clear_s (consensus): no triangle meeting the cell grown by the sphere's reach has
    //    a vertex more than delta / 2 on side s. A local-visibility segment runs from a
    //    node to P's origin, both clearly on side s, inside that box, so nothing can block
    //    it: no segment is traced.
    // Summaries are computed on first use and published like the nodes: the values depend
    // on the cell only, and the thread that claims a record is the only one to write it.
    struct CellSummary {
        float n[3] = {0, 0, 0};  // Π: unit normal and offset, (n, x) = d on Π
        double d = 0;
        uint8_t flags = 0;
        // The cell's tolerance: planeDelta_'s rule at the largest coordinate the cell's
        // computations meet (its reach box and its reach's vertices), at most planeDelta_.
        // Every margin of the summaries, patches and culling of this cell scales with it, so
        // a small object near the coordinates' origin in a large scene keeps them.
        float delta = 0;
        // Consensus: the triangles whose bounding box meets the reach box (kTooMany: more
        // than kMaxReach; the back-end tests every segment), in an arena of the mesh.
        const uint32_t* reach = nullptr;
        uint32_t reachCount = 0;
    };
    static constexpr uint32_t kTooMany = UINT32_MAX;

    // Consensus with cell summaries: the triangles that could block a segment from a node
    // to this P. Every such segment lies in the cell's reach box, so only the reach list's
    // triangles can block it; of those, one whose vertices all lie on or behind P's plane
    // cannot (the segment runs clearly in front of it, like the planar argument). So:
    // the reach triangles with a vertex in front of P's triangle's plane (by more than
    // the cell's delta / 2, measured with the triangle's own plane so the list depends on the
    // cell, the triangle and the side only): points of one triangle in one cell, which a
    // tile shades one after another, share it, so each thread keeps the last few.
    struct FrontList {
        uint64_t owner = 0;  // serial_ of the light mesh it belongs to
        int64_t base = -1;
        uint32_t prim = UINT32_MAX;
        float sign = 0;
        FrontArrays arrays;
        // The cell patch (Patch): computed on first use; usable when `patch` is true.
        bool patchTried = false, patch = false;
        float delta = 0;   // the cell's tolerance (CellSummary::delta)
        Vec3 normal;       // the points' normal the patch was built with
        Vec3 qlo, qhi;     // the box of the patch's origins, grown by reachMargin_
        uint64_t known[kCubeWords], sees[kCubeWords];  // node states, by CubeBit
    };
    // A few lists per thread, replaced in turn: a tile's row of pixels crosses cells and
    // triangles back and forth, and its next row comes back to them.
    static constexpr int kFrontLists = 8;
    FrontList& FrontTriangles(const CellSummary& c, int64_t base, const ShadingPoint& sp) const {
        thread_local FrontList lists[kFrontLists];
        thread_local int next = 0;
        const TrianglePlane& own = planes_[sp.prim];
        const float sign = Dot(own.n, sp.n) >= 0 ? 1.0f : -1.0f;
        for (FrontList& list : lists)
            if (list.owner == serial_ && list.base == base && list.prim == sp.prim && list.sign == sign) return list;
        FrontList& list = lists[next];
        next = (next + 1) % kFrontLists;
        const TriangleMesh& mesh = scene_.mesh;
        const Vec3 n = own.n * sign;
        const float d = own.d * sign;
        FrontArrays& f = list.arrays;
        list.owner = 0;  // invalid until filled (Reserve may throw)
        f.Reserve(c.reachCount);
        uint32_t count = 0;
        for (uint32_t i = 0; i < c.reachCount; ++i) {
            const uint32_t t = c.reach[i];
            bool front = false;
            for (int k = 0; k < 3 && !front; ++k) front = Dot(n, mesh.Vertex(t, k)) - d > 0.5f * c.delta;
            if (!front) continue;
            const TrianglePlane& pl = planes_[t];
            const Vec3 &v0 = mesh.Vertex(t, 0), &v1 = mesh.Vertex(t, 1), &v2 = mesh.Vertex(t, 2);
            f.nx[count] = pl.n.x, f.ny[count] = pl.n.y, f.nz[count] = pl.n.z, f.d[count] = pl.d;
            f.lox[count] = pl.lo.x, f.loy[count] = pl.lo.y, f.loz[count] = pl.lo.z;
            f.hix[count] = pl.hi.x, f.hiy[count] = pl.hi.y, f.hiz[count] = pl.hi.z;
            f.v0x[count] = v0.x, f.v0y[count] = v0.y, f.v0z[count] = v0.z;
            f.v1x[count] = v1.x, f.v1y[count] = v1.y, f.v1z[count] = v1.z;
            f.v2x[count] = v2.x, f.v2y[count] = v2.y, f.v2z[count] = v2.z;
            ++count;
        }
        f.count = count;
        for (uint32_t i = count; i % 8 != 0; ++i) {  // padding: an empty box
            f.nx[i] = f.ny[i] = f.nz[i] = f.d[i] = f.sMin[i] = f.sMax[i] = 0;
            f.lox[i] = f.loy[i] = f.loz[i] = Infinity;
            f.hix[i] = f.hiy[i] = f.hiz[i] = -Infinity;
            f.v0x[i] = f.v0y[i] = f.v0z[i] = f.v1x[i] = f.v1y[i] = f.v1z[i] = f.v2x[i] = f.v2y[i] = f.v2z[i] = 0;
        }
        list.owner = serial_;
        list.delta = c.delta;
        list.base = base;
        list.prim = sp.prim;
        list.sign = sign;
        list.patchTried = list.patch = false;
        return list;
    }

    // ---- Cell patches (ours, exact) -------------------------------------------------
    //
    // The points of one triangle in one cell, seen from one side, have their origins on a
    // small convex patch Q: the triangle clipped to the cell's box, pushed off the surface
    // by the renderer's offset. Points of a patch ask for the same nodes again and again
    // (4 times each on the castle at 1024×768, 11 at 2048×1536). A node x that sees every
    // origin of Q needs no segment from any of them: no front triangle (the only ones that
    // can block, FrontTriangles) meets the hull of x and Q when x and all of Q lie clearly
    // on one side of its plane, or their box is apart from its box. Those are the tests the
    // segment culling already trusts (SeesPointCulled), with margins for Q's rounding, so
    // any exact test agrees: the image is ОТ's. Each node's answer is kept per patch (per
    // thread, with the front list); nodes that may be blocked from some of Q (inside walls,
    // behind edges) are tested point by point as before.
    //
    // The patch of `sp` (with its front list), or null where it cannot be used: no front
    // list (crowded cell), a degenerate triangle, or a point not made as the renderer makes
    // it — its origin SurfaceOffset() off P (within 2·delta, the cell's), P on its triangle's
    // plane, the normal the patch was built with. So whether a segment is decided by the
    // patch depends on the point and node only, never on which points a thread shaded
    // before: --stats are the same for any thread count.
    FrontList* Patch(const CellSummary& c, int64_t base, int ci, int cj, int ck, const ShadingPoint& sp) const {
        if (!patches_ || c.reachCount == kTooMany || planes_[sp.prim].n == Vec3(0.0f)) return nullptr;
        const Vec3 &v0 = scene_.mesh.Vertex(sp.prim, 0), &v1 = scene_.mesh.Vertex(sp.prim, 1),
                   &v2 = scene_.mesh.Vertex(sp.prim, 2);
        const float offset = SurfaceOffset(v0, v1, v2);
        const float measured = Dot(sp.origin - sp.p, sp.n);
        if (!(measured > 4 * c.delta) || !(std::abs(measured - offset) <= 2 * c.delta)) return nullptr;
        // P on its triangle's plane, and the normal the patch was built with (the renderer
        // makes it from the triangle alone; a caller's other normal gets no patch).
        const TrianglePlane& own = planes_[sp.prim];
        if (!(std::abs(Dot(own.n, sp.p) - own.d) <= 2 * c.delta)) return nullptr;
        FrontList& list = FrontTriangles(c, base, sp);
        if (!list.patchTried) BuildPatch(list, ci, cj, ck, sp, offset);
        if (!list.patch || list.normal != sp.n) return nullptr;
        return &list;
    }
    void BuildPatch(FrontList& list, int ci, int cj, int ck, const ShadingPoint& sp, float offset) const {
        list.patchTried = true;
        list.patch = false;
        list.normal = sp.n;
        const TriangleMesh& mesh = scene_.mesh;
        // The triangle clipped to the cell's box grown by reachMargin_ (a point's cell comes
        // from rounded coordinates), in double.
        const Vec3 c0 = lattice_.Node(ci, cj, ck), c1 = lattice_.Node(ci + 1, cj + 1, ck + 1);
        // Six clips of a triangle leave at most 9 vertices; rounding could add crossings, so
        // a polygon that would outgrow the buffer gets no patch (its points test as before).
        constexpr int kMaxPoly = 16;
        double poly[2][kMaxPoly][3];
        int n = 3;
        for (int k = 0; k < 3; ++k) {
            const Vec3& v = mesh.Vertex(sp.prim, k);
            poly[0][k][0] = v.x, poly[0][k][1] = v.y, poly[0][k][2] = v.z;
        }
        int cur = 0;
        for (int axis = 0; axis < 3 && n > 0; ++axis)
            for (int end = 0; end < 2 && n > 0; ++end) {
                // Keep (sign)·(v[axis] - bound) <= 0.
                const double bound = end == 0 ? double(c0[axis]) - reachMargin_ : double(c1[axis]) + reachMargin_;
                const double sign = end == 0 ? -1.0 : 1.0;
                int m = 0;
                for (int k = 0; k < n; ++k) {
                    if (m + 2 > kMaxPoly) return;  // list.patch stays false
                    const double* a = poly[cur][k];
                    const double* b = poly[cur][(k + 1) % n];
                    const double da = sign * (a[axis] - bound), db = sign * (b[axis] - bound);
                    if (da <= 0) std::copy(a, a + 3, poly[1 - cur][m++]);
                    if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
                        const double t = da / (da - db);
                        double* out = poly[1 - cur][m++];
                        for (int j = 0; j < 3; ++j) out[j] = a[j] + t * (b[j] - a[j]);
                        out[axis] = bound;
                    }
                }
                n = m;
                cur = 1 - cur;
            }
        if (n == 0) return;
        // The origins: the polygon pushed along n by the offset, give or take 8·delta
        // along n: Patch lets in points whose origin lies within 2·delta of that offset
        // from P and whose P lies within 2·delta of the triangle's plane; the rest covers
        // the rounding of P and of the origin. The slack moves a plane's value by at most as
        // much (unit normals).
        const double slack = 8.08 * list.delta;
        double qx[kMaxPoly], qy[kMaxPoly], qz[kMaxPoly];
        for (int k = 0; k < n; ++k) {
            qx[k] = poly[cur][k][0] + double(sp.n.x) * offset;
            qy[k] = poly[cur][k][1] + double(sp.n.y) * offset;
            qz[k] = poly[cur][k][2] + double(sp.n.z) * offset;
        }
        double lo[3] = {qx[0], qy[0], qz[0]}, hi[3] = {qx[0], qy[0], qz[0]};
        for (int k = 1; k < n; ++k) {
            lo[0] = std::min(lo[0], qx[k]), hi[0] = std::max(hi[0], qx[k]);
            lo[1] = std::min(lo[1], qy[k]), hi[1] = std::max(hi[1], qy[k]);
            lo[2] = std::min(lo[2], qz[k]), hi[2] = std::max(hi[2], qz[k]);
        }
        list.qlo = Vec3(NextFloatDown(float(lo[0] - slack)), NextFloatDown(float(lo[1] - slack)),
                        NextFloatDown(float(lo[2] - slack))) - Vec3(reachMargin_);
        list.qhi = Vec3(NextFloatUp(float(hi[0] + slack)), NextFloatUp(float(hi[1] + slack)),
                        NextFloatUp(float(hi[2] + slack))) + Vec3(reachMargin_);
        FrontArrays& f = list.arrays;
        for (uint32_t i = 0; i < f.count; ++i) {
            const double nx = f.nx[i], ny = f.ny[i], nz = f.nz[i], d = f.d[i];
            double smin = Infinity, smax = -Infinity;
            for (int k = 0; k < n; ++k) {
                const double v = nx * qx[k] + ny * qy[k] + nz * qz[k] - d;
                smin = std::min(smin, v);
                smax = std::max(smax, v);
            }
            f.sMin[i] = NextFloatDown(float(smin - slack));
            f.sMax[i] = NextFloatUp(float(smax + slack));
        }
        std::fill(list.known, list.known + cubeWords_, 0);
        list.patch = true;
    }
    // Whether node x (lane k of template block b) sees every origin of the patch; false
    // when not certain (the caller tests the segment).
    bool PatchSees(FrontList& list, const FrontBlock& b, int k, const Vec3& x) const {
        const uint32_t bit = b.cube[k], word = bit >> 6;
        const uint64_t mask = uint64_t(1) << (bit & 63);
        if (list.known[word] & mask) return (list.sees[word] & mask) != 0;
        PatchQuery q;
        q.x = x;
        q.lo = Min(x, list.qlo);
        q.hi = Max(x, list.qhi);
        q.m = CullMargin(list.delta);
        q.mQ = q.m + 4 * list.delta;
        const bool sees = patchSees_(list.arrays, q);
        list.known[word] |= mask;
        list.sees[word] = sees ? list.sees[word] | mask : list.sees[word] & ~mask;
        return sees;
    }
    // The first candidate (in the template's order) that sees the whole patch of `sp`, with
    // its lane in *lane; null if none does or there is no patch. Where the candidates
    // agree, such a node settles the point without a segment.
    const FrontBlock* PatchWitness(const CellSummary& c, int64_t base, int ci, int cj, int ck, const ShadingPoint& sp,
                                   const FrontRun& all, RenderCounters& counters, int* lane = nullptr) const {
        FrontList* patch = Patch(c, base, ci, cj, ck, sp);
        if (!patch) return nullptr;
        const FrontBlock* found = nullptr;
        all.Any([&](const FrontBlock& b, int k) {
            if (!PatchSees(*patch, b, k, EntryNode(ci, cj, ck, b, k))) return false;
            found = &b;
            if (lane) *lane = k;
            return true;
        });
        if (found) ++counters.patchSegments;
        return found;
    }
    void FindBlockers(const CellSummary& c, int64_t base, const ShadingPoint& sp, Blockers* b) const {
        b->tried = true;
        b->known = false;
        // (A degenerate own triangle has no plane to put the others in front of: no blockers.)
        if (c.reachCount == kTooMany || !(Dot(sp.origin - sp.p, sp.n) > 4 * c.delta) ||
            planes_[sp.prim].n == Vec3(0.0f))
            return;
        const FrontArrays& front = FrontTriangles(c, base, sp).arrays;
        BlockerQuery q;
        // The segments of this P lie within pointReach_ of it.
        q.lo = sp.p - Vec3(pointReach_);
        q.hi = sp.p + Vec3(pointReach_);
        q.o = sp.origin;
        q.margin = CullMargin(c.delta);
        q.far = pointReach_ + 2 * q.margin;
        q.reach = pointReach_;
        q.delta8 = 8 * c.delta;
        b->margin = q.margin;
        if (!findBlockers_(front, q, b)) return;  // too many: the back-end decides
        PadBlockers(b);
        b->known = true;
    }
    // Whether the segment from node x to P's origin o is unblocked, decided without a ray
    // where the answer is certain: it misses a blocker if its two ends lie clearly on one
    // side of the blocker's plane, or the line passes clearly outside one of its edges
    // (the triple products d·c_k, d = x - o, have both signs); it hits one if the ends lie
    // clearly on both sides of its plane and d·c_k have one sign clearly (it crosses the
    // inside). Any exact test agrees on such segments,
    // so when every blocker is missed the answer is "sees", when one is hit "blocked", and
    // otherwise the back-end decides, as for ОТ. The image is ОТ's either way.
    bool SeesPointCulled(const Vec3& x, const ShadingPoint& sp, const Blockers& b, RenderCounters& counters) const {
        if (b.known) {
            const int decided = cull_(b, x, sp.origin, b.margin);
            if (decided >= 0) {
                ++counters.culledSegments;
                return decided == 0;
            }
        }
        return SeesPoint(x, sp, counters);
    }
    static constexpr uint8_t kHasPlane = 1, kClear0 = 8, kClear1 = 16;
    static constexpr int kBrick = 4;  // summaries are stored by bricks of 4³ cells
    struct SideSummary {
        Word bits = 0, uniform = 0;
    };
    struct SummaryBrick {
        std::atomic<uint8_t> state[kBrick * kBrick * kBrick];  // 0 empty, 1 being written, 2 ready
        CellSummary cell[kBrick * kBrick * kBrick];
        // The brick's list from BinTrianglesByBrick: every triangle whose box meets the
        // reach of one of its cells; kTooMany if more than kMaxBrickNear.
        const uint32_t* near = nullptr;
        uint32_t nearCount = 0;
        std::atomic<uint8_t> sideState[kBrick * kBrick * kBrick][2];  // like state, per side of Π
        SideSummary side[kBrick * kBrick * kBrick][2];
    };
    static_assert(std::is_trivially_destructible_v<SummaryBrick>);  // freed with its chunk
    static constexpr uint32_t kMaxBrickNear = 16384;

    // The summary of cell (ci, cj, ck): the stored one, or one computed into `scratch`.
    const CellSummary& Summary(int ci, int cj, int ck, CellSummary* scratch, SummaryBrick** brickOut,
                               int* slotOut) const {
        const uint64_t brick = (static_cast<uint64_t>(ck / kBrick) * bricksY_ + static_cast<uint64_t>(cj / kBrick)) * bricksX_ +
                               static_cast<uint64_t>(ci / kBrick);
        SummaryBrick* b = bricks_[brick].load(std::memory_order_acquire);
        if (!b) b = AllocateBrick(brick);
        const int slot = ((ck % kBrick) * kBrick + (cj % kBrick)) * kBrick + (ci % kBrick);
        *brickOut = b;
        *slotOut = slot;
        uint8_t state = b->state[slot].load(std::memory_order_acquire);
        if (state == 2) return b->cell[slot];
        *scratch = ComputeSummary(ci, cj, ck, *b);
        if (state == 0 && b->state[slot].compare_exchange_strong(state, 1, std::memory_order_acquire)) {
            b->cell[slot] = *scratch;
            b->state[slot].store(2, std::memory_order_release);
            summarized_.fetch_add(1, std::memory_order_relaxed);
            if (scratch->flags & (kClear0 | kClear1)) planarCells_.fetch_add(1, std::memory_order_relaxed);
        }
        return *scratch;
    }

    // Copies a reach list into the arena (chunks never move, so the pointer stays valid).
    const uint32_t* StoreReach(const std::vector<uint32_t>& ids) const {
        if (ids.empty()) return nullptr;
        std::lock_guard<std::mutex> lock(brickMutex_);
        if (reachArena_.empty() || reachUsed_ + ids.size() > kReachChunk) {
            // Pages as used, huge ones (see AllocateBrick).
            reachArena_.emplace_back(static_cast<uint32_t*>(AllocateLarge(kReachChunk * sizeof(uint32_t))));
            reachUsed_ = 0;
        }
        uint32_t* out = reachArena_.back().get() + reachUsed_;
        std::copy(ids.begin(), ids.end(), out);
        reachUsed_ += ids.size();
        reachBytes_ += ids.size() * sizeof(uint32_t);
        return out;
    }

    // The box of everything cell (ci, cj, ck)'s summary looks at: every node any of its
    // points may use, so every segment of theirs.
    Bounds3 ReachBox(int ci, int cj, int ck) const {
        const LightMeshLattice& L = lattice_;
        return Bounds3(L.Node(ci + minOffset_, cj + minOffset_, ck + minOffset_) - Vec3(reachMargin_),
                       L.Node(ci + maxOffset_, cj + maxOffset_, ck + maxOffset_) + Vec3(reachMargin_));
    }

    SummaryBrick* AllocateBrick(uint64_t brick) const {
        SummaryBrick* fresh = nullptr;
        {
            // From chunks of kBricksPerChunk (on huge pages: a brick is 3.5 KiB, and a first
            // touch of each fresh 4 KiB page would cost a page fault). A brick that loses the
            // race below stays unused in its chunk.
            std::lock_guard<std::mutex> lock(brickMutex_);
            if (brickChunks_.empty() || brickChunkUsed_ == kBricksPerChunk) {
                brickChunks_.emplace_back(static_cast<SummaryBrick*>(AllocateLarge(kBricksPerChunk * sizeof(SummaryBrick))));
                brickChunkUsed_ = 0;
            }
            fresh = new (brickChunks_.back().get() + brickChunkUsed_++) SummaryBrick();
        }
        for (auto& st : fresh->state) st.store(0, std::memory_order_relaxed);
        for (auto& st : fresh->sideState) st[0].store(0, std::memory_order_relaxed), st[1].store(0, std::memory_order_relaxed);
        const uint64_t begin = brickStart_[brick], end = brickStart_[brick + 1];
        fresh->nearCount = end - begin > kMaxBrickNear ? kTooMany : static_cast<uint32_t>(end - begin);
        fresh->near = brickTris_.data() + begin;
        SummaryBrick* expected = nullptr;
        if (bricks_[brick].compare_exchange_strong(expected, fresh, std::memory_order_acq_rel)) {
            bricksUsed_.fetch_add(1, std::memory_order_relaxed);
            return fresh;
        }
        return expected;  // another thread's brick
    }

    CellSummary ComputeSummary(int ci, int cj, int ck, const SummaryBrick& brick) const {
        CellSummary c;
        c.delta = planeDelta_;
        const LightMeshLattice& L = lattice_;
        const TriangleMesh& mesh = scene_.mesh;
        thread_local std::vector<uint32_t> tris;
        thread_local std::vector<uint32_t> reach;
        reach.clear();
        tris.clear();
        const Bounds3 cellBox(L.Node(ci, cj, ck) - Vec3(reachMargin_), L.Node(ci + 1, cj + 1, ck + 1) + Vec3(reachMargin_));
        const Bounds3 reachBox = ReachBox(ci, cj, ck);
        // Too crowded a brick (dense foliage): no summary; such points walk and trace.
        if (brick.nearCount == kTooMany) {
            c.reachCount = kTooMany;
            return c;
        }
        // From the brick's candidates: the reach (bounding boxes meeting the reach box) and
        // the triangles meeting the cell (bounding boxes too: they only choose Π).
        auto meets = [](const TrianglePlane& pl, const Bounds3& b) {
            return pl.hi.x >= b.lo.x && pl.lo.x <= b.hi.x && pl.hi.y >= b.lo.y && pl.lo.y <= b.hi.y &&
                   pl.hi.z >= b.lo.z && pl.lo.z <= b.hi.z;
        };
        for (uint32_t i = 0; i < brick.nearCount; ++i) {
            const uint32_t t = brick.near[i];
            const TrianglePlane& pl = planes_[t];
            if (!meets(pl, reachBox)) continue;
            reach.push_back(t);
            if (meets(pl, cellBox)) tris.push_back(t);
        }
        // The cell's tolerance: every coordinate its tests compute with lies in the reach box
        // (nodes, points, origins) or is a vertex of a reach triangle (planes, patches).
        float magnitude = std::max(MaxComponent(Abs(reachBox.lo)), MaxComponent(Abs(reachBox.hi)));
        for (const uint32_t t : reach)
            for (int k = 0; k < 3; ++k) magnitude = std::max(magnitude, MaxComponent(Abs(mesh.Vertex(t, k))));
        c.delta = std::min(planeDelta_, PlaneDelta(magnitude));
        if (variant_.local == LocalVisibility::Consensus) {
            if (reach.size() > kMaxReach) {
                c.reachCount = kTooMany;
            } else {
                c.reachCount = static_cast<uint32_t>(reach.size());
                c.reach = StoreReach(reach);
            }
        }
        // Π: the largest triangle meeting the cell (grown by the reach margin); a tie goes to
        // the lower id, so the choice does not depend on the lists' order.
        double best = 0, n[3] = {0, 0, 0};
        uint32_t plane = UINT32_MAX;
        for (const uint32_t t : tris) {
            double m[3];
            const double area = UnitNormal(mesh, t, m);
            if (area > best || (area == best && area > 0 && t < plane)) {
                best = area;
                plane = t;
                for (int a = 0; a < 3; ++a) n[a] = m[a];
            }
        }
        if (plane == UINT32_MAX) return c;
        const Vec3& v0 = mesh.Vertex(plane, 0);
        c.n[0] = static_cast<float>(n[0]);
        c.n[1] = static_cast<float>(n[1]);
        c.n[2] = static_cast<float>(n[2]);
        // Heights are measured with the stored (float) normal, as the points are tested.
        const double nf[3] = {c.n[0], c.n[1], c.n[2]};
        c.d = nf[0] * v0.x + nf[1] * v0.y + nf[2] * v0.z;
        c.flags = kHasPlane;

        if (variant_.local == LocalVisibility::Consensus) {
            // clear_s: the extreme heights of the vertices of the triangles in reach (of all
            // whose bounding box is in reach: more triangles can only make it stricter).
            // In float from a vertex of Π: v - v0 is short and exact to half an ulp of the
            // coordinates, so the error stays below the delta / 2 compared with.
            const Vec3 np(c.n[0], c.n[1], c.n[2]);
            const float limit = 0.5f * c.delta;
            bool up = false, down = false;  // a vertex above Π (side 0), below (side 1)
            for (size_t i = 0; i < reach.size() && !(up && down); ++i)
                for (int k = 0; k < 3; ++k) {
                    const float hv = Dot(np, mesh.Vertex(reach[i], k) - v0);
                    up |= hv > limit;
                    down |= hv < -limit;
                }
            if (!up) c.flags |= kClear0;
            if (!down) c.flags |= kClear1;
        }
        return c;
    }

    // uniform_s of the cell's plane, for one side, light by light: computed the first time
    // a point on that side asks (so only the nodes on the side that is seen are evaluated,
    // as a walk would), and stored in the brick like the summary itself.
    SideSummary Side(const CellSummary& c, SummaryBrick* brick, int slot, int side, int ci, int cj, int ck) const {
        if (brick) {
            if (brick->sideState[slot][side].load(std::memory_order_acquire) == 2) return brick->side[slot][side];
        }
        const LightMeshLattice& L = lattice_;
        const int64_t base = static_cast<int64_t>(L.Index(ci, cj, ck));
        const double nf[3] = {c.n[0], c.n[1], c.n[2]};
        Word all = kVisMask, any = 0;
        for (size_t e = 0; e < cellNodes_.size(); ++e) {
            const uint64_t index = static_cast<uint64_t>(base + cellNodes_[e]);
            const std::array<int8_t, 3>& o = cellOffsets_[e];
            const Vec3 x = L.Node(ci + o[0], cj + o[1], ck + o[2]);  // NodeAt(index), without its divisions
            const double hx = nf[0] * x.x + nf[1] * x.y + nf[2] * x.z - c.d;
            if (side == 0 ? !(hx > 0) : !(hx < 0)) continue;  // the other side, or on Π
            const Word w = Evaluate(index) & kVisMask;
            all &= w;
            any |= w;
        }
        SideSummary r{all, static_cast<Word>(~(all ^ any) & kVisMask)};
        if (brick) {
            uint8_t expected = 0;
            if (brick->sideState[slot][side].compare_exchange_strong(expected, 1, std::memory_order_acquire)) {
                brick->side[slot][side] = r;
                brick->sideState[slot][side].store(2, std::memory_order_release);
                if (r.uniform == kVisMask) uniformCells_.fetch_add(1, std::memory_order_relaxed);
            }
        }
        return r;
    }

    // Unit normal of triangle t in double into n; returns twice its area (0 if degenerate).
    static double UnitNormal(const TriangleMesh& mesh, uint32_t t, double n[3]) {
        const Vec3 &a = mesh.Vertex(t, 0), &b = mesh.Vertex(t, 1), &c = mesh.Vertex(t, 2);
        const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
        const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(len > 0) || !std::isfinite(len)) return 0;
        for (int k = 0; k < 3; ++k) n[k] /= len;
        return len;
    }

    uint64_t SummaryBytes() const {
        std::lock_guard<std::mutex> lock(brickMutex_);
        return bricksUsed_.load() * sizeof(SummaryBrick) + reachBytes_ + planes_.size() * sizeof(TrianglePlane) +
               brickTris_.size() * sizeof(uint32_t) + brickStart_.size() * sizeof(uint64_t) +
               bricksX_ * bricksY_ * sizeof(void*) * ((lattice_.nz + kBrick - 1) / kBrick);
    }

    // The sums of formula (2): m and, per light, the visible nodes. With one-byte node
    // words the eight bits are counted at once, one byte lane each (kSpread), and the lanes
    // are moved to `visible` before they can overflow, and at the end (Flush).
    struct Accumulator {
        uint32_t m = 0;
        uint32_t pending = 0;
        uint64_t lanes = 0;
        uint32_t visible[64];
        // Contact-hardening penumbrae: the visibilities themselves, for every light needed.
        bool weighted = false;
        float vis[64];
        explicit Accumulator(size_t lights) {
            // Flush adds all eight byte lanes, so the first eight are always zeroed.
            for (size_t l = 0; l < std::max<size_t>(lights, 8); ++l) visible[l] = 0;
        }
        void Flush() {
            for (int b = 0; b < 8; ++b) visible[b] += static_cast<uint32_t>((lanes >> (8 * b)) & 0xFF);
            lanes = 0;
            pending = 0;
        }
    };
    static constexpr std::array<uint64_t, 256> MakeSpread() {
        std::array<uint64_t, 256> t{};
        for (int w = 0; w < 256; ++w)
            for (int b = 0; b < 8; ++b) t[w] |= static_cast<uint64_t>((w >> b) & 1) << (8 * b);
        return t;
    }
    static constexpr std::array<uint64_t, 256> kSpread = MakeSpread();

    // Segments traced when a node is evaluated: one per light, plus, for СТ, the extra
    // segments that complete its vote of three (see EvaluateNode).
    size_t SegmentsPerNode() const {
        const size_t n = scene_.lights.size();
        return variant_.local == LocalVisibility::Inside && n < 3 ? 3 : n;
    }

    Word NodeWord(uint64_t index) const { return Evaluate(index); }

    // Adds node x to the interpolation set.
    void Use(Accumulator& acc, Word w) const {
        ++acc.m;
        if constexpr (sizeof(Word) == 1) {
            acc.lanes += kSpread[w];
            if (++acc.pending == 255) acc.Flush();
        } else {
            for (size_t l = 0; l < scene_.lights.size(); ++l) acc.visible[l] += (w >> l) & 1;
        }
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
                const Word w = Evaluate(index);
                if (!(w & kInside)) Use(acc, w);
                return;
            }
            default: break;
        }
        Use(acc, Evaluate(index));
    }

    // A candidate node for the penumbra mode (PenumbraInterpolate).
    struct PenumbraNode {
        Vec3 x;
        float d2;  // |x − P|²
        uint64_t index;
        Word w;
    };

    // The paper's "Grid" enumeration (§3.1 pseudocode): the cube of nodes around the
    // sphere, each tested against r. Also the fallback of the templates near the lattice's
    // border, where a template would reach outside it.
    void CubeWalk(const ShadingPoint& sp, Word neededMask, Accumulator& acc, RenderCounters& counters) const {
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
        thread_local std::vector<PenumbraNode> cubeNodes;
        cubeNodes.clear();
        for (int k = k0; k <= k1; ++k)
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) {
                    const Vec3 x = L.Node(i, j, k);
                    const Vec3 d = x - sp.p;
                    if (LengthSquared(d) > r2) continue;
                    // Behind the surface, (n(P), x - P) <= 0, or on it (see frontEps_).
                    if (Dot(sp.n, d) <= frontEps_ * L.h) continue;
                    if (lightRadius_ > 0) {
                        const uint64_t index = L.Index(i, j, k);
                        cubeNodes.push_back({x, LengthSquared(d), index, Evaluate(index)});
                        continue;
                    }
                    Candidate(x, L.Index(i, j, k), sp, acc, counters);
                }
        if (lightRadius_ > 0) CubePenumbra(sp, neededMask, cubeNodes, acc, counters);
    }

    // The cube loop's candidates in penumbra mode (points whose template would reach out of
    // the lattice: on the scene box's far faces, such as the walls of a room that bound
    // it): consensus's rule as in ConsensusWalk — where the candidates agree on the needed
    // lights, the first that sees P gives its bits; else the penumbra mode's answer.
    void CubePenumbra(const ShadingPoint& sp, Word neededMask, std::vector<PenumbraNode>& nodes, Accumulator& acc,
                      RenderCounters& counters) const {
        counters.candidates += nodes.size();
        bool agree = true;
        for (const PenumbraNode& c : nodes) agree &= ((c.w ^ nodes.front().w) & neededMask) == 0;
        if (!agree) {
            Blockers blockers;  // no cell summary here: every segment goes to the back-end
            blockers.tried = true;
            PenumbraInterpolate(sp, neededMask, nodes, 0, false, nullptr, blockers, acc, counters);
            return;
        }
        for (const PenumbraNode& c : nodes)
            if (SeesPoint(c.x, sp, counters)) {
                Use(acc, c.w);
                return;
            }
    }

    // Templates (§3.1): snap P to the nearest sub-position of its cell and walk that
    // sub-position's list; no distance tests. Returns false (and does nothing) when the
    // template would reach outside the lattice, which only happens for points on or
    // outside the far faces of the scene's box; the cube loop takes those.
    //
    // With cell summaries (ours), a point whose cell's nodes all agree is answered without
    // the walk: *uniform gets those bits with kInit set (the caller averages nothing).
    bool TemplateWalk(const ShadingPoint& sp, Word neededMask, Accumulator& acc, RenderCounters& counters,
                      Word* uniform) const {
        const LightMeshLattice& L = lattice_;
        const Vec3 q = (sp.p - L.origin) * invH_;
        const int ci = static_cast<int>(std::floor(q.x)), cj = static_cast<int>(std::floor(q.y)),
                  ck = static_cast<int>(std::floor(q.z));
        if (ci + minOffset_ < 0 || cj + minOffset_ < 0 || ck + minOffset_ < 0 || ci + maxOffset_ >= L.nx ||
            cj + maxOffset_ >= L.ny || ck + maxOffset_ >= L.nz)
            return false;
        const Vec3 frac = q - Vec3(static_cast<float>(ci), static_cast<float>(cj), static_cast<float>(ck));
        const int ns = templates_.templates.ns;
        // Nearest sub-step, halves up (f >= 0 here, so the truncation is a floor).
        auto snap = [ns](float f) { return std::clamp(static_cast<int>(f * static_cast<float>(ns) + 0.5f), 0, ns); };
        const int s = templates_.templates.SubPosition(snap(frac.x), snap(frac.y), snap(frac.z));
        const int64_t base = static_cast<int64_t>(L.Index(ci, cj, ck));
        // (n(P), x - P) with x - P = (offset - frac)·h, over the tolerance of frontEps_.
        // (offset - frac)·n = offset·n - frac·n: the second term once per point.
        const float nfrac = Dot(sp.n, frac);
        auto node = [&](const FrontBlock& b, int k) { return EntryNode(ci, cj, ck, b, k); };
        // The front test of all of s's entries at once, a bit mask per block of eight.
        const uint32_t fb = frontBegin_[s], fi = frontInner_[s], fe = frontBegin_[s + 1];
        uint8_t maskBuffer[256];
        std::vector<uint8_t> maskHeap;
        uint8_t* masks = maskBuffer;
        if (fe - fb > sizeof(maskBuffer)) {
            maskHeap.resize(fe - fb);
            masks = maskHeap.data();
        }
        frontMasks_(frontBlocks_.data() + fb, fe - fb, sp.n, nfrac, frontEps_, masks);
        const FrontRun all{frontBlocks_.data() + fb, masks, fe - fb};
        const FrontRun boundary{frontBlocks_.data() + fb, masks, fi - fb};
        const FrontRun inner{frontBlocks_.data() + fi, masks + (fi - fb), fe - fi};

        bool planar = false;
        Blockers blockers;
        CellSummary scratch;
        const CellSummary* summary = nullptr;
        if (summaries_) {
            SummaryBrick* brick = nullptr;
            int slot = 0;
            const CellSummary& c = Summary(ci, cj, ck, &scratch, &brick, &slot);
            summary = &c;
            int side = -1;
            bool onPlane = false;
            if (c.flags & kHasPlane) {
                // Is P on Π? Its point within planeDelta_ (twice, for the rounding of this
                // test), its normal within kPlaneEps.
                const double hp = double(c.n[0]) * sp.p.x + double(c.n[1]) * sp.p.y + double(c.n[2]) * sp.p.z - c.d;
                const Vec3 np(c.n[0], c.n[1], c.n[2]);
                if (std::abs(hp) <= 2 * planeDelta_ && LengthSquared(Cross(sp.n, np)) <= kPlaneEps * kPlaneEps)
                    side = Dot(sp.n, np) > 0 ? 0 : 1;
                onPlane = std::abs(hp) <= 2 * c.delta;
            }
            if (side >= 0) {
                // The planar argument needs P on Π and its own origin clearly off it by the
                // cell's tolerance (the uniform one only needs the nodes' side of Π).
                planar = onPlane && (c.flags & (side == 0 ? kClear0 : kClear1)) &&
                         Dot(sp.origin - sp.p, sp.n) > 4 * c.delta;
                if (planar) ++counters.planarCellPoints;
            }
            const SideSummary sideSummary = side >= 0 ? Side(c, brick, slot, side, ci, cj, ck) : SideSummary{};
            if (side >= 0 && (neededMask & ~sideSummary.uniform) == 0) {
                const Word w = sideSummary.bits;
                // Every light needed is uniform: the answer is w's bits if at least one
                // candidate survives the variant's test, else the fallback (m = 0), exactly
                // as the walk would find.
                bool some = false;
                if (variant_.local == LocalVisibility::Inside) {
                    some = all.Any([&](const FrontBlock& b, int k) {
                        return !(Evaluate(static_cast<uint64_t>(base + b.linear[k])) & kInside);
                    });
                } else if (variant_.local != LocalVisibility::Consensus || planar) {
                    some = all.Any([](const FrontBlock&, int) { return true; });
                } else {
                    some = PatchWitness(c, base, ci, cj, ck, sp, all, counters) != nullptr;
                    // Else usually the first candidate sees P: one ray is cheaper than
                    // finding the blockers, which pay only when more segments follow.
                    int tested = 0;
                    if (!some)
                        some = all.Any([&](const FrontBlock& b, int k) {
                            ++counters.candidates;
                            if (tested++ == 1) FindBlockers(c, base, sp, &blockers);
                            return SeesPointCulled(node(b, k), sp, blockers, counters);
                        });
                }
                if (some) *uniform = (w & kVisMask) | kInit;
                return true;  // with !some, m = 0: the caller falls back to shadow rays
            }
        }

        if (variant_.local == LocalVisibility::Consensus) {
            ConsensusWalk(sp, neededMask, all, base, ci, cj, ck, planar, summary, blockers, acc, counters);
            return true;
        }
        if (variant_.local == LocalVisibility::None) {
            UseAll(all, base, acc);  // Нет: every node in front
            counters.candidates += acc.m;
            return true;
        }
        if (variant_.local != LocalVisibility::Reduced) {
            all.ForEach([&](const FrontBlock& b, int k) {
                Candidate(node(b, k), static_cast<uint64_t>(base + b.linear[k]), sp, acc, counters);
            });
            return true;
        }
        // У (§3.2): test the boundary nodes first; if all of them see P, take the inner
        // nodes without testing them, otherwise test the inner nodes too.
        bool allSee = true;
        boundary.ForEach([&](const FrontBlock& b, int k) {
            ++counters.candidates;
            if (SeesPoint(node(b, k), sp, counters)) Use(acc, Evaluate(static_cast<uint64_t>(base + b.linear[k])));
            else allSee = false;
        });
        inner.ForEach([&](const FrontBlock& b, int k) {
            ++counters.candidates;
            if (allSee || SeesPoint(node(b, k), sp, counters)) Use(acc, Evaluate(static_cast<uint64_t>(base + b.linear[k])));
        });
        return true;
    }

    // The position of lane k of block b for a point of cell (ci, cj, ck).
    Vec3 EntryNode(int ci, int cj, int ck, const FrontBlock& b, int k) const {
        return lattice_.Node(ci + static_cast<int>(b.ox[k]), cj + static_cast<int>(b.oy[k]), ck + static_cast<int>(b.oz[k]));
    }

    // Use() for every entry of the run in front of P: Нет's whole walk, and consensus's in
    // a planar cell. The counts live in registers (one byte per light, flushed before 255)
    // instead of in *acc, which the lazy evaluation's call might change for all the
    // compiler knows.
    void UseAll(const FrontRun& run, int64_t base, Accumulator& acc) const {
        auto word = [&](int32_t linear) { return Evaluate(static_cast<uint64_t>(base + linear)); };
        if constexpr (sizeof(Word) == 1) {
            if (sumFront_ &&
                sumFront_(run.blocks, run.masks, run.count, reinterpret_cast<const uint8_t*>(nodes_.get() + base),
                          static_cast<int>(scene_.lights.size()), acc.visible, &acc.m))
                return;
            uint64_t lanes = 0;
            uint32_t m = 0, pending = 0;
            auto flush = [&] {
                for (int l = 0; l < 8; ++l) acc.visible[l] += static_cast<uint32_t>((lanes >> (8 * l)) & 0xFF);
                lanes = 0;
                pending = 0;
            };
            for (uint32_t b = 0; b < run.count; ++b)
                for (unsigned mask = run.masks[b]; mask; mask &= mask - 1) {
                    lanes += kSpread[word(run.blocks[b].linear[__builtin_ctz(mask)])];
                    ++m;
                    if (++pending == 255) flush();
                }
            flush();
            acc.m += m;
        } else {
            run.ForEach([&](const FrontBlock& b, int k) { Use(acc, word(b.linear[k])); });
        }
    }

    // Consensus (ours, exact): ОТ keeps the candidates that see P and averages their bits.
    // If every candidate carries the same bits, the average over any non-empty subset is
    // those bits, so it is enough to find one candidate that sees P; only if none does
    // (m = 0) does the result change to the fallback, exactly as with ОТ. Where the
    // candidates disagree (penumbrae, edges of objects) MinorityFirst decides as few
    // segments as ОТ's average allows. The image is identical to ОТ's; only the mean m in
    // --stats differs.
    //
    // In a planar cell (cell summaries) no segment is traced at all: every candidate sees P.
    void ConsensusWalk(const ShadingPoint& sp, Word neededMask, const FrontRun& all, int64_t base, int ci, int cj,
                       int ck, bool planar, const CellSummary* summary, Blockers& blockers,
                       Accumulator& acc, RenderCounters& counters) const {
        if (planar && lightRadius_ == 0) {
            UseAll(all, base, acc);
            counters.candidates += acc.m;
            return;
        }
        // Pass 1: evaluate the candidates and count, per light, those that see it (Нет's
        // sums): they agree on the needed lights when every count is 0 or all of them.
        // (Only the lights the renderer needs matter: the others light P from behind.)
        Accumulator counts(scene_.lights.size());
        UseAll(all, base, counts);
        if constexpr (sizeof(Word) == 1) counts.Flush();
        const uint32_t n = counts.m;
        Word majority = 0;  // per light, the bit most candidates carry (MinorityFirst)
        bool agree = true;
        for (size_t l = 0; l < scene_.lights.size(); ++l) {
            if (!((neededMask >> l) & 1)) continue;
            agree &= counts.visible[l] == 0 || counts.visible[l] == n;
            if (2 * counts.visible[l] > n) majority |= Word(1) << l;
        }
        counters.candidates += n;
        if (lightRadius_ > 0) {
            if (!agree) {
                thread_local std::vector<PenumbraNode> nodes;
                nodes.clear();
                all.ForEach([&](const FrontBlock& b, int k) {
                    const uint64_t index = static_cast<uint64_t>(base + b.linear[k]);
                    const Vec3 x = EntryNode(ci, cj, ck, b, k);
                    nodes.push_back({x, LengthSquared(x - sp.p), index, Evaluate(index)});  // evaluated by pass 1
                });
                PenumbraInterpolate(sp, neededMask, nodes, base, planar, summary, blockers, acc, counters);
                return;
            }
            if (planar) {
                UseAll(all, base, acc);
                return;
            }
        }
        if (!agree) {
            MinorityFirst(sp, neededMask, majority, all, base, ci, cj, ck, summary, blockers, acc, counters);
            return;
        }
        // Pass 2: the first candidate that sees P settles it: one that sees the whole cell
        // patch, else, in the template's order, by segments. The blockers (cell summaries)
        // pay when several segments are to be decided; for the first one a ray is cheaper.
        if (summary) {
            int lane = 0;
            if (const FrontBlock* b = PatchWitness(*summary, base, ci, cj, ck, sp, all, counters, &lane)) {
                Use(acc, Evaluate(static_cast<uint64_t>(base + b->linear[lane])));  // evaluated by pass 1
                return;
            }
        }
        uint32_t c = 0;
        all.Any([&](const FrontBlock& b, int k) {
            if (summary && !blockers.tried && c == 1) FindBlockers(*summary, base, sp, &blockers);
            ++c;
            if (!SeesPointCulled(EntryNode(ci, cj, ck, b, k), sp, blockers, counters)) return false;
            Use(acc, Evaluate(static_cast<uint64_t>(base + b.linear[k])));  // evaluated by pass 1
            return true;
        });
    }

    // Consensus where the candidates disagree (ours, exact): ОТ averages the words of the
    // candidates that see P (the set S). Take the majority word W (per light, the bit most
    // candidates carry on the needed lights) and call the candidates with another word on
    // the needed lights the minority. The minority's segments are decided first. If none
    // of the minority sees P, S holds W-nodes only, so ОТ's average is W's bits: one
    // W-node that sees P settles it, as when all candidates agree (and if none does, m = 0
    // and the fallback follows, as for ОТ). Only if a minority node sees P are the other
    // segments decided too. Measured (1024×768, kI 2): the minority is all blocked at 16 %
    // (castle), 16 % (gazebo) and 36 % (garden) of the disagreeing points — nodes inside
    // walls, trunks and the ground next to an object, where the sphere's open-air nodes
    // agree — and their segments drop from every candidate's to the minority's + 1.
    // (W only orders the segments: any word gives ОТ's image.)
    void MinorityFirst(const ShadingPoint& sp, Word neededMask, Word majority, const FrontRun& all, int64_t base,
                       int ci, int cj, int ck, const CellSummary* summary, Blockers& blockers, Accumulator& acc,
                       RenderCounters& counters) const {
        FrontList* patch = summary ? Patch(*summary, base, ci, cj, ck, sp) : nullptr;
        auto sees = [&](const FrontBlock& b, int k) {
            const Vec3 x = EntryNode(ci, cj, ck, b, k);
            if (patch && PatchSees(*patch, b, k, x)) {
                ++counters.patchSegments;
                return true;
            }
            if (summary && !blockers.tried) FindBlockers(*summary, base, sp, &blockers);
            return SeesPointCulled(x, sp, blockers, counters);
        };
        bool minoritySeen = false;
        all.ForEach([&](const FrontBlock& b, int k) {
            const Word w = Evaluate(static_cast<uint64_t>(base + b.linear[k]));  // evaluated by pass 1
            if ((w & neededMask) != majority && sees(b, k)) {
                Use(acc, w);
                minoritySeen = true;
            }
        });
        all.Any([&](const FrontBlock& b, int k) {
            const Word w = Evaluate(static_cast<uint64_t>(base + b.linear[k]));
            if ((w & neededMask) != majority || !sees(b, k)) return false;
            Use(acc, w);
            return !minoritySeen;  // with no minority node in S, one W-node settles it
        });
    }

    // ---- Contact-hardening penumbrae (ours, beyond the paper) -------------------------
    //
    // A sphere light of radius R seen past an occluder edge gives a penumbra whose
    // half-width, measured across the shadow's boundary, is w = R·(d_P − d_b)/d_b (d_P,
    // d_b: the distances from the light to P and to the blocker; similar triangles). The
    // visible fraction across it is the share of the light's disc left uncovered. The
    // paper's formula (2) averages the nodes' hard visibility over a ball of fixed radius
    // r: a penumbra of half-width r everywhere. Here, at a point whose candidates disagree
    // on light l (the only points that can be in a penumbra of that light within r):
    //  1. d_b is the mean of the blocked candidates' blocker distances, which their
    //     evaluation stored (no new rays), and w follows;
    //  2. the nodes are weighted by an Epanechnikov kernel k = 1 − |x − P|²/ρ² of support
    //     ρ = kSupportPerWidth·w (at most r): its profile across a plane, the share of the
    //     kernel on one side, rises from 25 % to 75 % over 0.562·ρ, and the disc's over
    //     0.808·w, so the blur spans the true penumbra;
    //  3. P's own shadow ray (the hard answer, the centre of the penumbra) joins with
    //     weight 1;
    //  4. where ρ is below what the lattice resolves (contact, thin gaps: ρ < 1.5·h) the
    //     nodes only say whether a shadow edge is near; if it is, a few rays to the light's
    //     disc decide, else P's own ray (NarrowPenumbra).
    // Local visibility stays ОТ's: every node that gets a weight passes its segment test
    // (leak-free as the default); only nodes within the largest ρ are tested. Lights the
    // candidates agree on keep consensus's answer. The blocker estimate reads every
    // candidate, also ones a segment test would drop: it only sets the width.
    static constexpr float kSupportPerWidth = 1.438f;  // 0.808 / 0.562
    // Narrow penumbrae (ρ < kNarrow·h: a kernel on so few nodes would be the lattice's
    // shape, not the penumbra's): the light itself is sampled, 2·kNarrowPerRing rays to its
    // disc on two rings (DiscLightVisibility: the outer ring first, the inner one only if
    // those disagree). These points lie where the candidates disagree only, a band of
    // about 2r along each shadow edge. Chosen by measurement (gazebo and castle, 1024×768,
    // against the 256-sample reference): the two rings gave 45.4 and 53.8 dB where a
    // Vogel spiral of 8 traced 4 + 4 gave 43.8 and 51.0 and traced whole 45.3 and 53.4
    // for 15 % more time; a first round of 2 lost 3-4 dB more.
    static constexpr float kNarrow = 1.5f;
    static constexpr int kNarrowPerRing = 4;
    // Before sampling, the lattice's own answer where it is likely right: if every
    // candidate within ρ + kDetect·h of P has the same bit for the light and P's own shadow
    // ray agrees, no shadow edge of that light is taken to pass within the penumbra's reach
    // of P, so V is that bit. (A ball of radius √3/2·h always holds a node; 1.5·h leaves
    // room for the half of it behind the surface.) Measured: the castle 18 % and the garden
    // 13 % less time for −0.04 dB; kDetect = 1 lost 0.5 dB, and trusting the nodes without
    // P's ray 2-4.5 dB.
    static constexpr float kDetect = 1.5f;
    // Whether light sampling (not the nodes' kernel) answers a penumbra of support ρ.
    bool Sampled(float rho2) const { return !(rho2 >= kNarrow * kNarrow * lattice_.h * lattice_.h); }
    // V of light l at a point whose penumbra (support rho) is too narrow for the kernel:
    // the lattice's answer checked by P's own ray where the nodes near P agree (kDetect),
    // else the light sampled.
    float NarrowPenumbra(const ShadingPoint& sp, size_t l, float rho, const std::vector<PenumbraNode>& nodes,
                         RenderCounters& counters) const {
        const Vec3& light = scene_.lights[l].position;
        const float reach = rho + kDetect * lattice_.h, reach2 = reach * reach;
        const Word bit = Word(1) << l;
        int near = 0;
        Word first = 0;
        bool same = true;
        for (const PenumbraNode& c : nodes) {
            if (!(c.d2 < reach2)) continue;
            if (near++ == 0) first = c.w & bit;
            else if ((c.w & bit) != first) same = false;
        }
        if (near > 0 && same) {
            ++counters.shadowRays;
            const bool centre = LightVisible(accel_, sp.origin, light);
            if (centre == (first != 0)) return centre ? 1.0f : 0.0f;
        }
        ++counters.penumbraSampled;
        int rays = 0;
        const float v =
            DiscLightVisibility(accel_, sp.origin, light, lightRadius_, kNarrowPerRing, AreaLightSeed(sp, static_cast<uint32_t>(l)), &rays);
        counters.shadowRays += static_cast<uint64_t>(rays);
        return v;
    }
    // `nodes`: the candidates, in the walk's order. `summary` (may be null) and `base` give
    // the segment culling's blockers; `planar`: no segment can be blocked.
    void PenumbraInterpolate(const ShadingPoint& sp, Word neededMask, const std::vector<PenumbraNode>& nodes,
                             int64_t base, bool planar, const CellSummary* summary, Blockers& blockers,
                             Accumulator& acc, RenderCounters& counters) const {
        const size_t nLights = scene_.lights.size();
        thread_local std::vector<uint8_t> kept;
        const size_t n = nodes.size();
        // Per light: uniform over the candidates, or a penumbra with support radius ρ_l.
        float rho2[64];
        Word mixed = 0;
        float rhoMax2 = 0;
        // The lights the candidates disagree on, from their words alone.
        Word someSee = 0, allSee = kVisMask;
        for (const PenumbraNode& c : nodes) {
            someSee |= c.w;
            allSee &= c.w;
        }
        const Word disagree = (someSee & ~allSee) & neededMask;
        for (size_t l = 0; l < nLights; ++l) {
            if (!((disagree >> l) & 1)) continue;
            const Vec3& light = scene_.lights[l].position;
            uint32_t blocked = 0;
            double sum = 0;
            for (const PenumbraNode& c : nodes) {
                if ((c.w >> l) & 1) continue;
                ++blocked;
                const float t = BlockerParameter(c.index, l);
                sum += (1.0 - t) * Length(light - c.x);
            }
            const double db = sum / blocked, dp = Length(light - sp.p);
            const double width = db > 0 ? lightRadius_ * std::max(dp - db, 0.0) / db : lattice_.r;
            const float rho = static_cast<float>(std::min<double>(kSupportPerWidth * width, lattice_.r));
            rho2[l] = rho * rho;
            mixed |= Word(1) << l;
            // Only the kernel's nodes need segments; a narrow penumbra samples the light.
            if (!Sampled(rho2[l])) rhoMax2 = std::max(rhoMax2, rho2[l]);
        }
        // The segments: every node that gets a weight, then, for the lights the candidates
        // agree on, until one node sees P (consensus's rule).
        kept.assign(n, 0);
        uint32_t keptCount = 0;
        auto test = [&](size_t i) {
            if (!planar) {
                if (summary && !blockers.tried) FindBlockers(*summary, base, sp, &blockers);
                if (!SeesPointCulled(nodes[i].x, sp, blockers, counters)) return;
            }
            kept[i] = 1;
            ++keptCount;
        };
        for (size_t i = 0; i < n; ++i)
            if (nodes[i].d2 < rhoMax2) test(i);
        int firstKept = -1;
        for (size_t i = 0; i < n && firstKept < 0; ++i) {
            if (!kept[i] && nodes[i].d2 >= rhoMax2 && (neededMask & ~mixed)) test(i);
            if (kept[i]) firstKept = static_cast<int>(i);
        }
        for (size_t l = 0; l < nLights; ++l) {
            if (!((neededMask >> l) & 1)) continue;
            const Vec3& light = scene_.lights[l].position;
            if (!((mixed >> l) & 1)) {
                // Every candidate has the same bit: any node that sees P gives it.
                if (firstKept >= 0) {
                    acc.vis[l] = static_cast<float>((nodes[firstKept].w >> l) & 1);
                } else {
                    ++counters.shadowRays;
                    acc.vis[l] = LightVisible(accel_, sp.origin, light) ? 1.0f : 0.0f;
                }
                continue;
            }
            ++counters.penumbraLights;
            if (Sampled(rho2[l])) {
                acc.vis[l] = NarrowPenumbra(sp, l, std::sqrt(rho2[l]), nodes, counters);
                continue;
            }
            ++counters.penumbraKernel;
            ++counters.shadowRays;
            float sum = LightVisible(accel_, sp.origin, light) ? 1.0f : 0.0f, weight = 1.0f;
            if (rho2[l] > 0) {
                const float inv = 1.0f / rho2[l];
                for (size_t i = 0; i < n; ++i) {
                    if (!kept[i] || !(nodes[i].d2 < rho2[l])) continue;
                    const float k = 1.0f - nodes[i].d2 * inv;
                    weight += k;
                    if ((nodes[i].w >> l) & 1) sum += k;
                }
            }
            acc.vis[l] = sum / weight;
        }
        acc.weighted = true;
        acc.m = keptCount;
    }

    void ConvertTemplates() {
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
            ThrowError("light mesh %dx%dx%d: too many nodes for the templates' 32-bit offsets: lower --cc", lattice_.nx,
                       lattice_.ny, lattice_.nz);
        const int cubeSide = maxOffset_ - minOffset_ + 1;
        const uint64_t cubeNodes = static_cast<uint64_t>(cubeSide) * cubeSide * cubeSide;
        cubeWords_ = static_cast<uint32_t>(std::min<uint64_t>((cubeNodes + 63) / 64, kCubeWords));
        const bool cubeFits = cubeNodes <= 64 * kCubeWords;
        // An offset's place in the cube of all offsets, x fastest.
        auto cubeIndex = [&](const std::array<int8_t, 3>& o) {
            return static_cast<uint64_t>((o[0] - minOffset_) + cubeSide * ((o[1] - minOffset_) + cubeSide * (o[2] - minOffset_)));
        };
        auto cubeBit = [&](const std::array<int8_t, 3>& o) { return cubeFits ? static_cast<uint16_t>(cubeIndex(o)) : uint16_t(0); };
        auto pack = [&](uint32_t from, uint32_t to) {
            for (uint32_t first = from; first < to; first += 8) {
                FrontBlock b;
                for (uint32_t k = 0; k < 8; ++k) {
                    const float nan = std::numeric_limits<float>::quiet_NaN();
                    const bool real = first + k < to;
                    const std::array<int8_t, 3> o = real ? t.offsets[first + k] : std::array<int8_t, 3>{};
                    b.ox[k] = real ? o[0] : nan;
                    b.oy[k] = real ? o[1] : nan;
                    b.oz[k] = real ? o[2] : nan;
                    b.linear[k] = static_cast<int32_t>(linear(o[0], o[1], o[2]));
                    b.cube[k] = cubeBit(o);
                }
                frontBlocks_.push_back(b);
            }
        };
        size_t blocks = 0;
        for (size_t sp = 0; sp + 1 < t.begin.size(); ++sp)
            blocks += (t.boundaryCount[sp] + 7) / 8 + (t.begin[sp + 1] - t.begin[sp] - t.boundaryCount[sp] + 7) / 8;
        frontBlocks_.reserve(blocks);
        for (size_t sp = 0; sp + 1 < t.begin.size(); ++sp) {
            frontBegin_.push_back(static_cast<uint32_t>(frontBlocks_.size()));
            pack(t.begin[sp], t.begin[sp] + t.boundaryCount[sp]);
            frontInner_.push_back(static_cast<uint32_t>(frontBlocks_.size()));
            pack(t.begin[sp] + t.boundaryCount[sp], t.begin[sp + 1]);
        }
        frontBegin_.push_back(static_cast<uint32_t>(frontBlocks_.size()));
        // The union of all sub-positions' sets: every node a point of a cell may use, in
        // memory order (the cell summaries read them all): marked in the offsets' cube,
        // then read back z, y, x.
        std::vector<std::array<int8_t, 3>> all;
        std::vector<bool> present(cubeNodes);
        for (const auto& o : t.offsets) present[cubeIndex(o)] = true;
        for (int z = 0, e = 0; z < cubeSide; ++z)
            for (int y = 0; y < cubeSide; ++y)
                for (int x = 0; x < cubeSide; ++x, ++e)
                    if (present[e]) all.push_back({static_cast<int8_t>(x + minOffset_), static_cast<int8_t>(y + minOffset_),
                                                   static_cast<int8_t>(z + minOffset_)});
        for (const auto& o : all) cellNodes_.push_back(linear(o[0], o[1], o[2]));
        patchesFit_ = cubeFits;
        cellOffsets_ = std::move(all);
    }

    // The node's word, computing it on first use: one shadow ray to each light; for СТ
    // also the inside flag.
    // The node's position is only computed when the node is, so a use costs one load.
    Word Evaluate(uint64_t index) const {
        const Word w = nodes_[index].load(std::memory_order_acquire);
        if (w & kInit) [[likely]] return w;
        return EvaluateSlow(index);
    }
    [[gnu::noinline]] Word EvaluateSlow(uint64_t index) const {
        const Vec3 x = lattice_.NodeAt(index);
        const Word value = variant_.local == LocalVisibility::Inside ? EvaluateWithInside(x) : EvaluateVisibility(x, index);
        Word expected = 0;
        if (nodes_[index].compare_exchange_strong(expected, value, std::memory_order_acq_rel))
            evaluated_.fetch_add(1, std::memory_order_relaxed);
        return value;
    }

    Word EvaluateVisibility(const Vec3& x, uint64_t index) const {
        Word value = kInit;
        const size_t nLights = scene_.lights.size();
        if (lightRadius_ > 0) {
            // Penumbra mode: the same segment, but the nearest blocker's distance too, as
            // its parameter t along x → light in 16 bits (0: no blocker). The stores are
            // relaxed: they happen before the word's publication (release), and racing
            // threads store the same values.
            for (size_t l = 0; l < nLights; ++l) {
                const Vec3& light = scene_.lights[l].position;
                Hit hit;
                if (!accel_.Intersect(Ray{x, light - x, 0.0f, 1.0f - 1e-5f}, &hit)) {
                    value |= Word(1) << l;
                    continue;
                }
                const float q = std::clamp(std::round(hit.t * 65535.0f), 1.0f, 65535.0f);
                blockerT_[index * nLights + l].store(static_cast<uint16_t>(q), std::memory_order_relaxed);
            }
            return value;
        }
        for (size_t l = 0; l < nLights; ++l)
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

    static constexpr float kPlaneEps = 1e-5f;

    const Scene& scene_;
    const Accelerator& accel_;
    const LightMeshLattice lattice_;
    const LightMeshVariant variant_;
    const TemplateLoad templates_;
    int minOffset_ = 0, maxOffset_ = 0;
    float invH_ = 0;
    Bounds3 sceneBox_;
    float planeDelta_ = 0, frontEps_ = 0, reachMargin_ = 0, cullMargin_ = 0, pointReach_ = 0;
    // The plane margin of the segment culling and the patches' test for a tolerance delta:
    // cullMargin_ at the scene's (the triangles' grown boxes), a cell's at its own.
    static float CullMargin(float delta) { return 4 * delta; }
    // How far from a plane a point may lie and still count as on it, for coordinates up to
    // `magnitude`: a few float ulps (planeDelta_ at the lattice's, a cell's at its own).
    static float PlaneDelta(float magnitude) { return 2e-7f * magnitude; }
    // The templates again, as FrontBlocks: sub-position s's boundary entries are blocks
    // frontBegin_[s] … frontInner_[s] - 1, its inner entries frontInner_[s] … frontBegin_[s + 1] - 1,
    // each run in the template's order.
    std::vector<FrontBlock, HugePageAllocator<FrontBlock>> frontBlocks_;  // ~0.5 MiB at kI 2
    std::vector<uint32_t> frontBegin_, frontInner_;
    FrontFunction frontMasks_ = nullptr;
    CullFunction cull_ = nullptr;
    FindBlockersFunction findBlockers_ = nullptr;
    PatchSeesFunction patchSees_ = nullptr;
    // Cell patches: on for consensus with summaries when the neighbourhood cube of a cell
    // (the nodes any of its points may use) has at most kCubeWords·64 nodes.
    bool patches_ = false, patchesFit_ = false;
    uint32_t cubeWords_ = 0;
    SumFrontFunction sumFront_ = nullptr;  // for one-byte words
    static constexpr uint64_t kNodePadding = 8;  // words after the last node, for SumFrontBytesAvx2's loads
    const uint64_t serial_ = NextSerial();  // tells this mesh's thread-local caches from others'
    static uint64_t NextSerial() {
        static std::atomic<uint64_t> next{1};
        return next.fetch_add(1, std::memory_order_relaxed);
    }
    bool summaries_ = false;
    bool summariesOff_ = false;  // asked for, but the binning was over its budget
    uint64_t binPairs_ = 0;      // (triangle, brick) pairs the binning counted
    std::vector<int64_t> cellNodes_;  // linear offsets of the union of the templates
    std::vector<std::array<int8_t, 3>> cellOffsets_;  // the same nodes' offsets per axis
    ZeroedPtr<std::atomic<Word>> nodes_;
    // Penumbra mode (lightRadius_ > 0): per node and light, the nearest blocker's parameter
    // along the node's shadow segment, t·65535 (EvaluateVisibility); light l of node i at
    // i·lights + l.
    const float lightRadius_;
    ZeroedPtr<std::atomic<uint16_t>> blockerT_;
    static constexpr size_t kReachChunk = 1 << 18;
    mutable std::vector<std::unique_ptr<uint32_t[], FreeDeleter>> reachArena_;
    mutable size_t reachUsed_ = 0, reachBytes_ = 0;
    // Cell summaries: each triangle's plane (unit normal, offset) and bounding box (grown
    // by cullMargin_), for the binning, the reach lists and the segment culling.
    struct TrianglePlane {
        Vec3 n;
        float d;
        Vec3 lo, hi;
    };
    // (These two on huge pages: on the garden 18 and 15 MiB, filled at once.)
    std::vector<TrianglePlane, HugePageAllocator<TrianglePlane>> planes_;
    std::vector<uint64_t, HugePageAllocator<uint64_t>> brickStart_;  // CSR of the bricks' candidate triangles
    std::vector<uint32_t, HugePageAllocator<uint32_t>> brickTris_;
    uint64_t bricksX_ = 0, bricksY_ = 0;
    ZeroedPtr<std::atomic<SummaryBrick*>> bricks_;  // per brick of cells, allocated on first use
    mutable std::mutex brickMutex_;
    static constexpr size_t kBricksPerChunk = 512;  // 1.8 MiB
    mutable std::vector<std::unique_ptr<SummaryBrick, FreeDeleter>> brickChunks_;
    mutable size_t brickChunkUsed_ = 0;
    mutable std::atomic<uint64_t> bricksUsed_{0};
    mutable std::atomic<uint64_t> evaluated_{0}, summarized_{0}, uniformCells_{0}, planarCells_{0};
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
    if (!(options.lightRadius >= 0) || !std::isfinite(options.lightRadius))
        ThrowError("light mesh: the light radius must be finite and >= 0, got %g", options.lightRadius);
    if (options.lightRadius > 0 && variant.local != LocalVisibility::Consensus)
        ThrowError("light mesh: a light radius (contact-hardening penumbrae) needs the consensus variant (the "
                   "default), not %s",
                   variant.name.c_str());
    const int bytesPerNode = LightMeshStorageBytesPerNode(nLights, options.lightRadius);
    // Node words. (Cell summaries add a pointer per 4³ cells, zero pages until used, and
    // their records, about 32 bytes per cell used, lazily like the nodes.)
    const uint64_t need = lattice.NodeCount() * static_cast<uint64_t>(bytesPerNode);
    const uint64_t physical = PhysicalMemoryBytes();
    if (physical && need > physical / 2)
        ThrowError("light mesh %dx%dx%d (CC %d, kI %g) needs %s of node storage%s, more than half of "
                   "this machine's %s: lower --cc",
                   lattice.nx, lattice.ny, lattice.nz, options.cc, options.ki, FormatBytes(need).c_str(),
                   options.lightRadius > 0
                       ? StringPrintf(" (%d bytes per node with the blocker distances of the light radius)", bytesPerNode).c_str()
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
        templates = LoadOrBuildSphereTemplates(ns, options.ki, options.templateDir);
        if (!templates.note.empty()) LogWarning("templates: " + templates.note);
    }
    const std::string& summaries = options.cellSummaries;
    if (summaries != "auto" && summaries != "on" && summaries != "off")
        ThrowError("cell summaries \"%s\": choose auto, on or off", summaries.c_str());
    if (options.simdWidth != 0 && options.simdWidth != 1 && options.simdWidth != 4 && options.simdWidth != 8)
        ThrowError("light mesh: SIMD width %d: choose 0, 1, 4 or 8", options.simdWidth);
    switch (bytes) {
        case 1: return std::make_unique<LightMesh<uint8_t>>(scene, accel, lattice, variant, std::move(templates), options);
        case 2: return std::make_unique<LightMesh<uint16_t>>(scene, accel, lattice, variant, std::move(templates), options);
        case 4: return std::make_unique<LightMesh<uint32_t>>(scene, accel, lattice, variant, std::move(templates), options);
        default: return std::make_unique<LightMesh<uint64_t>>(scene, accel, lattice, variant, std::move(templates), options);
    }
}

}  // namespace lm
