// lightmesh -- the command line: render, info. Thin: all the work is in lightmesh_core.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/distributed/launch.h"
#include "lightmesh/distributed/rank_report.h"
#ifdef LIGHTMESH_HAS_MPI
#include "lightmesh/distributed/mpi_render.h"
#endif
#include "lightmesh/io/compare.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/benchmark.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/shadow/sphere_templates.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/progress.h"
#include "lightmesh/util/system.h"

namespace {

using Clock = std::chrono::steady_clock;
double SecondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// "1,234,567": counts are easier to read with thousands separators.
std::string Count(uint64_t n) {
    std::string s = std::to_string(n);
    for (int i = static_cast<int>(s.size()) - 3; i > 0; i -= 3) s.insert(static_cast<size_t>(i), ",");
    return s;
}

/// Runs a command so that every exception becomes one line and exit code 1.
template <typename F>
int Guarded(F&& run) {
    try {
        return run();
    } catch (...) {
        std::fprintf(stderr, "lightmesh: error: %s\n", lm::CurrentExceptionLine().c_str());
    }
    return 1;
}

/// Options shared by the commands that load a scene.
struct CommonOptions {
    std::string scene;
    bool strict = false;
    bool quiet = false;
    bool verbose = false;
    int threads = 0;
};

void AddCommonOptions(CLI::App* cmd, CommonOptions* o) {
    cmd->add_option("scene", o->scene,
                    "Scene: a .json scene file, a mesh file (.obj, .gltf, .ply, .dae, ...), or "
                    "builtin:gazebo")
        ->required();
    cmd->add_flag("--strict", o->strict, "Unknown keys in the scene file are errors, not warnings");
    cmd->add_flag("-q,--quiet", o->quiet, "Print errors only: no progress bar, no warnings");
    cmd->add_flag("-v,--verbose", o->verbose, "Print more about what is done");
    cmd->add_option("-t,--threads", o->threads, "Worker threads (default: all cores)")
        ->check(CLI::Range(1, 1024));
}

lm::Scene LoadWithWarnings(const CommonOptions& o, int frameWidth = 0, int frameHeight = 0) {
    lm::SceneLoadOptions load;
    load.strict = o.strict;
    load.frameWidth = frameWidth;
    load.frameHeight = frameHeight;
    std::vector<std::string> warnings;
    lm::Scene scene = lm::LoadScene(o.scene, load, &warnings);
    for (const std::string& w : warnings) lm::LogWarning(w);
    for (const std::string& note : scene.report.notes) lm::LogInfo(note);
    return scene;
}

void ApplyLogLevel(const CommonOptions& o) {
    lm::SetLogLevel(o.quiet ? lm::LogLevel::Error : (o.verbose ? lm::LogLevel::Debug : lm::LogLevel::Info));
}

/// `lightmesh render`: options as given on the command line; unset ones keep the scene's.
struct RenderCommand {
    CommonOptions common;
    std::string output;
    std::optional<int> width, height, aa, maxDepth, grid, cc, ns;
    std::optional<float> ki, lightRadius;
    std::optional<int> samples;
    std::optional<std::string> shadows, accel, variant, templateDir, cellSummaries;
    bool stats = false;
};

// The range of a numeric knob of the settings table, as CLI11 checks it.
CLI::Range SettingRange(const char* key) {
    const lm::RenderSetting& s = lm::RenderSettingFor(key);
    if (s.kind == lm::RenderSetting::Kind::Int) return CLI::Range(static_cast<int>(s.lo), static_cast<int>(s.hi));
    return CLI::Range(static_cast<float>(s.lo), static_cast<float>(s.hi));
}

// A `render` option from the settings table: its flag, help text and range or choices.
template <typename T>
CLI::Option* AddSetting(CLI::App* cmd, const char* key, T* value) {
    const lm::RenderSetting& s = lm::RenderSettingFor(key);
    CLI::Option* option = cmd->add_option(s.flag, *value, s.help);
    using K = lm::RenderSetting::Kind;
    // (A range without an upper end, light_radius's, is checked where the value is used.)
    if ((s.kind == K::Int || s.kind == K::Float) && std::isfinite(s.hi)) option->check(SettingRange(key));
    if (s.kind == K::Choice) option->check(CLI::IsMember(s.choices));
    return option;
}

void PrintFigures(const char* title, const std::vector<std::pair<std::string, std::string>>& figures) {
    if (figures.empty()) return;
    std::printf("%-10s", title);
    for (size_t i = 0; i < figures.size(); ++i)
        std::printf("%s%s %s", i ? ", " : "", figures[i].first.c_str(), figures[i].second.c_str());
    std::printf("\n");
}

/// A render ready to run: the scene loaded, options merged and checked, the output's folder
/// checked, the back-end and the shadow method built.
struct PreparedRender {
    lm::Scene scene;
    lm::RenderOptions options;
    std::string output;
    std::unique_ptr<lm::RenderJob> job;
    double loadSeconds = 0;
};

std::unique_ptr<PreparedRender> PrepareRender(const RenderCommand& cmd) {
    auto prepared = std::make_unique<PreparedRender>();
    const auto t0 = Clock::now();
    lm::Scene& scene = prepared->scene;
    scene = LoadWithWarnings(cmd.common, cmd.width.value_or(0), cmd.height.value_or(0));
    prepared->loadSeconds = SecondsSince(t0);

    lm::RenderOptions& options = prepared->options;
    options = scene.render;
    if (cmd.width) options.width = *cmd.width;
    if (cmd.height) options.height = *cmd.height;
    if (cmd.aa) options.aa = *cmd.aa;
    if (cmd.maxDepth) options.maxDepth = *cmd.maxDepth;
    if (cmd.shadows) options.shadows = *cmd.shadows;
    if (cmd.accel) options.accel = *cmd.accel;
    if (cmd.grid) options.accelOptions.gridResolution = *cmd.grid;
    if (cmd.cc) options.lightMesh.cc = *cmd.cc;
    if (cmd.ki) options.lightMesh.ki = *cmd.ki;
    if (cmd.variant) options.lightMesh.variant = *cmd.variant;
    if (cmd.ns) options.lightMesh.ns = *cmd.ns;
    if (cmd.templateDir) options.lightMesh.templateDir = *cmd.templateDir;
    if (cmd.cellSummaries) options.lightMesh.cellSummaries = *cmd.cellSummaries;
    if (cmd.lightRadius) options.areaLight.radius = *cmd.lightRadius;
    if (cmd.samples) options.areaLight.samples = *cmd.samples;

    if (cmd.variant && cmd.variant->empty())
        lm::ThrowError("--variant: must not be empty (leave it out for the default)");
    // Options the chosen method does not use: a warning each, as pbrt reports unused
    // parameters.
    auto unused = [&](bool given, const char* option, const char* usedBy) {
        if (given)
            lm::LogWarning(lm::StringPrintf("%s is not used by --shadows %s (only by %s); ignored",
                                            option, options.shadows.c_str(), usedBy));
    };
    if (options.shadows != "lmm") {
        unused(cmd.cc.has_value(), "--cc", "lmm");
        unused(cmd.ki.has_value(), "--ki", "lmm");
        unused(cmd.variant.has_value(), "--variant", "lmm");
        unused(cmd.ns.has_value(), "--ns", "lmm");
        unused(cmd.templateDir.has_value(), "--template-dir", "lmm");
    }
    if (options.shadows != "area") {
        unused(cmd.lightRadius.has_value(), "--light-radius", "area");
        unused(cmd.samples.has_value(), "--samples", "area");
    }
    if (cmd.grid && options.accel != "grid")
        lm::LogWarning(lm::StringPrintf("--grid is not used by --accel %s (only by grid); ignored",
                                        options.accel.c_str()));
    if (options.shadows == "lmm") lm::ParseLightMeshVariant(options.lightMesh.variant);
    if (options.shadows == "area" || cmd.lightRadius || cmd.samples)
        lm::ValidateAreaLightOptions(options.areaLight);
    if (options.shadows == "area") {
        if (options.areaLight.radius == 0)
            lm::LogWarning("--shadows area with light radius 0: point lights, the same image as --shadows rt "
                           "(set --light-radius)");
    }
    // Check everything about the output before spending time on the render.
    std::string& output = prepared->output;
    output = cmd.output;
    if (output.empty()) {
        std::string stem = cmd.common.scene.rfind("builtin:", 0) == 0
                               ? cmd.common.scene.substr(8)
                               : std::filesystem::path(cmd.common.scene).stem().string();
        output = stem + ".png";
    }
    lm::ImageFormatFor(output);
    lm::CheckWritableFolder(output);
    const uint64_t imageBytes = static_cast<uint64_t>(options.width) * options.height * sizeof(lm::Color);
    const uint64_t physical = lm::PhysicalMemoryBytes();
    if (physical && imageBytes > physical / 2)
        lm::ThrowError("image %dx%d would need %s, more than half of this machine's %s",
                       options.width, options.height, lm::FormatBytes(imageBytes).c_str(),
                       lm::FormatBytes(physical).c_str());

    prepared->job = std::make_unique<lm::RenderJob>(scene, options);
    return prepared;
}

// The summary line, and with --stats the figures (per rank under MPI).
void PrintRender(const RenderCommand& cmd, const PreparedRender& p, const lm::RenderResult& result,
                 double writeSeconds, const std::vector<lm::RankReport>* ranks) {
    const lm::RenderOptions& options = p.options;
    std::printf("%s: %dx%d, shadows %s, accel %s, %zu triangles, %zu lights: render %.3f s\n",
                p.output.c_str(), options.width, options.height, std::string(p.job->Shadows().Name()).c_str(),
                std::string(p.job->Accel().Name()).c_str(), p.scene.mesh.TriangleCount(), p.scene.lights.size(),
                result.seconds);
    if (!cmd.stats) return;
    const lm::RenderCounters& c = result.counters;
    std::printf("time      load %.3f s, build %.3f s, shadow setup %.3f s, render %.3f s, write %.3f s\n",
                p.loadSeconds, p.job->BuildSeconds(), p.job->ShadowSetupSeconds(), result.seconds, writeSeconds);
    std::printf("threads   %d%s\n",
                static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)),
                ranks ? " per rank" : "");
    if (ranks) {
        uint64_t nodes = 0;
        for (const lm::RankReport& r : *ranks) nodes += r.nodesEvaluated;
        std::printf("ranks     %zu, tiles handed out in batches from a counter on rank 0 (one-sided MPI)%s\n",
                    ranks->size(),
                    nodes ? lm::StringPrintf("; light-mesh nodes evaluated by all ranks together %s", Count(nodes).c_str()).c_str()
                          : "");
        for (const lm::RankReport& r : *ranks)
            std::printf("rank %-5d tiles %d (%d batches, %.2f ms waiting for them), render %.3f s, rays camera %s, "
                        "shadow %s, reflection %s%s\n",
                        r.rank, r.tiles, r.batches, r.fetchSeconds * 1e3, r.seconds, Count(r.counters.cameraRays).c_str(),
                        Count(r.counters.shadowRays).c_str(), Count(r.counters.reflectionRays).c_str(),
                        nodes ? (", nodes evaluated " + Count(r.nodesEvaluated)).c_str() : "");
    }
    std::printf("rays      camera %s, shadow %s, reflection %s; shading points %s\n",
                Count(c.cameraRays).c_str(), Count(c.shadowRays).c_str(),
                Count(c.reflectionRays).c_str(), Count(c.shadingPoints).c_str());
    PrintFigures("accel", p.job->Accel().Figures());
    if (c.interpolations + c.fallbacks > 0) {
        const double points = static_cast<double>(c.interpolations + c.fallbacks);
        std::printf("lmm       interpolated points %s, mean m %.1f, candidates per point %.1f, "
                    "local-visibility segments %s, fallbacks %s (%.2f%%)\n",
                    Count(c.interpolations).c_str(),
                    c.interpolations ? static_cast<double>(c.nodesUsed) / static_cast<double>(c.interpolations) : 0.0,
                    static_cast<double>(c.candidates) / points, Count(c.localSegments).c_str(),
                    Count(c.fallbacks).c_str(), 100.0 * static_cast<double>(c.fallbacks) / points);
        if (c.uniformCellPoints + c.planarCellPoints > 0)
            std::printf("cells     points answered by their cell's summary %s (%.1f%%), in planar cells %s (%.1f%%), "
                        "segments decided without a ray %s; mean m counts the other points only\n",
                        Count(c.uniformCellPoints).c_str(), 100.0 * static_cast<double>(c.uniformCellPoints) / points,
                        Count(c.planarCellPoints).c_str(), 100.0 * static_cast<double>(c.planarCellPoints) / points,
                        Count(c.culledSegments).c_str());
    }
    PrintFigures(ranks ? "shadows (rank 0)" : "shadows", p.job->Shadows().Figures());
    std::printf("memory    peak %s%s\n", lm::FormatBytes(lm::PeakMemoryBytes()).c_str(), ranks ? " (rank 0)" : "");
}

