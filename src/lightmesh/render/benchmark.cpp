#include "lightmesh/render/benchmark.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <set>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/io/image.h"
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

std::vector<BenchResult> RunBenchmark(const BenchMatrix& m,
                                      const std::function<void(int, int, const BenchResult&)>& progress) {
    if (m.repeat < 1) ThrowError("bench: --repeat must be at least 1");
    if (m.accels.empty()) ThrowError("bench: no ray-query back-end given");
    for (const std::string& v : m.variants) ParseLightMeshVariant(v);  // fail before any work
    if (!m.imageDir.empty()) CheckWritableFolder((std::filesystem::path(m.imageDir) / "x.png").string());
    const int perSize = (m.noShadows ? 1 : 0) + static_cast<int>(m.accels.size()) +
                        static_cast<int>(m.cc.size() * m.ki.size() * m.variants.size());
    const int total = static_cast<int>(m.scenes.size() * m.sizes.size()) * perSize;
    int done = 0;
    std::vector<BenchResult> results;
    for (const std::string& spec : m.scenes) {
        SceneLoadOptions load;
        std::vector<std::string> warnings;
        Scene scene = LoadScene(spec, load, &warnings);
        std::map<std::string, std::unique_ptr<Accelerator>> accels;
        for (const std::string& a : m.accels) accels[a] = CreateAccelerator(a, scene.mesh, scene.render.accelOptions);
        const Accelerator& lmmAccel = *accels[m.accels.front()];
        for (const auto& size : m.sizes) {
            // Plain variables, not structured bindings: the lambdas below capture them,
            // which clang before 16 rejects (the sanitizer and fuzzing builds use clang 14).
            const int width = size.first, height = size.second;
            RenderOptions base = scene.render;
            base.width = width;
            base.height = height;
            auto run = [&](BenchResult r, const Accelerator& accel, RenderOptions options) {
                r.scene = spec;
                r.width = width;
                r.height = height;
                r.accel = std::string(accel.Name());
                options.shadows = r.method;
                for (int i = -1; i < m.repeat; ++i) {  // i = -1: the warm-up run
                    const auto t0 = Clock::now();
                    auto shadows = CreateShadowMethod(r.method, scene, accel, options);
                    r.setupSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
                    WhittedRenderer renderer(scene, accel, *shadows, options);
                    RenderResult rr = renderer.Render();
                    if (i < 0) continue;
                    r.seconds.push_back(rr.seconds);
                    r.counters = rr.counters;
                    if (auto* lmm = dynamic_cast<const LightMeshShadows*>(shadows.get()))
                        r.nodesEvaluated = lmm->NodesEvaluated();
                    if (i == m.repeat - 1 && !m.imageDir.empty()) {
                        std::string name = SceneStem(spec) + StringPrintf("-%dx%d-", width, height) +
                                           (r.method == "lmm" ? StringPrintf("cc%d-ki%g-%s", r.cc, r.ki, r.variant.c_str())
                                                              : r.method + "-" + r.accel) + ".png";
                        r.image = (std::filesystem::path(m.imageDir) / name).string();
                        WriteImage(r.image, rr.image);
                    }
                }
                r.median = Median(r.seconds);
                r.peakMemoryBytes = PeakMemoryBytes();
                results.push_back(r);
                if (progress) progress(++done, total, results.back());
            };
            if (m.noShadows) {
                BenchResult r;
                r.method = "none";
                r.paperName = "none";
                run(r, lmmAccel, base);
            }
            for (const std::string& a : m.accels) {
                BenchResult r;
                r.method = "rt";
                r.paperName = "RT";
                run(r, *accels[a], base);
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
                        run(r, lmmAccel, options);
                    }
        }
    }
    return results;
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

}  // namespace

std::string BenchMarkdown(const std::vector<BenchResult>& rs) {
    std::string out;
    // Groups of (scene, size) in the order they were run.
    std::vector<const BenchResult*> groups;
    for (const BenchResult& r : rs) {
        bool seen = false;
        for (const BenchResult* g : groups) seen |= g->scene == r.scene && g->width == r.width && g->height == r.height;
        if (!seen) groups.push_back(&r);
    }
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
        // Seconds.
        out += "| CC | kI |";
        for (const std::string& v : variants) out += " " + ParseLightMeshVariant(v).paperName + " (" + v + ") |";
        out += "\n|---|---|";
        for (size_t i = 0; i < variants.size(); ++i) out += "---|";
        out += "\n";
        for (auto [cc, ki] : rows) {
            out += StringPrintf("| %d | %g |", cc, ki);
            for (const std::string& v : variants) {
                const BenchResult* r = Find(rs, *g, v, cc, ki);
                out += r ? StringPrintf(" %.3f |", r->median) : " – |";
            }
            out += "\n";
        }
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
        out += "\n";
    }
    return out;
}

std::string BenchCsv(const std::vector<BenchResult>& rs) {
    std::string out =
        "scene,width,height,method,variant,paper_name,accel,cc,ki,median_s,runs_s,setup_s,camera_rays,shadow_rays,"
        "reflection_rays,local_segments,interpolations,mean_m,fallbacks,nodes_evaluated,peak_memory_bytes,image\n";
    for (const BenchResult& r : rs) {
        std::string runs;
        for (double s : r.seconds) runs += StringPrintf("%s%.4f", runs.empty() ? "" : " ", s);
        const RenderCounters& c = r.counters;
        out += StringPrintf("%s,%d,%d,%s,%s,%s,%s,%d,%g,%.4f,%s,%.4f,%llu,%llu,%llu,%llu,%llu,%.2f,%llu,%llu,%llu,%s\n",
                            r.scene.c_str(), r.width, r.height, r.method.c_str(), r.variant.c_str(),
                            r.paperName.c_str(), r.accel.c_str(), r.cc, r.ki, r.median, runs.c_str(), r.setupSeconds,
                            static_cast<unsigned long long>(c.cameraRays), static_cast<unsigned long long>(c.shadowRays),
                            static_cast<unsigned long long>(c.reflectionRays),
                            static_cast<unsigned long long>(c.localSegments),
                            static_cast<unsigned long long>(c.interpolations),
                            c.interpolations ? static_cast<double>(c.nodesUsed) / static_cast<double>(c.interpolations) : 0.0,
                            static_cast<unsigned long long>(c.fallbacks),
                            static_cast<unsigned long long>(r.nodesEvaluated),
                            static_cast<unsigned long long>(r.peakMemoryBytes), r.image.c_str());
    }
    return out;
}

}  // namespace lm
