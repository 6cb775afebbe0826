// benchmark.h -- `lightmesh bench`: renders a matrix of scenes × sizes × CC × kI × shadow
// methods side by side in one run, with a warm-up and the median of several runs.
#pragma once

#include <atomic>
#include <functional>
#include <limits>
#include <optional>
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
    /// The default shadow method ("soft", what `render` does without options) timed once per
    /// scene and size beside RT. `lightmesh bench` and a matrix file turn it on unless their
    /// variants list leaves "soft" out (TakeSoftFromVariants: --variants soft asks for it
    /// alone); the paper's tables leave it out; with --quality its competitors' table times
    /// it instead. Off for a matrix built in code.
    bool soft = false;
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
    /// With --quality, per scene and size also the default shadow method against its
    /// competitors (BenchCompetitors): RT, "soft", the paper's LMM (the default variant,
    /// CC 100, kI 2) and naive area sampling with these N per light, all on the renderer's
    /// default back-end and timed round-robin with the matrix's cells, judged against an
    /// "area" reference of `refSamples` samples with the same light radii, drawn from
    /// rotations of its own. The default measures area up to the reference's own N, so the
    /// N at which area matches soft is measured, not extrapolated, below 256.
    std::vector<int> competitorSamples{1, 2, 4, 8, 16, 32, 64, 128, 256};
    /// With --quality, also the competitor a renderer would pick today: "denoised" (N rays
    /// per light, then the shadow denoiser) with these N, beside the area rows.
    std::vector<int> denoisedSamples{1, 2, 4};
    /// The competitors table's light radii: unset, each light's own (the scene's, as
    /// `render` uses them); set (bench --light-radius), every light this radius. The
    /// paper's-table rows (QualityRadius) are not affected.
    std::optional<float> lightRadius;
    /// Where each CC and kI value came from ("--cc", "m.json /cc/2", "bench --table 1"),
    /// by index into cc and ki, so a value the light mesh refuses (too large for memory) is
    /// named where it was given; empty: the defaults.
    std::vector<SourceLoc> ccOrigins, kiOrigins;
    /// Refuse a matrix estimated to take longer than this many seconds (0: no limit; the
    /// CLI's default is kBenchLimitSeconds, --force lifts it).
    double maxSeconds = 0;
    /// Once *stop is true (a front end's Ctrl-C), no further render starts: RunBenchmarkReport
    /// throws Error ("bench: stopped") before its next one. Null: never.
    const std::atomic<bool>* stop = nullptr;
};

/// `bench` refuses a matrix estimated above this (one hour) unless --force is given.
inline constexpr double kBenchLimitSeconds = 3600;

/// One cell of the matrix, measured.
struct BenchResult {
    std::string scene;
    int width = 0, height = 0;
    std::string method;   ///< "none", "rt", "lmm", "penumbra" (lmm with a light radius), "soft" or "area"
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
    int samples = 0;              ///< "area" only: shadow rays per light and point
    /// "" for a cell of the matrix; "competitor": a cell added for the default-vs-competitors
    /// table only (the matrix's tables leave it out); "reference": that table's area-light
    /// reference (rendered once after the round-robin, one run). Matrix cells the table
    /// reuses (RT, the LMM default at CC 100, kI 2) stay "".
    std::string role;
    /// A row of the default-vs-competitors table (BenchCompetitors): its PSNR (dB; 99 for
    /// an image equal to the reference), SSIM and shadow total against that table's
    /// reference; NaN for the other cells.
    double refPsnr = std::numeric_limits<double>::quiet_NaN();
    double refSsim = std::numeric_limits<double>::quiet_NaN();
    double shadowRatio = std::numeric_limits<double>::quiet_NaN();
};

/// One row of the default-vs-competitors table.
struct CompetitorRow {
    std::string label;   ///< "RT", "soft (default)", "LMM consensus CC 100 kI 2", "area N=4", "reference area N=256"
    std::string method;  ///< "rt", "soft", "exact", "lmm", "area", "denoised"
    int samples = 0;     ///< "area", "denoised": rays per light
    bool reference = false;  ///< the reference itself (one run, not in the round-robin)
    double seconds = 0;  ///< median render time of the interleaved runs (the reference: its one run)
    size_t runs = 0;     ///< timed runs behind `seconds`
    double setupSeconds = 0;  ///< the shadow method's set-up (not in `seconds`)
    double psnr = 0;     ///< dB against the reference (99: equal)
    double ssim = 0;
    /// Shadow total against the reference's: Σ over the image of (no shadows − this image)
    /// in linear luminance (Rec. 709), over the same sum for the reference; 1 is right,
    /// below 1 too little shadow, above too much. NaN when the reference casts none.
    double shadowRatio = 0;
    std::string image;   ///< PNG, when the cells' images are written
};