int RunRender(const RenderCommand& cmd) {
    ApplyLogLevel(cmd.common);
    lm::InstallInterruptCleanup();
    const std::unique_ptr<PreparedRender> p = PrepareRender(cmd);
    lm::RenderResult result;
    {
        lm::ProgressReporter progress(p->job->Renderer().TileCount(), "Rendering",
                                      !cmd.common.quiet && lm::ProgressReporter::StderrIsTerminal());
        result = p->job->Render(&progress);
    }
    const auto t3 = Clock::now();
    lm::WriteImage(p->output, result.image);
    PrintRender(cmd, *p, result, SecondsSince(t3), nullptr);
    return 0;
}

#ifdef LIGHTMESH_HAS_MPI
/// `mpirun -np N lightmesh render …`: every rank prepares the render; if one fails, rank 0
/// prints the first failing rank's message and every rank exits 1. The tiles are shared out
/// (RenderDistributed), rank 0 gathers and writes the image, and prints the figures.
int RunRenderMpi(const RenderCommand& cmd, const lm::MpiSession& session) {
    const bool root = session.Rank() == 0;
    ApplyLogLevel(cmd.common);
    if (!root) lm::SetLogLevel(lm::LogLevel::Error);  // warnings once, from rank 0
    lm::InstallInterruptCleanup();
    auto fail = [&](const std::string& message, int rank) {
        if (root)
            std::fprintf(stderr, "lightmesh: error: %s%s\n", message.c_str(),
                         rank > 0 ? lm::StringPrintf(" (rank %d of %d)", rank, session.Size()).c_str() : "");
        return 1;
    };
    std::unique_ptr<PreparedRender> p;
    std::string error, message;
    int failedRank = -1;
    try {
        p = PrepareRender(cmd);
    } catch (...) {
        error = lm::CurrentExceptionLine();
    }
    if (!session.AllSucceeded(error, &message, &failedRank)) return fail(message, failedRank);
    // mpirun binds each of up to two ranks to one core by default: more threads than the
    // CPUs a rank may run on only share them.
    const int cpus = lm::AffinityCpuCount();
    if (root && cmd.common.threads > 0 && cpus > 0 && cmd.common.threads > cpus)
        lm::LogWarning(lm::StringPrintf("--threads %d, but each rank may run on %d CPU(s) only (mpirun's binding): "
                                        "the threads share them; run mpirun with --bind-to none",
                                        cmd.common.threads, cpus));

    const lm::ShadowMethod& shadows = p->job->Shadows();
    const std::function<uint64_t()> nodes = [&shadows] { return shadows.NodesEvaluated(); };
    lm::DistributedRender d;
    {
        lm::ProgressReporter progress(p->job->Renderer().TileCount(), "Rendering",
                                      root && !cmd.common.quiet && lm::ProgressReporter::StderrIsTerminal());
        d = lm::RenderDistributed(session, p->job->Renderer(), nodes, root ? &progress : nullptr);
    }
    if (d.errorRank >= 0) return fail(d.error, d.errorRank);
    if (!root) return 0;
    const auto t3 = Clock::now();
    lm::WriteImage(p->output, d.result.image);
    PrintRender(cmd, *p, d.result, SecondsSince(t3), &d.ranks);
    return 0;
}
#endif

