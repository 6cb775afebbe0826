// runner.cpp -- `lightmesh bench`'s runner: one run of the matrix, from its plan to its
// report, the paper's table presets and --matrix files. A run's parts are matrix_plan.cpp
// (checks, counts, the time estimate), cell_runs.cpp (a scene and size's cells rendered
// round-robin with a warm-up) and quality_judge.cpp (the --quality references and
// judgements); the tables and the HTML report are tables.cpp and html_report.cpp.
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/bench/runner_internal.h"

#include <algorithm>
#include <filesystem>
#include <memory>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/settings/render_settings.h"
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

BenchReport RunBenchmarkReport(const BenchMatrix& m,
                               const std::function<void(int, int, const BenchResult&)>& progress,
                               const std::function<void(double)>& estimate) {
    const BenchPlan plan = PlanBench(m);
    BenchRun run{.m = m, .plan = plan, .progress = progress, .report = {}, .done = 0};
    run.report.repeat = m.repeat;
    // Load every scene first: a missing model fails before any work.
    const std::vector<std::unique_ptr<LoadedScene>> loaded = LoadBenchScenes(m, plan);
    EstimateBench(m, plan, loaded, estimate);
    for (size_t si = 0; si < loaded.size(); ++si) {
        const std::string& spec = m.scenes[si];
        const Scene& scene = loaded[si]->scene;
        auto& accels = loaded[si]->accels;
        const Accelerator& lmmAccel = *accels[m.accels.front()];
        for (const auto& size : m.sizes) {
            const int width = size.first, height = size.second;
            RenderOptions base = scene.render;
            base.width = width;
            base.height = height;
            RenderOptions compBase = base;
            if (m.lightRadius) compBase.areaLight.radius = *m.lightRadius;
            SceneSizeRun s{.spec = spec,
                           .scene = scene,
                           .lmmAccel = lmmAccel,
                           .compAcc = m.quality ? *accels.at(plan.compAccel) : lmmAccel,  // loaded with --quality
                           .width = width,
                           .height = height,
                           .base = base,
                           .compBase = compBase,
                           .first = run.report.results.size(),
                           .images = {}};
            std::vector<BenchCell> cells = PlanCells(run, *loaded[si], s);
            RunCells(run, cells, s);
            if (m.quality) JudgeQuality(run, s);
        }
    }
    return std::move(run.report);
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
