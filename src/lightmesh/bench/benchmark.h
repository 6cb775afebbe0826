// benchmark.h -- `lightmesh bench`: renders a matrix of scenes × sizes × CC × kI × shadow
// methods side by side in one run, with a warm-up and the median of several runs.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "lightmesh/util/counters.h"
#include "lightmesh/settings/options.h"

namespace lm {

/// The matrix to run. Every LMM variant is run for every (CC, kI); "rt" once per
/// ray-query back-end in `accels`, and "none" (no shadows: the floor that shadow work sits
/// on) once, per scene and size.
struct BenchMatrix {
    std::vector<std::string> scenes{"builtin:gazebo"};
    std::vector<std::pair<int, int>> sizes{{1024, 768}};
    std::vector<int> cc{100};
    std::vector<float> ki{2.0f};
    std::vector<std::string> variants{"grid", "templates", "reduced", "none", "inside", "object", "consensus"};
    std::string cellSummaries = "auto";  ///< LightMeshOptions::cellSummaries for every LMM cell
    /// Back-ends for RT; the first one also serves "none" and the LMM variants, so a
    /// matrix with one back-end compares every method on the same one. Default: the
    /// render default (Embree when built with it).
    std::vector<std::string> accels{kDefaultAccelerator};
    bool noShadows = true;
    int repeat = 3;       ///< timed runs per cell, after one warm-up run
    std::string imageDir; ///< if set, each cell's image is written there as PNG
    /// --quality: per scene and size, compare every cell with a converged area-light
    /// reference (see BenchQuality).
    bool quality = false;
    int refSamples = 256;                             ///< samples of the reference
    std::vector<float> radiusFactors{0.5f, 1.0f, 2.0f};  ///< reference radii R = r·factor
    std::vector<int> areaSamples{1, 2, 4, 16, 64};    ///< naive soft shadows timed against LMM
    /// With --quality, per (CC, kI) also the default variant with contact-hardening
    /// penumbrae (method "penumbra": --shadows lmm with the light radius of the main
    /// reference, R = r of the first (CC, kI)), timed like the other cells.
    bool penumbrae = true;
    /// The penumbra cells' thin-occluder check (LightMeshOptions::thinCheck): "all" (the
    /// render default), "lit" or "off".
    std::string thinCheck = "all";
};

/// One cell of the matrix, measured.
struct BenchResult {
    std::string scene;
    int width = 0, height = 0;
    std::string method;   ///< "none", "rt", "lmm" or "penumbra" (lmm with a light radius)
    std::string variant;  ///< LMM variant name ("" otherwise)
    std::string paperName;  ///< "RT", "Grid", "Ш", … ("none" for no shadows)
    std::string accel;
    int cc = 0;
    float ki = 0;
    float lightRadius = 0;        ///< "penumbra" only
    std::string thinCheck;        ///< "penumbra" only: its --thin-check
    std::vector<double> seconds;  ///< render wall time of each timed run
    double median = 0;
    double setupSeconds = 0;      ///< shadow-method set-up of the last run (templates, mesh)
    RenderCounters counters;      ///< of the last run
    uint64_t nodesEvaluated = 0;  ///< LMM only
    uint64_t peakMemoryBytes = 0; ///< of the process, after the cell
    std::string image;            ///< the PNG written, if any
};

/// One image judged against the area-light references of its (scene, size).
struct QualityRow {
    std::string label;   ///< "RT", "Grid CC 100 kI 2", "area N=16", …
    std::string method;  ///< "rt", "lmm", "penumbra", "area"
    std::string variant;
    int cc = 0;
    float ki = 0;
    int samples = 0;     ///< area only
    double seconds = 0;  ///< median render time (area: one run)
    std::vector<double> psnr, ssim;  ///< per reference radius (BenchQuality::radii)
    long long leaks = -1;  ///< lit pixels deep inside RT's shadow (see BenchQuality); -1: n/a
};

/// --quality for one (scene, size). The reference is the "area" method with
/// `refSamples` samples, for each radius R in `radii` = r·radiusFactors where r = kI·h of
/// the first (CC, kI) of the matrix (h = longest side of the scene's box / CC); rows are
/// compared with the reference of radius `radii[mainRadius]` (R = r) in the tables, and
/// with all for the best-matching R per kI.
///
/// Leaks (approximate, in image space): a pixel is in RT's shadow where the luma of the
/// RT image is below 95% of the render without shadows (minus 0.002); the shadow's edge
/// is where that mask changes between 4-neighbours. A leak is a pixel of RT's shadow
/// farther than `radiusPixels` from the edge that a variant lights, i.e. gives back more
/// than a quarter of the light RT's shadow removed. `radiusPixels` is r projected at the
/// distance from the camera to its look-at point (one figure for the whole image).
struct BenchQuality {
    std::string scene;
    int width = 0, height = 0;
    float meshStep = 0;      ///< h of the first CC
    float radius = 0;        ///< r = kI·h of the first (CC, kI)
    float radiusPixels = 0;
    int refSamples = 0;
    std::vector<float> radii;
    std::vector<double> refSeconds;  ///< per radius
    size_t mainRadius = 0;
    std::string refImage;  ///< the main reference as PNG, when the cells' images are written
    std::vector<QualityRow> rows;
};

/// Everything one run measured.
struct BenchReport {
    std::vector<BenchResult> results;
    std::vector<BenchQuality> quality;  ///< empty without --quality
    int repeat = 0;
};

/// Runs the matrix; `progress` is called after each cell with (done, total, result).
/// `estimate` (if given) is called once before the matrix runs with a rough estimate of
/// the total seconds: one RT render per scene at the first size is timed and every cell
/// extrapolated from it by its pixels and a cost model of the method (LMM ≈ 0.5·kI²×RT,
/// area with N samples ≈ (0.5 + 0.5·N)×RT). Scenes are all loaded first, so a missing
/// model fails before any work.
BenchReport RunBenchmarkReport(const BenchMatrix& matrix,
                               const std::function<void(int, int, const BenchResult&)>& progress = nullptr,
                               const std::function<void(double)>& estimate = nullptr);

/// The results of RunBenchmarkReport only.
std::vector<BenchResult> RunBenchmark(
    const BenchMatrix& matrix,
    const std::function<void(int, int, const BenchResult&)>& progress = nullptr);

/// The presets of `bench --table N` (N = 1..4) reproducing the paper's tables 1–4 (method
/// note §6) on the scenes of `repoDir`/scenes/real. `quick` divides every size by 4 in
/// each dimension and sets repeat to 1. Throws Error for another N or a missing scene file.
BenchMatrix BenchTablePreset(int table, bool quick, const std::string& repoDir);

/// Reads a matrix from JSON: {"scenes": [...], "sizes": [[w,h],...], "cc": [...],
/// "ki": [...], "variants": [...], "accels": [...], "repeat": N}; every key optional (the
/// BenchMatrix defaults). Relative scene paths are relative to the file's folder. Throws
/// Error naming the file and the JSON path (e.g. "m.json /sizes/1: expected [width, height]").
BenchMatrix LoadBenchMatrix(const std::string& path);

/// The quality tables (PSNR/SSIM, reference radius sweep, naive soft shadows) as Markdown.
std::string BenchQualityMarkdown(const BenchReport& report);

/// A self-contained HTML report: tables, inline SVG charts of seconds and of LMM/RT against
/// kI, and (if the cells have images) the images side by side, base64-embedded, each with a
/// zoomed crop of the window where RT and the LMM images differ most.
std::string BenchHtml(const BenchReport& report, const std::string& title = "lightmesh bench");

/// Tables laid out like the paper's: per scene and size, rows (CC, kI), columns RT and the
/// variants in seconds; then the ratios variant/RT, Ш/Grid, У/Ш, СТ/ОТ, СТ/Нет.
std::string BenchMarkdown(const std::vector<BenchResult>& results);

/// One line per cell with every measured figure.
std::string BenchCsv(const std::vector<BenchResult>& results);

/// Median of a non-empty list.
double Median(std::vector<double> values);

}  // namespace lm
