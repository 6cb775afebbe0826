// runner.cpp -- `lightmesh bench`'s runner: the matrix's cells rendered round-robin with a
// warm-up, medians, the --quality references and judgements, the paper's table presets and
// --matrix files. The tables and the HTML report are tables.cpp and html_report.cpp.
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/bench/report_internal.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <fstream>
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

/// The light radius of --quality's main reference and of the penumbra cells: R = r = kI·h of
/// the matrix's first (CC, kI), so that R follows the scene's size (about 2 % of its longest
/// side at CC 100, kI 2).
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
    const int perSize = (m.noShadows ? 1 : 0) + static_cast<int>(m.accels.size()) +
                        static_cast<int>(m.cc.size() * m.ki.size() *
                                         (m.variants.size() + (m.quality && m.penumbrae ? 1 : 0)));
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
        std::vector<std::string> warnings;
        ls->scene = LoadScene(spec, load, &warnings);
        for (const std::string& a : m.accels)
            ls->accels[a] = CreateAccelerator(a, ls->scene.mesh, ls->scene.render.accelOptions);
        loaded.push_back(std::move(ls));
    }

    // One render on the scene's shared back-end; *job keeps the shadow method for its figures.
    auto render = [&](const Scene& scene, const Accelerator& accel, const RenderOptions& options, double* setup,
                      std::unique_ptr<RenderJob>* job) {
        *job = std::make_unique<RenderJob>(scene, options, &accel);
        if (setup) *setup = (*job)->ShadowSetupSeconds();
        return (*job)->Render();
    };

    if (estimate) {
        double seconds = 0;
        for (size_t si = 0; si < loaded.size(); ++si) {
            const Scene& scene = loaded[si]->scene;
            RenderOptions o = scene.render;
            o.width = m.sizes.front().first;
            o.height = m.sizes.front().second;
            o.shadows = "rt";
            std::unique_ptr<RenderJob> keep;
            const double rt = render(scene, *loaded[si]->accels[m.accels.front()], o, nullptr, &keep).seconds;
            const double px0 = static_cast<double>(o.width) * o.height;
            for (const auto& size : m.sizes) {
                const double unit = rt * (static_cast<double>(size.first) * size.second / px0) * (m.repeat + 1);
                double cells = (m.noShadows ? 0.5 : 0.0) + static_cast<double>(m.accels.size());
                const double lmmCells = static_cast<double>(m.variants.size()) + (m.quality && m.penumbrae ? 1.0 : 0.0);
                for (size_t c = 0; c < m.cc.size(); ++c)
                    for (float ki : m.ki) cells += lmmCells * 0.5 * ki * ki;
                seconds += unit * cells;
                if (m.quality) {
                    const double once = unit / (m.repeat + 1);
                    seconds += once * m.radiusFactors.size() * (0.5 + 0.5 * m.refSamples);
                    for (int n : m.areaSamples) seconds += once * (0.5 + 0.5 * n);
                    if (!m.noShadows) seconds += once * 0.5;
                }
            }
        }
        estimate(seconds);
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
            // An LMM cell: a variant at (CC, kI), with a light radius for the penumbra mode.
            auto addLmm = [&](const char* method, const std::string& name, int cc, float ki, float lightRadius) {
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
                options.lightMesh.variant = name;
                options.lightMesh.cellSummaries = m.cellSummaries;
                options.areaLight.radius = lightRadius;
                if (lightRadius > 0) {
                    options.lightMesh.thinCheck = m.thinCheck;
                    r.thinCheck = m.thinCheck;
                }
                add(r, lmmAccel, options);
            };
            for (int cc : m.cc)
                for (float ki : m.ki)
                    for (const std::string& v : m.variants) addLmm("lmm", v, cc, ki, 0.0f);
            // Contact-hardening penumbrae: the light radius of the main quality reference.
            if (m.quality && m.penumbrae)
                for (int cc : m.cc)
                    for (float ki : m.ki) addLmm("penumbra", kDefaultLightMeshVariant, cc, ki, QualityRadius(scene, m));
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
                                                                     : r.method + "-" + r.accel) + ".png";
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
                if (results[i].method == "rt" && !rtImage) rtImage = &images[i];
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
                o.areaLight.radius = q.radius * f;
                o.areaLight.samples = m.refSamples;
                std::unique_ptr<RenderJob> keep;
                RenderResult rr = render(scene, lmmAccel, o, nullptr, &keep);
                if (f == 1.0f) {
                    q.mainRadius = q.radii.size();
                    if (!m.imageDir.empty()) {
                        q.refImage = (std::filesystem::path(m.imageDir) /
                                      (SceneStem(spec) + StringPrintf("-%dx%d-area-R%g-N%d.png", width, height,
                                                                      o.areaLight.radius, m.refSamples)))
                                         .string();
                        WriteImage(q.refImage, rr.image);
                    }
                }
                q.radii.push_back(o.areaLight.radius);
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
                if (r.method == "none") continue;
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
    for (size_t i = 0; i < m.variants.size(); ++i) {
        try {
            ParseLightMeshVariant(m.variants[i]);
        } catch (const Error& e) {
            r.Fail(json::Index("/variants", i), e.what());
        }
    }
    strings("accels", &m.accels);
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
        for (size_t i = 0; i < l->size(); ++i)
            m.cc.push_back(json::SettingInt(r, (*l)[i], json::Index("/cc", i), RenderSettingFor("cc")));
    }
    if (const Json* l = list("ki")) {
        m.ki.clear();
        for (size_t i = 0; i < l->size(); ++i)
            m.ki.push_back(json::SettingFloat(r, (*l)[i], json::Index("/ki", i), RenderSettingFor("ki")));
    }
    if (const Json* v = o.Find("repeat")) m.repeat = json::Int(r, *v, "/repeat", 1, 100);
    if (const Json* v = o.Find("thin_check"))
        m.thinCheck = json::SettingChoice(r, *v, "/thin_check", RenderSettingFor("thin_check"));
    o.Finish();
    return m;
}

}  // namespace lm
