// shadow_denoiser.h -- the soft shadows a renderer would trace today ("--shadows
// denoised"): N stratified shadow rays per light to its sphere (area's rays), then a
// shadow-only denoiser per light, in the manner of NVIDIA's SIGMA (NRD) and Heitz, Hill and
// McGuire's ratio estimator (2018):
//   - the ratio estimator: what is filtered is each light's visibility weighted by its
//     unshadowed term, and the result multiplies the unshadowed term back, so textures,
//     shading and everything but the shadow stay as sharp as the rays made them;
//   - the footprint of the filter at each pixel is the penumbra's width there, estimated
//     from the distance of the blockers the rays met and the light's radius (for a blocker
//     at distance b from the point and the light's centre at d, the penumbra's half width is
//     R·b/(d − b)), projected to pixels;
//   - edge stops: a neighbour counts only on the pixel's plane (within its footprint) and
//     with a normal within 25° of the pixel's;
//   - no blur where the neighbourhood's rays all agree (all lit or all shadowed).
// The image is the camera hits' shading split in two (WhittedRenderer::ShadeSplit): the
// lights' terms, whose visibility is filtered, and the rest (ambient, mirror), as rendered.
// Mirror reflections keep area's noisy N-ray shadows (only the camera hits are filtered).
//
// Determinism: a pixel's noisy data depends on the pixel alone (area's per-point seeds),
// and a filtered pixel on the noisy data within kApron rows and columns of it (blocks on
// the image's grid), so any band of rows rendered with its apron is the whole image's
// band bit for bit: threads, and MPI ranks rendering bands, give the same bytes.
#pragma once

#include <cstddef>
#include <vector>

#include "lightmesh/render/band_renderer.h"
#include "lightmesh/render/whitted.h"

namespace lm {

/// The filter's fixed sizes.
inline constexpr int kDenoiseBlock = 8;              ///< pixels per side of the blocks that classify the image
inline constexpr float kDenoiseMaxRadius = 32.0f;    ///< the widest footprint, in pixels (its radius)
/// The floor of a footprint's radius, in pixels: a penumbra of half width r is filtered at
/// max(r, min(2r, kDenoiseMinRadius)). The pixel grid, not the penumbra, bounds how fine the
/// filter can usefully be (Mehta et al. 2012 take the smaller of the shadow's and the
/// pixels' bandwidths): under it the passes' taps round to the pixel itself.
inline constexpr float kDenoiseMinRadius = 1.5f;
inline constexpr int kDenoiseTaps = 16;              ///< taps per pass besides the centre (two passes)
/// Rows of noisy data computed above and below a band. Its filtered pixels read at most 48
/// rows away (the second pass 16, the first 32, a pixel's blocks 15); the apron is kept at
/// two full passes of the widest footprint plus the blocks, rounded up to whole tiles.
inline constexpr int kDenoiseApron = 96;
static_assert(kDenoiseApron >= 2 * 32 + 3 * kDenoiseBlock && kDenoiseApron % WhittedRenderer::kTileSize == 0);

/// The geometry of a region of the image (rows y0 .. y0 + height − 1, all columns), per
/// pixel: the first camera hit's point, unit geometric normal, and its footprint (the
/// world size of a pixel there; 0 where the camera ray missed).
struct DenoiseFrame {
    int width = 0, height = 0;
    int y0 = 0;  ///< the region's first row in the image: blocks and tap patterns use image coordinates
    std::vector<Vec3> position, normal;
    std::vector<float> footprint;
    size_t Index(int x, int y) const { return static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x); }
};

/// One light's noisy shadow over a DenoiseFrame, per pixel.
struct DenoiseLayer {
    /// The ratio Σ V·w / Σ w over the pixel's camera hits, in [0, 1] (V: the fraction of
    /// the hit's rays that reached the light; w: the luminance of its unshadowed term).
    std::vector<float> visibility;
    /// Σ w per camera ray: the filter's weight (0: the light does not reach the pixel).
    std::vector<float> weight;
    /// The penumbra's estimated half width in pixels where some ray was blocked, else −1.
    std::vector<float> penumbra;
};

/// The denoised visibility of rows [outY0, outY1) of the region (region rows), row after
/// row into out. Pixels whose 3 × 3 blocks (kDenoiseBlock, on the image's grid) hold only
/// fully lit or only fully shadowed values, or whose footprint is under half a pixel, keep
/// their value bit for bit. The others: two passes (radius r, then r/2; r = scale × the
/// mean penumbra of the blocked pixels in those blocks, averaged with the pixel's own
/// where it has one, raised to min(2r, kDenoiseMinRadius), at most kDenoiseMaxRadius) of a
/// Gaussian-weighted disc of kDenoiseTaps taps turned per pixel, the ratio estimator
/// Σ k·w·V / Σ k·w with the edge stops. A filtered pixel reads the noisy data within 48
/// rows and columns.
/// `scale`: ShadowDenoiser passes 1/√N for N rays per light (less noise, less blur).
void FilterShadowLayer(const DenoiseFrame& frame, const DenoiseLayer& layer, int outY0, int outY1, float* out,
                       float scale = 1.0f);

/// Renders "--shadows denoised": the Whitted image with each camera hit's lights'
/// visibility from options.areaLight.samples stratified rays per light (area's rays and
/// seeds), filtered by FilterShadowLayer, and the rest of its shading from `renderer`.
class ShadowDenoiser final : public BandRenderer {
  public:
    /// `renderer` (whose shadow method renders the mirrors' shadows), `scene` and `accel`
    /// must outlive it. radii: LightRadii. Throws Error for bad options or radii.
    ShadowDenoiser(const Scene& scene, const Accelerator& accel, const WhittedRenderer& renderer,
                   const RenderOptions& options, std::vector<float> radii);

    /// The whole image (one band, no apron).
    RenderResult Render(ProgressReporter* progress = nullptr) const {
        return BandRenderer::Render(options_.width, options_.height, progress);
    }
    /// Image rows [y0, y1) into the same rows of *image (of the render's size), from the
    /// noisy data of rows [y0 − kDenoiseApron, y1 + kDenoiseApron) (clipped to the image).
    /// `progress` gets one unit per tile of the band's rows. Throws Error when the band's
    /// buffers would need more than half the memory budget.
    void RenderRows(int y0, int y1, Image* image, RenderCounters& counters, ProgressReporter* progress = nullptr,
                    VisibilityImage* visibility = nullptr) const override;

    /// Bytes of buffers per pixel of a band (and its apron).
    size_t BytesPerPixel() const;

  private:
    /// Light `light`'s visibility from sp by area's rays and seeds (rt's ray for a point
    /// light); where some ray is blocked, *penumbra gets the penumbra's half width in
    /// pixels of `footprint` (the world size of a pixel at sp). rays, hits: samples each.
    float NoisyVisibility(const ShadingPoint& sp, size_t light, float footprint, Ray* rays, Hit* hits, float* penumbra,
                          RenderCounters& counters) const;

    const Scene& scene_;
    const Accelerator& accel_;
    const WhittedRenderer& renderer_;
    const RenderOptions options_;
    const std::vector<float> radii_;
    float pixelAngle_ = 0;  ///< the camera's angle per pixel (vertical), radians
};

}  // namespace lm
