// light_mesh_walks.h -- the walks over a point's sphere (paper §3.1: the cube loop and the
// templates) and the variants' local-visibility rules (§3.2, §4; ours: consensus).
// Part of LightMesh<Word>'s definition (light_mesh_impl.h): included once, by light_mesh.cpp,
// whose anonymous namespace it shares.
#pragma once

#include "lightmesh/shadow/light_mesh_impl.h"

namespace lm {
namespace {

// A candidate that passed the sphere and surface tests, for the variants that decide
// node by node (all but У).
template <typename Word>
inline void LightMesh<Word>::Candidate(const Vec3& x, uint64_t index, const ShadingPoint& sp, Accumulator& acc,
                                       SegmentBatch& batch, RenderCounters& counters) const {
    ++Count(counters, LightMeshCount::kCandidates);
    switch (variant_.local) {
        case LocalVisibility::Object:
        case LocalVisibility::Reduced:    // only on the cube loop's fallback path: test all
        case LocalVisibility::Consensus:
            Queue(batch, x, index, sp, acc, counters);
            return;
        case LocalVisibility::Inside: {
            const Word w = Evaluate(index);
            if (!(w & kInside)) Use(acc, w);
            return;
        }
        default: break;
    }
    Use(acc, Evaluate(index));
}

// The paper's "Grid" enumeration (§3.1 pseudocode): the cube of nodes around the
// sphere, each tested against r. Also the fallback of the templates near the lattice's
// border, where a template would reach outside it.
template <typename Word>
inline void LightMesh<Word>::CubeWalk(const ShadingPoint& sp, Word neededMask, Accumulator& acc,
                                      RenderCounters& counters) const {
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
    SegmentBatch batch;
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
                Candidate(x, L.Index(i, j, k), sp, acc, batch, counters);
            }
    Flush(batch, acc, counters);
    if (lightRadius_ > 0) CubePenumbra(sp, neededMask, cubeNodes, acc, counters);
}

// The cube loop's candidates in penumbra mode (points whose template would still reach
// out of the lattice: only points outside the scene's box, since the lattice's extra far
// node and the near faces' lift give every point on the box a template): consensus's
// rule as in ConsensusWalk — where the candidates agree on the needed
// lights, the first that sees P gives its bits; else the penumbra mode's answer.
template <typename Word>
inline void LightMesh<Word>::CubePenumbra(const ShadingPoint& sp, Word neededMask, std::vector<PenumbraNode>& nodes,
                                          Accumulator& acc, RenderCounters& counters) const {
    Count(counters, LightMeshCount::kCandidates) += nodes.size();
    bool agree = true;
    for (const PenumbraNode& c : nodes) agree &= ((c.w ^ nodes.front().w) & neededMask) == 0;
    if (!agree) {
        Blockers blockers;  // no cell summary here: every segment goes to the back-end
        blockers.tried = true;
        PenumbraInterpolate(sp, neededMask, nodes, 0, false, nullptr, blockers, acc, counters);
        return;
    }
    if (OwnRayChecksAgreement() && !nodes.empty()) {
        Use(acc, nodes.front().w);
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
// template would reach outside the lattice, which only happens for points outside the
// scene's box (points on its faces have room: see LightMeshLattice and the lift below);
// the cube loop takes those.
//
// With cell summaries (ours), a point whose cell's nodes all agree is answered without
// the walk: *uniform gets those bits with kInit set (the caller averages nothing).
template <typename Word>
inline bool LightMesh<Word>::TemplateWalk(const ShadingPoint& sp, Word neededMask, Accumulator& acc,
                                          RenderCounters& counters, Word* uniform) const {
    const LightMeshLattice& L = lattice_;
    const Vec3 q = (sp.p - L.origin) * invH_;
    // P lies in the scene's box, so q within the lattice's range (as for the cast before).
    int ci = FloorToInt(q.x), cj = FloorToInt(q.y), ck = FloorToInt(q.z);
    Vec3 frac = q - Vec3(static_cast<float>(ci), static_cast<float>(cj), static_cast<float>(ck));
    const int ns = templates_.templates.ns;
    // Nearest sub-step, halves up (f >= 0 here, so the truncation is a floor).
    auto snap = [ns](float f) { return std::clamp(static_cast<int>(f * static_cast<float>(ns) + 0.5f), 0, ns); };
    int sx = snap(frac.x), sy = snap(frac.y), sz = snap(frac.z);
    // A point on a near face of the scene's box lies on lattice plane ceil(kI), but its
    // coordinate may round a hair below it, into the cell under it, whose template would
    // reach one node below the lattice. Its sub-step there is the last one, the very spot
    // of the first sub-step of the cell above (the same nodes): take that cell. (Without
    // this, a floor at the box's lowest point took the cube loop wherever its coordinate
    // rounded down: a third of a scaled room's points.)
    auto lift = [&](int& c, int& sub, float& f) {
        if (c + minOffset_ < 0 && sub == ns) ++c, sub = 0, f -= 1.0f;
    };
    lift(ci, sx, frac.x);
    lift(cj, sy, frac.y);
    lift(ck, sz, frac.z);
    if (ci + minOffset_ < 0 || cj + minOffset_ < 0 || ck + minOffset_ < 0 || ci + maxOffset_ >= L.nx ||
        cj + maxOffset_ >= L.ny || ck + maxOffset_ >= L.nz)
        return false;
    const int s = templates_.templates.SubPosition(sx, sy, sz);
    const int64_t base = static_cast<int64_t>(L.Index(ci, cj, ck));
    // (n(P), x - P) with x - P = (offset - frac)·h, over the tolerance of frontEps_.
    // (offset - frac)·n = offset·n - frac·n: the second term once per point.
    const float nfrac = Dot(sp.n, frac);
    auto node = [&](const FrontBlock& b, int k) { return EntryNode(ci, cj, ck, b, k); };
    // The front test of all of s's entries at once, a bit mask per block of eight (after
    // the cell summary: a uniform planar point only needs one entry in front).
    const FrontRuns& runs = frontRuns_[s];
    const uint32_t fb = runs.begin, fi = runs.inner, fe = runs.end;
    Scratch<uint8_t, 256> maskScratch(fe - fb);
    uint8_t* masks = maskScratch.data();
    const FrontRun all{frontBlocks_.data() + fb, masks, fe - fb};
    const FrontRun boundary{frontBlocks_.data() + fb, masks, fi - fb};
    const FrontRun inner{frontBlocks_.data() + fi, masks + (fi - fb), fe - fi};
    auto frontTest = [&] { frontMasks_(frontBlocks_.data() + fb, fe - fb, sp.n, nfrac, frontEps_, masks); };

    bool planar = false;
    Blockers blockers;
    CellSummary scratch;
    const CellSummary* summary = nullptr;
    if (summaries_ && SummaryPays(sp)) {
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
            if (planar) ++Count(counters, LightMeshCount::kPlanarCellPoints);
        }
        const SideSummary sideSummary = side >= 0 ? Side(c, brick, slot, side, ci, cj, ck) : SideSummary{};
        if (side >= 0 && (neededMask & ~sideSummary.uniform) == 0) {
            const Word w = sideSummary.bits;
            // Every light needed is uniform: the answer is w's bits if at least one
            // candidate survives the variant's test, else the fallback (m = 0), exactly
            // as the walk would find.
            bool some = false;
            if (variant_.local != LocalVisibility::Inside &&
                (variant_.local != LocalVisibility::Consensus || planar || OwnRayChecksAgreement())) {
                // Any entry in front: the blocks one at a time, stopping at the first with
                // one (on the gazebo the full test was 5 % of the light mesh, and more than
                // half of its points end here).
                for (uint32_t b = fb; b < fe && !some; ++b) {
                    uint8_t mask = 0;
                    frontMasks_(frontBlocks_.data() + b, 1, sp.n, nfrac, frontEps_, &mask);
                    some = mask != 0;
                }
                if (some) *uniform = (w & kVisMask) | kInit;
                return true;  // with !some, m = 0: the caller falls back to shadow rays
            }
            frontTest();
            if (variant_.local == LocalVisibility::Inside) {
                some = all.Any([&](const FrontBlock& b, int k) {
                    return !(Evaluate(static_cast<uint64_t>(base + b.linear[k])) & kInside);
                });
            } else {
                some = PatchWitness(c, base, ci, cj, ck, sp, all, counters) != nullptr;
                // Else usually the first candidate sees P: one ray is cheaper than
                // finding the blockers, which pay only when more segments follow.
                int tested = 0;
                if (!some)
                    some = all.Any([&](const FrontBlock& b, int k) {
                        ++Count(counters, LightMeshCount::kCandidates);
                        if (tested++ == 1) FindBlockers(c, base, sp, &blockers);
                        return SeesPointCulled(node(b, k), sp, blockers, counters);
                    });
            }
            if (some) *uniform = (w & kVisMask) | kInit;
            return true;  // with !some, m = 0: the caller falls back to shadow rays
        }
    }

    frontTest();
    if (variant_.local == LocalVisibility::Consensus) {
        ConsensusWalk(sp, neededMask, all, base, ci, cj, ck, planar, summary, blockers, acc, counters);
        return true;
    }
    if (variant_.local == LocalVisibility::None) {
        UseAll(all, base, acc);  // Нет: every node in front
        Count(counters, LightMeshCount::kCandidates) += acc.m;
        return true;
    }
    SegmentBatch batch;
    if (variant_.local != LocalVisibility::Reduced) {
        all.ForEach([&](const FrontBlock& b, int k) {
            Candidate(node(b, k), static_cast<uint64_t>(base + b.linear[k]), sp, acc, batch, counters);
        });
        Flush(batch, acc, counters);
        return true;
    }
    // У (§3.2): test the boundary nodes first; if all of them see P, take the inner
    // nodes without testing them, otherwise test the inner nodes too.
    size_t boundaryCount = 0;
    boundary.ForEach([&](const FrontBlock& b, int k) {
        ++Count(counters, LightMeshCount::kCandidates);
        ++boundaryCount;
        Queue(batch, node(b, k), static_cast<uint64_t>(base + b.linear[k]), sp, acc, counters);
    });
    Flush(batch, acc, counters);
    const bool allSee = batch.seen == boundaryCount;
    inner.ForEach([&](const FrontBlock& b, int k) {
        ++Count(counters, LightMeshCount::kCandidates);
        const uint64_t index = static_cast<uint64_t>(base + b.linear[k]);
        if (allSee) Use(acc, Evaluate(index));
        else Queue(batch, node(b, k), index, sp, acc, counters);
    });
    Flush(batch, acc, counters);
    return true;
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
template <typename Word>
inline void LightMesh<Word>::ConsensusWalk(const ShadingPoint& sp, Word neededMask, const FrontRun& all, int64_t base,
                                           int ci, int cj, int ck, bool planar, const CellSummary* summary,
                                           Blockers& blockers, Accumulator& acc, RenderCounters& counters) const {
    if (planar && lightRadius_ == 0) {
        UseAll(all, base, acc);
        Count(counters, LightMeshCount::kCandidates) += acc.m;
        return;
    }
    // Pass 1: evaluate the candidates and count, per light, those that see it (Нет's
    // sums): they agree on the needed lights when every count is 0 or all of them.
    // (Only the lights the renderer needs matter: the others light P from behind.)
    Accumulator counts(lights_.size());
    UseAll(all, base, counts);
    counts.Flush();
    const uint32_t n = counts.m;
    Word majority = 0;  // per light, the bit most candidates carry (MinorityFirst)
    bool agree = true;
    for (size_t l = 0; l < lights_.size(); ++l) {
        if (!((neededMask >> l) & 1)) continue;
        agree &= counts.visible[l] == 0 || counts.visible[l] == n;
        if (2 * counts.visible[l] > n) majority |= Word(1) << l;
    }
    Count(counters, LightMeshCount::kCandidates) += n;
    if (lightRadius_ > 0) {
        if (!agree) {
            // The candidates' positions and squared distances to P from tables per offset
            // and axis: the floats EntryNode and LengthSquared give (Node is per axis, and
            // Dot adds x², y², z² in this order), in a third of the operations (a point's
            // candidates share cubeSide_ offsets per axis).
            float coord[3][kMaxCubeSide], square[3][kMaxCubeSide];
            for (int o = 0; o < cubeSide_; ++o) {
                const Vec3 x = lattice_.Node(ci + minOffset_ + o, cj + minOffset_ + o, ck + minOffset_ + o);
                const Vec3 d = x - sp.p;
                coord[0][o] = x.x, coord[1][o] = x.y, coord[2][o] = x.z;
                square[0][o] = d.x * d.x, square[1][o] = d.y * d.y, square[2][o] = d.z * d.z;
            }
            thread_local std::vector<PenumbraNode> nodes;
            nodes.clear();
            all.ForEach([&](const FrontBlock& b, int k) {
                const uint64_t index = static_cast<uint64_t>(base + b.linear[k]);
                const int ox = b.ox[k] - minOffset_, oy = b.oy[k] - minOffset_, oz = b.oz[k] - minOffset_;
                nodes.push_back({Vec3(coord[0][ox], coord[1][oy], coord[2][oz]),
                                 square[0][ox] + square[1][oy] + square[2][oz], index,
                                 EvaluatedWord(index)});  // evaluated by pass 1
            });
            PenumbraInterpolate(sp, neededMask, nodes, base, planar, summary, blockers, acc, counters);
            return;
        }
        if (planar || OwnRayChecksAgreement()) {
            // Every candidate's word: pass 1's sums already (acc is still empty here).
            assert(acc.m == 0);
            acc = counts;
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
            Use(acc, EvaluatedWord(static_cast<uint64_t>(base + b->linear[lane])));
            return;
        }
    }
    uint32_t c = 0;
    all.Any([&](const FrontBlock& b, int k) {
        if (summary && !blockers.tried && c == 1) FindBlockers(*summary, base, sp, &blockers);
        ++c;
        if (!SeesPointCulled(EntryNode(ci, cj, ck, b, k), sp, blockers, counters)) return false;
        Use(acc, EvaluatedWord(static_cast<uint64_t>(base + b.linear[k])));
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
template <typename Word>
inline void LightMesh<Word>::MinorityFirst(const ShadingPoint& sp, Word neededMask, Word majority, const FrontRun& all,
                                           int64_t base, int ci, int cj, int ck, const CellSummary* summary,
                                           Blockers& blockers, Accumulator& acc, RenderCounters& counters) const {
    FrontList* patch = summary ? Patch(*summary, base, ci, cj, ck, sp, counters) : nullptr;
    // A segment decided without the back-end (the cell patch, the point's blockers): 1
    // sees, 0 blocked, -1 for the back-end.
    // The node's position is computed only where the patch has not already decided (most
    // candidates of a cell's later points: 12 instructions each, 2 % of the castle's light
    // mesh).
    auto decide = [&](const FrontBlock& b, int k, Vec3* x) {
        const int known = patch ? PatchKnown(*patch, b, k) : 0;
        if (known < 1) *x = EntryNode(ci, cj, ck, b, k);
        if (known == 1 || (known < 0 && PatchSees(*patch, b, k, *x))) {
            ++Count(counters, LightMeshCount::kPatchSegments);
            return 1;
        }
        if (summary && !blockers.tried) FindBlockers(*summary, base, sp, &blockers);
        return CullSegment(*x, sp, blockers, counters);
    };
    SegmentBatch batch;
    size_t seenWithoutRays = 0;
    // The minority's and the majority's entries as masks per block (every entry in front
    // was evaluated by pass 1), so that the passes below visit their own entries only, in
    // the template's order as before, without a branch per entry on its word (about every
    // other one mispredicted where the two are mixed).
    Scratch<uint8_t, 256> maskScratch(2 * size_t(all.count));
    uint8_t* minorityMasks = maskScratch.data();
    uint8_t* majorityMasks = minorityMasks + all.count;
    // (With gathers a block at a time: at kI 3 the entry-by-entry loop below was 4 % of
    // the castle's light mesh.)
    if (minority_) {
        minority_(all.blocks, all.masks, all.count, static_cast<const void*>(nodes_.get() + base),
                  static_cast<uint32_t>(neededMask), static_cast<uint32_t>(majority), minorityMasks, majorityMasks);
    } else {
        for (uint32_t b = 0; b < all.count; ++b) {
            unsigned minority = 0;
            for (unsigned m = all.masks[b]; m; m &= m - 1) {
                const int k = __builtin_ctz(m);
                const Word w = EvaluatedWord(static_cast<uint64_t>(base + all.blocks[b].linear[k]));
                minority |= static_cast<unsigned>((w & neededMask) != majority) << k;
            }
            minorityMasks[b] = static_cast<uint8_t>(minority);
            majorityMasks[b] = static_cast<uint8_t>(all.masks[b] & ~minority);
        }
    }
    const FrontRun minorityRun{all.blocks, minorityMasks, all.count}, majorityRun{all.blocks, majorityMasks, all.count};
    // Decides every segment of the run's candidates, and uses those that see P (the
    // back-end's answers may still be pending in `batch`).
    auto useAllSeeing = [&](const FrontRun& run) {
        run.ForEach([&](const FrontBlock& b, int k) {
            const Word w = EvaluatedWord(static_cast<uint64_t>(base + b.linear[k]));
            Vec3 x;
            const int d = decide(b, k, &x);
            if (d == 1) {
                Use(acc, w);
                ++seenWithoutRays;
            } else if (d < 0) {
                Queue(batch, x, static_cast<uint64_t>(base + b.linear[k]), sp, acc, counters);
            }
        });
    };
    useAllSeeing(minorityRun);
    // Whether a minority node sees P; if one is already known to, the minority's pending
    // segments share their packets with the majority's, which are all needed then.
    if (seenWithoutRays + batch.seen == 0) Flush(batch, acc, counters);
    if (seenWithoutRays + batch.seen > 0) {  // a minority node sees P: ОТ's average needs every segment
        useAllSeeing(majorityRun);
        Flush(batch, acc, counters);
        return;
    }
    // No minority node sees P: the first W-node that does settles it.
    majorityRun.Any([&](const FrontBlock& b, int k) {
        const Word w = EvaluatedWord(static_cast<uint64_t>(base + b.linear[k]));
        Vec3 x;
        const int d = decide(b, k, &x);
        if (d == 0 || (d < 0 && !SeesPoint(x, sp, counters))) return false;
        Use(acc, w);
        return true;
    });
}

}  // namespace
}  // namespace lm