int RunInfo(const CommonOptions& common, const std::string& accelName, int grid) {
    ApplyLogLevel(common);
    lm::Scene scene = LoadWithWarnings(common);
    const lm::Bounds3 b = scene.mesh.Bounds();
    const lm::EdgeReport edges = lm::AnalyzeEdges(scene.mesh);
    std::printf("scene      %s\n", scene.name.c_str());
    for (const std::string& s : scene.report.sources) std::printf("source     %s\n", s.c_str());
    std::printf("triangles  %s (removed: %s degenerate, %s duplicate; meshes excluded: %zu)\n",
                Count(scene.mesh.TriangleCount()).c_str(), Count(scene.report.degenerateRemoved).c_str(),
                Count(scene.report.duplicatesRemoved).c_str(), scene.report.meshesExcluded);
    std::printf("vertices   %s%s\n", Count(scene.mesh.positions.size()).c_str(),
                scene.mesh.normals.empty() ? "" : " (with shading normals)");
    std::printf("bounds     [%g %g %g] - [%g %g %g], size %g x %g x %g\n", b.lo.x, b.lo.y, b.lo.z,
                b.hi.x, b.hi.y, b.hi.z, b.Diagonal().x, b.Diagonal().y, b.Diagonal().z);
    std::printf("edges      %s: %s open, %s non-manifold -> %s\n", Count(edges.edges).c_str(),
                Count(edges.open).c_str(), Count(edges.nonManifold).c_str(),
                edges.Closed() ? "every object is a closed solid"
                               : "not all objects are closed solids (the inside-object test is unreliable there)");
    std::printf("lights     %zu\n", scene.lights.size());
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        const lm::PointLight& l = scene.lights[i];
        std::printf("  light %zu  at [%g %g %g], intensity [%g %g %g], falloff %s\n", i, l.position.x,
                    l.position.y, l.position.z, l.intensity.r, l.intensity.g, l.intensity.b,
                    l.falloff == lm::Falloff::None ? "none" : "inverse_square");
    }
    std::vector<size_t> uses(scene.materials.size());
    for (uint32_t m : scene.mesh.materialIds) ++uses[m];
    std::printf("materials  %zu\n", scene.materials.size());
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        const lm::Material& m = scene.materials[i];
        std::printf("  %-12s kd [%g %g %g], ks [%g %g %g], phong %g, mirror [%g %g %g]; %s triangles\n",
                    m.name.c_str(), m.kd.r, m.kd.g, m.kd.b, m.ks.r, m.ks.g, m.ks.b, m.phong,
                    m.mirror.r, m.mirror.g, m.mirror.b, Count(uses[i]).c_str());
    }
    const lm::Camera& cam = scene.camera;
    std::printf("camera     at [%g %g %g] looking at [%g %g %g], fov %g\n", cam.position.x,
                cam.position.y, cam.position.z, cam.lookAt.x, cam.lookAt.y, cam.lookAt.z, cam.fovY);
    lm::AccelOptions accelOptions = scene.render.accelOptions;
    if (grid >= 0) accelOptions.gridResolution = grid;
    const std::string name = accelName.empty() ? scene.render.accel : accelName;
    const auto t = Clock::now();
    auto accel = lm::CreateAccelerator(name, scene.mesh, accelOptions);
    std::printf("accel      %s, built in %.3f s\n", name.c_str(), SecondsSince(t));
    PrintFigures("  figures", accel->Figures());
    return 0;
}

