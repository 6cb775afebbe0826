// runner.cpp -- `lightmesh bench`'s runner: the matrix's cells rendered round-robin with a
// warm-up, medians, the --quality references and judgements, the paper's table presets and
// --matrix files. The tables and the HTML report are tables.cpp and html_report.cpp.
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/bench/report_internal.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>


#include "lightmesh/accel/accelerator.h"
#include "lightmesh/io/compare.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

double Median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace {

using Clock = std::chrono::steady_clock;

std::string SceneStem(const std::string& spec) {
    if (spec.rfind("builtin:", 0) == 0) return spec.substr(8);
    return std::filesystem::path(spec).stem().string();
}

}  // namespace

namespace {

/// Pixels of RT's shadow deeper than `radiusPixels` from its edge that `img` lights
/// (BenchQuality documents the margins).
long long CountLeaks(const Image& rt, const Image& none, const Image& img, float radiusPixels) {
    const int w = rt.width, h = rt.height;
    std::vector<uint8_t> shadow(static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            shadow[static_cast<size_t>(y) * w + x] = Luma(rt.At(x, y)) < 0.95f * Luma(none.At(x, y)) - 0.002f;
    // Chamfer distance (1, √2) to the nearest edge pixel.
    const float inf = 1e9f;
    std::vector<float> d(shadow.size(), inf);
    auto S = [&](int x, int y) { return shadow[static_cast<size_t>(y) * w + x]; };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const uint8_t s = S(x, y);
            if ((x > 0 && S(x - 1, y) != s) || (x + 1 < w && S(x + 1, y) != s) || (y > 0 && S(x, y - 1) != s) ||
                (y + 1 < h && S(x, y + 1) != s))
                d[static_cast<size_t>(y) * w + x] = 0;
        }
    auto D = [&](int x, int y) -> float& { return d[static_cast<size_t>(y) * w + x]; };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float& v = D(x, y);
            if (x > 0) v = std::min(v, D(x - 1, y) + 1);
            if (y > 0) v = std::min(v, D(x, y - 1) + 1);
            if (x > 0 && y > 0) v = std::min(v, D(x - 1, y - 1) + 1.4142f);
            if (x + 1 < w && y > 0) v = std::min(v, D(x + 1, y - 1) + 1.4142f);
        }
    for (int y = h - 1; y >= 0; --y)
        for (int x = w - 1; x >= 0; --x) {
            float& v = D(x, y);
            if (x + 1 < w) v = std::min(v, D(x + 1, y) + 1);
            if (y + 1 < h) v = std::min(v, D(x, y + 1) + 1);
            if (x + 1 < w && y + 1 < h) v = std::min(v, D(x + 1, y + 1) + 1.4142f);
            if (x > 0 && y + 1 < h) v = std::min(v, D(x - 1, y + 1) + 1.4142f);
        }
    long long leaks = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!S(x, y) || D(x, y) <= radiusPixels) continue;
            const float lr = Luma(rt.At(x, y)), ln = Luma(none.At(x, y)), lv = Luma(img.At(x, y));
            if (lv - lr > 0.25f * (ln - lr)) ++leaks;
        }
    return leaks;
}

struct LoadedScene {
    Scene scene;
    std::map<std::string, std::unique_ptr<Accelerator>> accels;
};

}  // namespace

/// PSNR per doubling of independent samples: 10·log10(2).
constexpr double kDbPerDoubling = 3.010299956639812;  // 10·log10 2

