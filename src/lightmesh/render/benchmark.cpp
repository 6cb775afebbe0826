#include "lightmesh/render/benchmark.h"

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

float Luma(const Color& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

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
            for (int cc : m.cc)
                for (float ki : m.ki)
                    for (const std::string& v : m.variants) {
                        const LightMeshVariant variant = ParseLightMeshVariant(v);
                        BenchResult r;
                        r.method = "lmm";
                        r.variant = variant.name;
                        r.paperName = variant.paperName;
                        r.cc = cc;
                        r.ki = ki;
                        RenderOptions options = base;
                        options.lightMesh.cc = cc;
                        options.lightMesh.ki = ki;
                        options.lightMesh.variant = v;
                        options.lightMesh.cellSummaries = m.cellSummaries;
                        add(r, lmmAccel, options);
                    }
            // Contact-hardening penumbrae: the light radius of the main quality reference.
            if (m.quality && m.penumbrae)
                for (int cc : m.cc)
                    for (float ki : m.ki) {
                        const LightMeshVariant variant = ParseLightMeshVariant(kDefaultLightMeshVariant);
                        BenchResult r;
                        r.method = "penumbra";
                        r.variant = variant.name;
                        r.paperName = variant.paperName;
                        r.cc = cc;
                        r.ki = ki;
                        r.lightRadius = QualityRadius(scene, m);
                        RenderOptions options = base;
                        options.lightMesh.cc = cc;
                        options.lightMesh.ki = ki;
                        options.lightMesh.variant = variant.name;
                        options.lightMesh.cellSummaries = m.cellSummaries;
                        options.areaLight.radius = r.lightRadius;
                        add(r, lmmAccel, options);
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
                                            : r.method == "penumbra" ? StringPrintf("cc%d-ki%g-%s-R%g", r.cc, r.ki,
                                                                                    r.variant.c_str(), r.lightRadius)
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
                            : r.method == "penumbra" ? StringPrintf("%s (%s) CC %d kI %g, light radius %.3g",
                                                                    r.paperName.c_str(), r.variant.c_str(), r.cc, r.ki,
                                                                    r.lightRadius)
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

namespace {

const BenchResult* Find(const std::vector<BenchResult>& rs, const BenchResult& like, const std::string& variant,
                        int cc, float ki) {
    for (const BenchResult& r : rs)
        if (r.scene == like.scene && r.width == like.width && r.height == like.height && r.method == "lmm" &&
            r.variant == variant && r.cc == cc && r.ki == ki)
            return &r;
    return nullptr;
}

std::string Ratio(const BenchResult* a, const BenchResult* b) {
    if (!a || !b || !(b->median > 0)) return "–";
    return StringPrintf("%.2f", a->median / b->median);
}

/// The first result of each (scene, image size), in the order they were run: the tables and
/// report sections.
std::vector<const BenchResult*> SceneSizeGroups(const std::vector<BenchResult>& rs) {
    std::vector<const BenchResult*> groups;
    for (const BenchResult& r : rs) {
        bool seen = false;
        for (const BenchResult* g : groups) seen |= g->scene == r.scene && g->width == r.width && g->height == r.height;
        if (!seen) groups.push_back(&r);
    }
    return groups;
}

}  // namespace

std::string BenchMarkdown(const std::vector<BenchResult>& rs) {
    std::string out;
    const std::vector<const BenchResult*> groups = SceneSizeGroups(rs);
    for (const BenchResult* g : groups) {
        std::vector<std::string> variants;
        std::vector<std::pair<int, float>> rows;
        const BenchResult *none = nullptr, *rt = nullptr;
        std::string rtLine;
        for (const BenchResult& r : rs) {
            if (r.scene != g->scene || r.width != g->width || r.height != g->height) continue;
            if (r.method == "none") none = &r;
            if (r.method == "rt") {
                if (!rt) rt = &r;
                rtLine += StringPrintf("%sRT (%s) %.3f s", rtLine.empty() ? "" : ", ", r.accel.c_str(), r.median);
            }
            if (r.method != "lmm") continue;
            if (std::find(variants.begin(), variants.end(), r.variant) == variants.end()) variants.push_back(r.variant);
            if (std::find(rows.begin(), rows.end(), std::pair{r.cc, r.ki}) == rows.end()) rows.push_back({r.cc, r.ki});
        }
        out += StringPrintf("### %s, %dx%d\n\n", g->scene.c_str(), g->width, g->height);
        if (none) out += StringPrintf("No shadows %.3f s; ", none->median);
        out += rtLine + StringPrintf(" (median of %zu runs after a warm-up).\n\n", g->seconds.size());
        for (const BenchResult& r : rs)
            if (r.method == "penumbra" && r.scene == g->scene && r.width == g->width && r.height == g->height)
                out += StringPrintf("Contact-hardening penumbrae (%s, light radius %.3g), CC %d kI %g: %.3f s%s.\n\n",
                                    r.variant.c_str(), r.lightRadius, r.cc, r.ki, r.median,
                                    rt && rt->median > 0 ? StringPrintf(", %.2f× RT", r.median / rt->median).c_str() : "");
        // A (CC, kI) × variant table of one figure per cell.
        auto variantTable = [&](bool longNames, const char* format, auto&& value) {
            out += "| CC | kI |";
            for (const std::string& v : variants)
                out += " " + ParseLightMeshVariant(v).paperName + (longNames ? " (" + v + ")" : "") + " |";
            out += "\n|---|---|";
            for (size_t i = 0; i < variants.size(); ++i) out += "---|";
            out += "\n";
            for (auto [cc, ki] : rows) {
                out += StringPrintf("| %d | %g |", cc, ki);
                for (const std::string& v : variants) {
                    const BenchResult* r = Find(rs, *g, v, cc, ki);
                    out += r ? StringPrintf(format, value(*r)) : " – |";
                }
                out += "\n";
            }
        };
        // Seconds.
        variantTable(true, " %.3f |", [](const BenchResult& r) { return r.median; });
        // Ratios.
        out += "\nRatios (same run):\n\n| CC | kI |";
        for (const std::string& v : variants) out += " " + ParseLightMeshVariant(v).paperName + "/RT |";
        out += " Ш/Grid | У/Ш | СТ/ОТ | СТ/Нет |\n|---|---|";
        for (size_t i = 0; i < variants.size() + 4; ++i) out += "---|";
        out += "\n";
        for (auto [cc, ki] : rows) {
            out += StringPrintf("| %d | %g |", cc, ki);
            for (const std::string& v : variants) out += " " + Ratio(Find(rs, *g, v, cc, ki), rt) + " |";
            out += " " + Ratio(Find(rs, *g, "templates", cc, ki), Find(rs, *g, "grid", cc, ki)) + " |";
            out += " " + Ratio(Find(rs, *g, "reduced", cc, ki), Find(rs, *g, "templates", cc, ki)) + " |";
            out += " " + Ratio(Find(rs, *g, "inside", cc, ki), Find(rs, *g, "object", cc, ki)) + " |";
            out += " " + Ratio(Find(rs, *g, "inside", cc, ki), Find(rs, *g, "none", cc, ki)) + " |";
            out += "\n";
        }
        // The shadow work alone: what each method adds to the render without shadows.
        if (none && rt && rt->median > none->median) {
            out += "\nShadow part, (method - no shadows) / (RT - no shadows), same run:\n\n";
            variantTable(false, " %.2f |", [&](const BenchResult& r) {
                return (r.median - none->median) / (rt->median - none->median);
            });
        }
        out += "\n";
    }
    return out;
}

std::string BenchCsv(const std::vector<BenchResult>& rs) {
    std::string out =
        "scene,width,height,method,variant,paper_name,accel,cc,ki,median_s,runs_s,setup_s,camera_rays,shadow_rays,"
        "reflection_rays,local_segments,interpolations,mean_m,fallbacks,nodes_evaluated,peak_memory_bytes,image,"
        "uniform_cell_points,culled_segments,light_radius,penumbra_lights\n";
    for (const BenchResult& r : rs) {
        std::string runs;
        for (double s : r.seconds) runs += StringPrintf("%s%.4f", runs.empty() ? "" : " ", s);
        const RenderCounters& c = r.counters;
        out += StringPrintf("%s,%d,%d,%s,%s,%s,%s,%d,%g,%.4f,%s,%.4f,%llu,%llu,%llu,%llu,%llu,%.2f,%llu,%llu,%llu,%s,%llu,%llu,%g,%llu\n",
                            r.scene.c_str(), r.width, r.height, r.method.c_str(), r.variant.c_str(),
                            r.paperName.c_str(), r.accel.c_str(), r.cc, r.ki, r.median, runs.c_str(), r.setupSeconds,
                            static_cast<unsigned long long>(c.cameraRays), static_cast<unsigned long long>(c.shadowRays),
                            static_cast<unsigned long long>(c.reflectionRays),
                            static_cast<unsigned long long>(c.localSegments),
                            static_cast<unsigned long long>(c.interpolations),
                            c.interpolations ? static_cast<double>(c.nodesUsed) / static_cast<double>(c.interpolations) : 0.0,
                            static_cast<unsigned long long>(c.fallbacks),
                            static_cast<unsigned long long>(r.nodesEvaluated),
                            static_cast<unsigned long long>(r.peakMemoryBytes), r.image.c_str(),
                            static_cast<unsigned long long>(c.uniformCellPoints),
                            static_cast<unsigned long long>(c.culledSegments), r.lightRadius,
                            static_cast<unsigned long long>(c.penumbraLights));
    }
    return out;
}

}  // namespace lm

// ---------------------------------------------------------------------------------------
// Presets, --matrix files, quality tables and the HTML report

namespace lm {

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
    o.Finish();
    return m;
}

namespace {

std::string Psnr(double v) { return v >= 99 ? "∞" : StringPrintf("%.2f", v); }

}  // namespace

namespace {

/// PSNR (against the main reference) of naive soft shadows at `seconds`, read off the area
/// rows' time–PSNR curve by linear interpolation; NaN outside the times measured.
double AreaPsnrAt(const BenchQuality& q, double seconds) {
    std::vector<std::pair<double, double>> curve;
    for (const QualityRow& row : q.rows)
        if (row.method == "area") curve.push_back({row.seconds, row.psnr[q.mainRadius]});
    std::sort(curve.begin(), curve.end());
    for (size_t i = 1; i < curve.size(); ++i)
        if (seconds >= curve[i - 1].first && seconds <= curve[i].first && curve[i].first > curve[i - 1].first)
            return curve[i - 1].second + (curve[i].second - curve[i - 1].second) * (seconds - curve[i - 1].first) /
                                             (curve[i].first - curve[i - 1].first);
    return std::nan("");
}

/// The contact-hardening rows against RT, the same (CC, kI) without a light radius and
/// naive soft shadows at equal time: the targets of the penumbra mode, as ratios and dB
/// differences from one run.
std::string PenumbraQualityMarkdown(const BenchQuality& q) {
    const size_t mr = q.mainRadius;
    const QualityRow* rt = nullptr;
    for (const QualityRow& row : q.rows)
        if (row.method == "rt" && !rt) rt = &row;
    std::string out;
    for (const QualityRow& row : q.rows) {
        if (row.method != "penumbra") continue;
        if (out.empty())
            out = StringPrintf(
                "\n\nContact-hardening penumbrae (light radius = the main reference's R = %.4g) against RT, the "
                "same light mesh with its fixed radius, and naive soft shadows at equal time (interpolated on "
                "their time–PSNR curve):\n\n| Method | s | × RT | PSNR dB | SSIM | − RT dB | − fixed radius dB | "
                "area at equal time dB |\n|---|---|---|---|---|---|---|---|\n",
                q.radii[mr]);
        const QualityRow* fixed = nullptr;
        for (const QualityRow& other : q.rows)
            if (other.method == "lmm" && other.variant == row.variant && other.cc == row.cc && other.ki == row.ki)
                fixed = &other;
        const double area = AreaPsnrAt(q, row.seconds);
        // Outside the curve: say on which side, with the nearest end's figures.
        std::string areaText = Psnr(area);
        if (std::isnan(area)) {
            const QualityRow *fastest = nullptr, *slowest = nullptr;
            for (const QualityRow& other : q.rows) {
                if (other.method != "area") continue;
                if (!fastest || other.seconds < fastest->seconds) fastest = &other;
                if (!slowest || other.seconds > slowest->seconds) slowest = &other;
            }
            areaText = !fastest ? "–"
                       : row.seconds < fastest->seconds
                           ? StringPrintf("faster than N=%d (%.3f s, %s dB)", fastest->samples, fastest->seconds,
                                          Psnr(fastest->psnr[mr]).c_str())
                           : StringPrintf("slower than N=%d (%.3f s, %s dB)", slowest->samples, slowest->seconds,
                                          Psnr(slowest->psnr[mr]).c_str());
        }
        out += StringPrintf("| %s | %.3f | %s | %s | %.4f | %s | %s | %s |\n", row.label.c_str(), row.seconds,
                            rt && rt->seconds > 0 ? StringPrintf("%.2f", row.seconds / rt->seconds).c_str() : "–",
                            Psnr(row.psnr[mr]).c_str(), row.ssim[mr],
                            rt ? StringPrintf("%+.1f", row.psnr[mr] - rt->psnr[mr]).c_str() : "–",
                            fixed ? StringPrintf("%+.1f", row.psnr[mr] - fixed->psnr[mr]).c_str() : "–",
                            areaText.c_str());
    }
    return out;
}

}  // namespace

std::string BenchQualityMarkdown(const BenchReport& report) {
    std::string out;
    for (const BenchQuality& q : report.quality) {
        const size_t mr = q.mainRadius;
        out += StringPrintf("### Quality: %s, %dx%d\n\n", q.scene.c_str(), q.width, q.height);
        out += StringPrintf(
            "Against the area-light reference (\"area\", %d samples) of radius R = r = kI·h = %.4g (h = %.4g; "
            "%.1f px at the look-at distance). Leaks: pixels deeper than r inside RT's shadow that the method "
            "lights (approximate, see BenchQuality).\n\n",
            q.refSamples, q.radius, q.meshStep, q.radiusPixels);
        out += "| Method | s | PSNR dB | SSIM | leaks px |\n|---|---|---|---|---|\n";
        for (const QualityRow& row : q.rows)
            out += StringPrintf("| %s | %.3f | %s | %.4f | %s |\n", row.label.c_str(), row.seconds,
                                Psnr(row.psnr[mr]).c_str(), row.ssim[mr],
                                row.leaks < 0 ? "–" : std::to_string(row.leaks).c_str());
        // Radius sweep: mean PSNR of the LMM rows of each kI against each reference.
        std::vector<float> kis;
        for (const QualityRow& row : q.rows)
            if (row.method == "lmm" && std::find(kis.begin(), kis.end(), row.ki) == kis.end()) kis.push_back(row.ki);
        out += "\nReference radius sweep (mean PSNR dB of the LMM variants):\n\n| kI |";
        for (size_t i = 0; i < q.radii.size(); ++i) out += StringPrintf(" R=%.4g |", q.radii[i]);
        out += " best R |\n|---|";
        for (size_t i = 0; i <= q.radii.size(); ++i) out += "---|";
        out += "\n";
        for (float ki : kis) {
            out += StringPrintf("| %g |", ki);
            size_t best = 0;
            double bestV = -1e9;
            for (size_t i = 0; i < q.radii.size(); ++i) {
                double sum = 0;
                int n = 0;
                for (const QualityRow& row : q.rows)
                    if (row.method == "lmm" && row.ki == ki) sum += row.psnr[i], ++n;
                const double mean = n ? sum / n : 0;
                if (mean > bestV) bestV = mean, best = i;
                out += " " + Psnr(mean) + " |";
            }
            out += StringPrintf(" %.4g (%.2g·kI·h) |\n", q.radii[best], q.radii[best] / (ki * q.meshStep));
        }
        out += StringPrintf("\nReference render times:");
        for (size_t i = 0; i < q.radii.size(); ++i) out += StringPrintf(" R=%.4g %.2f s;", q.radii[i], q.refSeconds[i]);
        // Naive soft shadows against the best LMM row of the first kI.
        const QualityRow* lmm = nullptr;
        for (const QualityRow& row : q.rows)
            if (row.method == "lmm" && row.ki == (kis.empty() ? 0 : kis.front()) &&
                (!lmm || row.psnr[mr] > lmm->psnr[mr]))
                lmm = &row;
        if (lmm) {
            out += StringPrintf("\n\nNaive soft shadows (area, R = r) against the best LMM at kI %g, %s (%.2f dB, %.3f s):\n\n",
                                lmm->ki, lmm->label.c_str(), lmm->psnr[mr], lmm->seconds);
            out += "| N | s | × LMM time | PSNR dB | SSIM |\n|---|---|---|---|---|\n";
            const QualityRow* reach = nullptr;
            for (const QualityRow& row : q.rows) {
                if (row.method != "area") continue;
                out += StringPrintf("| %d | %.3f | %.2f | %s | %.4f |\n", row.samples, row.seconds,
                                    lmm->seconds > 0 ? row.seconds / lmm->seconds : 0.0, Psnr(row.psnr[mr]).c_str(),
                                    row.ssim[mr]);
                if (!reach && row.psnr[mr] >= lmm->psnr[mr]) reach = &row;
            }
            if (reach)
                out += StringPrintf("\nNaive soft shadows reach LMM's PSNR at N = %d, %.1f× LMM's time.\n", reach->samples,
                                    lmm->seconds > 0 ? reach->seconds / lmm->seconds : 0.0);
            else
                out += "\nNaive soft shadows do not reach LMM's PSNR at the N tried.\n";
        }
        out += PenumbraQualityMarkdown(q);
        out += "\n";
    }
    return out;
}

}  // namespace lm

