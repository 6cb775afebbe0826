// soft_frame.cpp -- the soft default's stream of tiles (see the header).
#include "lightmesh/render/soft_frame.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <memory_resource>
#include <mutex>

#include "lightmesh/render/penumbra_classifier.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/huge_pages.h"
#include "lightmesh/util/parallel.h"
#include "lightmesh/util/system.h"

namespace lm {

/// One (camera hit, light) pair.
struct SoftFrame::Entry {
    uint32_t light = 0;
    Color omega;       ///< the light's unshadowed term at the hit
    float v = 0;       ///< its visibility, once known
    uint8_t probe = 0;   ///< the centre ray reached the light
    uint8_t seed = 0;    ///< a neighbour's probe disagrees
    uint8_t marked = 0;  ///< in a penumbra
    uint8_t spacing = 1; ///< its penumbra's samples per independent value (1, 2 or 4)
    uint8_t direct = 0;  ///< sampled (else interpolated from the anchors of its spacing)
};

/// One camera ray's hit.
struct SoftFrame::Sample {
    ShadingPoint sp;
    float footprint = 0;  ///< the world size of a sample on the surface there
    Color rest;           ///< the shading without the lights' terms (ambient, mirror)
    uint32_t first = 0;   ///< its entries in its tile's list, ascending by light
    uint32_t count = 0;
    bool hit = false;
    /// With at most 64 lights: bit l set where it needs light l, and where light l's probe
    /// reached it (the seeds' test compares neighbours by these words).
    uint64_t need = 0, lit = 0;
};

/// Where the rows' buffers come from: 2 MiB chunks on huge pages (AllocateLarge), handed
/// out in turn and released together at the end of the render. The first touch of a 4 KiB
/// page costs a fault, about 11 µs on the machines measured here (util/huge_pages.h): the
/// rows of the castle at 1024×768 took 8,000 of them, 90 ms against RT's 170 ms render. A
/// tile's vectors grow a few times and keep their room from row to row, so what a growth
/// leaves behind is bounded by what the vectors hold.
class RowMemory final : public std::pmr::memory_resource {
  public:
    ~RowMemory() override {
        for (void* c : chunks_) std::free(c);
    }

