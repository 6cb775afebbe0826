// runner_internal.h -- what the bench's runner (runner.cpp) shares with the parts of one
// run: the matrix checked, counted, loaded and estimated (matrix_plan.cpp), a scene and
// size's cells run round-robin (cell_runs.cpp), and --quality's references and judgements
// (quality_judge.cpp); not part of the bench's interface.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/settings/options.h"

namespace lm {

/// A scene of the matrix with its ray-query back-ends, by name.
struct LoadedScene {
    Scene scene;
    std::map<std::string, std::unique_ptr<Accelerator>> accels;
};

/// The matrix checked and counted before any work (PlanBench).
struct BenchPlan {
    /// The default-vs-competitors cells (--quality): on the renderer's default back-end; RT
    /// and the paper's LMM at CC 100, kI 2 are the matrix's own cells when it has them there.
    std::string compAccel;
    LightMeshOptions lmmDefaults;
    bool compRtInMatrix = false;
    bool compLmmInMatrix = false;
    int softCells = 0;        ///< per scene and size
    double cellCount = 0;     ///< every cell of the run, counted wide
    int total = 0;            ///< the cells `progress` counts
};

/// One RunBenchmarkReport as it goes: the matrix, its plan, the report so far and the
/// cells done.
struct BenchRun {
    const BenchMatrix& m;
    const BenchPlan& plan;
    const std::function<void(int, int, const BenchResult&)>& progress;
    BenchReport report;
    int done = 0;
};

/// One (scene, size) of the matrix: what its cells share and, with --quality, the last
/// image of each cell (indexed like the report's results).
struct SceneSizeRun {
    const std::string& spec;
    const Scene& scene;
    const Accelerator& lmmAccel;  ///< the matrix's first back-end: none, LMM, the references
    const Accelerator& compAcc;   ///< the competitors' back-end (lmmAccel without --quality)
    int width = 0, height = 0;
    RenderOptions base;
    RenderOptions compBase;       ///< base with the bench's --light-radius, if given
    size_t first = 0;             ///< the index of its first cell in the report's results
    std::map<size_t, Image> images;
};

/// A cell of a (scene, size), to be run round-robin (RunCells).
struct BenchCell {
    BenchResult r;
    const Accelerator* accel;
    RenderOptions options;
};

// matrix_plan.cpp

/// The matrix checked (Error naming what is wrong) and its cells counted, before any work.
BenchPlan PlanBench(const BenchMatrix& m);
/// Every scene of the matrix with its back-ends (the competitors' too with --quality).
std::vector<std::unique_ptr<LoadedScene>> LoadBenchScenes(const BenchMatrix& m, const BenchPlan& plan);
/// The run's seconds, estimated on sampled tiles (RunBenchmarkReport): told to `estimate`,
/// and a matrix over m.maxSeconds refused.
void EstimateBench(const BenchMatrix& m, const BenchPlan& plan, const std::vector<std::unique_ptr<LoadedScene>>& loaded,
                   const std::function<void(double)>& estimate);

// cell_runs.cpp

/// The name a scene spec gives its images: the file's stem, or the built-in's name.
std::string SceneStem(const std::string& spec);
/// Where m.cc[i] / m.ki[i] came from, for the light mesh's messages ("--cc", "m.json
/// /cc/2"): set in `options` when known.
void NameOrigins(const BenchMatrix& m, int cc, float ki, RenderOptions* options);
/// One render on the scene's shared back-end; *job keeps the shadow method for its figures.
RenderResult BenchRender(const BenchMatrix& m, const Scene& scene, const Accelerator& accel,
                         const RenderOptions& options, double* setup, std::unique_ptr<RenderJob>* job);
/// The cells of one (scene, size): none, RT, soft, the LMM variants, the penumbra cells
/// and the competitors' cells.
std::vector<BenchCell> PlanCells(const BenchRun& run, LoadedScene& loaded, const SceneSizeRun& s);
/// The cells run round-robin: a warm-up pass, then m.repeat passes over all of them, so
/// that a change in the machine's load (it is shared) reaches every cell alike and the
/// ratios of medians stay fair. Each cell is added to the report's results (and `progress`
/// told) after its last pass; with --quality its last image goes to s.images.
void RunCells(BenchRun& run, std::vector<BenchCell>& cells, SceneSizeRun& s);

// quality_judge.cpp

/// The light radius of --quality's main reference and of the penumbra cells: R = r = kI·h of
/// the matrix's first (CC, kI), so that R follows the scene's size (about 2 % of its longest
/// side at CC 100, kI 2).
float QualityRadius(const Scene& scene, const BenchMatrix& m);
/// --quality for one (scene, size) whose cells have run: the references, the cells and
/// naive soft shadows judged, the default against its competitors; the competitors'
/// reference added to the report's results and the BenchQuality to its quality.
void JudgeQuality(BenchRun& run, SceneSizeRun& s);

}  // namespace lm
