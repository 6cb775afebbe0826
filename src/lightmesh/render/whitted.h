// whitted.h -- Whitted ray tracing, formula (1) of the paper, with a pluggable shadow term.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/light_cut.h"
#include "lightmesh/render/light_lists.h"
#include "lightmesh/render/light_terms.h"
#include "lightmesh/render/visibility_image.h"
#include "lightmesh/util/counters.h"
#include "lightmesh/settings/options.h"
#include "lightmesh/scene/camera.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/progress.h"

namespace lm {

struct RenderResult {
    Image image;
    RenderCounters counters;
    double seconds = 0;  ///< wall time of the pixel loop
};

/// Renders I(P) = A·kd + Σ_i V_i·Ω(i, P) + mirror·I_r at the nearest hit P of each camera
/// ray, recursing along mirror rays up to RenderOptions::maxDepth. V_i comes from the
/// ShadowMethod: one shadow ray (formula (1), "rt"), or the light mesh (formula (2)).
class WhittedRenderer {
  public:
    /// Throws Error for a degenerate camera or a bad image size. Any number of lights.
    WhittedRenderer(const Scene& scene, const Accelerator& accel, const ShadowMethod& shadows,
                    const RenderOptions& options);

    /// Radiance arriving along `ray`; depth counts the rays already followed.
    Color Li(const Ray& ray, int depth, RenderCounters& counters) const;
    /// Li for a ray whose closest hit is already known.
    Color Shade(const Ray& ray, const Hit& hit, int depth, RenderCounters& counters) const;

    /// The value of pixel (x, y): the mean over aa × aa sub-pixel camera rays.
    Color Pixel(int x, int y, RenderCounters& counters) const;

    /// Renders the whole image in parallel over kTileSize² tiles. Every pixel depends only
    /// on its own rays, so the image is the same for any number of threads (or processes:
    /// RenderTile renders any subset of the tiles into the same pixels). With `progress`,
    /// kEstimateTiles tiles spread over the image (SpreadOverGrid) are rendered first, the
    /// reporter's sample for its estimate (ProgressReporter::BeginWork); once it says
    /// Stopped() (its RefuseIfLonger limit passed), no more tiles are rendered. With
    /// `visibility` (of the render's size and light count), each pixel's lights' visibility
    /// at its camera hits goes there too (VisibilityImage).
    RenderResult Render(ProgressReporter* progress = nullptr, VisibilityImage* visibility = nullptr) const;
    static constexpr int kEstimateTiles = 64;
    /// Tiles of the image, row by row: tile t covers the pixels from
    /// ((t % tilesX)·kTileSize, (t / tilesX)·kTileSize), clipped to the image.
    static constexpr int kTileSize = 16;
    int Width() const { return options_.width; }
    int Height() const { return options_.height; }
    int TilesX() const { return (options_.width + kTileSize - 1) / kTileSize; }
    int TileCount() const { return TilesX() * ((options_.height + kTileSize - 1) / kTileSize); }
    /// The per-cell lists of the lights with a range (inactive when no light has one).
    const LightLists& Lists() const { return lightLists_; }
    /// The light cut's hierarchy, or null where every light is shaded.
    const LightCuts* Cuts() const { return cuts_.get(); }
    /// The pixels of one tile into *image (of the render's size): Pixel()'s values, with the
    /// camera rays of kPacketSize × kPacketSize pixels traced together (IntersectMany).
    /// With an origin, pixel (x, y) goes to image->At(x - originX, y - originY) instead
    /// (a tile-sized scratch image). With `visibility` (the render's size, no origin), the
    /// tile's pixels of it are written as well.
    void RenderTile(int tile, Image* image, RenderCounters& counters, int originX = 0, int originY = 0,
                    VisibilityImage* visibility = nullptr) const;
    /// The seconds the whole render would take, from `samples` of its tiles spread evenly
    /// over the image (SpreadOverGrid; all of them if it has no more), rendered in parallel into scratch
    /// images in two interleaved halves: the faster half's wall time per tile × tiles.
    /// `bench` estimates its matrix so; the lazily evaluated work a render shares
    /// between neighbouring tiles (the light mesh's nodes) is shared less among spread
    /// tiles, so the figure errs high. With `maxSeconds` > 0 each half starts no tile past
    /// half of it (each does one at least) and counts the tiles it did: a slow render is
    /// estimated in about that time, from a spread prefix of the sample.
    double EstimateSeconds(int samples, double maxSeconds = 0) const;
    static constexpr int kPacketSize = 8;

