// quality_judge.cpp -- `lightmesh bench --quality`: per scene and size, area-light
// references at several radii, every cell and naive soft shadows judged against them
// (PSNR, SSIM, leaks), and the default shadow method against its competitors, with where
// area sampling reaches its quality and the denoiser's quality at its time.
#include "lightmesh/bench/runner_internal.h"
#include "lightmesh/bench/report_internal.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>

#include "lightmesh/io/compare.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

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

}  // namespace

/// The references' stream of sample rotations (AreaLightOptions::stream): independent of
/// the rows they judge, so that area with as many rays as the reference is not judged
/// against itself, nor fewer rays against rotations they share with it.
constexpr uint32_t kReferenceStream = 1;

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

float QualityRadius(const Scene& scene, const BenchMatrix& m) {
    return m.ki.front() * scene.mesh.Bounds().MaxExtent() / static_cast<float>(m.cc.front());
}

namespace {

/// The competitors' reference: area with refSamples rays per light at the same radii; one
/// run, after the round-robin. Its image goes to *refImage.
BenchResult RenderCompetitorsReference(const BenchRun& run, const SceneSizeRun& s, Image* refImage) {
    const BenchMatrix& m = run.m;
    const std::string& spec = s.spec;
    const int width = s.width, height = s.height;
    const std::string& compAccel = run.plan.compAccel;
    const RenderOptions& compBase = s.compBase;
    BenchResult ref;
    ref.scene = spec;
    ref.width = width;
    ref.height = height;
    ref.method = "area";
    ref.paperName = StringPrintf("reference area N=%d", m.refSamples);
    ref.accel = compAccel;
    ref.samples = m.refSamples;
    ref.role = "reference";
    RenderOptions o = compBase;
    o.shadows = "area";
    o.areaLight.samples = m.refSamples;
    o.areaLight.stream = kReferenceStream;
    std::unique_ptr<RenderJob> keep;
    RenderResult rr = BenchRender(m, s.scene, s.compAcc, o, &ref.setupSeconds, &keep);
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
    *refImage = std::move(rr.image);
    return ref;
}

/// The default against its competitors: every row on the default back-end, the lights'
/// own radii (or --light-radius), one reference of those radii, rendered here. `noneImage`:
/// no shadows on the matrix's first back-end. Returns the reference, for the results.
BenchResult JudgeCompetitors(BenchRun& run, SceneSizeRun& s, const Image* noneImage, BenchCompetitors& comp) {
    const BenchMatrix& m = run.m;
    std::vector<BenchResult>& results = run.report.results;
    const Scene& scene = s.scene;
    const size_t first = s.first;
    auto& images = s.images;
    const RenderOptions& base = s.base;
    const RenderOptions& compBase = s.compBase;
    const Accelerator& lmmAccel = s.lmmAccel;
    const Accelerator& compAcc = s.compAcc;
    const std::string& compAccel = run.plan.compAccel;
    const LightMeshOptions& lmmDefaults = run.plan.lmmDefaults;
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
            compNoneOwned = BenchRender(m, scene, compAcc, o, nullptr, &keep).image;
            compNone = &compNoneOwned;
        }
    }
    Image refImage;
    BenchResult ref = RenderCompetitorsReference(run, s, &refImage);
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
    return ref;
}

}  // namespace

void JudgeQuality(BenchRun& run, SceneSizeRun& s) {
    const BenchMatrix& m = run.m;
    std::vector<BenchResult>& results = run.report.results;
    const std::string& spec = s.spec;
    const Scene& scene = s.scene;
    const int width = s.width, height = s.height;
    const RenderOptions& base = s.base;
    const Accelerator& lmmAccel = s.lmmAccel;
    const size_t first = s.first;
    auto& images = s.images;
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
        noneOwned = BenchRender(m, scene, lmmAccel, o, nullptr, &keep).image;
        noneImage = &noneOwned;
    }
    std::vector<Image> refs;
    for (float f : m.radiusFactors) {
        RenderOptions o = base;
        o.shadows = "area";
        o.areaLight.radius = q.radius * f;  // the override: every light this size
        o.areaLight.samples = m.refSamples;
        o.areaLight.stream = kReferenceStream;
        std::unique_ptr<RenderJob> keep;
        RenderResult rr = BenchRender(m, scene, lmmAccel, o, nullptr, &keep);
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
        RenderResult rr = BenchRender(m, scene, lmmAccel, o, nullptr, &keep);
        QualityRow row;
        row.method = "area";
        row.samples = n;
        row.seconds = rr.seconds;
        row.label = StringPrintf("area N=%d R=%.3g", n, q.radius);
        judge(row, rr.image);
    }
    results.push_back(JudgeCompetitors(run, s, noneImage, q.competitors));
    if (run.progress) run.progress(++run.done, run.plan.total, results.back());
    run.report.quality.push_back(std::move(q));
}

}  // namespace lm
