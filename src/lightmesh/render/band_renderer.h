// band_renderer.h -- renderers whose pixels read their neighbours' data (a shadow filter,
// penumbrae found between neighbouring pixels): they render whole bands of image rows, each
// with the apron of rows it reads, instead of independent tiles.
#pragma once

#include "lightmesh/io/image.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/util/counters.h"
#include "lightmesh/util/progress.h"

namespace lm {

class BandRenderer {
  public:
    virtual ~BandRenderer() = default;
    /// Image rows [y0, y1) into the same rows of *image (of the render's size), computing
    /// what they read of the rows around them. Any band gets the whole image's bytes (a
    /// pixel depends on a fixed neighbourhood, never on the band), so MPI ranks render bands.
    /// `progress` gets one unit per WhittedRenderer tile of the band; once it is Stopped(),
    /// the soft frame leaves its remaining rows undone. With `visibility` (of the render's
    /// size and light count), the rows' per-light visibility at the camera hits goes there
    /// too (VisibilityImage).
    virtual void RenderRows(int y0, int y1, Image* image, RenderCounters& counters,
                            ProgressReporter* progress = nullptr, VisibilityImage* visibility = nullptr) const = 0;
    /// The whole image as one band, timed.
    RenderResult Render(int width, int height, ProgressReporter* progress = nullptr,
                        VisibilityImage* visibility = nullptr) const;
};

}  // namespace lm