namespace lm {
namespace {

std::string HtmlEscape(const std::string& s) {
    std::string o;
    for (char c : s) {
        if (c == '<') o += "&lt;";
        else if (c == '>') o += "&gt;";
        else if (c == '&') o += "&amp;";
        else if (c == '"') o += "&quot;";
        else o += c;
    }
    return o;
}

/// The subset of Markdown that BenchMarkdown and BenchQualityMarkdown write.
std::string MarkdownToHtml(const std::string& md) {
    std::string out;
    std::istringstream in(md);
    std::string line;
    bool inTable = false, header = false;
    while (std::getline(in, line)) {
        if (!line.empty() && line[0] == '|') {
            if (line.rfind("|---", 0) == 0) continue;
            if (!inTable) out += "<table>\n", inTable = true, header = true;
            std::vector<std::string> cells;
            size_t p = 1;
            while (p < line.size()) {
                const size_t q = line.find('|', p);
                if (q == std::string::npos) break;
                std::string c = line.substr(p, q - p);
                const size_t a = c.find_first_not_of(' '), b = c.find_last_not_of(' ');
                cells.push_back(a == std::string::npos ? "" : c.substr(a, b - a + 1));
                p = q + 1;
            }
            out += "<tr>";
            for (const std::string& c : cells) out += (header ? "<th>" : "<td>") + HtmlEscape(c) + (header ? "</th>" : "</td>");
            out += "</tr>\n";
            header = false;
            continue;
        }
        if (inTable) out += "</table>\n", inTable = false;
        if (line.rfind("### ", 0) == 0) out += "<h3>" + HtmlEscape(line.substr(4)) + "</h3>\n";
        else if (!line.empty()) out += "<p>" + HtmlEscape(line) + "</p>\n";
    }
    if (inTable) out += "</table>\n";
    return out;
}

std::string Base64(const std::string& bytes) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string o;
    o.reserve((bytes.size() + 2) / 3 * 4);
    for (size_t i = 0; i < bytes.size(); i += 3) {
        uint32_t v = static_cast<uint8_t>(bytes[i]) << 16;
        if (i + 1 < bytes.size()) v |= static_cast<uint8_t>(bytes[i + 1]) << 8;
        if (i + 2 < bytes.size()) v |= static_cast<uint8_t>(bytes[i + 2]);
        o += t[(v >> 18) & 63];
        o += t[(v >> 12) & 63];
        o += i + 1 < bytes.size() ? t[(v >> 6) & 63] : '=';
        o += i + 2 < bytes.size() ? t[v & 63] : '=';
    }
    return o;
}

std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) ThrowError("%s: cannot read the image for the report", path.c_str());
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"};

