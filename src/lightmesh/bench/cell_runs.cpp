// cell_runs.cpp -- the cells of one (scene, size) of `lightmesh bench`: none, RT, soft,
// the light-mesh variants at every (CC, kI), the penumbra cells and the competitors'
// cells, rendered round-robin with a warm-up; each cell's median, counters, peak memory
// and image.
#include "lightmesh/bench/runner_internal.h"

#include <algorithm>
#include <filesystem>
#include <memory>

#include "lightmesh/io/image.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

std::string SceneStem(const std::string& spec) {
    if (spec.rfind("builtin:", 0) == 0) return spec.substr(8);
    return std::filesystem::path(spec).stem().string();
}

void NameOrigins(const BenchMatrix& m, int cc, float ki, RenderOptions* options) {
    const auto ci = std::find(m.cc.begin(), m.cc.end(), cc) - m.cc.begin();
    const auto ki_ = std::find(m.ki.begin(), m.ki.end(), ki) - m.ki.begin();
    if (static_cast<size_t>(ci) < m.ccOrigins.size()) options->origins["cc"] = m.ccOrigins[static_cast<size_t>(ci)];
    if (static_cast<size_t>(ki_) < m.kiOrigins.size()) options->origins["ki"] = m.kiOrigins[static_cast<size_t>(ki_)];
}

RenderResult BenchRender(const BenchMatrix& m, const Scene& scene, const Accelerator& accel,
                         const RenderOptions& options, double* setup, std::unique_ptr<RenderJob>* job) {
    if (m.stop && m.stop->load()) ThrowError("bench: stopped");
    *job = std::make_unique<RenderJob>(scene, options, &accel);
    if (setup) *setup = (*job)->ShadowSetupSeconds();
    return (*job)->Render();
}

std::vector<BenchCell> PlanCells(const BenchRun& run, LoadedScene& loaded, const SceneSizeRun& s) {
    const BenchMatrix& m = run.m;
    const std::string& spec = s.spec;
    const Scene& scene = s.scene;
    auto& accels = loaded.accels;
    const Accelerator& lmmAccel = s.lmmAccel;
    const Accelerator& compAcc = s.compAcc;
    const int width = s.width, height = s.height;
    const RenderOptions& base = s.base;
    const RenderOptions& compBase = s.compBase;
    const LightMeshOptions& lmmDefaults = run.plan.lmmDefaults;
    const bool compRtInMatrix = run.plan.compRtInMatrix, compLmmInMatrix = run.plan.compLmmInMatrix;
    std::vector<BenchCell> cells;
    auto add = [&](BenchResult r, const Accelerator& accel, RenderOptions options) {
        r.scene = spec;
        r.width = width;
        r.height = height;
        r.accel = std::string(accel.Name());
        options.shadows = r.method == "penumbra" ? "lmm" : r.method;
        cells.push_back({std::move(r), &accel, std::move(options)});
    };
    if (m.noShadows) {
        BenchResult r;
        r.method = "none";
        r.paperName = "none";
        add(r, lmmAccel, base);
    }
    for (const std::string& a : m.accels) {
        BenchResult r;
        r.method = "rt";
        r.paperName = "RT";
        add(r, *accels[a], base);
    }
    // The default shadow method, as `render` runs it (--quality times it among the competitors).
    if (m.soft && !m.quality) {
        BenchResult r;
        r.method = "soft";
        r.paperName = "soft";
        add(r, lmmAccel, base);
    }
    // An LMM cell: a variant at (CC, kI), with a light radius for the penumbra mode.
    auto addLmm = [&](const char* method, const std::string& name, int cc, float ki, float lightRadius,
                      const Accelerator& accel, const char* role) {
        const LightMeshVariant variant = ParseLightMeshVariant(name);
        BenchResult r;
        r.method = method;
        r.variant = variant.name;
        r.paperName = variant.paperName;
        r.cc = cc;
        r.ki = ki;
        r.lightRadius = lightRadius;
        RenderOptions options = base;
        options.lightMesh.cc = cc;
        options.lightMesh.ki = ki;
        NameOrigins(m, cc, ki, &options);
        options.lightMesh.variant = name;
        options.lightMesh.cellSummaries = m.cellSummaries;
        options.areaLight.radius = lightRadius;  // explicit: 0 keeps the paper's fixed radius
        if (lightRadius > 0) {
            options.lightMesh.thinCheck = m.thinCheck;
            r.thinCheck = m.thinCheck;
        }
        r.role = role;
        add(r, accel, options);
    };
    for (int cc : m.cc)
        for (float ki : m.ki)
            for (const std::string& v : m.variants) addLmm("lmm", v, cc, ki, 0.0f, lmmAccel, "");
    // Contact-hardening penumbrae: the light radius of the main quality reference.
    if (m.quality && m.penumbrae)
        for (int cc : m.cc)
            for (float ki : m.ki)
                addLmm("penumbra", kDefaultLightMeshVariant, cc, ki, QualityRadius(scene, m), lmmAccel, "");
    // The default against its competitors, on the renderer's default back-end, with
    // the lights' own radii (or the bench's --light-radius): soft and area N…, and
    // RT and the paper's LMM unless the matrix has them there. Timed round-robin
    // with the matrix's cells.
    if (m.quality) {
        if (!compRtInMatrix) {
            BenchResult r;
            r.method = "rt";
            r.paperName = "RT";
            r.role = "competitor";
            add(r, compAcc, base);
        }
        BenchResult soft;
        soft.method = "soft";
        soft.paperName = "soft";
        soft.role = "competitor";
        add(soft, compAcc, compBase);
        BenchResult exact;
        exact.method = "exact";
        exact.paperName = "exact";
        exact.role = "competitor";
        RenderOptions exactOptions = compBase;
        exactOptions.shadows = "exact";
        add(exact, compAcc, exactOptions);
        if (!compLmmInMatrix)
            addLmm("lmm", kDefaultLightMeshVariant, lmmDefaults.cc, lmmDefaults.ki, 0.0f, compAcc, "competitor");
        // Area sampling and the denoiser, each with its N rays per light (add sets the method).
        for (const auto& [method, counts] : {std::pair{"area", &m.competitorSamples}, std::pair{"denoised", &m.denoisedSamples}})
            for (int n : *counts) {
                BenchResult r;
                r.method = method;
                r.paperName = StringPrintf("%s N=%d", method, n);
                r.samples = n;
                r.role = "competitor";
                RenderOptions o = compBase;
                o.areaLight.samples = n;
                add(r, compAcc, o);
            }
    }
    return cells;
}