EqualQuality EqualQualityFrom(std::vector<AreaPoint> area, double targetPsnr, double softSeconds) {
    EqualQuality e;
    e.targetPsnr = targetPsnr;
    e.softSeconds = softSeconds;
    area.erase(std::remove_if(area.begin(), area.end(), [](const AreaPoint& p) { return p.samples < 1; }), area.end());
    std::sort(area.begin(), area.end(), [](const AreaPoint& a, const AreaPoint& b) { return a.samples < b.samples; });
    if (area.empty() || !std::isfinite(targetPsnr)) return e;
    auto finish = [&](double samples, double seconds) {
        e.samples = samples;
        e.areaSeconds = seconds;
        e.speedup = softSeconds > 0 ? seconds / softSeconds : 0;
        e.valid = std::isfinite(samples) && samples > 0 && std::isfinite(seconds) && seconds > 0 && softSeconds > 0;
        return e;
    };
    if (area.front().psnr >= targetPsnr) {  // the fewest samples already do
        e.atMost = true;
        return finish(area.front().samples, area.front().seconds);
    }
    // The first pair a.psnr < target <= b.psnr: linear in log2 N, the time likewise.
    for (size_t i = 1; i < area.size(); ++i) {
        const AreaPoint &a = area[i - 1], &b = area[i];
        if (b.psnr < targetPsnr) continue;
        const double f = (targetPsnr - a.psnr) / (b.psnr - a.psnr);
        const double la = std::log2(a.samples), lb = std::log2(b.samples);
        return finish(std::exp2(la + f * (lb - la)), a.seconds + f * (b.seconds - a.seconds));
    }
    // Past the largest N: 3.01 dB per doubling of N (the error's variance halves), the time
    // linear in N through the last two rows.
    e.extrapolated = true;
    if (area.size() < 2) return e;
    const AreaPoint &a = area[area.size() - 2], &b = area.back();
    const double n = b.samples * std::exp2((targetPsnr - b.psnr) / kDbPerDoubling);
    return finish(n, b.seconds + (n - b.samples) * (b.seconds - a.seconds) / (b.samples - a.samples));
}

EqualTime EqualTimeFrom(std::vector<TimePoint> rows, double softPsnr, double softSeconds) {
    EqualTime e;
    e.seconds = softSeconds;
    e.softPsnr = softPsnr;
    rows.erase(std::remove_if(rows.begin(), rows.end(), [](const TimePoint& p) { return !(p.seconds > 0); }), rows.end());
    std::sort(rows.begin(), rows.end(), [](const TimePoint& a, const TimePoint& b) { return a.seconds < b.seconds; });
    if (rows.empty() || !(softSeconds > 0)) return e;
    e.valid = true;
    if (softSeconds <= rows.front().seconds) {
        e.atLeast = true;
        e.psnr = rows.front().psnr;
        return e;
    }
    for (size_t i = 1; i < rows.size(); ++i) {
        const TimePoint &a = rows[i - 1], &b = rows[i];
        if (b.seconds < softSeconds) continue;
        const double f = (std::log2(softSeconds) - std::log2(a.seconds)) / (std::log2(b.seconds) - std::log2(a.seconds));
        e.psnr = a.psnr + f * (b.psnr - a.psnr);
        return e;
    }
    e.extrapolated = true;
    e.psnr = rows.back().psnr + kDbPerDoubling * std::log2(softSeconds / rows.back().seconds);
    return e;
}

/// The light radius of --quality's main reference and of the penumbra cells: R = r = kI·h of
/// the matrix's first (CC, kI), so that R follows the scene's size (about 2 % of its longest
/// side at CC 100, kI 2).
static float QualityRadius(const Scene& scene, const BenchMatrix& m);

