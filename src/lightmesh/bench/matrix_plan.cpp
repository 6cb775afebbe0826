// matrix_plan.cpp -- `lightmesh bench` before its first cell: the matrix checked and its
// cells counted, every scene loaded, and the run's time estimated on sampled tiles (a
// matrix over the limit refused).
#include "lightmesh/bench/runner_internal.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace {

/// At most this long a probe renders tiles (the RT probe and up to three LMM probes: the
/// estimate within the rule's 2 s however slow a tile).
constexpr double kProbeSeconds = 0.4;

/// Tiles a probe renders (WhittedRenderer::EstimateSeconds): enough for every thread to
/// have several, few enough to take a fraction of a second.
int ProbeTiles() {
    return std::max(64, 8 * static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
}

/// The bench's estimate of one scene's LMM cells, measured on sampled tiles at
/// the first size with the first variant: set-up and render seconds at the smallest and
/// the largest CC (at the largest kI), and at the largest CC with the smallest kI.
class LmmCost {
  public:
    LmmCost(const Scene& scene, const Accelerator& accel, const BenchMatrix& m, RenderOptions base) {
        if (m.cc.empty() || m.ki.empty() || m.variants.empty()) return;
        bounds_ = scene.mesh.Bounds();
        ccLo_ = *std::min_element(m.cc.begin(), m.cc.end());
        ccHi_ = *std::max_element(m.cc.begin(), m.cc.end());
        kiLo_ = *std::min_element(m.ki.begin(), m.ki.end());
        kiHi_ = *std::max_element(m.ki.begin(), m.ki.end());
        base.shadows = "lmm";
        base.lightMesh.variant = m.variants.front();
        base.lightMesh.cellSummaries = m.cellSummaries;
        auto probe = [&](int cc, float ki, double* setup, double* render) {
            RenderOptions o = base;
            o.lightMesh.cc = cc;
            o.lightMesh.ki = ki;
            NameOrigins(m, cc, ki, &o);
            const RenderJob job(scene, o, &accel);
            *setup = job.ShadowSetupSeconds();
            *render = job.Renderer().EstimateSeconds(ProbeTiles(), kProbeSeconds);
        };
        probe(ccHi_, kiHi_, &setupHi_, &renderHi_);
        setupLo_ = setupHi_;
        renderLo_ = renderHi_;
        if (ccLo_ != ccHi_) probe(ccLo_, kiHi_, &setupLo_, &renderLo_);
        kiRatio_ = 1;
        if (kiLo_ != kiHi_) {
            double setup = 0, render = 0;
            probe(ccHi_, kiLo_, &setup, &render);
            kiRatio_ = renderHi_ > 0 ? std::clamp(render / renderHi_, 0.05, 1.0) : 1.0;
        }
        nodesLo_ = Nodes(ccLo_);
        nodesHi_ = Nodes(ccHi_);
        active_ = true;
    }
    /// Seconds of one run of every (cc, ki) pair of the lists, at `pixelRatio` times the
    /// first size's pixels: set-up by CC, render by CC times a factor of kI (O(|cc| + |ki|),
    /// for matrices of thousands of values).
    double SumSeconds(const std::vector<int>& ccs, const std::vector<float>& kis, double pixelRatio) const {
        if (!active_) return 0;
        double setup = 0, render = 0, kiFactors = 0;
        for (int cc : ccs) {
            const double t = ccHi_ > ccLo_ ? (std::log(double(cc)) - std::log(double(ccLo_))) /
                                                 (std::log(double(ccHi_)) - std::log(double(ccLo_)))
                                           : 1.0;
            render += std::max(0.0, renderLo_ + t * (renderHi_ - renderLo_));
            const double n = Nodes(cc);
            setup += std::max(0.0, nodesHi_ > nodesLo_
                                       ? setupLo_ + (setupHi_ - setupLo_) * (n - nodesLo_) / (nodesHi_ - nodesLo_)
                                       : setupHi_);
        }
        const double lo2 = double(kiLo_) * kiLo_, hi2 = double(kiHi_) * kiHi_;
        for (float ki : kis)
            kiFactors += hi2 > lo2 ? kiRatio_ + (1 - kiRatio_) * (double(ki) * ki - lo2) / (hi2 - lo2) : 1.0;
        return setup * static_cast<double>(kis.size()) + render * kiFactors * pixelRatio;
    }

  private:
    double Nodes(int cc) const { return static_cast<double>(LightMeshLattice::Make(bounds_, cc, kiHi_).NodeCount()); }
    bool active_ = false;
    Bounds3 bounds_;
    int ccLo_ = 0, ccHi_ = 0;
    float kiLo_ = 0, kiHi_ = 0;
    double setupLo_ = 0, setupHi_ = 0, renderLo_ = 0, renderHi_ = 0, kiRatio_ = 1, nodesLo_ = 0, nodesHi_ = 0;
};

}  // namespace