/// Where naive area sampling reaches the default's PSNR: N read off the area rows' PSNR,
/// linear in log2(N) between the two measured N around the default's PSNR; past the
/// largest N measured, 3.01 dB per doubling of N from it (independent samples: the
/// variance halves); below the smallest N the smallest N itself (`atMost`: area needs at
/// most that). Area's time at that N is interpolated the same way (linear in log2 N), or
/// extrapolated linearly in N from the last two rows.
struct EqualQuality {
    bool valid = false;         ///< false: no area rows, or PSNR not rising where it must be extrapolated
    double targetPsnr = 0;      ///< the default's PSNR
    double samples = 0;         ///< N (not an integer in general)
    bool extrapolated = false;  ///< beyond the largest N measured
    bool atMost = false;        ///< the smallest N measured already reaches it
    double areaSeconds = 0;     ///< area's render time at that N
    double softSeconds = 0;     ///< the default's
    double speedup = 0;         ///< areaSeconds / softSeconds: "soft is X× faster"
};

/// The denoiser's PSNR at the default's render time, from its rows (N rays per light and a
/// filter): linear in log2(time) between the two rows around the default's time; past the
/// slowest row, 3.01 dB per doubling of time (of its rays); faster than the fastest row,
/// that row itself (`atLeast`: the denoiser needs at least its time for its PSNR).
struct EqualTime {
    bool valid = false;
    double seconds = 0;         ///< the default's time
    double psnr = 0;            ///< the denoiser's PSNR at that time
    bool extrapolated = false;  ///< beyond the slowest denoiser row
    bool atLeast = false;       ///< the default is faster than the fastest row
    double softPsnr = 0;        ///< the default's
};
struct TimePoint {
    double seconds = 0, psnr = 0;
};
EqualTime EqualTimeFrom(std::vector<TimePoint> rows, double softPsnr, double softSeconds);

/// The default-vs-competitors table of one (scene, size) (--quality; BenchMatrix::
/// competitorSamples). The lights keep their own radii (`lightRadii`) unless the bench's
/// --light-radius overrides them; the reference is "area" with `refSamples` rays per light
/// at those radii. Every row runs on `accel`, the renderer's default back-end.
struct BenchCompetitors {
    std::string accel;
    std::vector<float> lightRadii;  ///< per light, as every row and the reference use them
    bool radiusOverride = false;    ///< the radii come from --light-radius
    int refSamples = 0;
    int repeat = 0;                 ///< interleaved timed runs per row
    std::vector<CompetitorRow> rows;  ///< RT, soft, exact, LMM, area N…, denoised N…, then the reference
    EqualQuality equal;
    EqualTime denoised;
};

/// EqualQuality from area rows (N, PSNR dB, seconds; any order) and the default's PSNR and
/// seconds.
struct AreaPoint {
    int samples = 0;
    double psnr = 0, seconds = 0;
};
EqualQuality EqualQualityFrom(std::vector<AreaPoint> area, double targetPsnr, double softSeconds);

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
    BenchCompetitors competitors;  ///< the default against its competitors (lights' own radii)
};

/// Everything one run measured.
struct BenchReport {
    std::vector<BenchResult> results;
    std::vector<BenchQuality> quality;  ///< empty without --quality
    int repeat = 0;
};

/// Runs the matrix; `progress` is called after each cell with (done, total, result).
/// `estimate` (if given) is called once before the matrix runs with an estimate of the
/// total seconds, and a matrix estimated above `maxSeconds` (> 0) is refused with an Error
/// (so a 10^10-cell matrix does not run on; the estimate counts CC, without which a subset
/// estimated at 1 s takes 15 s). Measured per scene at the first size, on sampled tiles
/// (WhittedRenderer::EstimateSeconds): an RT render, and LMM renders with the first variant
/// at the smallest and the largest CC (largest kI) and at the largest CC with the smallest
/// kI, their shadow set-up (which grows with CC³) timed; every cell is extrapolated from
/// them by its pixels, its CC (set-up by node count, render by log CC between the two), its
/// kI (by kI² between the two), its runs (repeat + 1), and for the other methods by a cost
/// model (none ≈ 0.5×RT, area with N samples ≈ (0.5 + 0.5·N)×RT, soft ≈ 3×RT), the
/// competitors' cells and references included. Scenes are all loaded first, so a missing
/// model fails before any work.
///
/// With --quality, the competitors' cells (BenchCompetitors: RT and the LMM default unless
/// the matrix has them on the default back-end, soft, area N…) run round-robin with the
/// matrix's cells and are in `results` (role "competitor"), and so is their reference
/// (role "reference", after the round-robin).
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

/// A variants list given by the user: "soft" taken out of it into m->soft (true when the
/// list names it, false when it does not); the rest are light-mesh variants.
void TakeSoftFromVariants(BenchMatrix* m);

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

/// One line per cell with every measured figure (the competitors' cells and reference with
/// their samples, role, PSNR, SSIM and shadow total against that table's reference).
std::string BenchCsv(const std::vector<BenchResult>& results);

/// The default-vs-competitors tables as Markdown (part of BenchQualityMarkdown).
std::string BenchCompetitorsMarkdown(const BenchQuality& q);

/// Every cell and the --quality tables as one JSON document (bench --json): {"repeat",
/// "cells": [...], "quality": [{"scene", "width", "height", ..., "competitors": {"accel",
/// "light_radii", "rows": [...], "equal_quality": {...}}}]}; NaN and infinities are null.
std::string BenchJson(const BenchReport& report);

/// Median of a non-empty list.
double Median(std::vector<double> values);

}  // namespace lm
