// bench_accel.cpp -- the ray-query back-ends on the same seeded ray sets: build time,
// camera rays (closest hit), shadow rays to a light and short light-mesh segments
// (occlusion), on one thread (rays per CPU second) and on all (rays per wall-clock second),
// with the grid/Embree ratios, build times and bytes per triangle printed at the end.
//
//   bench_accel [--scene=NAME,...] [--scene-file=a.json,...] [--mesh=a.obj:b.obj] [--grid16]
//               [benchmark flags]
//   e.g. bench_accel --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//   scripts/bench-accel.sh runs every scene below, the real ones included.
//
// Scenes (--scene, default all that are available; "none": only the --scene-file ones):
//  - "gazebo": builtin:gazebo, a few thousand triangles;
//  - "stadium": "a teapot in a stadium", a 196,608-triangle sphere on a ground slab three
//    times its width (procedural, always there);
//  - "trees": real meshes from a Debian package (scripts/fetch-bench-mesh.sh: two trees,
//    385,704 triangles) on a ground quad; the files come from --mesh or LIGHTMESH_BENCH_MESH
//    (':'-separated), else from the fetch script's cache folder; skipped with a note
//    without them;
//  - scene files given with --scene-file (e.g. scenes/real/castle.json), named by their
//    file's stem: their mesh, camera and first light.
#include <benchmark/benchmark.h>
#include <sys/stat.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "support/accel_scenes.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/scene/camera.h"
#include "lightmesh/scene/demo_scene.h"
#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace {

constexpr int kWidth = 320, kHeight = 240;  // camera rays: one per pixel
constexpr size_t kBruteRays = 1024;         // brute force gets a prefix of each ray set

struct BenchScene {
    std::string name;
    TriangleMesh mesh;
    Camera camera;
    Vec3 light;
    // Seeded ray sets, the same for every back-end.
    std::vector<Ray> cameraRays, shadowRays, shortRays;
    // The same camera and shadow rays tile by tile (kPacketTile² pixels), for the packet
    // workloads: packet k is rays [offsets[k], offsets[k + 1]).
    std::vector<Ray> cameraTileRays, shadowTileRays;
    std::vector<size_t> cameraTiles, shadowTiles;
};

// The packet workloads' tiles: 8 × 8 pixels, one 64-ray packet (what a renderer hands
// IntersectMany for a tile's camera rays, and OccludedMany for their shadow rays).
constexpr int kPacketTile = 8;

bool FileExists(const std::string& path) {
    struct stat st;
    return stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::vector<std::string> Split(const std::string& s, char sep) {
    std::vector<std::string> parts;
    size_t start = 0;
    for (;;) {
        const size_t end = s.find(sep, start);
        const std::string part = s.substr(start, end - start);
        if (!part.empty()) parts.push_back(part);
        if (end == std::string::npos) return parts;
        start = end + 1;
    }
}

// The camera rays, then from their hits the shadow rays to the light and the light-mesh
// segments: from a node up to 3 mesh steps (h = longest side / 100) away to the point,
// stopping just short of it as the local-visibility test does (paper §2, §3).
void MakeRays(BenchScene* s) {
    const auto accel = CreateAccelerator("grid", s->mesh);
    const CameraRays camera(s->camera, kWidth, kHeight);
    testing_scenes::Rng rng(2024);
    const float h = s->mesh.Bounds().MaxExtent() / 100.0f;
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x)
            s->cameraRays.push_back(
                camera.Generate(float(x) + rng.Uniform(), float(y) + rng.Uniform()));
    std::vector<Vec3> points;
    for (const Ray& r : s->cameraRays) {
        Hit hit;
        if (accel->Intersect(r, &hit)) points.push_back(r.At(hit.t));
    }
    for (const Vec3& p : points) s->shadowRays.push_back(Ray{p, s->light - p, 1e-4f, 1.0f});
    s->cameraTiles.push_back(0);
    s->shadowTiles.push_back(0);
    for (int ty = 0; ty < kHeight; ty += kPacketTile)
        for (int tx = 0; tx < kWidth; tx += kPacketTile) {
            for (int y = ty; y < std::min(ty + kPacketTile, kHeight); ++y)
                for (int x = tx; x < std::min(tx + kPacketTile, kWidth); ++x) {
                    const Ray& r = s->cameraRays[size_t(y) * kWidth + size_t(x)];
                    s->cameraTileRays.push_back(r);
                    Hit hit;
                    if (accel->Intersect(r, &hit)) {
                        const Vec3 p = r.At(hit.t);
                        s->shadowTileRays.push_back(Ray{p, s->light - p, 1e-4f, 1.0f});
                    }
                }
            s->cameraTiles.push_back(s->cameraTileRays.size());
            s->shadowTiles.push_back(s->shadowTileRays.size());
        }
    for (const Vec3& p : points) {
        const Vec3 node = p + rng.Direction() * (3.0f * h * rng.Uniform(0.05f, 1.0f));
        s->shortRays.push_back(Ray{node, p - node, 0.0f, 0.999f});
    }
}