  private:
    static constexpr size_t kChunk = size_t(2) << 20;
    void* do_allocate(size_t bytes, size_t align) override {
        std::lock_guard<std::mutex> lock(mutex_);
        size_t at = (used_ + align - 1) & ~(align - 1);
        if (chunks_.empty() || at + bytes > size_) {
            size_ = std::max(kChunk, (bytes + kChunk - 1) / kChunk * kChunk);
            chunks_.push_back(AllocateLarge(size_, 64, kChunk));
            at = 0;
        }
        used_ = at + bytes;
        return static_cast<char*>(chunks_.back()) + at;
    }
    void do_deallocate(void*, size_t, size_t) override {}
    bool do_is_equal(const std::pmr::memory_resource& o) const noexcept override { return this == &o; }
    std::mutex mutex_;
    std::vector<void*> chunks_;
    size_t used_ = 0, size_ = 0;
};

/// A tile's hits and their (hit, light) pairs.
struct SoftFrame::Tile {
    explicit Tile(std::pmr::memory_resource* m) : samples(m), entries(m) {}
    std::pmr::vector<Sample> samples;  ///< tileSamples_² (row-major), clipped to the frame
    std::pmr::vector<Entry> entries;
    int x0 = 0, y0 = 0, w = 0, h = 0;  ///< its samples in the frame
};

/// A tile's silhouette points and their lights.
struct SoftFrame::TileSeeds {
    explicit TileSeeds(std::pmr::memory_resource* m) : points(m), light(m) {}
    std::pmr::vector<SilhouettePoint> points;
    std::pmr::vector<uint32_t> light;
};

/// The rows of tiles the stream holds, in two rings: the hits of the rows the stages from
/// the seeds to the pixels read, and the silhouette points of the rows the marks read.
struct SoftFrame::Window {
    int tilesX = 0, tileRows = 0, ring = 0, seedRing = 0, ts = 0;
    std::vector<int> rowHeld;        ///< per ring slot, the tile row it holds (−1: none)
    std::vector<std::vector<Tile>> slots;
    std::vector<std::vector<TileSeeds>> seedSlots;
    Tile& At(int row, int col) { return slots[static_cast<size_t>(row % ring)][static_cast<size_t>(col)]; }
    TileSeeds& SeedsAt(int row, int col) {
        return seedSlots[static_cast<size_t>(row % seedRing)][static_cast<size_t>(col)];
    }
    /// The sample at frame coordinates (x, y) and its tile, or null outside the frame or
    /// the held rows.
    const Sample* SampleAt(int x, int y, const Tile** tile) {
        if (x < 0 || y < 0 || x >= tilesX * ts || y >= tileRows * ts) return nullptr;
        const int row = y / ts, col = x / ts;
        if (rowHeld[static_cast<size_t>(row % ring)] != row) return nullptr;
        const Tile& t = At(row, col);
        if (x - t.x0 >= t.w || y - t.y0 >= t.h) return nullptr;
        *tile = &t;
        return &t.samples[static_cast<size_t>(y - t.y0) * static_cast<size_t>(ts) + static_cast<size_t>(x - t.x0)];
    }
};

namespace {

/// The entry of `light` among a sample's entries (ascending by light), or null.
template <typename E>
E* FindEntry(E* first, uint32_t count, uint32_t light) {
    for (uint32_t k = 0; k < count; ++k) {
        if (first[k].light == light) return first + k;
        if (first[k].light > light) break;
    }
    return nullptr;
}

/// A silhouette point that may mark a tile's pairs: its light, and the box of samples it reaches.
struct Candidate {
    uint32_t light;
    const SilhouettePoint* p;
    int xa, xb, ya, yb;
};

/// A thread's buffers, kept from tile to tile (a tile's steps run on one thread, none nested).
struct Scratch {
    std::vector<Ray> rays;
    std::vector<Hit> hits;
    std::vector<Color> omega;
    std::vector<uint32_t> ids, owner, lights, slotOf, start, order, who;
    std::vector<std::pair<uint32_t, uint32_t>> blocked;
    std::vector<Candidate> cand;
    std::vector<std::vector<uint32_t>> blocks;
    std::vector<SoftFrame::Entry> entries;
    std::unique_ptr<bool[]> occluded;
    size_t room = 0;
    bool* Occluded(size_t n) {
        if (room < n) occluded.reset(new bool[room = std::max<size_t>(n, 2 * room)]);
        return occluded.get();
    }
};
Scratch& ThreadScratch() {
    thread_local Scratch scratch;
    return scratch;
}

/// Whether two neighbouring samples lie on one surface (no depth edge between them): their
/// points within 3 footprints.
bool Continuous(const ShadingPoint& a, float fa, const ShadingPoint& b, float fb) {
    const float reach = 3.0f * std::max(fa, fb);
    return LengthSquared(a.p - b.p) <= reach * reach;
}

/// Whether a marked pair at (x, y) of spacing s is sampled by its position alone: spacing 1,
/// or on the grid of its spacing.
inline bool OnGrid(int x, int y, int s) { return s == 1 || (x % s == 0 && y % s == 0); }

/// The spacing of the values of a penumbra whose silhouette point reaches `reach` samples:
/// the visibility across it changes over about 2·(reach − 2) samples, so values every 2, 4
/// or 8 samples (3 to 4 across the penumbra), interpolated, keep its profile.
inline uint8_t SpacingOf(float reach) { return reach < 4 ? 1 : reach < 8 ? 2 : reach < 16 ? 4 : 8; }

}  // namespace

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
                    for (uint32_t e = 0; e < count; ++e) entries.push_back(Entry{ids[e], omega[e]});
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
            for (uint32_t e = s.first; e < s.first + s.count; ++e) {
                Entry& en = t.entries[e];
                if (radii_[en.light] <= 0) continue;  // a point light: the probe is the answer
                if (lights64 && !(differ >> en.light & 1)) continue;
                for (int k = 0; k < 4 && !en.seed; ++k) {
                    if (!nb[k]) continue;
                    const Entry* other = FindEntry(nt[k]->entries.data() + nb[k]->first, nb[k]->count, en.light);
                    if (other && other->probe != en.probe) en.seed = 1;
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
    std::vector<Candidate>& cand = ThreadScratch().cand;
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
    if (cand.empty()) {
        for (const Entry& en : t.entries) c.method[kSoftFrameMarked] += en.seed;
        for (Entry& en : t.entries) en.marked = en.seed;
        return;
    }
    // The candidates of each block of 4×4 samples (those whose box meets it), in order.
    constexpr int B = 4;
    const int blocksX = (ts + B - 1) / B;
    std::vector<std::vector<uint32_t>>& blocks = ThreadScratch().blocks;
    blocks.resize(static_cast<size_t>(blocksX * blocksX));
    for (auto& b : blocks) b.clear();
    for (uint32_t k = 0; k < cand.size(); ++k) {
        const Candidate& q = cand[k];
        for (int by = (q.ya - t.y0) / B; by <= (q.yb - t.y0) / B; ++by)
            for (int bx = (q.xa - t.x0) / B; bx <= (q.xb - t.x0) / B; ++bx) blocks[by * blocksX + bx].push_back(k);
    }
    for (size_t i = 0; i < t.samples.size(); ++i) {
        const Sample& s = t.samples[i];
        if (!s.count) continue;
        const int lx = static_cast<int>(i % ts), ly = static_cast<int>(i / ts);
        const int x = t.x0 + lx, y = t.y0 + ly;
        const std::vector<uint32_t>& list = blocks[(ly / B) * blocksX + lx / B];
        for (uint32_t e = s.first; e < s.first + s.count; ++e) {
            Entry& en = t.entries[e];
            const Vec3& center = scene_.lights[en.light].position;
            for (const uint32_t k : list) {
                const Candidate& q = cand[k];
                if (q.light != en.light || x < q.xa || x > q.xb || y < q.ya || y > q.yb) continue;
                if (ConeHolds(s.sp.origin, center, radii_[en.light], q.p->x, q.p->slop)) {
                    en.marked = 1;
                    en.spacing = SpacingOf(q.p->reach);
                    break;
                }
            }
            if (en.seed && !en.marked) en.marked = 1, en.spacing = 1;
            c.method[kSoftFrameMarked] += en.marked;
        }
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

void SoftFrame::ComposeTile(Window& w, int row, int col, int y0, int y1, Image* image, RenderCounters& /*c*/) const {
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
        }
    }
}

void SoftFrame::RenderRows(int y0, int y1, Image* image, RenderCounters& counters, ProgressReporter* progress) const {
    const int height = options_.height;
    y0 = std::clamp(y0, 0, height);
    y1 = std::clamp(y1, y0, height);
    if (y0 == y1) return;
    RowMemory pool;
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
    for (int j = std::max(0, k0 - R - 3); j < std::min(T, k1) + 4 + R + 1; ++j)
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
                        default: ComposeTile(w, row, col, y0, y1, image, c); break;
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
