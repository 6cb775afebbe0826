// soft_frame_rows.h -- the soft default's rows of tiles and the helpers its stages share
// (render/soft_frame.cpp: hits, probes, samples and pixels; render/soft_frame_penumbrae.cpp:
// seeds and marks). Internal to those two files.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <memory_resource>
#include <utility>
#include <vector>

#include "lightmesh/render/penumbra_classifier.h"
#include "lightmesh/render/soft_frame.h"

namespace lm {

/// One (camera hit, light) pair: 24 bytes (the rows in flight hold one per pair). The
/// flags are separate memory locations where one stage writes a tile's own pairs while its
/// neighbours read theirs (the seeds read the probes, the samples read the marks and
/// spacings): only `marked` and `spacing`, both written by the marks alone, share a byte.
struct SoftFrame::Entry {
    uint32_t light = 0;
    Color omega;              ///< the light's unshadowed term at the hit
    float v = 0;              ///< its visibility, once known
    uint8_t probe = 0;        ///< the centre ray reached the light
    uint8_t seed = 0;         ///< a neighbour's probe disagrees
    uint8_t marked : 1 = 0;   ///< in a penumbra
    uint8_t spacing : 4 = 1;  ///< its penumbra's samples per independent value (1, 2, 4 or 8)
    uint8_t direct = 0;       ///< sampled (else interpolated from the anchors of its spacing)
};
static_assert(sizeof(SoftFrame::Entry) == 24);

/// One camera ray's hit: 80 bytes.
struct SoftFrame::Sample {
    ShadingPoint sp;
    float footprint = 0;  ///< the world size of a sample on the surface there
    Color rest;           ///< the shading without the lights' terms (ambient, mirror)
    uint32_t first = 0;   ///< its entries in its tile's list, ascending by light
    uint32_t count : 31 = 0;
    uint32_t hit : 1 = 0;  ///< the camera ray hit the scene
    /// With at most 64 lights: bit l set where it needs light l, and where light l's probe
    /// reached it (the seeds' test compares neighbours by these words).
    uint64_t need = 0, lit = 0;
};
static_assert(sizeof(SoftFrame::Sample) == 80);

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

namespace soft_frame {

/// The entry of `light` among a sample's entries (ascending by light), or null.
template <typename E>
E* FindEntry(E* first, uint32_t count, uint32_t light) {
    if (count > 16) {  // many lights: halving (the entries ascend by light)
        E* at = std::lower_bound(first, first + count, light, [](const E& e, uint32_t l) { return e.light < l; });
        return at != first + count && at->light == light ? at : nullptr;
    }
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
    std::vector<LightCone> cones;  ///< MarkTile's: a pair's cone, made when first needed
    std::vector<uint8_t> made;
    std::vector<SoftFrame::Entry> entries;
    std::unique_ptr<bool[]> occluded;
    size_t room = 0;
    bool* Occluded(size_t n) {
        if (room < n) occluded.reset(new bool[room = std::max<size_t>(n, 2 * room)]);
        return occluded.get();
    }
};
Scratch& ThreadScratch();

/// Whether two neighbouring samples lie on one surface (no depth edge between them): their
/// points within 3 footprints.
inline bool Continuous(const ShadingPoint& a, float fa, const ShadingPoint& b, float fb) {
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

}  // namespace soft_frame
}  // namespace lm