    /// The camera ray of sub-pixel (sx, sy) of pixel (x, y), as Pixel() and RenderTile make it.
    Ray CameraRay(int x, int y, int sx, int sy) const { return camera_.Generate(SubPixel(x, sx), SubPixel(y, sy)); }
    /// A hit's shading split around its lights' visibility, for a caller that computes and
    /// filters the visibility itself (the shadow denoiser): the lights that light the hit,
    /// litIds[0 .. *litCount-1] (ascending), with their unshadowed terms omega[k], and *rest
    /// gets the other terms (A·kd and the mirror's, whose shadows come from the renderer's
    /// method). Shade() gives rest plus Σ omega[k]·V(litIds[k]). omega and litIds have room
    /// for one entry per light. Returns the shading point.
    ShadingPoint ShadeSplit(const Ray& ray, const Hit& hit, Color* omega, uint32_t* litIds, uint32_t* litCount,
                            Color* rest, RenderCounters& counters) const;

    /// Builds the shading point for a hit of `ray` (also used by tests and the shadow
    /// methods' tests), and its shading normal into *shadingNormal when given: the
    /// interpolated vertex normals where the mesh has them (then the origin starts from the
    /// point lifted to the vertices' tangent planes, geometry/shadow_terminator.h), else the
    /// triangle's, on the side the ray came from.
    static ShadingPoint MakeShadingPoint(const TriangleMesh& mesh, const Ray& ray, const Hit& hit,
                                         Vec3* shadingNormal = nullptr);

  private:
    /// A hit's shading before its lights' visibility is known (formula (1)'s terms).
    struct Lighting {
        ShadingPoint sp;
        Vec3 ns;  ///< shading normal
        const Material* mat = nullptr;
        Color kd;  ///< the diffuse reflectance here (the material's, or its texture's)
        /// The lights whose term is not black (in range, facing P): their visibility is
        /// needed. lit[k] (ascending) and its unshadowed term omega[k], k < litCount, in
        /// storage of the caller (TileBuffers, Shade) with room for every light.
        uint32_t* lit = nullptr;
        Color* omega = nullptr;
        uint32_t litCount = 0;
        LightIndices Lights() const { return {lit, litCount}; }
    };
    /// Hits shaded together in RenderTile: the points whose visibility one
    /// ShadowMethod::VisibilityMany call computes.
    static constexpr size_t kShadingBatch = 64;
    /// RenderTile's buffers, one set per thread, kept from tile to tile.
    struct TileBuffers {
        std::vector<Ray> rays;
        std::vector<Hit> hits;
        std::vector<Color> colors;
        std::vector<Lighting> batch;
        // The points whose visibility is needed: the point, its lights and where their
        // values go (VisibilityMany's arguments).
        std::vector<ShadingPoint> points;
        std::vector<LightIndices> lists;
        std::vector<float*> visOut;
        std::vector<int> pixelHits;  // with a visibility image: the packet's pixels' camera hits
        size_t roomLights = 0;
        // The batch's Lighting terms and values: room for kShadingBatch × lights each
        // (Lighting points into them); only the entries of the lights lit are touched.
        std::unique_ptr<Color[]> litOmega;
        std::unique_ptr<uint32_t[]> litIds;
        std::unique_ptr<float[]> litVis;
        bool inUse = false;  // a RenderTile on this thread holds them
        void Reserve(size_t lights) {
            if (batch.size() < kShadingBatch)
                batch.resize(kShadingBatch), points.resize(kShadingBatch), lists.resize(kShadingBatch),
                    visOut.resize(kShadingBatch);
            if (!litOmega || roomLights < lights) {
                roomLights = std::max<size_t>(lights, 1);
                litOmega.reset(new Color[kShadingBatch * roomLights]);
                litIds.reset(new uint32_t[kShadingBatch * roomLights]);
                litVis.reset(new float[kShadingBatch * roomLights]);
            }
            for (size_t i = 0; i < kShadingBatch; ++i) {
                batch[i].omega = litOmega.get() + i * roomLights;
                batch[i].lit = litIds.get() + i * roomLights;
            }
        }
        float* Vis(size_t slot) const { return litVis.get() + slot * roomLights; }
    };
    /// Shade, before and after the visibility: PrepareShading fills *lit (and counts the
    /// shading point); FinishShading adds the lights' terms times vis and the mirror's.
    void PrepareShading(const Ray& ray, const Hit& hit, Lighting* lit, RenderCounters& counters) const;
    Color FinishShading(const Ray& ray, const Lighting& lit, const float* vis, int depth,
                        RenderCounters& counters) const;

    /// Position of sub-pixel s (of aa) in pixel coordinate i: the centre of the s-th of aa
    /// equal parts.
    float SubPixel(int i, int s) const {
        return static_cast<float>(i) + (static_cast<float>(s) + 0.5f) / static_cast<float>(options_.aa);
    }

    const Scene& scene_;
    const Accelerator& accel_;
    const ShadowMethod& shadows_;
    const RenderOptions options_;
    CameraRays camera_;
    float spread_ = 0;  ///< radians between neighbouring camera rays (textures' footprints)
    LightLists lightLists_;  // the lights near each cell, where lights have a range
    LightTerms lightTerms_;  // the lights' arrays for their terms at a point
    std::unique_ptr<LightCuts> cuts_;  // with a light cut: its hierarchy (else every light)
};

}  // namespace lm
