// benchmark.h -- `lightmesh bench`: renders a matrix of scenes × sizes × CC × kI × shadow
// methods side by side in one run, with a warm-up and the median of several runs.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "lightmesh/render/counters.h"

namespace lm {

/// The matrix to run. Every LMM variant is run for every (CC, kI); "rt" once per
/// ray-query back-end in `accels`, and "none" (no shadows: the floor that shadow work sits
/// on) once, per scene and size.
struct BenchMatrix {
    std::vector<std::string> scenes{"builtin:gazebo"};
    std::vector<std::pair<int, int>> sizes{{1024, 768}};
    std::vector<int> cc{100};
    std::vector<float> ki{2.0f};
    std::vector<std::string> variants{"grid", "templates", "reduced", "none", "inside", "object"};
    std::vector<std::string> accels{"grid"};  ///< first one is used for the LMM variants
    bool noShadows = true;
    int repeat = 3;       ///< timed runs per cell, after one warm-up run
    std::string imageDir; ///< if set, each cell's image is written there as PNG
};

/// One cell of the matrix, measured.
struct BenchResult {
    std::string scene;
    int width = 0, height = 0;
    std::string method;   ///< "none", "rt" or "lmm"
    std::string variant;  ///< LMM variant name ("" otherwise)
    std::string paperName;  ///< "RT", "Grid", "Ш", … ("none" for no shadows)
    std::string accel;
    int cc = 0;
    float ki = 0;
    std::vector<double> seconds;  ///< render wall time of each timed run
    double median = 0;
    double setupSeconds = 0;      ///< shadow-method set-up of the last run (templates, mesh)
    RenderCounters counters;      ///< of the last run
    uint64_t nodesEvaluated = 0;  ///< LMM only
    uint64_t peakMemoryBytes = 0; ///< of the process, after the cell
    std::string image;            ///< the PNG written, if any
};

/// Runs the matrix; `progress` is called after each cell with (done, total, result).
std::vector<BenchResult> RunBenchmark(
    const BenchMatrix& matrix,
    const std::function<void(int, int, const BenchResult&)>& progress = nullptr);

/// Tables laid out like the paper's: per scene and size, rows (CC, kI), columns RT and the
/// variants in seconds; then the ratios variant/RT, Ш/Grid, У/Ш, СТ/ОТ, СТ/Нет.
std::string BenchMarkdown(const std::vector<BenchResult>& results);

/// One line per cell with every measured figure.
std::string BenchCsv(const std::vector<BenchResult>& results);

/// Median of a non-empty list.
double Median(std::vector<double> values);

}  // namespace lm