/// `lightmesh templates`: build (or load) and cache sphere templates; with --measure, the
/// error of snapping P to a sub-position for several ns, which is how the default was chosen.
int RunTemplates(int ns, float ki, const std::string& dir, bool measure) {
    const lm::TemplateLoad load = lm::LoadOrBuildSphereTemplates(ns, ki, dir);
    if (!load.note.empty()) lm::LogWarning("templates: " + load.note);
    const lm::SphereTemplates& t = load.templates;
    size_t boundary = 0;
    for (uint32_t b : t.boundaryCount) boundary += b;
    std::printf("templates ns %d, kI %g: %d sub-positions, %s nodes (%.1f per sphere, %.1f on its boundary), "
                "%s in %.2f ms%s%s\n",
                t.ns, t.ki, t.SubPositionCount(), Count(t.offsets.size()).c_str(),
                static_cast<double>(t.offsets.size()) / t.SubPositionCount(),
                static_cast<double>(boundary) / t.SubPositionCount(),
                load.loaded ? "loaded" : (load.written ? "built and cached" : "built"), load.seconds * 1e3,
                load.path.empty() ? "" : ": ", load.path.c_str());
    if (!measure) return 0;
    // For random P in a cell, compare the snapped template's node set with the exact set
    // |x - P| <= kI·h: mismatched nodes per sphere, as a share of the exact set's size.
    std::printf("\n%4s %12s %14s %12s %12s\n", "ns", "entries", "mismatch/P", "mismatch %", "build ms");
    for (int n : {1, 2, 4, 8, 16, 32}) {
        const auto t0 = Clock::now();
        const lm::SphereTemplates tn = lm::SphereTemplates::Build(n, ki);
        const double buildMs = SecondsSince(t0) * 1e3;
        uint64_t state = 0x9E3779B97F4A7C15ull;
        auto uniform = [&state] {
            state ^= state << 13; state ^= state >> 7; state ^= state << 17;
            return static_cast<double>(state >> 11) * 0x1.0p-53;
        };
        const int reach = static_cast<int>(std::ceil(ki)) + 1;
        double mismatched = 0, exactTotal = 0;
        const int samples = 20000;
        for (int s = 0; s < samples; ++s) {
            const double px = uniform(), py = uniform(), pz = uniform();
            const int a = static_cast<int>(std::lround(px * n)), b = static_cast<int>(std::lround(py * n)),
                      c = static_cast<int>(std::lround(pz * n));
            const int sp = tn.SubPosition(a, b, c);
            std::vector<std::array<int8_t, 3>> list(tn.offsets.begin() + tn.begin[sp], tn.offsets.begin() + tn.begin[sp + 1]);
            std::sort(list.begin(), list.end());
            for (int dk = -reach; dk <= reach; ++dk)
                for (int dj = -reach; dj <= reach; ++dj)
                    for (int di = -reach; di <= reach; ++di) {
                        const double dx = di - px, dy = dj - py, dz = dk - pz;
                        const bool exact = dx * dx + dy * dy + dz * dz <= static_cast<double>(ki) * ki;
                        const std::array<int8_t, 3> o{static_cast<int8_t>(di), static_cast<int8_t>(dj), static_cast<int8_t>(dk)};
                        const bool inTemplate = std::binary_search(list.begin(), list.end(), o);
                        exactTotal += exact;
                        mismatched += exact != inTemplate;
                    }
        }
        std::printf("%4d %12s %14.3f %11.2f%% %12.2f\n", n, Count(tn.offsets.size()).c_str(), mismatched / samples,
                    100.0 * mismatched / exactTotal, buildMs);
    }
    return 0;
}