void RunCells(BenchRun& run, std::vector<BenchCell>& cells, SceneSizeRun& s) {
    const BenchMatrix& m = run.m;
    std::vector<BenchResult>& results = run.report.results;
    const std::string& spec = s.spec;
    const int width = s.width, height = s.height;
    int& done = run.done;
    const int total = run.plan.total;
    const auto& progress = run.progress;
    for (int i = -1; i < m.repeat; ++i) {  // i = -1: the warm-up pass
        for (size_t c = 0; c < cells.size(); ++c) {
            BenchResult& r = cells[c].r;
            std::unique_ptr<RenderJob> job;
            RenderResult rr = BenchRender(m, s.scene, *cells[c].accel, cells[c].options, &r.setupSeconds, &job);
            // The process's peak so far, as before the round-robin: read in the first
            // pass, which runs the cells in order (later passes would all read the
            // matrix's peak).
            if (i < 0) {
                r.peakMemoryBytes = PeakMemoryBytes();
                continue;
            }
            r.seconds.push_back(rr.seconds);
            r.counters = rr.counters;
            r.nodesEvaluated = job->Shadows().NodesEvaluated();
            if (i < m.repeat - 1) continue;
            // The last pass: the cell is done.
            if (!m.imageDir.empty()) {
                std::string name = SceneStem(spec) + StringPrintf("-%dx%d-", width, height) +
                                   (r.method == "lmm"        ? StringPrintf("cc%d-ki%g-%s", r.cc, r.ki, r.variant.c_str())
                                    : r.method == "penumbra" ? StringPrintf("cc%d-ki%g-%s-R%g-thin-%s", r.cc, r.ki,
                                                                            r.variant.c_str(), r.lightRadius,
                                                                            r.thinCheck.c_str())
                                    : r.method == "area" || r.method == "denoised"
                                        ? StringPrintf("%s-N%d-%s", r.method.c_str(), r.samples, r.accel.c_str())
                                                         : r.method + "-" + r.accel) +
                                   // the competitors' LMM beside the matrix's on another back-end
                                   (r.method == "lmm" && !r.role.empty() ? "-" + r.accel : std::string()) +
                                   ".png";
                r.image = (std::filesystem::path(m.imageDir) / name).string();
                WriteImage(r.image, rr.image);
            }
            if (m.quality) s.images[s.first + c] = std::move(rr.image);
            r.median = Median(r.seconds);
            results.push_back(r);
            if (progress) progress(++done, total, results.back());
        }
    }
}

}  // namespace lm
