// soft_frame.cpp -- the soft default's stream of tiles (see the header).
#include "lightmesh/render/soft_frame.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <memory_resource>
#include <mutex>

#include "lightmesh/render/penumbra_classifier.h"
#include "lightmesh/render/soft_frame_rows.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/huge_pages.h"
#include "lightmesh/util/parallel.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace soft_frame {
Scratch& ThreadScratch() {
    thread_local Scratch scratch;
    return scratch;
}
}  // namespace soft_frame
using namespace soft_frame;

void SoftFrame::CheckMemory(Window& w) const {
    // The rows held: their hits and (hit, light) pairs. Past half the memory budget the
    // render stops with an error rather than running the machine out of memory (many
    // lights without a range: every hit keeps a pair per light).
    uint64_t bytes = 0;
    for (const auto& slot : w.slots)
        for (const Tile& t : slot) bytes += t.samples.capacity() * sizeof(Sample) + t.entries.capacity() * sizeof(Entry);
    for (const auto& slot : w.seedSlots)
        for (const TileSeeds& t : slot) bytes += t.points.capacity() * (sizeof(SilhouettePoint) + sizeof(uint32_t));
    const uint64_t limit = PhysicalMemoryBytes() / 2;
    if (limit && bytes > limit)
        ThrowErrorAt({scene_.name},
                     "soft shadows: the %d rows of tiles in flight hold %s for %zu lights, more than half the memory "
                     "budget (%s); give the lights a \"range\", render a narrower image, or use --shadows rt",
                     w.ring, FormatBytes(bytes).c_str(), scene_.lights.size(), FormatBytes(limit * 2).c_str());
}

bool SoftFrame::Interpolable(Window& w, const Sample& s, uint32_t light, int x, int y, int sp) const {
    const int ax = x - x % sp, ay = y - y % sp;
    for (int k = 0; k < 4; ++k) {
        const int qx = ax + (k & 1) * sp, qy = ay + (k >> 1) * sp;
        const Tile* at;
        const Sample* a = w.SampleAt(qx, qy, &at);
        if (!a || !a->hit) return false;
        const Entry* en = FindEntry(at->entries.data() + a->first, a->count, light);
        if (!en || (en->marked && !OnGrid(qx, qy, en->spacing))) return false;
        // On the sample's surface: the anchor within its plane (half a sample per sample of
        // distance) and facing the same way.
        const Vec3 d = a->sp.p - s.sp.p;
        if (std::abs(Dot(d, s.sp.n)) > 0.25f * Length(d) + s.footprint || Dot(a->sp.n, s.sp.n) < 0.9f) return false;
    }
    return true;
}

SoftFrame::SoftFrame(const Scene& scene, const Accelerator& accel, const WhittedRenderer& renderer,
                     const RenderOptions& options, std::vector<float> radii, int samples)
    : scene_(scene), accel_(accel), renderer_(renderer), options_(options), radii_(std::move(radii)),
      samples_(samples), pattern_(DiscPattern::Golden(samples, 2)) {
    if (radii_.size() != scene.lights.size())
        ThrowError("soft shadows: %zu radii for %zu lights", radii_.size(), scene.lights.size());
    if (samples < 4 || samples > 256 || samples % 4)
        ThrowSettingError("soft_samples", "soft shadows: %d rays per light in a penumbra: must be a multiple of 4 from 4 to 256",
                          samples);
    sampleAngle_ = 2.0f * std::tan(0.5f * scene.camera.fovY * Pi / 180.0f) / static_cast<float>(options.height * options.aa);
    tilePixels_ = std::max(1, 16 / options.aa);
    tileSamples_ = tilePixels_ * options.aa;
    reachTiles_ = (kReach + tileSamples_ - 1) / tileSamples_;
}