struct Series {
    std::string name;
    std::vector<std::pair<double, double>> points;
};

/// A line chart: x = kI, one polyline per series, an optional dashed horizontal line.
std::string SvgChart(const std::string& title, const std::string& yLabel, const std::vector<Series>& series,
                     double hline, const std::string& hlineName) {
    const double W = 520, H = 300, L = 60, R = 150, T = 30, B = 45;
    double x0 = 1e300, x1 = -1e300, y1 = hline > 0 ? hline : 0;
    for (const Series& s : series)
        for (auto [x, y] : s.points) x0 = std::min(x0, x), x1 = std::max(x1, x), y1 = std::max(y1, y);
    if (x0 > x1) return "";
    if (x1 - x0 < 1e-9) x0 -= 0.5, x1 += 0.5;
    y1 = y1 > 0 ? y1 * 1.1 : 1;
    auto X = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
    auto Y = [&](double y) { return H - B - y / y1 * (H - T - B); };
    std::string o = StringPrintf("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%g\" height=\"%g\" viewBox=\"0 0 %g %g\">", W, H, W, H);
    o += StringPrintf("<rect width=\"%g\" height=\"%g\" fill=\"#fff\"/>", W, H);
    o += StringPrintf("<text x=\"%g\" y=\"18\" font-size=\"14\" font-weight=\"bold\">%s</text>", L, HtmlEscape(title).c_str());
    for (int i = 0; i <= 4; ++i) {  // y grid
        const double v = y1 * i / 4;
        o += StringPrintf("<line x1=\"%g\" y1=\"%.1f\" x2=\"%g\" y2=\"%.1f\" stroke=\"#ddd\"/>", L, Y(v), W - R, Y(v));
        o += StringPrintf("<text x=\"%g\" y=\"%.1f\" font-size=\"11\" text-anchor=\"end\">%.3g</text>", L - 5, Y(v) + 4, v);
    }
    std::vector<double> xs;
    for (const Series& s : series)
        for (auto p : s.points)
            if (std::find(xs.begin(), xs.end(), p.first) == xs.end()) xs.push_back(p.first);
    for (double x : xs)
        o += StringPrintf("<text x=\"%.1f\" y=\"%g\" font-size=\"11\" text-anchor=\"middle\">%g</text>", X(x), H - B + 15, x);
    o += StringPrintf("<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"#000\"/>", L, H - B, W - R, H - B);
    o += StringPrintf("<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"#000\"/>", L, T, L, H - B);
    o += StringPrintf("<text x=\"%g\" y=\"%g\" font-size=\"12\" text-anchor=\"middle\">kI</text>", (L + W - R) / 2, H - 8);
    o += StringPrintf("<text x=\"14\" y=\"%g\" font-size=\"12\" text-anchor=\"middle\" transform=\"rotate(-90 14 %g)\">%s</text>",
                      (T + H - B) / 2, (T + H - B) / 2, HtmlEscape(yLabel).c_str());
    if (hline > 0) {
        o += StringPrintf("<line x1=\"%g\" y1=\"%.1f\" x2=\"%g\" y2=\"%.1f\" stroke=\"#000\" stroke-dasharray=\"6 4\"/>", L, Y(hline),
                          W - R, Y(hline));
        o += StringPrintf("<text x=\"%g\" y=\"%.1f\" font-size=\"11\">%s</text>", W - R + 5, Y(hline) + 4,
                          HtmlEscape(hlineName).c_str());
    }
    for (size_t i = 0; i < series.size(); ++i) {
        const char* c = kPalette[i % 8];
        std::string pts;
        for (auto [x, y] : series[i].points) pts += StringPrintf("%.1f,%.1f ", X(x), Y(y));
        o += StringPrintf("<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\" points=\"%s\"/>", c, pts.c_str());
        for (auto [x, y] : series[i].points)
            o += StringPrintf("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"/>", X(x), Y(y), c);
        o += StringPrintf("<rect x=\"%g\" y=\"%g\" width=\"12\" height=\"3\" fill=\"%s\"/>", W - R + 8, T + 10 + 16.0 * i, c);
        o += StringPrintf("<text x=\"%g\" y=\"%g\" font-size=\"11\">%s</text>", W - R + 24, T + 15 + 16.0 * i,
                          HtmlEscape(series[i].name).c_str());
    }
    return o + "</svg>";
}

/// The window (a quarter of each side) where the LMM images differ most from RT.
struct Window { int x = 0, y = 0, w = 0, h = 0; };
Window MostDifferent(const Image& rt, const std::vector<Image>& others) {
    const int W = rt.width, H = rt.height;
    Window win{0, 0, std::max(1, W / 4), std::max(1, H / 4)};
    // Summed-area table of the summed |luma difference|.
    std::vector<double> sat(static_cast<size_t>(W + 1) * (H + 1), 0.0);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double d = 0;
            for (const Image& o : others)
                if (o.width == W && o.height == H) d += std::abs(Luma(o.At(x, y)) - Luma(rt.At(x, y)));
            sat[static_cast<size_t>(y + 1) * (W + 1) + x + 1] = d + sat[static_cast<size_t>(y) * (W + 1) + x + 1] +
                                                                sat[static_cast<size_t>(y + 1) * (W + 1) + x] -
                                                                sat[static_cast<size_t>(y) * (W + 1) + x];
        }
    auto S = [&](int x, int y) { return sat[static_cast<size_t>(y) * (W + 1) + x]; };
    double best = -1;
    const int step = std::max(1, std::min(W, H) / 64);
    for (int y = 0; y + win.h <= H; y += step)
        for (int x = 0; x + win.w <= W; x += step) {
            const double s = S(x + win.w, y + win.h) - S(x, y + win.h) - S(x + win.w, y) + S(x, y);
            if (s > best) best = s, win.x = x, win.y = y;
        }
    return win;
}

}  // namespace

std::string BenchHtml(const BenchReport& report, const std::string& title) {
    const std::vector<BenchResult>& rs = report.results;
    std::string o = "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + HtmlEscape(title) +
                    "</title>\n<style>\n"
                    "body{font-family:system-ui,sans-serif;margin:20px;color:#222;max-width:1400px}\n"
                    "table{border-collapse:collapse;margin:8px 0 16px}td,th{border:1px solid #bbb;padding:3px 8px;"
                    "text-align:right;font-size:13px}th{background:#eef}td:first-child{text-align:left}\n"
                    "h2{border-bottom:2px solid #99c;margin-top:32px}.charts{display:flex;flex-wrap:wrap;gap:12px}\n"
                    ".charts svg{border:1px solid #ccc}.imgs{display:flex;flex-wrap:wrap;gap:10px}\n"
                    "figure{margin:0;width:240px;font-size:12px}.full{position:relative;width:240px;"
                    "background-size:100% 100%;image-rendering:pixelated}\n"
                    ".crop{width:240px;border:1px solid #555;margin-top:4px;image-rendering:pixelated}\n"
                    ".win{position:absolute;border:2px solid #f0f;box-sizing:border-box}\n"
                    "</style></head><body>\n<h1>" + HtmlEscape(title) + "</h1>\n";
    o += StringPrintf("<p>Seconds are the median of %d timed run(s) after a warm-up. Charts: render time and the LMM/RT "
                      "ratio against kI per variant (dashed: RT). Images: every cell, with a zoomed crop (magenta "
                      "window) where the LMM images differ most from RT.</p>\n", report.repeat);
    const std::vector<const BenchResult*> groups = SceneSizeGroups(rs);
    for (const BenchResult* g : groups) {
        std::vector<BenchResult> group;
        for (const BenchResult& r : rs)
            if (r.scene == g->scene && r.width == g->width && r.height == g->height) group.push_back(r);
        o += StringPrintf("<h2>%s, %d×%d</h2>\n", HtmlEscape(g->scene).c_str(), g->width, g->height);
        std::string md = BenchMarkdown(group);
        if (md.rfind("### ", 0) == 0) md = md.substr(md.find('\n') + 1);  // the h2 says it
        o += MarkdownToHtml(md);
        // Charts.
        const BenchResult* rt = nullptr;
        for (const BenchResult& r : group)
            if (r.method == "rt" && !rt) rt = &r;
        std::vector<Series> secs, ratios;
        std::set<int> ccs;
        for (const BenchResult& r : group)
            if (r.method == "lmm") ccs.insert(r.cc);
        for (const BenchResult& r : group) {
            if (r.method != "lmm") continue;
            const std::string name = r.paperName + " " + r.variant + (ccs.size() > 1 ? StringPrintf(" CC%d", r.cc) : "");
            auto it = std::find_if(secs.begin(), secs.end(), [&](const Series& s) { return s.name == name; });
            if (it == secs.end()) secs.push_back({name, {}}), ratios.push_back({name, {}}), it = secs.end() - 1;
            const size_t i = static_cast<size_t>(it - secs.begin());
            secs[i].points.push_back({r.ki, r.median});
            if (rt && rt->median > 0) ratios[i].points.push_back({r.ki, r.median / rt->median});
        }
        if (!secs.empty()) {
            o += "<div class=\"charts\">" + SvgChart("Render time", "seconds", secs, rt ? rt->median : 0, "RT");
            o += SvgChart("LMM / RT", "ratio", ratios, 1.0, "RT = 1") + "</div>\n";
        }
        // Images.
        bool haveImages = rt && !rt->image.empty();
        if (haveImages) {
            const Image rtImage = ReadImage(rt->image);
            std::vector<Image> lmm;
            for (const BenchResult& r : group)
                if ((r.method == "lmm" || r.method == "penumbra") && !r.image.empty()) lmm.push_back(ReadImage(r.image));
            const Window win = MostDifferent(rtImage, lmm);
            const double fullH = 240.0 * g->height / g->width;
            const double zoom = 240.0 / win.w;  // crop width 240 px
            o += "<h3>Images</h3>\n<div class=\"imgs\">\n";
            int n = 0;
            // One image with its crop of the window.
            auto figure = [&](const std::string& path, const std::string& caption) {
                const std::string cls = StringPrintf("i%zu_%d", static_cast<size_t>(g - rs.data()), n++);
                o += "<style>." + cls + "{background-image:url(data:image/png;base64," + Base64(ReadBytes(path)) +
                     ")}</style>\n";
                o += StringPrintf("<figure><div class=\"full %s\" style=\"height:%.0fpx\"><div class=\"win\" style=\"left:%.1fpx;"
                                  "top:%.1fpx;width:%.1fpx;height:%.1fpx\"></div></div>",
                                  cls.c_str(), fullH, 240.0 * win.x / g->width, 240.0 * win.y / g->width,
                                  240.0 * win.w / g->width, 240.0 * win.h / g->width);
                o += StringPrintf("<div class=\"crop %s\" style=\"height:%.0fpx;background-size:%.1fpx %.1fpx;"
                                  "background-position:%.1fpx %.1fpx\"></div>",
                                  cls.c_str(), win.h * zoom, g->width * zoom, g->height * zoom, -win.x * zoom, -win.y * zoom);
                o += "<figcaption>" + HtmlEscape(caption) + "</figcaption></figure>\n";
            };
            for (const BenchQuality& q : report.quality)
                if (q.scene == g->scene && q.width == g->width && q.height == g->height && !q.refImage.empty())
                    figure(q.refImage, StringPrintf("area-light reference, R = %.3g, N = %d, %.2f s", q.radii[q.mainRadius],
                                                    q.refSamples, q.refSeconds[q.mainRadius]));
            for (const BenchResult& r : group) {
                if (r.image.empty()) continue;
                const std::string caption =
                    r.method == "penumbra"
                        ? StringPrintf("%s (%s) CC %d kI %g, light radius %.3g, %.3f s", r.paperName.c_str(),
                                       r.variant.c_str(), r.cc, r.ki, r.lightRadius, r.median)
                    : r.method == "lmm" ? StringPrintf("%s (%s) CC %d kI %g, %.3f s", r.paperName.c_str(), r.variant.c_str(), r.cc,
                                                     r.ki, r.median)
                                      : StringPrintf("%s (%s), %.3f s", r.method == "rt" ? "RT" : "no shadows",
                                                     r.accel.c_str(), r.median);
                figure(r.image, caption);
            }
            o += "</div>\n";
        }
        // Quality of this group.
        for (const BenchQuality& q : report.quality)
            if (q.scene == g->scene && q.width == g->width && q.height == g->height) {
                BenchReport one;
                one.quality.push_back(q);
                o += MarkdownToHtml(BenchQualityMarkdown(one));
            }
    }
    return o + "</body></html>\n";
}

}  // namespace lm
