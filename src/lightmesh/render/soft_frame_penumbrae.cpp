// soft_frame_penumbrae.cpp -- the soft default's penumbra finding: the seeds (neighbouring
// probes that disagree, their silhouette points) and the marks (the pairs whose cone holds
// a silhouette point within reach). See render/soft_frame.h.
#include <algorithm>
#include <cmath>
#include <vector>

#include "lightmesh/render/soft_frame_rows.h"

namespace lm {

using namespace soft_frame;

void SoftFrame::SeedTile(Window& w, int row, int col, RenderCounters& c) const {
    Tile& t = w.At(row, col);
    TileSeeds& seeds = w.SeedsAt(row, col);
    seeds.points.clear(), seeds.light.clear();
    const int ts = tileSamples_;
    Scratch& sc = ThreadScratch();
    std::vector<Ray>& rays = sc.rays;
    std::vector<Hit>& hits = sc.hits;
    std::vector<std::pair<uint32_t, uint32_t>>& blocked = sc.blocked;  // (sample, entry) of the blocked seeds
    rays.clear(), blocked.clear();
    const bool lights64 = scene_.lights.size() <= 64;
    for (int y = 0; y < t.h; ++y)
        for (int x = 0; x < t.w; ++x) {
            const size_t i = static_cast<size_t>(y) * ts + x;
            const Sample& s = t.samples[i];
            if (!s.hit || s.count == 0) continue;
            const Sample* nb[4];
            const Tile* nt[4] = {&t, &t, &t, &t};
            const int X = t.x0 + x, Y = t.y0 + y;
            if (x > 0 && y > 0 && x + 1 < t.w && y + 1 < t.h) {  // inside the tile
                nb[0] = &s - 1, nb[1] = &s + 1, nb[2] = &s - ts, nb[3] = &s + ts;
            } else {
                nb[0] = w.SampleAt(X - 1, Y, &nt[0]), nb[1] = w.SampleAt(X + 1, Y, &nt[1]);
                nb[2] = w.SampleAt(X, Y - 1, &nt[2]), nb[3] = w.SampleAt(X, Y + 1, &nt[3]);
            }
            // The lights whose probes may disagree (all of them past 64 lights).
            uint64_t differ = 0;
            for (int k = 0; k < 4; ++k) {
                if (!nb[k] || !nb[k]->hit) {
                    nb[k] = nullptr;
                    continue;
                }
                const uint64_t d = lights64 ? (s.lit ^ nb[k]->lit) & s.need & nb[k]->need : ~uint64_t(0);
                if (d && !Continuous(s.sp, s.footprint, nb[k]->sp, nb[k]->footprint)) nb[k] = nullptr;
                else differ |= d;
            }
            if (!differ) continue;
            if (!lights64) {
                // Past 64 lights, each neighbour's pairs walked beside the sample's (both
                // ascend by light): the pairs of one light whose probes differ.
                for (int k = 0; k < 4; ++k) {
                    if (!nb[k]) continue;
                    const Entry *o = nt[k]->entries.data() + nb[k]->first, *end = o + nb[k]->count;
                    for (uint32_t e = s.first; e < s.first + s.count && o != end; ++e) {
                        Entry& en = t.entries[e];
                        while (o != end && o->light < en.light) ++o;
                        if (o != end && o->light == en.light && o->probe != en.probe && radii_[en.light] > 0) en.seed = 1;
                    }
                }
            }
            for (uint32_t e = s.first; e < s.first + s.count; ++e) {
                Entry& en = t.entries[e];
                if (radii_[en.light] <= 0) continue;  // a point light: the probe is the answer
                if (lights64) {
                    if (!(differ >> en.light & 1)) continue;
                    for (int k = 0; k < 4 && !en.seed; ++k) {
                        if (!nb[k]) continue;
                        const Entry* other = FindEntry(nt[k]->entries.data() + nb[k]->first, nb[k]->count, en.light);
                        if (other && other->probe != en.probe) en.seed = 1;
                    }
                }
                if (en.seed) {
                    ++c.method[kSoftFrameSeeds];
                    if (!en.probe) blocked.emplace_back(static_cast<uint32_t>(i), e);
                }
            }
        }
    // The blocked seeds' probes again, to their closest hit: a point of the silhouette.
    for (const auto& [i, e] : blocked)
        rays.push_back(LightSegment(t.samples[i].sp.origin, scene_.lights[t.entries[e].light].position));
    hits.resize(rays.size());
    if (!rays.empty()) accel_.IntersectMany(rays.data(), rays.size(), hits.data());
    c.shadowRays += rays.size();
    for (size_t k = 0; k < blocked.size(); ++k) {
        if (hits[k].prim == UINT32_MAX) continue;  // cannot happen for an occluded ray; kept safe
        const auto [i, e] = blocked[k];
        const Sample& s = t.samples[i];
        const uint32_t light = t.entries[e].light;
        SilhouettePoint p;
        p.x = rays[k].At(hits[k].t);
        p.slop = 1.5f * s.footprint;
        p.sx = t.x0 + static_cast<int>(i % ts), p.sy = t.y0 + static_cast<int>(i / ts);
        p.reach = PenumbraReach(s.sp.origin, s.sp.n, scene_.lights[light].position, radii_[light],
                                Length(p.x - s.sp.origin), s.footprint, static_cast<float>(kReach));
        seeds.points.push_back(p);
        seeds.light.push_back(light);
    }
    c.method[kSoftFrameSilhouettes] += seeds.points.size();
}

void SoftFrame::MarkTile(Window& w, int row, int col, RenderCounters& c) const {
    Tile& t = w.At(row, col);
    const int ts = tileSamples_;
    // Mark the pairs whose cone holds a silhouette point of the seeds within reach. The
    // candidates: the seeds whose box meets the tile, by light, the nearest tiles' first
    // (a pair stops at the first that holds it).
    Scratch& sc = ThreadScratch();
    std::vector<Candidate>& cand = sc.cand;
    cand.clear();
    for (int ring = 0; ring <= reachTiles_; ++ring)
        for (int r = row - ring; r <= row + ring; ++r) {
            if (r < 0 || r >= w.tileRows) continue;
            const bool edgeRow = r == row - ring || r == row + ring;
            for (int q = col - ring; q <= col + ring; q += edgeRow || ring == 0 ? 1 : 2 * ring) {
                if (q < 0 || q >= w.tilesX) continue;
                const TileSeeds& o = w.SeedsAt(r, q);
                for (size_t k = 0; k < o.points.size(); ++k) {
                    const SilhouettePoint& p = o.points[k];
                    const int reach = static_cast<int>(std::ceil(p.reach));
                    const int xa = std::max(p.sx - reach, t.x0), xb = std::min(p.sx + reach, t.x0 + t.w - 1);
                    const int ya = std::max(p.sy - reach, t.y0), yb = std::min(p.sy + reach, t.y0 + t.h - 1);
                    if (xa <= xb && ya <= yb) cand.push_back(Candidate{o.light[k], &p, xa, xb, ya, yb});
                }
            }
        }
    // Each candidate in turn over the samples of its box: a pair takes the first candidate
    // (nearest tiles first) whose light is its own and whose silhouette point its cone
    // holds. A pair's cone is made when a candidate first reaches it. A seed no candidate
    // marks is marked at spacing 1 (its own penumbra, narrower than a sample).
    std::vector<LightCone>& cones = sc.cones;
    std::vector<uint8_t>& made = sc.made;
    cones.resize(t.entries.size());
    made.assign(t.entries.size(), 0);
    for (const Candidate& q : cand) {
        const Vec3 x = q.p->x;
        const float slop = q.p->slop;
        const uint8_t spacing = SpacingOf(q.p->reach);
        for (int y = q.ya; y <= q.yb; ++y) {
            const Sample* row = &t.samples[static_cast<size_t>(y - t.y0) * static_cast<size_t>(ts)];
            for (int x0 = q.xa; x0 <= q.xb; ++x0) {
                const Sample& s = row[x0 - t.x0];
                if (!s.count) continue;
                Entry* en = FindEntry(t.entries.data() + s.first, s.count, q.light);
                if (!en || en->marked) continue;
                const size_t e = static_cast<size_t>(en - t.entries.data());
                if (!made[e]) cones[e] = LightCone(s.sp.origin, scene_.lights[q.light].position, radii_[q.light]), made[e] = 1;
                if (cones[e].Holds(x, slop)) en->marked = 1, en->spacing = spacing;
            }
        }
    }
    for (Entry& en : t.entries) {
        if (en.seed && !en.marked) en.marked = 1, en.spacing = 1;
        c.method[kSoftFrameMarked] += en.marked;
    }
}

}  // namespace lm