BenchScene Gazebo() {
    Scene scene = MakeBuiltinScene("gazebo");
    BenchScene s;
    s.name = "gazebo";
    s.mesh = std::move(scene.mesh);
    s.camera = scene.camera;
    s.light = scene.lights.empty() ? s.mesh.Bounds().hi * 2.0f : scene.lights[0].position;
    MakeRays(&s);
    return s;
}

// The teapot in a stadium: a detailed closed model on a slab three times its width, seen
// from the front and above, lit from above and to the side.
std::unique_ptr<BenchScene> Stadium() {
    auto s = std::make_unique<BenchScene>();
    s->name = "stadium";
    s->mesh = testing_scenes::TeapotInStadium(256, 384, 3.0f);
    s->camera = Camera{{0.0f, 2.5f, 7.0f}, {0.0f, 0.8f, 0.0f}, {0, 1, 0}, 45.0f};
    s->light = {-4.0f, 8.0f, 3.0f};
    MakeRays(s.get());
    return s;
}

// A scene file: its mesh, camera and first light.
std::unique_ptr<BenchScene> FromSceneFile(const std::string& path) {
    std::vector<std::string> warnings;
    Scene scene = LoadScene(path, SceneLoadOptions{}, &warnings);
    auto s = std::make_unique<BenchScene>();
    std::string stem = path.substr(path.find_last_of('/') + 1);
    s->name = stem.substr(0, stem.find_last_of('.'));
    s->mesh = std::move(scene.mesh);
    s->camera = scene.camera;
    s->light = scene.lights.front().position;
    MakeRays(s.get());
    return s;
}

// The trees: the given meshes side by side along x on a ground quad, y up (as the Sweet
// Home 3D models are), seen from the front, lit from high above and to the left.
std::unique_ptr<BenchScene> Trees(const std::vector<std::string>& paths) {
    auto s = std::make_unique<BenchScene>();
    s->name = "trees";
    float x = 0;
    for (const std::string& path : paths) {
        TriangleMesh m = LoadMeshFile(path).mesh;
        const Bounds3 b = m.Bounds();
        const Vec3 shift(x - b.lo.x, -b.lo.y, -b.Center().z);
        for (Vec3& p : m.positions) p += shift;
        x += 1.1f * b.Diagonal().x;
        s->mesh.Append(m);
        std::printf("trees: %s, %zu triangles\n", path.c_str(), m.TriangleCount());
    }
    const Bounds3 b = s->mesh.Bounds();
    const Vec3 c = b.Center(), e = b.Diagonal();
    const float ground = 1.5f * std::max(e.x, e.z);
    TriangleMesh quad;
    testing_scenes::AddTriangle(&quad, {c.x - ground, 0, c.z - ground},
                                {c.x + ground, 0, c.z + ground}, {c.x + ground, 0, c.z - ground});
    testing_scenes::AddTriangle(&quad, {c.x - ground, 0, c.z - ground},
                                {c.x - ground, 0, c.z + ground}, {c.x + ground, 0, c.z + ground});
    s->mesh.Append(quad);
    s->camera =
        Camera{c + Vec3(0.1f * e.x, 0.3f * e.y, 1.2f * std::max(e.x, e.y)), c, {0, 1, 0}, 45.0f};
    s->light = c + Vec3(-0.6f * e.x, 2.0f * e.y, 0.4f * e.x);
    MakeRays(s.get());
    return s;
}

std::vector<std::string> TreePaths(const std::string& flag) {
    std::string list = flag;
    if (list.empty())
        if (const char* env = std::getenv("LIGHTMESH_BENCH_MESH")) list = env;
    if (!list.empty()) return Split(list, ':');
    std::string cache;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
        cache = xdg;
    else if (const char* home = std::getenv("HOME"))
        cache = std::string(home) + "/.cache";
    const std::string dir = cache + "/lightmesh/garden/scopia/";
    std::vector<std::string> paths = {dir + "japaneseMaple/japaneseMaple.obj",
                                      dir + "copperBeech/copperBeech.obj"};
    for (const std::string& p : paths)
        if (!FileExists(p)) return {};
    return paths;
}