/// `lightmesh bench`: the matrix, a progress line per cell, then the tables.
struct BenchCommand {
    lm::BenchMatrix matrix;
    std::vector<std::string> sizes;
    std::string csv, markdown, html, matrixFile;
    int table = 0;
    bool quick = false;
    bool quiet = false;
    bool noNone = false;
    CLI::Option* repeatOption = nullptr;
    CLI::Option* accelsOption = nullptr;
    std::string argv0;
};

/// The repository (for scenes/real): the source dir compiled in, else two folders above
/// the executable (build/apps/lightmesh).
std::string BenchRepoDir(const std::string& argv0) {
    namespace fs = std::filesystem;
    std::vector<fs::path> candidates;
#ifdef LIGHTMESH_SOURCE_DIR
    candidates.push_back(LIGHTMESH_SOURCE_DIR);
#endif
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) candidates.push_back(exe.parent_path().parent_path().parent_path());
    if (!argv0.empty()) candidates.push_back(fs::absolute(argv0, ec).parent_path().parent_path().parent_path());
    for (const fs::path& c : candidates)
        if (fs::exists(c / "scenes" / "real", ec)) return c.string();
    lm::ThrowError("bench --table: cannot find the repository's scenes/real folder (looked in %s)",
                   candidates.empty() ? "nothing" : candidates.front().string().c_str());
}

