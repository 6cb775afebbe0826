// compare.h -- image quality metrics (PSNR, SSIM, RMSE, max difference) and false-colour
// difference images, for `lightmesh compare` and the quality report of `lightmesh bench`.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "lightmesh/io/image.h"

namespace lm {

/// Differences between two images of the same size.
///
/// Units. Every figure but rmseLinear is computed on display values: each linear channel
/// clamped to [0, 1] and sRGB-encoded with the exact (not 8-bit) transfer curve, so a PNG
/// and an EXR of one render compare the same way, and the figures speak of what a viewer
/// sees (the question when judging LMM against the reference). PSNR = 10·log10(1 / MSE)
/// with MSE the mean over the included pixels and the three channels, so
/// PSNR = −20·log10(rmse). It is +infinity when the images are equal on display.
struct ImageMetrics {
    double psnr = 0;        ///< dB; std::isinf(psnr) for equal images
    double ssim = 0;        ///< mean SSIM of the luma (Wang et al. 2004), in [-1, 1]
    double rmse = 0;        ///< root mean squared difference of display values
    double rmseLinear = 0;  ///< the same on unclamped linear values
    double maxDiff = 0;     ///< largest |difference| of one channel's display value
    size_t pixels = 0;      ///< pixels compared (all, or the mask's, finite in both)
    int width = 0, height = 0;
    /// Pixels (of the mask's) with a NaN or infinite channel in A, in B, and in B where A's
    /// is finite. They are left out of every figure: a NaN is no colour to measure (it was
    /// compared as 0, and an all-NaN image judged as black).
    size_t nonFiniteA = 0, nonFiniteB = 0, nonFiniteOnlyInB = 0;
    /// Equal on display, with no non-finite pixel in either.
    bool Identical() const { return rmse == 0 && nonFiniteA == 0 && nonFiniteB == 0; }
};

/// The memory `lightmesh compare` takes per pixel at its peak: each image read (12 bytes of
/// float RGB; two, and one each for a mask and --no-shadows) and CompareImages's planes
/// (seven of doubles, and the blur's two). Past half the budget a comparison is refused
/// before an image is read.
inline constexpr uint64_t kCompareBytesPerPixel = 72;
inline uint64_t CompareBytes(uint64_t pixels, int images) {
    return pixels * (kCompareBytesPerPixel + 12 * static_cast<uint64_t>(images));
}

/// Compares `a` with `b`. With a mask (same size), only the pixels where the mask is not
/// black are compared: where one of its channels is above 0 (NaN and negative are black). SSIM uses an 11×11 Gaussian window (σ = 1.5), K1 = 0.01,
/// K2 = 0.03, on the luma Y' = 0.2126 R' + 0.7152 G' + 0.0722 B' of the display values;
/// the window is cut at the image's border and its weights renormalised (so any size
/// works), and the SSIM map is averaged over the compared pixels. Pixels with a NaN or
/// infinite channel in either image are counted (nonFiniteA, nonFiniteB) and left out of
/// every figure (in the SSIM windows of their neighbours they count as their display values,
/// clamped: NaN as 0). Throws Error if the sizes differ (naming both), an image is empty,
/// the mask selects no pixel, or no selected pixel is finite in both images.
ImageMetrics CompareImages(const Image& a, const Image& b, const Image* mask = nullptr);

/// Writes a false-colour image of where `a` and `b` differ: per pixel the largest
/// |difference| of a channel's display value, divided by `scale` (or by the largest
/// difference when scale <= 0), through Google's Turbo colour map (dark blue = equal, dark
/// red = the scale or more). Pixels outside the mask are black. Throws Error as
/// CompareImages and WriteImage do.
void WriteDiffImage(const std::string& path, const Image& a, const Image& b, float scale = 0,
                    const Image* mask = nullptr);

/// One JSON line (no newline) of the metrics, for scripts:
/// {"a":"x.png","b":"y.png","psnr":41.2,"ssim":0.987,"rmse":0.0031,"rmse_linear":0.001,
///  "max_diff":0.2,"pixels":480000,"nonfinite_a":0,"nonfinite_b":0,"identical":false}.
/// Equal images have "psnr":null and "identical":true (JSON has no infinity).
std::string ImageMetricsJson(const ImageMetrics& m, const std::string& a, const std::string& b);

/// Σ over the image of (none − img) in linear luminance (Rec. 709 weights): the light the
/// image's shadows take away from the same render without shadows. The ratio of two
/// images' totals says whether one has too little shadow (below 1) or too much; a hard
/// shadow moves light around its edges but keeps the total. Pixels where the difference is
/// NaN or infinite are left out. Throws Error if the sizes differ.
double ShadowTotal(const Image& none, const Image& img);

/// Turbo (Mikhailov 2019), Ruofei Du's polynomial fit: x in [0, 1] → sRGB in [0, 1].
Color TurboColormap(float x);

}  // namespace lm