// ---------------------------------------------------------------------------------------
// The benchmarks

// The packet workloads hand a tile's rays to IntersectMany / OccludedMany at once.
enum class Workload { Camera, Shadow, Short, CameraPackets, ShadowPackets };
const char* WorkloadName(Workload w) {
    switch (w) {
        case Workload::Camera: return "camera";
        case Workload::Shadow: return "shadow";
        case Workload::Short: return "short";
        case Workload::CameraPackets: return "camera-packets";
        case Workload::ShadowPackets: return "shadow-packets";
    }
    return "?";
}

// "grid16" (--grid16) is the grid with gridMaxTrianglesPerCell = 16 instead of the paper's 63:
// how much a finer subdivision of the crowded cells buys (a tuning data point for AccelOptions).
std::unique_ptr<Accelerator> Create(const std::string& name, const TriangleMesh& mesh) {
    if (name == "grid16") {
        AccelOptions options;
        options.gridMaxTrianglesPerCell = 16;
        return CreateAccelerator("grid", mesh, options);
    }
    return CreateAccelerator(name, mesh);
}

// Accelerators are built once per scene and back-end, outside the timed loops.
std::map<std::string, std::unique_ptr<Accelerator>> gAccels;
const Accelerator& GetAccel(const BenchScene& s, const std::string& name) {
    auto& slot = gAccels[s.name + "/" + name];
    if (!slot) slot = Create(name, s.mesh);
    return *slot;
}

// The timed loop of a workload: `items` calls of one(i), each returning its hits, on one
// thread or all (TBB, `grain` items per task); the last iteration's hits.
template <typename One>
size_t TimeLoop(benchmark::State& state, size_t items, size_t grain, bool allThreads, One&& one) {
    size_t hits = 0;
    for (auto _ : state) {
        if (allThreads) {
            std::atomic<size_t> count{0};
            tbb::parallel_for(tbb::blocked_range<size_t>(0, items, grain), [&](const tbb::blocked_range<size_t>& r) {
                size_t c = 0;
                for (size_t i = r.begin(); i != r.end(); ++i) c += one(i);
                count += c;
            });
            hits = count;
        } else {
            size_t c = 0;
            for (size_t i = 0; i < items; ++i) c += one(i);
            hits = c;
        }
        benchmark::DoNotOptimize(hits);
    }
    return hits;
}

