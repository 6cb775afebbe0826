// light_mesh_penumbra.h -- contact-hardening penumbrae (ours, beyond the paper): the width from
// the blockers' distances and the kernel or the light's disc.
// Part of LightMesh<Word>'s definition (light_mesh_impl.h): included once, by light_mesh.cpp,
// whose anonymous namespace it shares.
#pragma once

#include "lightmesh/shadow/light_mesh_impl.h"

namespace lm {
namespace {

// V of light l at a point whose penumbra (support rho) is too narrow for the kernel:
// the lattice's answer checked by P's own ray where the nodes near P agree (kDetect),
// else the light sampled.
template <typename Word>
inline float LightMesh<Word>::NarrowPenumbra(const ShadingPoint& sp, size_t l, float rho,
                                             const std::vector<PenumbraNode>& nodes, RenderCounters& counters) const {
    const Vec3& light = lights_[l].position;
    const float reach = rho + kDetect * lattice_.h, reach2 = reach * reach;
    const Word bit = Word(1) << l;
    // Whether some node within reach sees the light, and whether some does not (without
    // a branch per node: about every other one mispredicted where they are mixed).
    Word seeing = 0, hidden = 0;
    for (const PenumbraNode& c : nodes) {
        const Word within = c.d2 < reach2 ? bit : Word(0);
        seeing |= c.w & within;
        hidden |= ~c.w & within;
    }
    if ((seeing != 0) != (hidden != 0)) {  // some node within reach, and they agree
        ++counters.shadowRays;
        const bool centre = LightVisible(accel_, sp.origin, light);
        if (centre == (seeing != 0)) return centre ? 1.0f : 0.0f;
    }
    ++Count(counters, LightMeshCount::kPenumbraSampled);
    if (DiscQueue* queue = ThreadDiscQueue()) {
        // Traced after the block's walks (TraceDiscs); the value here is replaced then.
        queue->entries.push_back({queue->point, l,
                                  DiscRings(sp.origin, light, lightRadius_, kNarrowPerRing,
                                            AreaLightSeed(sp, static_cast<uint32_t>(l)))});
        return 0.0f;
    }
    int rays = 0;
    const float v =
        DiscLightVisibility(accel_, sp.origin, light, lightRadius_, kNarrowPerRing, AreaLightSeed(sp, static_cast<uint32_t>(l)), &rays);
    counters.shadowRays += static_cast<uint64_t>(rays);
    return v;
}

// `nodes`: the candidates, in the walk's order. `summary` (may be null) and `base` give
// the segment culling's blockers; `planar`: no segment can be blocked.
template <typename Word>
inline void LightMesh<Word>::PenumbraInterpolate(const ShadingPoint& sp, Word neededMask,
                                                 const std::vector<PenumbraNode>& nodes, int64_t base, bool planar,
                                                 const CellSummary* summary, Blockers& blockers, Accumulator& acc,
                                                 RenderCounters& counters) const {
    const size_t nLights = lights_.size();
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
        const Vec3& light = lights_[l].position;
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
    // Which nodes passed their segment test: only the kernel reads it, and only consensus's
    // search below fills it otherwise (most points: every penumbra narrow, P's ray checking
    // the agreement, so no node is tested).
    const bool testsNodes = rhoMax2 > 0 || !OwnRayChecksAgreement();
    if (testsNodes) kept.assign(n, 0);
    uint32_t keptCount = 0;
    auto test = [&](size_t i) {
        if (!planar) {
            if (summary && !blockers.tried) FindBlockers(*summary, base, sp, &blockers);
            if (!SeesPointCulled(nodes[i].x, sp, blockers, counters)) return;
        }
        kept[i] = 1;
        ++keptCount;
    };
    if (rhoMax2 > 0)
        for (size_t i = 0; i < n; ++i)
            if (nodes[i].d2 < rhoMax2) test(i);
    int firstKept = -1;
    if (OwnRayChecksAgreement()) {
        firstKept = 0;  // any node's bit: P's own ray checks it (CheckThin)
    } else {
        for (size_t i = 0; i < n && firstKept < 0; ++i) {
            if (!kept[i] && nodes[i].d2 >= rhoMax2 && (neededMask & ~mixed)) test(i);
            if (kept[i]) firstKept = static_cast<int>(i);
        }
    }
    for (size_t l = 0; l < nLights; ++l) {
        if (!((neededMask >> l) & 1)) continue;
        const Vec3& light = lights_[l].position;
        if (!((mixed >> l) & 1)) {
            // Every candidate has the same bit: any node that sees P gives it.
            if (firstKept >= 0) {
                acc.vis[l] = static_cast<float>((nodes[firstKept].w >> l) & 1);
            } else {
                acc.ownRays |= uint64_t(1) << l;
                ++counters.shadowRays;
                acc.vis[l] = LightVisible(accel_, sp.origin, light) ? 1.0f : 0.0f;
            }
            continue;
        }
        ++Count(counters, LightMeshCount::kPenumbraLights);
        // The kernel has P's own ray at its centre; a narrow penumbra P's ray or the disc's.
        acc.ownRays |= uint64_t(1) << l;
        if (Sampled(rho2[l])) {
            acc.vis[l] = NarrowPenumbra(sp, l, std::sqrt(rho2[l]), nodes, counters);
            continue;
        }
        ++Count(counters, LightMeshCount::kPenumbraKernel);
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

}  // namespace
}  // namespace lm
