// soft_frame.h -- "--shadows soft", the default: soft shadows of spherical lights at about
// the price of hard ones, by sharing one shadow ray per pixel and light between
// neighbouring pixels (render/penumbra_classifier.h) and sampling only the penumbrae.
//
// Per light, every camera hit traces one ray to the light's centre (its probe, in packets).
// Where the probes of two neighbouring samples of one surface disagree, the blocked one's
// probe has met an occluder near its silhouette; the hits whose cone to the light's sphere
// holds such a point are in a penumbra and get N stratified rays to the sphere (the area
// reference's estimate; the rays of a point form packets). Every other hit sees all of the
// light or none of it, and its probe says which: one ray, no list, no per-point query.
// Mirror hits (not camera hits) take N rays per light like area's.
//
// The image is processed as a stream of rows of tiles: a tile's hits and probes, then its
// seeds (which read the neighbouring tiles' probes), then its penumbrae (which read the
// seeds within kReach samples) and its pixels; only the rows those steps need are kept.
// A hit's value depends on the hits within kReach + a tile of it, never on the threads or
// the order: any band of rows rendered with its apron is the whole image's band, bit for
// bit (MPI ranks render bands).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lightmesh/render/band_renderer.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/shadow/disc_pattern.h"

namespace lm {

/// Slots of RenderCounters::method the soft default fills.
enum SoftFrameCount : size_t {
    kSoftFrameLookups,  ///< (camera hit, light) pairs answered
    kSoftFrameSeeds,    ///< ... whose probe disagrees with a neighbour's
    kSoftFrameMarked,   ///< ... whose cone holds a silhouette point: sampled
    kSoftFramePartial,  ///< ... sampled and neither wholly lit nor wholly hidden
    kSoftFrameSilhouettes,  ///< silhouette points found (blocked seeds)
    kSoftFrameDirect,   ///< marked pairs sampled (the others interpolated)
};

class SoftFrame final : public BandRenderer {
  public:
    /// `renderer` (whose shadow method shades the mirrors' hits), `scene` and `accel` must
    /// outlive it. radii: LightRadii. samples: rays per light in a penumbra (multiple of 4).
    SoftFrame(const Scene& scene, const Accelerator& accel, const WhittedRenderer& renderer,
              const RenderOptions& options, std::vector<float> radii, int samples);

    /// The whole image (one band).
    RenderResult Render(ProgressReporter* progress = nullptr) const {
        return BandRenderer::Render(options_.width, options_.height, progress);
    }
    void RenderRows(int y0, int y1, Image* image, RenderCounters& counters, ProgressReporter* progress = nullptr,
                    VisibilityImage* visibility = nullptr) const override;

    /// The farthest a silhouette point found at one sample marks others, in samples.
    static constexpr int kReach = 64;
    /// Lines for --stats.
    std::vector<std::pair<std::string, std::string>> CounterLines(const RenderCounters& counters) const;

    struct Entry;   ///< one (camera hit, light) pair (soft_frame.cpp)
    struct Sample;  ///< one camera ray's hit

  private:
    struct Tile;
    struct TileSeeds;
    struct Window;
    void ShadeTile(Window& w, int row, int col, RenderCounters& c) const;
    void SeedTile(Window& w, int row, int col, RenderCounters& c) const;
    void MarkTile(Window& w, int row, int col, RenderCounters& c) const;
    void SampleTile(Window& w, int row, int col, RenderCounters& c) const;
    void ComposeTile(Window& w, int row, int col, int y0, int y1, Image* image, VisibilityImage* visibility) const;
    void RecordVisibility(const Tile& t, int px, int py, VisibilityImage* visibility) const;
    void CheckMemory(Window& w) const;
    bool Interpolable(Window& w, const Sample& s, uint32_t light, int x, int y, int spacing) const;

    const Scene& scene_;
    const Accelerator& accel_;
    const WhittedRenderer& renderer_;
    const RenderOptions options_;
    const std::vector<float> radii_;
    const int samples_;
    DiscPattern pattern_;
    float sampleAngle_ = 0;  ///< the camera's angle per sample (vertical), radians
    int tilePixels_ = 16;    ///< pixels per side of a tile
    int tileSamples_ = 16;   ///< samples per side of a tile (tilePixels_ · aa)
    int reachTiles_ = 4;     ///< tiles a silhouette point reaches
};

}  // namespace lm