namespace {

/// Tiles a probe renders (WhittedRenderer::EstimateSeconds): enough for every thread to
/// have several, few enough to take a fraction of a second.
/// At most this long a probe renders tiles (the RT probe and up to three LMM probes: the
/// estimate within the rule's 2 s however slow a tile).
constexpr double kProbeSeconds = 0.4;

int ProbeTiles() {
    return std::max(64, 8 * static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
}

/// Where m.cc[i] / m.ki[i] came from, for the light mesh's messages ("--cc", "m.json
/// /cc/2"): set in `options` when known.
void NameOrigins(const BenchMatrix& m, int cc, float ki, RenderOptions* options) {
    const auto ci = std::find(m.cc.begin(), m.cc.end(), cc) - m.cc.begin();
    const auto ki_ = std::find(m.ki.begin(), m.ki.end(), ki) - m.ki.begin();
    if (static_cast<size_t>(ci) < m.ccOrigins.size()) options->origins["cc"] = m.ccOrigins[static_cast<size_t>(ci)];
    if (static_cast<size_t>(ki_) < m.kiOrigins.size()) options->origins["ki"] = m.kiOrigins[static_cast<size_t>(ki_)];
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

static float QualityRadius(const Scene& scene, const BenchMatrix& m) {
    return m.ki.front() * scene.mesh.Bounds().MaxExtent() / static_cast<float>(m.cc.front());
}

BenchReport RunBenchmarkReport(const BenchMatrix& m,
                               const std::function<void(int, int, const BenchResult&)>& progress,
                               const std::function<void(double)>& estimate) {
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
    // Counted wide: a matrix file's lists multiply (10^10 cells overflowed an int).
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
    int done = 0;
    BenchReport report;
    report.repeat = m.repeat;
    std::vector<BenchResult>& results = report.results;

    // Load every scene first: a missing model fails before any work.
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

    // One render on the scene's shared back-end; *job keeps the shadow method for its figures.
    auto render = [&](const Scene& scene, const Accelerator& accel, const RenderOptions& options, double* setup,
                      std::unique_ptr<RenderJob>* job) {
        if (m.stop && m.stop->load()) ThrowError("bench: stopped");
        *job = std::make_unique<RenderJob>(scene, options, &accel);
        if (setup) *setup = (*job)->ShadowSetupSeconds();
        return (*job)->Render();
    };

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

    for (size_t si = 0; si < loaded.size(); ++si) {
        const std::string& spec = m.scenes[si];
        const Scene& scene = loaded[si]->scene;
        auto& accels = loaded[si]->accels;
        const Accelerator& lmmAccel = *accels[m.accels.front()];
        for (const auto& size : m.sizes) {
            // Plain variables, not structured bindings: the lambdas below capture them,
            // which clang before 16 rejects (the sanitizer and fuzzing builds use clang 14).
            const int width = size.first, height = size.second;
            RenderOptions base = scene.render;
            base.width = width;
            base.height = height;
            // With --quality, the last image of each cell (indexed like `results`).
            std::map<size_t, Image> images;
            // The cells of this scene and size, run round-robin: a warm-up pass, then
            // m.repeat passes over all of them, so that a change in the machine's load
            // (it is shared) reaches every cell alike and the ratios of medians stay fair.
            struct Cell {
                BenchResult r;
                const Accelerator* accel;
                RenderOptions options;
            };
            std::vector<Cell> cells;
            auto add = [&](BenchResult r, const Accelerator& accel, RenderOptions options) {
                r.scene = spec;
                r.width = width;
                r.height = height;
                r.accel = std::string(accel.Name());
                options.shadows = r.method == "penumbra" ? "lmm" : r.method;
                cells.push_back({std::move(r), &accel, std::move(options)});
            };
            const size_t first = results.size();
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
            const Accelerator& compAcc = m.quality ? *accels.at(compAccel) : lmmAccel;  // loaded with --quality
            RenderOptions compBase = base;
            if (m.lightRadius) compBase.areaLight.radius = *m.lightRadius;
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
                for (int n : m.competitorSamples) {
                    BenchResult r;
                    r.method = "area";
                    r.paperName = StringPrintf("area N=%d", n);
                    r.samples = n;
                    r.role = "competitor";
                    RenderOptions o = compBase;
                    o.areaLight.samples = n;
                    add(r, compAcc, o);
                }
                for (int n : m.denoisedSamples) {
                    BenchResult r;
                    r.method = "denoised";
                    r.paperName = StringPrintf("denoised N=%d", n);
                    r.samples = n;
                    r.role = "competitor";
                    RenderOptions o = compBase;
                    o.shadows = "denoised";
                    o.areaLight.samples = n;
                    add(r, compAcc, o);
                }
            }
            for (int i = -1; i < m.repeat; ++i) {  // i = -1: the warm-up pass
                for (size_t c = 0; c < cells.size(); ++c) {
                    BenchResult& r = cells[c].r;
                    std::unique_ptr<RenderJob> job;
                    RenderResult rr = render(scene, *cells[c].accel, cells[c].options, &r.setupSeconds, &job);
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
                    if (m.quality) images[first + c] = std::move(rr.image);
                    r.median = Median(r.seconds);
                    results.push_back(r);
                    if (progress) progress(++done, total, results.back());
                }
            }
            if (!m.quality) continue;

            // --quality: references, naive soft shadows, PSNR/SSIM and leaks.
            BenchQuality q;
            q.scene = spec;
            q.width = width;
            q.height = height;
            q.refSamples = m.refSamples;
            q.meshStep = scene.mesh.Bounds().MaxExtent() / static_cast<float>(m.cc.front());
            q.radius = QualityRadius(scene, m);
            const Camera& cam = scene.camera;
            const float dist = Length(cam.lookAt - cam.position);
            const float tanHalf = std::tan(0.5f * cam.fovY * 3.14159265f / 180.0f);
            q.radiusPixels = dist > 0 ? q.radius / (2 * dist * tanHalf) * static_cast<float>(height) : 0;
            const Image* rtImage = nullptr;
            const Image* noneImage = nullptr;
            for (size_t i = first; i < results.size(); ++i) {
                if (results[i].method == "rt" && !rtImage && results[i].role.empty()) rtImage = &images[i];
                if (results[i].method == "none") noneImage = &images[i];
            }
            Image noneOwned;
            if (!noneImage) {
                RenderOptions o = base;
                o.shadows = "none";
                std::unique_ptr<RenderJob> keep;
                noneOwned = render(scene, lmmAccel, o, nullptr, &keep).image;
                noneImage = &noneOwned;
            }
            std::vector<Image> refs;
            for (float f : m.radiusFactors) {
                RenderOptions o = base;
                o.shadows = "area";
                o.areaLight.radius = q.radius * f;  // the override: every light this size
                o.areaLight.samples = m.refSamples;
                std::unique_ptr<RenderJob> keep;
                RenderResult rr = render(scene, lmmAccel, o, nullptr, &keep);
                if (f == 1.0f) {
                    q.mainRadius = q.radii.size();
                    if (!m.imageDir.empty()) {
                        q.refImage = (std::filesystem::path(m.imageDir) /
                                      (SceneStem(spec) + StringPrintf("-%dx%d-area-R%g-N%d.png", width, height,
                                                                      *o.areaLight.radius, m.refSamples)))
                                         .string();
                        WriteImage(q.refImage, rr.image);
                    }
                }
                q.radii.push_back(*o.areaLight.radius);
                q.refSeconds.push_back(rr.seconds);
                refs.push_back(std::move(rr.image));
            }
            auto judge = [&](QualityRow& row, const Image& img) {
                for (const Image& ref : refs) {
                    const ImageMetrics im = CompareImages(ref, img);
                    row.psnr.push_back(std::isinf(im.psnr) ? 99.0 : im.psnr);
                    row.ssim.push_back(im.ssim);
                }
                if (rtImage && row.method != "rt") row.leaks = CountLeaks(*rtImage, *noneImage, img, q.radiusPixels);
                q.rows.push_back(std::move(row));
            };
            for (size_t i = first; i < results.size(); ++i) {
                const BenchResult& r = results[i];
                if (r.method == "none" || !r.role.empty()) continue;  // the competitors' cells: below
                QualityRow row;
                row.method = r.method;
                row.variant = r.variant;
                row.cc = r.cc;
                row.ki = r.ki;
                row.seconds = r.median;
                row.label = r.method == "rt"         ? "RT (" + r.accel + ")"
                            : r.method == "penumbra" ? StringPrintf("%s (%s) CC %d kI %g, light radius %.3g, thin check %s",
                                                                    r.paperName.c_str(), r.variant.c_str(), r.cc, r.ki,
                                                                    r.lightRadius, r.thinCheck.c_str())
                                                     : StringPrintf("%s (%s) CC %d kI %g", r.paperName.c_str(),
                                                                    r.variant.c_str(), r.cc, r.ki);
                judge(row, images[i]);
            }
            for (int n : m.areaSamples) {
                RenderOptions o = base;
                o.shadows = "area";
                o.areaLight.radius = q.radius;
                o.areaLight.samples = n;
                std::unique_ptr<RenderJob> keep;
                RenderResult rr = render(scene, lmmAccel, o, nullptr, &keep);
                QualityRow row;
                row.method = "area";
                row.samples = n;
                row.seconds = rr.seconds;
                row.label = StringPrintf("area N=%d R=%.3g", n, q.radius);
                judge(row, rr.image);
            }

            // The default against its competitors: every row on the default back-end, the
            // lights' own radii (or --light-radius), one reference of those radii.
            BenchCompetitors& comp = q.competitors;
            comp.accel = compAccel;
            comp.lightRadii = LightRadii(scene, compBase);
            comp.radiusOverride = compBase.areaLight.radius.has_value();
            comp.refSamples = m.refSamples;
            comp.repeat = m.repeat;
            // The competitors' rows, as indices into `results`: RT, soft, LMM, area N…
            std::vector<size_t> compCells;
            auto findCell = [&](auto&& match) {
                for (size_t i = first; i < results.size(); ++i)
                    if (results[i].accel == compAccel && match(results[i])) return compCells.push_back(i);
                ThrowError("bench: internal error: a competitors' cell is missing");
            };
            findCell([](const BenchResult& r) { return r.method == "rt"; });
            findCell([](const BenchResult& r) { return r.method == "soft"; });
            findCell([](const BenchResult& r) { return r.method == "exact"; });
            findCell([&](const BenchResult& r) {
                return r.method == "lmm" && r.variant == kDefaultLightMeshVariant && r.cc == lmmDefaults.cc &&
                       r.ki == lmmDefaults.ki;
            });
            for (int n : m.competitorSamples)
                findCell([&](const BenchResult& r) { return r.method == "area" && r.samples == n; });
            for (int n : m.denoisedSamples)
                findCell([&](const BenchResult& r) { return r.method == "denoised" && r.samples == n; });
            // No shadows on the same back-end: the shadow totals' zero.
            const Image* compNone = nullptr;
            for (size_t i = first; i < results.size(); ++i)
                if (results[i].method == "none" && results[i].accel == compAccel) compNone = &images[i];
            Image compNoneOwned;
            if (!compNone) {
                if (std::string(lmmAccel.Name()) == compAccel) {
                    compNone = noneImage;
                } else {
                    RenderOptions o = base;
                    o.shadows = "none";
                    std::unique_ptr<RenderJob> keep;
                    compNoneOwned = render(scene, compAcc, o, nullptr, &keep).image;
                    compNone = &compNoneOwned;
                }
            }
            // The reference: area with refSamples rays per light at the same radii; one run,
            // after the round-robin.
            BenchResult ref;
            ref.scene = spec;
            ref.width = width;
            ref.height = height;
            ref.method = "area";
            ref.paperName = StringPrintf("reference area N=%d", m.refSamples);
            ref.accel = compAccel;
            ref.samples = m.refSamples;
            ref.role = "reference";
            Image refImage;
            {
                RenderOptions o = compBase;
                o.shadows = "area";
                o.areaLight.samples = m.refSamples;
                std::unique_ptr<RenderJob> keep;
                RenderResult rr = render(scene, compAcc, o, &ref.setupSeconds, &keep);
                ref.seconds = {rr.seconds};
                ref.median = rr.seconds;
                ref.counters = rr.counters;
                ref.peakMemoryBytes = PeakMemoryBytes();
                if (!m.imageDir.empty()) {
                    ref.image = (std::filesystem::path(m.imageDir) /
                                 (SceneStem(spec) + StringPrintf("-%dx%d-reference-area-N%d-%s%s.png", width, height,
                                                                 m.refSamples, compAccel.c_str(),
                                                                 compBase.areaLight.radius
                                                                     ? StringPrintf("-R%g", *compBase.areaLight.radius).c_str()
                                                                     : "")))
                                    .string();
                    WriteImage(ref.image, rr.image);
                }
                refImage = std::move(rr.image);
            }
            const double refShadow = ShadowTotal(*compNone, refImage);
            auto judgeCompetitor = [&](BenchResult& r, const Image& img) {
                const ImageMetrics im = CompareImages(refImage, img);
                r.refPsnr = std::isinf(im.psnr) ? 99.0 : im.psnr;
                r.refSsim = im.ssim;
                r.shadowRatio = refShadow > 0 ? ShadowTotal(*compNone, img) / refShadow
                                              : std::numeric_limits<double>::quiet_NaN();
                CompetitorRow row;
                row.method = r.method;
                row.samples = r.samples;
                row.reference = r.role == "reference";
                row.seconds = r.median;
                row.runs = r.seconds.size();
                row.setupSeconds = r.setupSeconds;
                row.psnr = r.refPsnr;
                row.ssim = r.refSsim;
                row.shadowRatio = r.shadowRatio;
                row.image = r.image;
                row.label = row.reference      ? StringPrintf("reference: area N=%d", r.samples)
                            : r.method == "rt"   ? "RT"
                            : r.method == "soft" ? "soft (default)"
                            : r.method == "exact" ? "exact (the cells' lists)"
                            : r.method == "lmm"  ? StringPrintf("LMM %s CC %d kI %g", r.variant.c_str(), r.cc, r.ki)
                            : r.method == "denoised" ? StringPrintf("area N=%d + denoiser", r.samples)
                                                 : StringPrintf("area N=%d", r.samples);
                comp.rows.push_back(std::move(row));
            };
            for (size_t i : compCells) judgeCompetitor(results[i], images[i]);
            judgeCompetitor(ref, refImage);
            std::vector<AreaPoint> area;
            std::vector<TimePoint> denoised;
            const CompetitorRow* softRow = nullptr;
            for (const CompetitorRow& row : comp.rows) {
                if (row.method == "area" && !row.reference) area.push_back({row.samples, row.psnr, row.seconds});
                if (row.method == "denoised") denoised.push_back({row.seconds, row.psnr});
                if (row.method == "soft") softRow = &row;
            }
            comp.equal = EqualQualityFrom(area, softRow->psnr, softRow->seconds);
            comp.denoised = EqualTimeFrom(denoised, softRow->psnr, softRow->seconds);
            results.push_back(std::move(ref));
            if (progress) progress(++done, total, results.back());
            report.quality.push_back(std::move(q));
        }
    }
    return report;
}

std::vector<BenchResult> RunBenchmark(const BenchMatrix& m,
                                      const std::function<void(int, int, const BenchResult&)>& progress) {
    return RunBenchmarkReport(m, progress).results;
}

BenchMatrix BenchTablePreset(int table, bool quick, const std::string& repoDir) {
    BenchMatrix m;
    auto scene = [&](const char* name) {
        const std::filesystem::path p = std::filesystem::path(repoDir) / "scenes" / "real" / name;
        std::error_code ec;
        if (!std::filesystem::exists(p, ec))
            ThrowError("bench --table %d: %s does not exist (is %s the lightmesh repository?)", table,
                       p.string().c_str(), repoDir.c_str());
        return p.string();
    };
    switch (table) {
        case 1:  // "Child park": our castle and parque scenes
            m.scenes = {scene("castle.json"), scene("parque.json")};
            m.sizes = {{1024, 768}};
            m.cc = {100, 200};
            m.ki = {1.2f, 2.0f, 3.0f};
            m.variants = {"grid", "templates", "reduced", "consensus"};
            break;
        case 2:  // "Garden"
            m.scenes = {scene("garden.json")};
            m.sizes = {{1024, 600}};
            m.cc = {100};
            m.ki = {1.2f, 2.0f, 3.0f};
            m.variants = {"grid", "templates", "reduced", "consensus"};
            break;
        case 3:  // "Gazebo"
            m.scenes = {scene("barnum.json")};
            m.sizes = {{1024, 1024}};
            m.cc = {100};
            m.ki = {2.0f, 3.0f};
            m.variants = {"none", "inside", "object", "consensus"};
            break;
        case 4:  // "Child park"
            m.scenes = {scene("parque.json"), scene("castle.json")};
            m.sizes = {{1024, 1024}};
            m.cc = {100};
            m.ki = {3.0f};
            m.variants = {"none", "inside", "object", "consensus"};
            break;
        default: ThrowError("bench --table %d: expected 1, 2, 3 or 4 (the paper's tables)", table);
    }
    m.soft = false;  // the paper's tables: its methods only
    if (quick) {
        for (auto& s : m.sizes) s = {std::max(1, s.first / 4), std::max(1, s.second / 4)};
        m.repeat = 1;
    }
    return m;
}

BenchMatrix LoadBenchMatrix(const std::string& path) {
    // The scene files' reader: messages name the file and the JSON pointer (line and column
    // for a syntax error); unknown and duplicate keys are errors.
    json::Reader r(path, /*strict=*/true, nullptr);
    const std::string text = ReadRegularFile(path, "matrix file");  // never blocks on a FIFO
    const Json root = json::ParseJson(r, text);
    json::Object o(r, root, "");
    BenchMatrix m;
    auto list = [&](const char* key) -> const Json* {
        const Json* v = o.Find(key);
        if (!v) return nullptr;
        if (!v->is_array()) r.Fail(o.Child(key), "expected a list, got " + json::Describe(*v));
        if (v->empty()) r.Fail(o.Child(key), "must not be empty");
        return v;
    };
    auto strings = [&](const char* key, std::vector<std::string>* out) {
        if (const Json* l = list(key)) {
            out->clear();
            for (size_t i = 0; i < l->size(); ++i) out->push_back(json::String(r, (*l)[i], json::Index(o.Child(key), i)));
        }
    };
    strings("scenes", &m.scenes);
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    for (std::string& s : m.scenes)
        if (s.rfind("builtin:", 0) != 0 && std::filesystem::path(s).is_relative()) s = (folder / s).string();
    strings("variants", &m.variants);
    m.soft = true;  // as `lightmesh bench`: the default method timed too, unless "variants" leaves it out
    if (o.Find("variants")) TakeSoftFromVariants(&m);
    for (size_t i = 0; i < m.variants.size(); ++i) {
        // "" would be the default variant: refused like --variants "".
        if (m.variants[i].empty()) r.Fail(json::Index("/variants", i), "must not be empty (leave the key out for the default)");
        try {
            ParseLightMeshVariant(m.variants[i]);
        } catch (const Error& e) {
            r.Fail(json::Index("/variants", i), e.what());
        }
    }
    strings("accels", &m.accels);
    const std::vector<std::string> accelNames = AcceleratorNames();
    for (size_t i = 0; i < m.accels.size(); ++i)
        if (std::find(accelNames.begin(), accelNames.end(), m.accels[i]) == accelNames.end())
            r.Fail(json::Index("/accels", i), "unknown ray-query back-end " + json::Quoted(m.accels[i]) + " (choose " +
                                                  json::JoinQuoted(accelNames) + ")");
    if (const Json* l = list("sizes")) {
        m.sizes.clear();
        for (size_t i = 0; i < l->size(); ++i) {
            const Json& v = (*l)[i];
            const std::string where = json::Index("/sizes", i);
            if (!v.is_array() || v.size() != 2) r.Fail(where, "expected [width, height], got " + json::Describe(v));
            m.sizes.push_back({json::SettingInt(r, v[0], where + "/0", RenderSettingFor("width")),
                               json::SettingInt(r, v[1], where + "/1", RenderSettingFor("height"))});
        }
    }
    if (const Json* l = list("cc")) {
        m.cc.clear();
        for (size_t i = 0; i < l->size(); ++i) {
            m.cc.push_back(json::SettingInt(r, (*l)[i], json::Index("/cc", i), RenderSettingFor("cc")));
            m.ccOrigins.push_back(SourceLoc(path, 0, 0, json::Index("/cc", i)));
        }
    }
    if (const Json* l = list("ki")) {
        m.ki.clear();
        for (size_t i = 0; i < l->size(); ++i) {
            m.ki.push_back(json::SettingFloat(r, (*l)[i], json::Index("/ki", i), RenderSettingFor("ki")));
            m.kiOrigins.push_back(SourceLoc(path, 0, 0, json::Index("/ki", i)));
        }
    }
    if (const Json* v = o.Find("repeat")) m.repeat = json::Int(r, *v, "/repeat", 1, 100);
    if (const Json* v = o.Find("thin_check"))
        m.thinCheck = json::SettingChoice(r, *v, "/thin_check", RenderSettingFor("thin_check"));
    o.Finish();
    return m;
}

void TakeSoftFromVariants(BenchMatrix* m) {
    auto& v = m->variants;
    const auto soft = std::remove(v.begin(), v.end(), std::string("soft"));
    m->soft = soft != v.end();
    v.erase(soft, v.end());
}

}  // namespace lm