int RunBench(BenchCommand& cmd) {
    lm::SetLogLevel(cmd.quiet ? lm::LogLevel::Error : lm::LogLevel::Warning);
    lm::InstallInterruptCleanup();
    if (!cmd.sizes.empty()) {
        cmd.matrix.sizes.clear();
        for (const std::string& s : cmd.sizes) {
            int w = 0, h = 0;
            char x = 0;
            if (std::sscanf(s.c_str(), "%d%c%d", &w, &x, &h) != 3 || (x != 'x' && x != 'X') || w < 1 || h < 1 ||
                w > 16384 || h > 16384)
                lm::ThrowError("--size %s: expected WIDTHxHEIGHT, e.g. 1024x768", s.c_str());
            cmd.matrix.sizes.push_back({w, h});
        }
    }
    // --table / --matrix replace the scenes, sizes, CC, kI and variants (CLI11 rejects them
    // together); the other options still apply.
    if (cmd.table || !cmd.matrixFile.empty()) {
        lm::BenchMatrix preset = cmd.table ? lm::BenchTablePreset(cmd.table, cmd.quick, BenchRepoDir(cmd.argv0))
                                           : lm::LoadBenchMatrix(cmd.matrixFile);
        const lm::BenchMatrix& given = cmd.matrix;
        if (cmd.repeatOption->count()) preset.repeat = given.repeat;
        if (!cmd.matrixFile.empty() && cmd.accelsOption->count()) preset.accels = given.accels;
        // The paper's tables run on its nested grid unless --accels says otherwise.
        if (cmd.table) preset.accels = cmd.accelsOption->count() ? given.accels : std::vector<std::string>{"grid"};
        preset.imageDir = given.imageDir;
        preset.quality = given.quality;
        preset.refSamples = given.refSamples;
        cmd.matrix = preset;
    } else if (cmd.quick) {
        for (auto& s : cmd.matrix.sizes) s = {std::max(1, s.first / 4), std::max(1, s.second / 4)};
        if (!cmd.repeatOption->count()) cmd.matrix.repeat = 1;
    }
    cmd.matrix.noShadows = !cmd.noNone;
    for (const std::string& path : {cmd.csv, cmd.markdown, cmd.html})
        if (!path.empty()) lm::CheckWritableFolder(path);
    if (!cmd.html.empty() && cmd.matrix.imageDir.empty()) {
        // The report embeds the images: render them next to it.
        const std::filesystem::path p(cmd.html);
        cmd.matrix.imageDir = (p.parent_path() / (p.stem().string() + "-images")).string();
        std::filesystem::create_directories(cmd.matrix.imageDir);
    }
    const auto start = Clock::now();
    const auto report = lm::RunBenchmarkReport(
        cmd.matrix,
        [&](int done, int total, const lm::BenchResult& r) {
            if (cmd.quiet) return;
            const double elapsed = SecondsSince(start);
            std::fprintf(stderr, "[%d/%d] %s %dx%d %s%s: %.3f s (median of %zu); %.0f s elapsed, ~%.0f s left\n", done,
                         total, r.scene.c_str(), r.width, r.height, r.paperName.c_str(),
                         r.method == "lmm" ? lm::StringPrintf(" CC %d kI %g", r.cc, r.ki).c_str()
                                           : (" " + r.accel).c_str(),
                         r.median, r.seconds.size(), elapsed, elapsed / done * (total - done));
        },
        [&](double seconds) {
            if (cmd.quiet) return;
            std::fprintf(stderr,
                         "bench: rough estimate %.0f s (%.1f min) in all (one RT render per scene timed, "
                         "extrapolated by pixels and method)%s\n",
                         seconds, seconds / 60, cmd.matrix.quality ? ", quality references included" : "");
        });
    std::string md = lm::BenchMarkdown(report.results);
    if (!report.quality.empty()) md += lm::BenchQualityMarkdown(report);
    std::printf("%s", md.c_str());
    auto write = [](const std::string& path, const std::string& text) {
        lm::WriteFileAtomically(path, [&](const std::string& tmp) {
            FILE* f = std::fopen(tmp.c_str(), "wb");
            if (!f || std::fwrite(text.data(), 1, text.size(), f) != text.size() || std::fclose(f) != 0)
                lm::ThrowError("%s: cannot write", path.c_str());
        });
    };
    if (!cmd.csv.empty()) write(cmd.csv, lm::BenchCsv(report.results));
    if (!cmd.markdown.empty()) write(cmd.markdown, md);
    if (!cmd.html.empty()) {
        write(cmd.html, lm::BenchHtml(report, cmd.table ? lm::StringPrintf("lightmesh bench: the paper's table %d%s",
                                                                           cmd.table, cmd.quick ? " (quick)" : "")
                                                        : "lightmesh bench"));
        if (!cmd.quiet) std::fprintf(stderr, "bench: wrote %s\n", cmd.html.c_str());
    }
    return 0;
}

/// `lightmesh compare A B`: image quality of B against A (lightmesh/io/compare.h).
struct CompareCommand {
    std::string a, b, mask, diff;
    float diffScale = 0;
    bool json = false;
    std::optional<double> thresholdPsnr;
};

