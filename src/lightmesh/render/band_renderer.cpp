#include "lightmesh/render/band_renderer.h"

#include <chrono>

namespace lm {

RenderResult BandRenderer::Render(int width, int height, ProgressReporter* progress, VisibilityImage* visibility) const {
    RenderResult result;
    result.image = Image(width, height);
    const auto start = std::chrono::steady_clock::now();
    RenderRows(0, height, &result.image, result.counters, progress, visibility);
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

}  // namespace lm