void RunPackets(benchmark::State& state, const Accelerator& accel, const std::vector<Ray>& rays,
                const std::vector<size_t>& tiles, bool closest, bool allThreads) {
    const size_t packets = tiles.size() - 1;
    auto one = [&](size_t k) -> size_t {
        const size_t first = tiles[k], n = tiles[k + 1] - first;
        size_t c = 0;
        if (closest) {
            Hit hits[64];
            accel.IntersectMany(rays.data() + first, n, hits);
            for (size_t i = 0; i < n; ++i) c += hits[i].prim != UINT32_MAX;
        } else {
            bool occluded[64];
            accel.OccludedMany(rays.data() + first, n, occluded);
            for (size_t i = 0; i < n; ++i) c += occluded[i];
        }
        return c;
    };
    const size_t hits = TimeLoop(state, packets, 4, allThreads, one);
    state.counters["rays/s"] =
        benchmark::Counter(double(rays.size()) * double(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["hit%"] = 100.0 * double(hits) / double(std::max<size_t>(rays.size(), 1));
}

void RunQueries(benchmark::State& state, const BenchScene& s, const std::string& accelName,
                Workload w, bool allThreads) {
    const Accelerator& accel = GetAccel(s, accelName);
    if (w == Workload::CameraPackets || w == Workload::ShadowPackets) {
        RunPackets(state, accel, w == Workload::CameraPackets ? s.cameraTileRays : s.shadowTileRays,
                   w == Workload::CameraPackets ? s.cameraTiles : s.shadowTiles, w == Workload::CameraPackets,
                   allThreads);
        return;
    }
    const std::vector<Ray>& all = w == Workload::Camera   ? s.cameraRays
                                  : w == Workload::Shadow ? s.shadowRays
                                                          : s.shortRays;
    // Brute force gets every k-th ray (a spread-out sample, not the image's top rows).
    const size_t n = accelName == "brute" ? std::min(all.size(), kBruteRays) : all.size();
    const size_t stride = std::max<size_t>(1, all.size() / std::max<size_t>(n, 1));
    auto one = [&](size_t i) -> size_t {
        const Ray& r = all[i * stride];
        if (w == Workload::Camera) {
            Hit h;
            return accel.Intersect(r, &h) ? 1 : 0;
        }
        return accel.Occluded(r) ? 1 : 0;
    };
    const size_t hits = TimeLoop(state, n, 256, allThreads, one);
    state.counters["rays/s"] =
        benchmark::Counter(double(n) * double(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["hit%"] = 100.0 * double(hits) / double(std::max<size_t>(n, 1));
}

void RunBuild(benchmark::State& state, const BenchScene& s, const std::string& accelName) {
    for (auto _ : state) {
        auto accel = Create(accelName, s.mesh);
        benchmark::DoNotOptimize(accel.get());
    }
    state.counters["triangles"] = double(s.mesh.TriangleCount());
}

void Register(const BenchScene& s, const std::vector<std::string>& accels) {
    for (const std::string& a : accels) {
        if (a == "brute") continue;
        // Wall-clock: both builders use all threads.
        benchmark::RegisterBenchmark((s.name + "/build/" + a).c_str(),
                                     [&s, a](benchmark::State& st) { RunBuild(st, s, a); })
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
    }
    for (Workload w : {Workload::Camera, Workload::Shadow, Workload::Short, Workload::CameraPackets,
                       Workload::ShadowPackets})
        for (const std::string& a : accels)
            for (bool mt : {false, true}) {
                if (a == "brute" && (mt || s.mesh.TriangleCount() > 20000)) continue;
                // Brute force has no packets: its rows would only repeat the single-ray ones.
                if (a == "brute" && (w == Workload::CameraPackets || w == Workload::ShadowPackets)) continue;
                const std::string name =
                    s.name + "/" + WorkloadName(w) + "/" + a + (mt ? "/all" : "/1t");
                auto* b = benchmark::RegisterBenchmark(
                    name.c_str(),
                    [&s, a, w, mt](benchmark::State& st) { RunQueries(st, s, a, w, mt); });
                b->Unit(benchmark::kMillisecond);
                // One thread: rays per CPU second, which holds on a machine shared with other
                // jobs. All threads: wall-clock time, the only meaningful one there.
                if (mt) b->UseRealTime();
            }
}

// The console output, then one table: rays/s of each back-end per scene, workload and
// thread count (median of the repetitions when there are several), and grid ÷ Embree.
class RatioReporter : public benchmark::ConsoleReporter {
  public:
    void ReportRuns(const std::vector<Run>& runs) override {
        ConsoleReporter::ReportRuns(runs);
        for (const Run& r : runs) {
            const bool aggregate = r.run_type == Run::RT_Aggregate;
            if (aggregate && r.aggregate_name != "median") continue;
            const std::string name = r.run_name.function_name;
            const auto it = r.counters.find("rays/s");
            double value;
            if (it != r.counters.end())
                value = it->second.value;
            else
                value = r.GetAdjustedRealTime();  // build: wall-clock ms per build
            // Without repetitions each run reports once; with them, the median wins.
            if (aggregate || !results_.count(name)) results_[name] = value;
        }
    }
    void Finalize() override {
        ConsoleReporter::Finalize();
        std::printf("\nSummary (median where repeated): rays/s per back-end (1t: per CPU second, "
                    "all: per wall-clock second); time ratios grid ÷ Embree (the grid's targets: "
                    "rays ≤ 1.3, build ≤ 2)\n");
        std::printf("%-24s %10s %10s %10s %10s %12s %14s\n", "workload", "grid", "embree",
                    "brute", "grid16", "grid/embree", "grid16/embree");
        std::map<std::string, std::map<std::string, double>> rows;  // scene/work[/threads]
        for (const auto& [name, value] : results_) {
            const auto parts = Split(name, '/');
            if (parts.size() < 3) continue;
            std::string key = parts[0] + "/" + parts[1] + (parts.size() > 3 ? "/" + parts[3] : "");
            rows[key][parts[2]] = value;
        }
        for (const auto& row : rows) {
            // (Not a structured binding: clang before 16 does not let the lambdas capture one.)
            const std::string& key = row.first;
            const std::map<std::string, double>& byAccel = row.second;
            auto get = [&](const char* a) {
                const auto it = byAccel.find(a);
                return it == byAccel.end() ? -1.0 : it->second;
            };
            const double g = get("grid"), e = get("embree"), b = get("brute"), g16 = get("grid16");
            const bool build = key.find("/build") != std::string::npos;
            auto cell = [&](double v) {
                if (v < 0) return std::string("-");
                return build ? StringPrintf("%.1fms", v) : StringPrintf("%.3g", v);
            };
            // Time per ray (or per build) of the grid over Embree's: > 1 means the grid is
            // slower, in both kinds of row.
            auto ratio = [&](double x) {
                if (!(x > 0 && e > 0)) return std::string("-");
                return StringPrintf("%.2f", build ? x / e : e / x);
            };
            std::printf("%-24s %10s %10s %10s %10s %12s %14s\n", key.c_str(), cell(g).c_str(),
                        cell(e).c_str(), cell(b).c_str(), cell(g16).c_str(), ratio(g).c_str(),
                        ratio(g16).c_str());
        }
        std::printf("(build rows: wall-clock time per build)\n");
        for (const std::string& line : memoryLines) std::printf("%s\n", line.c_str());
    }
    std::vector<std::string> memoryLines;  // per scene: bytes per triangle of each back-end

  private:
    std::map<std::string, double> results_;
};

}  // namespace
}  // namespace lm

int main(int argc, char** argv) {
    using namespace lm;
    std::string meshFlag, sceneFlag, sceneFileFlag;
    bool withGrid16 = false;
    std::vector<char*> args;
    for (int i = 0; i < argc; ++i) {
        const std::string a = argv[i];
        if (a.rfind("--mesh=", 0) == 0)
            meshFlag = a.substr(7);
        else if (a.rfind("--scene=", 0) == 0)
            sceneFlag = a.substr(8);
        else if (a.rfind("--scene-file=", 0) == 0)
            sceneFileFlag = a.substr(13);
        else if (a == "--grid16")
            withGrid16 = true;
        else
            args.push_back(argv[i]);
    }
    int n = int(args.size());
    benchmark::Initialize(&n, args.data());
    if (benchmark::ReportUnrecognizedArguments(n, args.data())) return 1;

    std::vector<std::string> accels = {"grid"};
    if (withGrid16) accels.push_back("grid16");
#ifdef LIGHTMESH_HAS_EMBREE
    accels.push_back("embree");
#else
    std::printf("note: built without Embree; only the grid (and brute force) run\n");
#endif
    accels.push_back("brute");

    std::vector<std::unique_ptr<BenchScene>> scenes;
    const std::vector<std::string> wanted = Split(sceneFlag, ',');
    for (const std::string& w : wanted)
        if (w != "gazebo" && w != "stadium" && w != "trees" && w != "none") {
            std::fprintf(stderr, "bench_accel: --scene: unknown scene '%s' (gazebo, stadium, trees, or none with "
                                 "--scene-file)\n", w.c_str());
            return 1;
        }
    auto want = [&](const char* name) {
        return wanted.empty() || std::find(wanted.begin(), wanted.end(), name) != wanted.end();
    };
    try {
        if (want("gazebo")) scenes.push_back(std::make_unique<BenchScene>(Gazebo()));
        if (want("stadium")) scenes.push_back(Stadium());
        if (want("trees")) {
            const auto paths = TreePaths(meshFlag);
            if (paths.empty())
                std::printf(
                    "note: no tree meshes (run scripts/fetch-bench-mesh.sh, or give "
                    "--mesh= or LIGHTMESH_BENCH_MESH); the trees are skipped\n");
            else
                scenes.push_back(Trees(paths));
        }
        for (const std::string& file : Split(sceneFileFlag, ',')) scenes.push_back(FromSceneFile(file));
    } catch (const Error& e) {
        std::fprintf(stderr, "bench_accel: %s\n", e.what());
        return 1;
    }
    RatioReporter reporter;
    for (const auto& s : scenes) {
        std::printf("%s: %zu triangles; rays: %zu camera, %zu shadow, %zu short (h = %g)\n",
                    s->name.c_str(), s->mesh.TriangleCount(), s->cameraRays.size(),
                    s->shadowRays.size(), s->shortRays.size(), s->mesh.Bounds().MaxExtent() / 100);
        std::string memory = s->name + " memory:";
        for (const std::string& a : accels) {
            if (a == "brute") continue;
            for (const auto& [k, v] : GetAccel(*s, a).Figures()) {
                std::printf("  [%s] %s: %s\n", a.c_str(), k.c_str(), v.c_str());
                if (k == "grid bytes" || k == "embree bytes")
                    if (a != "grid16") memory += " " + a + " " + v.substr(0, v.find(')') + 1) + ";";
            }
        }
        reporter.memoryLines.push_back(memory);
        Register(*s, accels);
    }
    std::fflush(stdout);
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();
    return 0;
}
