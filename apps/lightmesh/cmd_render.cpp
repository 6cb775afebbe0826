// cmd_render.cpp -- `lightmesh render`, in one process or over MPI ranks.
#include "commands.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "lightmesh/distributed/rank_report.h"
#ifdef LIGHTMESH_HAS_MPI
#include "lightmesh/distributed/mpi_render.h"
#endif
#include "lightmesh/geometry/instances.h"
#include "lightmesh/io/image.h"
#include "lightmesh/io/channels_exr.h"
#include "lightmesh/io/tonemap.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/render/visibility_image.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/scene_writer.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/progress.h"

namespace lm::cli {

/// A render ready to run: the scene loaded, options merged and checked, the output's folder
/// checked, the back-end and the shadow method built.
struct PreparedRender {
    lm::Scene scene;
    std::string output;
    std::unique_ptr<lm::RenderJob> job;
    double loadSeconds = 0;
    lm::SceneSource source;  ///< for --save-scene
};

std::unique_ptr<PreparedRender> PrepareRender(const RenderCommand& cmd) {
    auto prepared = std::make_unique<PreparedRender>();
    const auto t0 = Clock::now();
    lm::Scene& scene = prepared->scene;
    CommonOptions common = cmd.common;
    common.textures = !cmd.noTextures;
    common.instancing = !cmd.noInstancing;
    // The camera options, checked before the scene is read (a bare mesh's --up x|z and
    // --fov reach its framing).
    const lm::CameraOverrides camera = CameraFromCommand(cmd, &common);
    prepared->source = {cmd.common.scene, common.upAxis, common.textures, common.instancing, common.smoothNormals};
    if (!cmd.saveScene.empty()) lm::CheckSceneSaveable(cmd.saveScene, prepared->source, "--save-scene");
    scene = LoadWithWarnings(common, cmd.width.value_or(0), cmd.height.value_or(0));
    prepared->loadSeconds = SecondsSince(t0);
    lm::ApplyCameraOverrides(camera, &scene);

    lm::RenderOptions options = scene.render;
    if (cmd.width) options.width = *cmd.width;
    if (cmd.height) options.height = *cmd.height;
    KeepAspectRatio(cmd, scene.render, &options);  // --width or --height alone
    if (cmd.exposure) options.exposure = *cmd.exposure;
    if (cmd.tonemap) options.tonemap = *cmd.tonemap;
    if (cmd.aa) options.aa = *cmd.aa;
    if (cmd.maxDepth) options.maxDepth = *cmd.maxDepth;
    if (cmd.shadows) options.shadows = *cmd.shadows;
    if (cmd.accel) options.accel = *cmd.accel;
    if (cmd.grid) options.accelOptions.gridResolution = *cmd.grid;
    if (cmd.cc) options.lightMesh.cc = options.soft.cc = *cmd.cc;
    if (cmd.ki) options.lightMesh.ki = *cmd.ki;
    if (cmd.variant) options.lightMesh.variant = *cmd.variant;
    if (cmd.ns) options.lightMesh.ns = *cmd.ns;
    if (cmd.templateDir) options.lightMesh.templateDir = *cmd.templateDir;
    if (cmd.cellSummaries) options.lightMesh.cellSummaries = *cmd.cellSummaries;
    if (cmd.lightRadius) options.areaLight.radius = *cmd.lightRadius;
    if (cmd.thinCheck) options.lightMesh.thinCheck = *cmd.thinCheck;
    if (cmd.samples) options.areaLight.samples = *cmd.samples;
    if (cmd.softSamples) options.soft.samples = *cmd.softSamples;
    if (cmd.lightCut) options.lightCut = *cmd.lightCut;

    if (cmd.variant && cmd.variant->empty())
        lm::ThrowError("--variant: must not be empty (leave it out for the default)");
    // The flags given replace the file's values: theirs is the place a message names.
    const std::pair<const char*, bool> flags[] = {
        {"width", cmd.width.has_value()},
        {"height", cmd.height.has_value()},
        {"aa", cmd.aa.has_value()},
        {"max_depth", cmd.maxDepth.has_value()},
        {"shadows", cmd.shadows.has_value()},
        {"accel", cmd.accel.has_value()},
        {"cc", cmd.cc.has_value()},
        {"ki", cmd.ki.has_value()},
        {"variant", cmd.variant.has_value()},
        {"ns", cmd.ns.has_value()},
        {"template_dir", cmd.templateDir.has_value()},
        {"cell_summaries", cmd.cellSummaries.has_value()},
        {"light_radius", cmd.lightRadius.has_value()},
        {"thin_check", cmd.thinCheck.has_value()},
        {"samples", cmd.samples.has_value()},
        {"soft_samples", cmd.softSamples.has_value()},
        {"light_cut", cmd.lightCut.has_value()},
        {"grid", cmd.grid.has_value()},
        {"textures", cmd.noTextures},
        {"instancing", cmd.noInstancing},
        {"exposure", cmd.exposure.has_value()},
        {"tonemap", cmd.tonemap.has_value()},
    };
    std::vector<std::string> given;
    for (const auto& [key, isGiven] : flags) {
        if (!isGiven) continue;
        given.push_back(key);
        options.origins[key] = lm::SourceLoc::Option(lm::RenderSettingFor(key).flag);
    }
    lm::CheckRenderOptions(scene, options, given);
    // Check everything about the output before spending time on the render.
    std::string& output = prepared->output;
    output = cmd.output;
    if (output.empty()) {
        std::string stem = cmd.common.scene.rfind("builtin:", 0) == 0
                               ? cmd.common.scene.substr(8)
                               : std::filesystem::path(cmd.common.scene).stem().string();
        output = stem + ".png";
    }
    // A folder is named so whatever its name looks like ("out", "out.png", ".", "out/"),
    // before the extension is judged.
    std::error_code folderError;
    if (std::filesystem::is_directory(output, folderError)) lm::ThrowErrorAt({output}, "is a folder, not a file");
    if (output.back() == '/') lm::ThrowErrorAt({output}, "names a folder, not a file");
    lm::ImageFormatFor(output);
    lm::CheckWritableFolder(output);
    if (!cmd.visibility.empty()) {
        const std::string& vis = cmd.visibility;
        if (std::filesystem::is_directory(vis, folderError) || vis.back() == '/')
            lm::ThrowErrorAt({vis}, "--visibility: names a folder, not a file");
        if (lm::ImageFormatFor(vis) != lm::ImageFormat::Exr)
            lm::ThrowErrorAt({vis}, "--visibility: must be an .exr file (one float channel per light)");
        if (std::filesystem::absolute(vis).lexically_normal() == std::filesystem::absolute(output).lexically_normal())
            lm::ThrowErrorAt({vis}, "--visibility: the same file as the image (-o)");
        lm::CheckWritableFolder(vis);
    }
    lm::PrepareSceneForRender(&scene, options, cmd.common.scene);
    prepared->job = std::make_unique<lm::RenderJob>(scene, options);
    return prepared;
}

// A render whose sample of tiles spread over the image says it will take longer than this
// says so (the rule's 30 s, from tiles spread over the image, set-up apart): 16384 x 16384
// at aa 16, 68.7 G camera rays, would otherwise run for hours without a word.
constexpr double kAnnouncedRenderSeconds = 30;
// A render whose estimate passes this is stopped unless --force (the rule: past an hour).
constexpr double kRefusedRenderSeconds = 3600;

// What a render has to do, for that line: "68,719,476,736 camera rays (16384x16384 at aa
// 16), shadows lmm".
std::string RenderWork(const lm::RenderOptions& o, bool ctrlC = true) {
    const uint64_t rays = static_cast<uint64_t>(o.width) * static_cast<uint64_t>(o.height) *
                          static_cast<uint64_t>(o.aa) * static_cast<uint64_t>(o.aa);
    return lm::StringPrintf("%s camera rays (%dx%d at aa %d), shadows %s%s", Count(rays).c_str(), o.width, o.height,
                            o.aa, o.shadows.c_str(), ctrlC ? "; Ctrl-C stops it and leaves the output as it was" : "");
}

// The summary line, and with --stats the figures (per rank under MPI).
void PrintRender(const RenderCommand& cmd, const PreparedRender& p, const lm::RenderResult& result,
                 double writeSeconds, const std::vector<lm::RankReport>* ranks) {
    // -q prints errors only; --stats asks for the figures, the summary line with them.
    if (cmd.common.quiet && !cmd.stats) return;
    const lm::RenderOptions& options = p.job->Options();
    std::printf("%s: %dx%d, shadows %s, accel %s, %s, %s: render %.3f s\n", p.output.c_str(), options.width,
                options.height, std::string(p.job->Shadows().Name()).c_str(),
                std::string(p.job->Accel().Name()).c_str(), Counted(p.scene.mesh.PrimCount(), "triangle").c_str(),
                Counted(p.scene.lights.size(), "light").c_str(), result.seconds);
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
    // The shadow method's own counts (under MPI every rank's, summed), as lines it words itself.
    for (const auto& [label, text] : p.job->CounterLines(c))
        std::printf("%-10s%s\n", label.c_str(), text.c_str());
    PrintFigures(ranks ? "shadows (rank 0)" : "shadows", p.job->Shadows().Figures());
    std::printf("memory    peak %s%s\n", lm::FormatBytes(lm::PeakMemoryBytes()).c_str(), ranks ? " (rank 0)" : "");
}

// The rendered image written: a PNG through the tone curve (--tonemap; EXR stays linear).
void WriteRendered(const std::string& output, lm::Image* image, const lm::RenderOptions& options) {
    if (lm::ImageFormatFor(output) == lm::ImageFormat::Png) lm::ApplyToneCurve(image, options.tonemap);
    lm::WriteImage(output, *image);
}

// What an interrupted render leaves: the interrupt handler's line ends with it.
std::string InterruptNote(const std::string& output) {
    std::error_code ec;
    return output + (std::filesystem::exists(output, ec) ? " not written: the previous file is kept" : " not written");
}

int RunRender(const RenderCommand& cmd) {
    ApplyLogLevel(cmd.common);
    lm::InstallInterruptCleanup();
    const std::unique_ptr<PreparedRender> p = PrepareRender(cmd);
    lm::SetInterruptMessage(InterruptNote(p->output));
    lm::RenderResult result;
    std::optional<lm::VisibilityImage> visibility;
    if (!cmd.visibility.empty()) visibility.emplace(p->job->MakeVisibility());
    {
        lm::ProgressReporter progress(p->job->Renderer().TileCount(), "Rendering",
                                      !cmd.common.quiet && lm::ProgressReporter::StderrIsTerminal());
        if (!cmd.common.quiet) progress.AnnounceIfLong(kAnnouncedRenderSeconds, RenderWork(p->job->Options()));
        // (The denoiser renders by bands, its own schedule: it is announced, not stopped.)
        if (!cmd.force && !p->job->Denoiser())
            progress.RefuseIfLonger(kRefusedRenderSeconds,
                                    "; " + RenderWork(p->job->Options(), false) + "; --force renders it anyway");
        result = p->job->Render(&progress, visibility ? &*visibility : nullptr);
        if (progress.Stopped()) lm::ThrowErrorAt({p->output}, "not rendered: %s", progress.StopReason().c_str());
    }
    const auto t3 = Clock::now();
    WriteRendered(p->output, &result.image, p->job->Options());
    if (visibility)
        lm::WriteChannelsExr(cmd.visibility, visibility->width, visibility->height,
                             lm::LightChannelNames(visibility->lights), visibility->values);
    if (!cmd.saveScene.empty()) lm::WriteSceneFile(cmd.saveScene, p->scene, p->job->Options(), p->source);
    lm::SetInterruptMessage("");
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
    if (!cmd.visibility.empty())
        return fail("--visibility: not available under mpirun (render in one process to write it)", 0);
    std::unique_ptr<PreparedRender> p;
    std::string error, message;
    int failedRank = -1;
    try {
        p = PrepareRender(cmd);
    } catch (...) {
        error = lm::CurrentExceptionLine();
    }
    if (!session.AllSucceeded(error, &message, &failedRank)) return fail(message, failedRank);
    if (root) lm::SetInterruptMessage(InterruptNote(p->output));
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
        if (root && !cmd.common.quiet) progress.AnnounceIfLong(kAnnouncedRenderSeconds, RenderWork(p->job->Options()));
        d = p->job->Bands()
                ? lm::RenderDistributedBands(session, p->job->Renderer(), *p->job->Bands(), root ? &progress : nullptr)
                : lm::RenderDistributed(session, p->job->Renderer(), nodes, root ? &progress : nullptr);
    }
    if (d.errorRank >= 0) return fail(d.error, d.errorRank);
    if (!root) return 0;
    const auto t3 = Clock::now();
    lm::ApplyExposure(&d.result.image, p->job->Options().exposure);  // (RenderJob::Render's, for the ranks' image)
    WriteRendered(p->output, &d.result.image, p->job->Options());
    if (!cmd.saveScene.empty()) lm::WriteSceneFile(cmd.saveScene, p->scene, p->job->Options(), p->source);
    lm::SetInterruptMessage("");
    PrintRender(cmd, *p, d.result, SecondsSince(t3), &d.ranks);
    return 0;
}
#endif

}  // namespace lm::cli
