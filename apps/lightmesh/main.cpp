// lightmesh -- the command line: render, info. Thin: all the work is in lightmesh_core.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/shadow.h"
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

lm::Scene LoadWithWarnings(const CommonOptions& o) {
    lm::SceneLoadOptions load;
    load.strict = o.strict;
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
    std::optional<int> width, height, aa, maxDepth, grid, cc;
    std::optional<float> ki;
    std::optional<std::string> shadows, accel, variant;
    bool stats = false;
};

void PrintFigures(const char* title, const std::vector<std::pair<std::string, std::string>>& figures) {
    if (figures.empty()) return;
    std::printf("%-10s", title);
    for (size_t i = 0; i < figures.size(); ++i)
        std::printf("%s%s %s", i ? ", " : "", figures[i].first.c_str(), figures[i].second.c_str());
    std::printf("\n");
}

int RunRender(const RenderCommand& cmd) {
    ApplyLogLevel(cmd.common);
    lm::InstallInterruptCleanup();
    const auto t0 = Clock::now();
    lm::Scene scene = LoadWithWarnings(cmd.common);
    const double loadSeconds = SecondsSince(t0);

    lm::RenderOptions options = scene.render;
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

    // Check everything about the output before spending time on the render.
    std::string output = cmd.output;
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

    const auto t1 = Clock::now();
    auto accel = lm::CreateAccelerator(options.accel, scene.mesh, options.accelOptions);
    const double buildSeconds = SecondsSince(t1);
    const auto t2 = Clock::now();
    auto shadows = lm::CreateShadowMethod(options.shadows, scene, *accel, options);
    const double shadowSetupSeconds = SecondsSince(t2);

    lm::WhittedRenderer renderer(scene, *accel, *shadows, options);
    const int tiles = ((options.width + 15) / 16) * ((options.height + 15) / 16);
    lm::RenderResult result;
    {
        lm::ProgressReporter progress(tiles, "Rendering",
                                      !cmd.common.quiet && lm::ProgressReporter::StderrIsTerminal());
        result = renderer.Render(&progress);
    }
    const auto t3 = Clock::now();
    lm::WriteImage(output, result.image);
    const double writeSeconds = SecondsSince(t3);

    std::printf("%s: %dx%d, shadows %s, accel %s, %zu triangles, %zu lights: render %.3f s\n",
                output.c_str(), options.width, options.height, std::string(shadows->Name()).c_str(),
                std::string(accel->Name()).c_str(), scene.mesh.TriangleCount(), scene.lights.size(),
                result.seconds);
    if (cmd.stats) {
        const lm::RenderCounters& c = result.counters;
        std::printf("time      load %.3f s, build %.3f s, shadow setup %.3f s, render %.3f s, write %.3f s\n",
                    loadSeconds, buildSeconds, shadowSetupSeconds, result.seconds, writeSeconds);
        std::printf("threads   %d\n", static_cast<int>(tbb::global_control::active_value(
                                          tbb::global_control::max_allowed_parallelism)));
        std::printf("rays      camera %s, shadow %s, reflection %s; shading points %s\n",
                    Count(c.cameraRays).c_str(), Count(c.shadowRays).c_str(),
                    Count(c.reflectionRays).c_str(), Count(c.shadingPoints).c_str());
        PrintFigures("accel", accel->Figures());
        if (c.interpolations + c.fallbacks > 0) {
            const double points = static_cast<double>(c.interpolations + c.fallbacks);
            std::printf("lmm       interpolated points %s, mean m %.1f, candidates per point %.1f, "
                        "local-visibility segments %s, fallbacks %s (%.2f%%)\n",
                        Count(c.interpolations).c_str(),
                        c.interpolations ? static_cast<double>(c.nodesUsed) / static_cast<double>(c.interpolations) : 0.0,
                        static_cast<double>(c.candidates) / points, Count(c.localSegments).c_str(),
                        Count(c.fallbacks).c_str(), 100.0 * static_cast<double>(c.fallbacks) / points);
        }
        PrintFigures("shadows", shadows->Figures());
        std::printf("memory    peak %s\n", lm::FormatBytes(lm::PeakMemoryBytes()).c_str());
    }
    return 0;
}

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
    renderCmd->add_option("--width", render.width, "Image width in pixels")->check(CLI::Range(1, 16384));
    renderCmd->add_option("--height", render.height, "Image height in pixels")->check(CLI::Range(1, 16384));
    renderCmd->add_option("--aa", render.aa, "Anti-aliasing: N x N camera rays per pixel")
        ->check(CLI::Range(1, 16));
    renderCmd->add_option("--max-depth", render.maxDepth, "Mirror recursion limit (1: no reflections)")
        ->check(CLI::Range(1, 64));
    renderCmd->add_option("--shadows", render.shadows,
                          "Shadows: none, rt (hard: one shadow ray per light) or lmm (soft: the light mesh method)")
        ->check(CLI::IsMember(lm::ShadowMethodNames()));
    renderCmd->add_option("--accel", render.accel, "Ray-query back-end: brute, grid or embree")
        ->check(CLI::IsMember(lm::AcceleratorNames()));
    renderCmd->add_option("--grid", render.grid,
                          "Nested grid: top-level cells along the longest side (0: automatic)")
        ->check(CLI::Range(0, 1024));
    renderCmd->add_option("--cc", render.cc,
                          "Light mesh: cells across the longest side of the scene (the paper's CC; default 100)")
        ->check(CLI::Range(1, 4096));
    renderCmd->add_option("--ki", render.ki,
                          "Light mesh: interpolation radius in mesh steps, r = kI*h (default 2)")
        ->check(CLI::Range(0.01f, 16.0f));
    renderCmd->add_option("--variant", render.variant,
                          "Light mesh variant: grid (the paper's Grid: cube loop, segment test from every "
                          "node to every point; default) or grid-none (no local-visibility test)")
        ->check(CLI::IsMember(lm::LightMeshVariantNames()));
    renderCmd->add_flag("--stats", render.stats, "Print rays by kind, time by phase, back-end figures, peak memory");

    CommonOptions info;
    std::string infoAccel;
    int infoGrid = -1;
    CLI::App* infoCmd = app.add_subcommand("info", "Describe a scene: triangles, bounds, closed solids, lights, materials");
    AddCommonOptions(infoCmd, &info);
    infoCmd->add_option("--accel", infoAccel, "Also build this back-end and print its figures")
        ->check(CLI::IsMember(lm::AcceleratorNames()));
    infoCmd->add_option("--grid", infoGrid, "Nested grid: top-level cells (0: automatic)")
        ->check(CLI::Range(0, 1024));

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }

    const CommonOptions& common = renderCmd->parsed() ? render.common : info;
    std::unique_ptr<tbb::global_control> threadLimit;
    if (common.threads > 0)
        threadLimit = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, static_cast<size_t>(common.threads));
    try {
        if (renderCmd->parsed()) return RunRender(render);
        return RunInfo(info, infoAccel, infoGrid);
    } catch (const lm::Error& e) {
        std::fprintf(stderr, "lightmesh: error: %s\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "lightmesh: error: out of memory\n");
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "lightmesh: internal error: %s\n", e.what());
        return 2;
    }
}
