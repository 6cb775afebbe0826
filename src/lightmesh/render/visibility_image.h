// visibility_image.h -- an optional output of a render: per pixel and per light, the
// visibility the shadow method gave the pixel's camera hits (the V_i of formula (1) that
// multiplied the light's term when the primary hit was shaded), averaged over the pixel's
// anti-aliasing samples. Renders without one do no work for it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lm {

/// Values of pixel (x, y): values[(y·width + x)·lights + l] for light l. A pixel none of
/// whose camera rays hit the scene is NaN for every light; a light that does not light a
/// hit (behind its surface, or beyond the light's range) counts 0 there. The mean is over
/// the pixel's samples that hit the scene, in sample order (the same bytes for any thread
/// count). "--shadows denoised" records its filtered value per pixel: the one the pixel's
/// mean unshadowed term was multiplied by.
struct VisibilityImage {
    int width = 0, height = 0;
    size_t lights = 0;
    std::vector<float> values;

    /// Allocates width × height × lights values; throws Error past half the machine's memory.
    VisibilityImage(int width, int height, size_t lights);
    float* At(int x, int y) {
        return values.data() + (static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * lights;
    }
};

/// A pixel's values are accumulated in place: zeroed, then each camera hit's values of the
/// lights it lists added (AddVisibility; the others count 0), then FinishVisibility divides
/// by the hits, or writes NaN where there were none.
inline void AddVisibility(float* out, const uint32_t* ids, const float* vis, size_t count) {
    for (size_t k = 0; k < count; ++k) out[ids[k]] += vis[k];
}
void FinishVisibility(float* out, size_t lights, int hits);

}  // namespace lm