/// Exit codes: 0 compared (and PSNR >= --threshold-psnr), 1 error, 3 below the threshold.
int RunCompare(const CompareCommand& cmd) {
    if (cmd.thresholdPsnr && !std::isfinite(*cmd.thresholdPsnr))
        lm::ThrowError("--threshold-psnr: must be a finite number of dB, got %g", *cmd.thresholdPsnr);
    if (!(cmd.diffScale >= 0) || !std::isfinite(cmd.diffScale))
        lm::ThrowError("--diff-scale: must be a finite number >= 0, got %g", double(cmd.diffScale));
    const lm::Image a = lm::ReadImage(cmd.a), b = lm::ReadImage(cmd.b);
    std::optional<lm::Image> mask;
    if (!cmd.mask.empty()) mask = lm::ReadImage(cmd.mask);
    const lm::Image* m = mask ? &*mask : nullptr;
    const lm::ImageMetrics q = lm::CompareImages(a, b, m);
    if (!cmd.diff.empty()) lm::WriteDiffImage(cmd.diff, a, b, cmd.diffScale, m);
    const std::string psnr = std::isinf(q.psnr) ? "inf" : lm::StringPrintf("%.2f dB", q.psnr);
    if (cmd.json)
        std::printf("%s\n", lm::ImageMetricsJson(q, cmd.a, cmd.b).c_str());
    else
        std::printf("%s vs %s: %s pixels: PSNR %s, SSIM %.5f, RMSE %.5f (linear %.5f), max diff %.4f\n",
                    cmd.a.c_str(), cmd.b.c_str(), Count(q.pixels).c_str(), psnr.c_str(), q.ssim, q.rmse,
                    q.rmseLinear, q.maxDiff);
    if (cmd.thresholdPsnr && q.psnr < *cmd.thresholdPsnr) {
        std::fprintf(stderr, "lightmesh: PSNR %s is below the threshold %.2f dB\n", psnr.c_str(), *cmd.thresholdPsnr);
        return 3;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"lightmesh: soft shadows from point lights by the light mesh method"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "lightmesh 0.1.0");

    RenderCommand render;
    CLI::App* renderCmd = app.add_subcommand("render", "Render a scene to a PNG or EXR image");
    AddCommonOptions(renderCmd, &render.common);
    renderCmd->add_option("-o,--output", render.output,
                          "Output image, .png (8-bit sRGB) or .exr (linear float); default: the "
                          "scene's name with .png, in the current folder");
    // The render knobs: flag, help and check from the settings table (the scene file's
    // "render" object is checked against the same rows).
    AddSetting(renderCmd, "width", &render.width);
    AddSetting(renderCmd, "height", &render.height);
    AddSetting(renderCmd, "aa", &render.aa);
    AddSetting(renderCmd, "max_depth", &render.maxDepth);
    AddSetting(renderCmd, "shadows", &render.shadows);
    AddSetting(renderCmd, "accel", &render.accel);
    AddSetting(renderCmd, "grid", &render.grid);
    AddSetting(renderCmd, "cc", &render.cc);
    AddSetting(renderCmd, "ki", &render.ki);
    AddSetting(renderCmd, "variant", &render.variant);
    AddSetting(renderCmd, "ns", &render.ns);
    AddSetting(renderCmd, "template_dir", &render.templateDir);
    AddSetting(renderCmd, "cell_summaries", &render.cellSummaries);
    AddSetting(renderCmd, "light_radius", &render.lightRadius);
    AddSetting(renderCmd, "samples", &render.samples);
    renderCmd->add_flag("--stats", render.stats, "Print rays by kind, time by phase, back-end figures, peak memory");

    CommonOptions info;
    std::string infoAccel;
    int infoGrid = -1;
    CLI::App* infoCmd = app.add_subcommand("info", "Describe a scene: triangles, bounds, closed solids, lights, materials");
    AddCommonOptions(infoCmd, &info);
    infoCmd->add_option("--accel", infoAccel, "Also build this back-end and print its figures")
        ->check(CLI::IsMember(lm::AcceleratorNames()));
    AddSetting(infoCmd, "grid", &infoGrid);

    int templatesNs = lm::kDefaultTemplateSubsteps;
    float templatesKi = 2.0f;
    std::string templatesDir;
    bool templatesMeasure = false;
    CLI::App* templatesCmd = app.add_subcommand(
        "templates", "Build and cache the light mesh's sphere templates for (ns, kI) (the paper's section 3.1)");
    templatesCmd->add_option("--ns", templatesNs, "Sub-steps per cell side")->check(CLI::Range(1, 64));
    templatesCmd->add_option("--ki", templatesKi, "Interpolation radius in mesh steps")->check(SettingRange("ki"));
    templatesCmd->add_option("--template-dir", templatesDir, "Cache folder (default: $XDG_CACHE_HOME/lightmesh/templates)");
    templatesCmd->add_flag("--measure", templatesMeasure,
                           "Also print, for ns = 1 … 32, how many nodes snapping P to a sub-position gets wrong");
    templatesCmd->add_flag("-q,--quiet", [](int64_t) { lm::SetLogLevel(lm::LogLevel::Error); }, "Print errors only");

    CompareCommand compare;
    CLI::App* compareCmd = app.add_subcommand(
        "compare", "Image quality of B against A (PNG or EXR): PSNR, SSIM, RMSE, max difference; "
                   "exit 0 = compared, 1 = error, 3 = below --threshold-psnr");
    compareCmd->add_option("a", compare.a, "Reference image (.png or .exr)")->required();
    compareCmd->add_option("b", compare.b, "Image to judge, the same size")->required();
    compareCmd->add_option("--mask", compare.mask, "Compare only where this image (same size) is not black");
    compareCmd->add_option("--diff", compare.diff, "Write a false-colour (Turbo) image of |A - B| here");
    compareCmd->add_option("--diff-scale", compare.diffScale,
                           "Difference shown as the top colour (display units, 0..1; default 0: the largest)");
    compareCmd->add_flag("--json", compare.json, "Print one JSON line (psnr is null for identical images)");
    compareCmd->add_option("--threshold-psnr", compare.thresholdPsnr, "Exit with 3 if the PSNR (dB) is lower");

    BenchCommand bench;
    CLI::App* benchCmd = app.add_subcommand(
        "bench", "Time shadow methods side by side: scenes x sizes x CC x kI x variants, plus RT and no shadows");
    bench.argv0 = argc > 0 ? argv[0] : "";
    CLI::Option* benchScene =
        benchCmd->add_option("--scene", bench.matrix.scenes, "Scenes (repeat the option); default builtin:gazebo");
    CLI::Option* benchSize =
        benchCmd->add_option("--size", bench.sizes, "Image sizes WIDTHxHEIGHT (repeat); default 1024x768");
    CLI::Option* benchCc = benchCmd->add_option("--cc", bench.matrix.cc, "Light mesh CC values, comma-separated; default 100")
        ->delimiter(',')->check(SettingRange("cc"));
    CLI::Option* benchKi = benchCmd->add_option("--ki", bench.matrix.ki, "Light mesh kI values, comma-separated; default 2")
        ->delimiter(',')->check(SettingRange("ki"));
    CLI::Option* benchVariants = benchCmd->add_option("--variants", bench.matrix.variants,
                         "LMM variants, comma-separated; default grid,templates,reduced,none,inside,object,consensus")
        ->delimiter(',');
    benchCmd->add_option("--cell-summaries", bench.matrix.cellSummaries,
                         "Light mesh cell summaries for every LMM cell: auto (consensus only), on or off")
        ->check(CLI::IsMember({"auto", "on", "off"}));
    CLI::Option* benchTable = benchCmd->add_option("--table", bench.table,
                         "Reproduce the paper's table 1, 2, 3 or 4 on scenes/real (replaces --scene --size --cc --ki --variants)")
        ->check(CLI::Range(1, 4));
    CLI::Option* benchMatrixFile = benchCmd->add_option("--matrix", bench.matrixFile,
                         "Read the matrix from JSON: {\"scenes\", \"sizes\": [[w,h]], \"cc\", \"ki\", \"variants\", \"accels\", \"repeat\"}")
        ->check(CLI::ExistingFile);
    for (CLI::Option* o : {benchScene, benchSize, benchCc, benchKi, benchVariants}) {
        o->excludes(benchTable);
        o->excludes(benchMatrixFile);
    }
    benchTable->excludes(benchMatrixFile);
    benchCmd->add_flag("--quick", bench.quick, "Every size divided by 4 in each dimension, --repeat 1 (a fast check)");
    benchCmd->add_option("--html", bench.html,
                         "Write a self-contained HTML report (tables, SVG charts, images with zoomed crops); "
                         "renders the images next to it unless --images is given");
    benchCmd->add_flag("--quality", bench.matrix.quality,
                       "Also judge every cell against a converged area-light reference: PSNR/SSIM, reference "
                       "radius sweep, naive soft shadows (N = 4, 16, 64) vs LMM, leak count");
    benchCmd->add_option("--ref-samples", bench.matrix.refSamples, "Samples of the --quality reference; default 256")
        ->check(CLI::Range(1, 4096));
    bench.accelsOption = benchCmd->add_option("--accels", bench.matrix.accels,
                         std::string("Ray-query back-ends for RT (the first also serves no shadows and LMM), comma-separated; default ") +
                             lm::kDefaultAccelerator + " (grid for --table, the paper's)")
        ->delimiter(',')->check(CLI::IsMember(lm::AcceleratorNames()));
    bench.repeatOption = benchCmd->add_option("--repeat", bench.matrix.repeat, "Timed runs per cell after a warm-up; the median is reported")
        ->check(CLI::Range(1, 100));
    benchCmd->add_flag("--no-none", bench.noNone, "Skip the render without shadows");
    benchCmd->add_option("--images", bench.matrix.imageDir, "Write each cell's image (PNG) into this folder");
    benchCmd->add_option("--csv", bench.csv, "Also write every figure of every cell as CSV");
    benchCmd->add_option("--markdown", bench.markdown, "Also write the tables to this Markdown file");
    benchCmd->add_option("-t,--threads", render.common.threads, "Worker threads (default: all cores)")
        ->check(CLI::Range(1, 1024));
    benchCmd->add_flag("-q,--quiet", bench.quiet, "No progress lines");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version exit 0; a command-line mistake exits 1 like any bad input
        // (CLI11's own codes are 100 and up).
        return app.exit(e) == 0 ? 0 : 1;
    }

    // Under mpirun: render spreads its tiles over the ranks; the other commands run once,
    // on rank 0, and the other ranks leave at once.
    const int worldSize = lm::LauncherWorldSize(), worldRank = lm::LauncherWorldRank();
    if (lm::LaunchedByMpi() && renderCmd->parsed()) {
#ifdef LIGHTMESH_HAS_MPI
        std::unique_ptr<lm::MpiSession> session;
        int threads = render.common.threads;
        try {
            session = std::make_unique<lm::MpiSession>(&argc, &argv);
            if (threads == 0) threads = session->DefaultThreads();
        } catch (...) {
            std::fprintf(stderr, "lightmesh: error: %s\n", lm::CurrentExceptionLine().c_str());
            return 1;
        }
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
        return Guarded([&] { return RunRenderMpi(render, *session); });
#else
        if (worldSize > 1) {
            if (worldRank == 0)
                std::fprintf(stderr,
                             "lightmesh: error: started by an MPI launcher with %d processes, but this lightmesh "
                             "was built without MPI: install OpenMPI (apt-get install libopenmpi-dev openmpi-bin, "
                             "or scripts/install-deps.sh) and rebuild (scripts/build.sh), or run it without "
                             "mpirun\n",
                             worldSize);
            return 1;
        }
#endif
    }
    if (worldSize > 1) {
        if (worldRank != 0) return 0;
        std::fprintf(stderr, "lightmesh: note: under mpirun only `render` is spread over the ranks; this command "
                             "runs once, on rank 0 (the other %d ranks exit)\n", worldSize - 1);
    }

    if (benchCmd->parsed()) {
        std::unique_ptr<tbb::global_control> limit;
        if (render.common.threads > 0)
            limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                          static_cast<size_t>(render.common.threads));
        return Guarded([&] { return RunBench(bench); });
    }
    if (compareCmd->parsed()) return Guarded([&] { return RunCompare(compare); });
    if (templatesCmd->parsed())
        return Guarded([&] { return RunTemplates(templatesNs, templatesKi, templatesDir, templatesMeasure); });
    const CommonOptions& common = renderCmd->parsed() ? render.common : info;
    std::unique_ptr<tbb::global_control> threadLimit;
    if (common.threads > 0)
        threadLimit = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, static_cast<size_t>(common.threads));
    return Guarded([&] {
        if (renderCmd->parsed()) return RunRender(render);
        return RunInfo(info, infoAccel, infoGrid);
    });
}