BenchPlan PlanBench(const BenchMatrix& m) {
    if (m.repeat < 1) ThrowError("bench: --repeat must be at least 1");
    if (m.accels.empty()) ThrowError("bench: no ray-query back-end given");
    if (m.scenes.empty() || m.sizes.empty()) ThrowError("bench: no scene or no size given");
    if (m.quality && (m.cc.empty() || m.ki.empty())) ThrowError("bench: --quality needs a CC and a kI");
    for (const std::string& v : m.variants) ParseLightMeshVariant(v);  // fail before any work
    if (!m.imageDir.empty()) CheckWritableFolder((std::filesystem::path(m.imageDir) / "x.png").string());
    for (const std::vector<int>* list : {&m.competitorSamples, &m.denoisedSamples})
        for (int n : *list)
            if (n < 1 || n > 4096) ThrowError("bench: area samples per light must be 1 to 4096, got %d", n);
    if (m.lightRadius && !(*m.lightRadius >= 0 && std::isfinite(*m.lightRadius)))
        ThrowError("bench: --light-radius must be finite and >= 0");
    // The default-vs-competitors cells (--quality): on the renderer's default back-end; RT
    // and the paper's LMM at CC 100, kI 2 are the matrix's own cells when it has them there.
    const std::string compAccel = kDefaultAccelerator;
    const LightMeshOptions lmmDefaults;
    const bool compRtInMatrix = std::find(m.accels.begin(), m.accels.end(), compAccel) != m.accels.end();
    const bool compLmmInMatrix =
        m.accels.front() == compAccel &&
        std::any_of(m.variants.begin(), m.variants.end(),
                    [](const std::string& v) { return ParseLightMeshVariant(v).name == kDefaultLightMeshVariant; }) &&
        std::find(m.cc.begin(), m.cc.end(), lmmDefaults.cc) != m.cc.end() &&
        std::find(m.ki.begin(), m.ki.end(), lmmDefaults.ki) != m.ki.end();
    const int competitorCells = m.quality ? (compRtInMatrix ? 0 : 1) + 2 /* soft, exact */ + (compLmmInMatrix ? 0 : 1) +
                                                static_cast<int>(m.competitorSamples.size() + m.denoisedSamples.size()) +
                                                1  // + the reference
                                          : 0;
    const int softCells = m.soft && !m.quality ? 1 : 0;
    const int perSize = (m.noShadows ? 1 : 0) + static_cast<int>(m.accels.size()) + softCells +
                        static_cast<int>(m.cc.size() * m.ki.size() *
                                         (m.variants.size() + (m.quality && m.penumbrae ? 1 : 0))) +
                        competitorCells;
    // Counted wide: a matrix file's lists multiply (10^10 cells would overflow an int).
    const double cellCount = static_cast<double>(m.scenes.size()) * static_cast<double>(m.sizes.size()) *
                             ((m.noShadows ? 1.0 : 0.0) + static_cast<double>(m.accels.size()) + softCells +
                              static_cast<double>(m.cc.size()) * static_cast<double>(m.ki.size()) *
                                  static_cast<double>(m.variants.size() + (m.quality && m.penumbrae ? 1 : 0)) +
                              competitorCells);
    if (cellCount > 1e8)
        ThrowError("bench: the matrix has %s cells, more than the 100,000,000 one run may hold (scenes x sizes x CC x "
                   "kI x variants, plus RT and no shadows)",
                   FormatCount(static_cast<uint64_t>(std::min(cellCount, 1.8e19))).c_str());
    const int total = static_cast<int>(m.scenes.size() * m.sizes.size()) * perSize;
    return BenchPlan{.compAccel = compAccel,
                     .lmmDefaults = lmmDefaults,
                     .compRtInMatrix = compRtInMatrix,
                     .compLmmInMatrix = compLmmInMatrix,
                     .softCells = softCells,
                     .cellCount = cellCount,
                     .total = total};
}

