// accel_options.h -- the tuning of the ray-query back-ends (accel/), from the CLI or the
// scene file; its own header so that the back-ends need not see the other settings.
#pragma once

namespace lm {

/// Tuning of the back-ends, from the CLI or the scene file.
struct AccelOptions {
    /// Nested grid (paper §2): top-level resolution along the longest side of the scene's
    /// box; 0 picks it from the triangle count and the box's proportions.
    int gridResolution = 0;
    /// A cell with more triangles than this is subdivided into a sub-grid.
    int gridMaxTrianglesPerCell = 63;
    /// Levels of grids including the top one (the paper used 2).
    int gridMaxDepth = 2;
    /// Triangles the grid tests at once: 0 = the widest the processor has (8 with AVX2,
    /// else 4), or 4 or 8 (8 falls back to 4 without AVX2). Only tests set it: the answers
    /// are the same bit for bit, only the speed differs.
    int gridSimdWidth = 0;
};

}  // namespace lm