void SoftFrame::ShadeTile(Window& w, int row, int col, RenderCounters& c) const {
    Tile& t = w.At(row, col);
    const int ts = tileSamples_, aa = options_.aa;
    const int sw = options_.width * aa, sh = options_.height * aa;
    t.x0 = col * ts, t.y0 = row * ts;
    t.w = std::min(ts, sw - t.x0), t.h = std::min(ts, sh - t.y0);
    t.samples.assign(static_cast<size_t>(ts) * ts, Sample{});
    // The pairs gathered in the thread's buffer, then copied to the tile at their size (the
    // row memory does not take back what a growing vector leaves).
    std::vector<Entry>& entries = ThreadScratch().entries;
    entries.clear();
    const size_t lights = scene_.lights.size();
    Scratch& sc = ThreadScratch();
    std::vector<Ray>& rays = sc.rays;
    std::vector<Hit>& hits = sc.hits;
    std::vector<Color>& omega = sc.omega;
    std::vector<uint32_t>& ids = sc.ids;
    omega.resize(lights), ids.resize(lights);
    // The camera rays of 8×8 samples at a time (a packet).
    for (int by = 0; by < t.h; by += 8)
        for (int bx = 0; bx < t.w; bx += 8) {
            rays.clear();
            for (int y = by; y < std::min(by + 8, t.h); ++y)
                for (int x = bx; x < std::min(bx + 8, t.w); ++x) {
                    const int X = t.x0 + x, Y = t.y0 + y;
                    rays.push_back(renderer_.CameraRay(X / aa, Y / aa, X % aa, Y % aa));
                }
            hits.resize(rays.size());
            accel_.IntersectMany(rays.data(), rays.size(), hits.data());
            c.cameraRays += rays.size();
            size_t k = 0;
            for (int y = by; y < std::min(by + 8, t.h); ++y)
                for (int x = bx; x < std::min(bx + 8, t.w); ++x, ++k) {
                    Sample& s = t.samples[static_cast<size_t>(y) * ts + x];
                    if (hits[k].prim == UINT32_MAX) {
                        s.rest = scene_.background;
                        continue;
                    }
                    uint32_t count = 0;
                    s.sp = renderer_.ShadeSplit(rays[k], hits[k], omega.data(), ids.data(), &count, &s.rest, c);
                    s.hit = true;
                    const float cosView = std::max(0.2f, std::abs(Dot(s.sp.n, rays[k].d)) / Length(rays[k].d));
                    s.footprint = hits[k].t * Length(rays[k].d) * sampleAngle_ / cosView;
                    s.first = static_cast<uint32_t>(entries.size());
                    s.count = count;
                    // Written in place (an Entry built aside and copied in stalled on its
                    // flag byte's store: a quarter of this function's time).
                    const size_t at = entries.size();
                    entries.resize(at + count);
                    for (uint32_t e = 0; e < count; ++e) entries[at + e].light = ids[e], entries[at + e].omega = omega[e];
                }
        }
    // A quarter more room than the first row needs, so that the rows after it seldom grow.
    if (t.entries.capacity() < entries.size()) t.entries.reserve(entries.size() + entries.size() / 4);
    t.entries.assign(entries.begin(), entries.end());
    c.method[kSoftFrameLookups] += t.entries.size();
    // The probes, light by light: the tile's rays to one light's centre go together (the
    // entries ordered by light, each sample's in place: a counting sort over the tile's
    // lights, which its samples list in ascending order).
    std::vector<uint32_t>& owner = sc.owner;
    owner.resize(t.entries.size());
    for (size_t i = 0; i < t.samples.size(); ++i)
        for (uint32_t e = 0; e < t.samples[i].count; ++e) owner[t.samples[i].first + e] = static_cast<uint32_t>(i);
    // The tile's lights (each once: slotOf marks them), ascending, then the entries by light.
    std::vector<uint32_t>& tileLights = sc.lights;
    std::vector<uint32_t>& slotOf = sc.slotOf;
    if (slotOf.size() < lights) slotOf.assign(lights, UINT32_MAX);
    tileLights.clear();
    for (const Entry& en : t.entries)
        if (slotOf[en.light] == UINT32_MAX) slotOf[en.light] = 0, tileLights.push_back(en.light);
    std::sort(tileLights.begin(), tileLights.end());
    for (uint32_t k = 0; k < tileLights.size(); ++k) slotOf[tileLights[k]] = k;
    std::vector<uint32_t>&start = sc.start, &order = sc.order;
    start.assign(tileLights.size() + 1, 0);
    order.resize(t.entries.size());
    for (const Entry& en : t.entries) ++start[slotOf[en.light] + 1];
    for (size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
    for (uint32_t e = 0; e < t.entries.size(); ++e) order[start[slotOf[t.entries[e].light]]++] = e;
    for (const uint32_t l : tileLights) slotOf[l] = UINT32_MAX;
    bool* occluded = sc.Occluded(order.size());
    rays.clear();
    for (uint32_t e : order) {
        const Entry& en = t.entries[e];
        rays.push_back(LightSegment(t.samples[owner[e]].sp.origin, scene_.lights[en.light].position));
    }
    if (!rays.empty()) accel_.OccludedMany(rays.data(), rays.size(), occluded);
    c.shadowRays += rays.size();
    for (size_t k = 0; k < order.size(); ++k) {
        Entry& en = t.entries[order[k]];
        en.probe = !occluded[k];
        en.v = en.probe ? 1.0f : 0.0f;
    }
    if (lights <= 64)
        for (Sample& s : t.samples)
            for (uint32_t e = s.first; e < s.first + s.count; ++e) {
                const uint64_t bit = uint64_t(1) << t.entries[e].light;
                s.need |= bit;
                if (t.entries[e].probe) s.lit |= bit;
            }
}

void SoftFrame::SampleTile(Window& w, int row, int col, RenderCounters& c) const {
    Tile& t = w.At(row, col);
    const int ts = tileSamples_;
    // Which marked pairs are sampled: those on their spacing's grid, and those whose four
    // anchors (the grid's samples around them) are not all known without them: an anchor
    // is known when it is unmarked (its probe) or sampled by its position.
    for (size_t i = 0; i < t.samples.size(); ++i) {
        const Sample& s = t.samples[i];
        const int x = t.x0 + static_cast<int>(i % ts), y = t.y0 + static_cast<int>(i / ts);
        for (uint32_t e = s.first; e < s.first + s.count; ++e) {
            Entry& en = t.entries[e];
            if (!en.marked) continue;
            const int sp = en.spacing;
            en.direct = OnGrid(x, y, sp) || !Interpolable(w, s, en.light, x, y, sp);
        }
    }
    // Sample the marked pairs: N rays each, a point's rays together.
    Scratch& sc = ThreadScratch();
    std::vector<Ray>& rays = sc.rays;
    std::vector<uint32_t>& who = sc.who;
    rays.clear(), who.clear();
    const int first = samples_ / 2;
    for (size_t i = 0; i < t.samples.size(); ++i) {
        const Sample& s = t.samples[i];
        for (uint32_t e = s.first; e < s.first + s.count; ++e) {
            Entry& en = t.entries[e];
            if (!en.marked || !en.direct) continue;
            ++c.method[kSoftFrameDirect];
            SphereCone cone(s.sp.origin, scene_.lights[en.light].position, radii_[en.light]);
            if (cone.Inside()) {
                en.v = 1;
                continue;
            }
            cone.Turn(static_cast<int>(AreaLightSeed(s.sp, en.light) >> 54));
            for (int k = 0; k < first; ++k) rays.push_back(cone.RayTo(pattern_.x[k], pattern_.y[k], pattern_.r2[k]));
            who.push_back(e), sc.owner.resize(who.size()), sc.owner.back() = static_cast<uint32_t>(i);
        }
    }
    if (rays.empty()) return;
    bool* occluded = sc.Occluded(rays.size());
    accel_.OccludedMany(rays.data(), rays.size(), occluded);
    c.shadowRays += rays.size();
    std::vector<uint32_t>& again = sc.order;
    std::vector<uint32_t>& seen = sc.start;
    again.clear(), seen.assign(who.size(), 0);
    for (size_t k = 0; k < who.size(); ++k) {
        int visible = 0;
        for (int j = 0; j < first; ++j) visible += !occluded[k * first + j];
        seen[k] = static_cast<uint32_t>(visible);
        Entry& en = t.entries[who[k]];
        const bool agrees = en.probe ? visible == first : visible == 0;
        if (first < samples_ && !agrees) again.push_back(static_cast<uint32_t>(k));
        en.v = static_cast<float>(visible) / static_cast<float>(first);
    }
    if (first == samples_) {
        for (size_t k = 0; k < who.size(); ++k) c.method[kSoftFramePartial] += seen[k] > 0 && seen[k] < uint32_t(samples_);
        return;
    }
    rays.clear();
    for (const uint32_t k : again) {
        const Sample& s = t.samples[sc.owner[k]];
        const Entry& en = t.entries[who[k]];
        SphereCone cone(s.sp.origin, scene_.lights[en.light].position, radii_[en.light]);
        cone.Turn(static_cast<int>(AreaLightSeed(s.sp, en.light) >> 54));
        for (int j = first; j < samples_; ++j) rays.push_back(cone.RayTo(pattern_.x[j], pattern_.y[j], pattern_.r2[j]));
    }
    if (rays.empty()) return;
    occluded = sc.Occluded(rays.size());
    accel_.OccludedMany(rays.data(), rays.size(), occluded);
    c.shadowRays += rays.size();
    const int rest = samples_ - first;
    for (size_t m = 0; m < again.size(); ++m) {
        int visible = static_cast<int>(seen[again[m]]);
        for (int j = 0; j < rest; ++j) visible += !occluded[m * rest + j];
        Entry& en = t.entries[who[again[m]]];
        en.v = static_cast<float>(visible) / static_cast<float>(samples_);
        c.method[kSoftFramePartial] += visible > 0 && visible < samples_;
    }
}

void SoftFrame::ComposeTile(Window& w, int row, int col, int y0, int y1, Image* image, VisibilityImage* visibility) const {
    Tile& t = w.At(row, col);
    const int ts = tileSamples_, aa = options_.aa;
    // The interpolated pairs: bilinear in their anchors' values.
    for (size_t i = 0; i < t.samples.size(); ++i) {
        const Sample& s = t.samples[i];
        const int x = t.x0 + static_cast<int>(i % ts), y = t.y0 + static_cast<int>(i / ts);
        for (uint32_t e = s.first; e < s.first + s.count; ++e) {
            Entry& en = t.entries[e];
            if (!en.marked || en.direct) continue;
            const int sp = en.spacing;
            const int ax = x - x % sp, ay = y - y % sp;
            const float fx = static_cast<float>(x - ax) / sp, fy = static_cast<float>(y - ay) / sp;
            float v[4];
            for (int k = 0; k < 4; ++k) {
                const Tile* at;
                const Sample* a = w.SampleAt(ax + (k & 1) * sp, ay + (k >> 1) * sp, &at);
                v[k] = FindEntry(at->entries.data() + a->first, a->count, en.light)->v;
            }
            en.v = (v[0] * (1 - fx) + v[1] * fx) * (1 - fy) + (v[2] * (1 - fx) + v[3] * fx) * fy;
        }
    }
    // The pixels: the mean of their samples' rest + Σ Ω·V (lights in ascending order).
    const float inv = 1.0f / static_cast<float>(aa * aa);
    for (int py = t.y0 / aa; py < (t.y0 + t.h) / aa; ++py) {
        if (py < y0 || py >= y1) continue;
        for (int px = t.x0 / aa; px < (t.x0 + t.w) / aa; ++px) {
            Color sum;
            for (int sy = 0; sy < aa; ++sy)
                for (int sx = 0; sx < aa; ++sx) {
                    const Sample& s = t.samples[static_cast<size_t>(py * aa + sy - t.y0) * ts + (px * aa + sx - t.x0)];
                    Color colour = s.rest;
                    for (uint32_t e = s.first; e < s.first + s.count; ++e) colour += t.entries[e].omega * t.entries[e].v;
                    sum += colour;
                }
            image->At(px, py) = sum * inv;
            if (visibility) RecordVisibility(t, px, py, visibility);
        }
    }
}

void SoftFrame::RecordVisibility(const Tile& t, int px, int py, VisibilityImage* visibility) const {
    // The pixel's samples' values, as ComposeTile weighs their lights' terms by them.
    const int ts = tileSamples_, aa = options_.aa;
    float* out = visibility->At(px, py);
    std::fill_n(out, visibility->lights, 0.0f);
    int hits = 0;
    for (int sy = 0; sy < aa; ++sy)
        for (int sx = 0; sx < aa; ++sx) {
            const Sample& s = t.samples[static_cast<size_t>(py * aa + sy - t.y0) * ts + (px * aa + sx - t.x0)];
            if (!s.hit) continue;
            ++hits;
            for (uint32_t e = s.first; e < s.first + s.count; ++e) out[t.entries[e].light] += t.entries[e].v;
        }
    FinishVisibility(out, visibility->lights, hits);
}

void SoftFrame::RenderRows(int y0, int y1, Image* image, RenderCounters& counters, ProgressReporter* progress,
                           VisibilityImage* visibility) const {
    const int height = options_.height;
    y0 = std::clamp(y0, 0, height);
    y1 = std::clamp(y1, y0, height);
    if (y0 == y1) return;
    HugePageArena pool;
    Window w;
    w.ts = tileSamples_;
    w.tilesX = (options_.width + tilePixels_ - 1) / tilePixels_;
    w.tileRows = (height + tilePixels_ - 1) / tilePixels_;
    const int R = reachTiles_;
    // Rows of tiles: the band's (k0 .. k1), the seeds they read (R more each side), the
    // hits those read (one more).
    const int k0 = y0 / tilePixels_, k1 = (y1 + tilePixels_ - 1) / tilePixels_;
    // At step j the hits of rows j − R − 5 (the pixels' anchors) to j are read, and the
    // silhouette points of rows j − 2R − 2 (the marks') to j − 1.
    w.ring = R + 6;
    w.seedRing = 2 * R + 3;
    w.rowHeld.assign(static_cast<size_t>(w.ring), -1);
    // Each tile's vectors built on the pool (a copy would take the default resource).
    w.slots.resize(static_cast<size_t>(w.ring));
    for (auto& slot : w.slots)
        for (int c = 0; c < w.tilesX; ++c) slot.emplace_back(&pool);
    w.seedSlots.resize(static_cast<size_t>(w.seedRing));
    for (auto& slot : w.seedSlots)
        for (int c = 0; c < w.tilesX; ++c) slot.emplace_back(&pool);
    // The stages, each a row of tiles behind the one before: hits and probes; seeds (the
    // rows above and below); marks (the seeds within R rows); samples (the marks of the
    // neighbouring rows: the anchors); the pixels (the neighbouring rows' samples).
    struct Stage {
        int lag, first, last;
    };
    const int T = w.tileRows;
    const Stage stages[5] = {{0, k0 - R - 3, k1 + R + 3},
                             {1, k0 - R - 2, k1 + R + 2},
                             {2 + R, k0 - 2, k1 + 2},
                             {3 + R, k0 - 1, k1 + 1},
                             {4 + R, k0, k1}};
    std::vector<RenderCounters> tileCounters(static_cast<size_t>(w.tilesX) * 5);
    const int64_t rendererTilesX = renderer_.TilesX();
    const int64_t unitsTotal = int64_t((y1 - y0 + 15) / 16) * rendererTilesX;
    int64_t unitsDone = 0;
    for (int j = std::max(0, k0 - R - 3); j < std::min(T, k1) + 4 + R + 1; ++j) {
        // Stopped (a refused estimate, the Python module's Ctrl-C): the rest is left undone.
        if (progress && progress->Stopped()) break;
        for (int which = 0; which < 5; ++which) {
            const Stage& st = stages[which];
            const int row = j - st.lag;
            if (row < std::max(0, st.first) || row >= std::min(T, st.last)) continue;
            if (which == 0) w.rowHeld[static_cast<size_t>(row % w.ring)] = row;
            if (which == 1) CheckMemory(w);
            ParallelFor(tbb::blocked_range<int>(0, w.tilesX, 1), [&](const tbb::blocked_range<int>& range) {
                for (int col = range.begin(); col != range.end(); ++col) {
                    RenderCounters& c = tileCounters[static_cast<size_t>(which * w.tilesX + col)];
                    switch (which) {
                        case 0: ShadeTile(w, row, col, c); break;
                        case 1: SeedTile(w, row, col, c); break;
                        case 2: MarkTile(w, row, col, c); break;
                        case 3: SampleTile(w, row, col, c); break;
                        default: ComposeTile(w, row, col, y0, y1, image, visibility); break;
                    }
                }
            });
            if (which == 4 && progress) {
                // One unit per renderer tile (16² pixels) of the band, as rows complete.
                const int rowsDone = std::min(y1, (row + 1) * tilePixels_) - y0;
                const int64_t units = rowsDone >= y1 - y0 ? unitsTotal : int64_t(rowsDone / 16) * rendererTilesX;
                progress->Update(units - unitsDone);
                unitsDone = units;
            }
        }
    }
    for (const RenderCounters& c : tileCounters) counters += c;
}

std::vector<std::pair<std::string, std::string>> SoftFrame::CounterLines(const RenderCounters& c) const {
    const double n = static_cast<double>(std::max<uint64_t>(c.method[kSoftFrameLookups], 1));
    return {{"soft", StringPrintf("%llu (hit, light) pairs: %.1f %% seeds, %.1f %% in a penumbra, %.1f %% sampled "
                                  "(%d rays, half first), %.1f %% partly lit; %llu silhouette points",
                                  static_cast<unsigned long long>(c.method[kSoftFrameLookups]),
                                  100.0 * c.method[kSoftFrameSeeds] / n, 100.0 * c.method[kSoftFrameMarked] / n,
                                  100.0 * c.method[kSoftFrameDirect] / n, samples_, 100.0 * c.method[kSoftFramePartial] / n,
                                  static_cast<unsigned long long>(c.method[kSoftFrameSilhouettes]))}};
}

}  // namespace lm