std::vector<std::unique_ptr<LoadedScene>> LoadBenchScenes(const BenchMatrix& m, const BenchPlan& plan) {
    const std::string& compAccel = plan.compAccel;
    std::vector<std::unique_ptr<LoadedScene>> loaded;
    for (const std::string& spec : m.scenes) {
        auto ls = std::make_unique<LoadedScene>();
        SceneLoadOptions load;
        load.instancing = false;  // every method and back-end on the same flat triangles
        load.noInstancingBy = "bench, which copies every reference so that every method sees the same triangles";
        std::vector<std::string> warnings;
        ls->scene = LoadScene(spec, load, &warnings);
        for (const std::string& a : m.accels)
            ls->accels[a] = CreateAccelerator(a, ls->scene.mesh, ls->scene.render.accelOptions);
        if (m.quality && !ls->accels.count(compAccel))
            ls->accels[compAccel] = CreateAccelerator(compAccel, ls->scene.mesh, ls->scene.render.accelOptions);
        loaded.push_back(std::move(ls));
    }
    return loaded;
}

void EstimateBench(const BenchMatrix& m, const BenchPlan& plan, const std::vector<std::unique_ptr<LoadedScene>>& loaded,
                   const std::function<void(double)>& estimate) {
    const double cellCount = plan.cellCount;
    const int softCells = plan.softCells;
    const bool compRtInMatrix = plan.compRtInMatrix, compLmmInMatrix = plan.compLmmInMatrix;
    const LightMeshOptions& lmmDefaults = plan.lmmDefaults;
    // A matrix over the limit is refused before its first cell; `partial`: the scenes
    // measured so far already exceed it.
    auto refuse = [&](double seconds, bool partial) {
        ThrowError("bench: the matrix (%s cells, %d runs each) is estimated at %s%s, more than the limit of %s "
                   "(measured on sampled tiles of RT and LMM renders at %dx%d); make it smaller, or --force runs it "
                   "anyway",
                   FormatCount(static_cast<uint64_t>(cellCount)).c_str(), m.repeat + 1,
                   partial ? "at least " : "", FormatDuration(seconds).c_str(), FormatDuration(m.maxSeconds).c_str(),
                   m.sizes.front().first, m.sizes.front().second);
    };
    if (estimate || m.maxSeconds > 0) {
        double seconds = 0;
        for (size_t si = 0; si < loaded.size(); ++si) {
            const Scene& scene = loaded[si]->scene;
            RenderOptions o = scene.render;
            o.width = m.sizes.front().first;
            o.height = m.sizes.front().second;
            o.shadows = "rt";
            // Sampled tiles, not a whole render: a 16384 x 16384 matrix is estimated in
            // about a second.
            const Accelerator& probeAccel = *loaded[si]->accels[m.accels.front()];
            const double rt = RenderJob(scene, o, &probeAccel).Renderer().EstimateSeconds(ProbeTiles(), kProbeSeconds);
            const LmmCost lmm(scene, probeAccel, m, o);
            const double px0 = static_cast<double>(o.width) * o.height;
            for (const auto& size : m.sizes) {
                const double pixelRatio = static_cast<double>(size.first) * size.second / px0;
                const double unit = rt * pixelRatio * (m.repeat + 1);
                // soft ≈ 3×RT (measured 3–7× on the gazebo, as for the competitors below).
                double cells = (m.noShadows ? 0.5 : 0.0) + static_cast<double>(m.accels.size()) + 3.0 * softCells;
                const double lmmCells = static_cast<double>(m.variants.size()) + (m.quality && m.penumbrae ? 1.0 : 0.0);
                seconds += lmmCells * (m.repeat + 1) * lmm.SumSeconds(m.cc, m.ki, pixelRatio);
                seconds += unit * cells;
                if (m.quality) {
                    const double once = unit / (m.repeat + 1);
                    seconds += once * m.radiusFactors.size() * (0.5 + 0.5 * m.refSamples);
                    for (int n : m.areaSamples) seconds += once * (0.5 + 0.5 * n);
                    if (!m.noShadows) seconds += once * 0.5;
                    // The competitors' cells, round-robin like the matrix's, and their
                    // reference (once). soft ≈ 3×RT: measured 3–7× on the gazebo (its
                    // lazily built cell lists weigh more in small images).
                    double comp = 3.0 + (compRtInMatrix ? 0.0 : 1.0) +
                                  (compLmmInMatrix ? 0.0 : 0.5 * lmmDefaults.ki * lmmDefaults.ki);
                    for (int n : m.competitorSamples) comp += 0.5 + 0.5 * n;
                    // denoised: area's rays (closest hits) and the filter, ≈ 2 RT measured on the gazebo.
                    for (int n : m.denoisedSamples) comp += 1.5 + 0.6 * n;
                    seconds += unit * comp + once * (0.5 + 0.5 * m.refSamples);
                }
            }
            if (m.maxSeconds > 0 && seconds > m.maxSeconds && si + 1 < loaded.size()) refuse(seconds, true);
        }
        if (estimate) estimate(seconds);
        if (m.maxSeconds > 0 && seconds > m.maxSeconds) refuse(seconds, false);
    }
}

}  // namespace lm
