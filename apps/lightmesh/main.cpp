// lightmesh -- the command line: render, info, templates, bench, compare. Thin: the work is
// in lightmesh_core; each command's code is in cmd_*.cpp (commands.h). This file defines
// each command's options and dispatches: parse, check, run, report.
#include "commands.h"

#include <tbb/global_control.h>

#include <memory>
#include <optional>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/distributed/launch.h"
#ifdef LIGHTMESH_HAS_MPI
#include "lightmesh/distributed/mpi_render.h"
#endif
#include "lightmesh/shadow/sphere_templates.h"
#include "lightmesh/util/log.h"

using namespace lm::cli;

namespace {

/// `lightmesh info`'s options.
struct InfoCommand {
    CommonOptions common;
    std::string accel;
    int grid = -1;
};

/// `lightmesh templates`'s options.
struct TemplatesCommand {
    int ns = lm::kDefaultTemplateSubsteps;
    float ki = 2.0f;
    std::string dir;
    bool measure = false;
    int threads = 0;
};

/// The command line: each command's options, filled by the CLI11 command defined for it.
struct CommandLine {
    CLI::App app{"lightmesh: soft shadows of lights the size of spheres; the default is --shadows soft, the "
                 "paper's light mesh method is --shadows lmm"};
    RenderCommand render;
    InfoCommand info;
    TemplatesCommand templates;
    CompareCommand compare;
    int compareThreads = 0;
    CLI::Option* diffScale = nullptr;  ///< compare's --diff-scale, to tell whether it was given
    BenchCommand bench;
    int benchThreads = 0;
    CLI::App* renderCmd = nullptr;
    CLI::App* infoCmd = nullptr;
    CLI::App* templatesCmd = nullptr;
    CLI::App* compareCmd = nullptr;
    CLI::App* benchCmd = nullptr;
};

void AddRenderCommand(CLI::App& app, RenderCommand* render, CLI::App** added) {
    CLI::App* cmd = *added = app.add_subcommand("render", "Render a scene to a PNG or EXR image");
    AddCommonOptions(cmd, &render->common);
    cmd->add_option("-o,--output", render->output,
                    "Output image, .png (8-bit sRGB) or .exr (linear float); default: the "
                    "scene's name with .png, in the current folder");
    // The render knobs: flag, help and check from the settings table (the scene file's
    // "render" object is checked against the same rows).
    AddSetting(cmd, "width", &render->width);
    AddSetting(cmd, "height", &render->height);
    AddSetting(cmd, "aa", &render->aa);
    AddSetting(cmd, "max_depth", &render->maxDepth);
    AddSetting(cmd, "shadows", &render->shadows);
    AddSetting(cmd, "accel", &render->accel);
    AddSetting(cmd, "grid", &render->grid);
    // The paper's method's knobs under their own heading in the help.
    const char* paper = "The paper's light mesh method (--shadows lmm; --cc also for exact)";
    AddSetting(cmd, "cc", &render->cc)->group(paper);
    AddSetting(cmd, "ki", &render->ki)->group(paper);
    AddSetting(cmd, "variant", &render->variant)->group(paper);
    AddSetting(cmd, "ns", &render->ns)->group(paper);
    AddSetting(cmd, "template_dir", &render->templateDir)->group(paper);
    AddSetting(cmd, "cell_summaries", &render->cellSummaries)->group(paper);
    AddSetting(cmd, "light_radius", &render->lightRadius);
    AddSetting(cmd, "thin_check", &render->thinCheck)->group(paper);
    AddSetting(cmd, "samples", &render->samples);
    AddSetting(cmd, "soft_samples", &render->softSamples);
    AddSetting(cmd, "light_cut", &render->lightCut);
    cmd->add_flag(lm::RenderSettingFor("textures").flag, render->noTextures, lm::RenderSettingFor("textures").help);
    cmd->add_flag(lm::RenderSettingFor("instancing").flag, render->noInstancing,
                  lm::RenderSettingFor("instancing").help);
    cmd->add_option("--visibility", render->visibility,
                    "Also write each light's visibility at each pixel's camera hits to this .exr: one float "
                    "channel per light (light0, light1, ...), NaN where no camera ray hit the scene");
    // The image's exposure and tone curve (settings table rows; io/tonemap.h).
    AddSetting(cmd, "exposure", &render->exposure);
    AddSetting(cmd, "tonemap", &render->tonemap);
    // The camera options and --save-scene (render_view.cpp).
    AddViewOptions(cmd, render);
    cmd->add_flag("--stats", render->stats, "Print rays by kind, time by phase, back-end figures, peak memory");
    cmd->add_flag("--force", render->force,
                  "Render even when its first tiles estimate more than an hour (refused otherwise)");
}

void AddInfoCommand(CLI::App& app, InfoCommand* info, CLI::App** added) {
    CLI::App* cmd = *added =
        app.add_subcommand("info", "Describe a scene: triangles, bounds, closed solids, lights, materials");
    AddCommonOptions(cmd, &info->common);
    cmd->add_option("--accel", info->accel, "Also build this back-end and print its figures")
        ->check(CLI::IsMember(lm::AcceleratorNames()));
    AddSetting(cmd, "grid", &info->grid);
}

void AddTemplatesCommand(CLI::App& app, TemplatesCommand* templates, CLI::App** added) {
    CLI::App* cmd = *added = app.add_subcommand(
        "templates", "Build and cache the light mesh's sphere templates for (ns, kI) (the paper's section 3.1)");
    // --ns and --ki take render's ranges (0: the default ns, as `render --ns 0`).
    cmd->add_option("--ns", templates->ns, "Sub-steps per cell side (default 8; 0: the default)")
        ->check(SettingRange("ns"));
    cmd->add_option("--ki", templates->ki, "Interpolation radius in mesh steps (default 2)")->check(SettingRange("ki"));
    cmd->add_option("--template-dir", templates->dir, "Cache folder (default: $XDG_CACHE_HOME/lightmesh/templates)");
    cmd->add_flag("--measure", templates->measure,
                  "Also print, for ns = 1 … 32, how many nodes snapping P to a sub-position gets wrong");
    cmd->add_flag("-q,--quiet", [](int64_t) { lm::SetLogLevel(lm::LogLevel::Error); },
                  "No warnings or notes: errors and the result line only");
    // -t and -v mean in every command what they mean in render.
    cmd->add_option("-t,--threads", templates->threads, "Worker threads (default: all cores)")
        ->check(InRange(1, 1024, true));
    cmd->add_flag("-v,--verbose", [](int64_t) { lm::SetLogLevel(lm::LogLevel::Debug); },
                  "Print more about what is done");
}

void AddCompareCommand(CommandLine* cl) {
    CompareCommand& compare = cl->compare;
    CLI::App* cmd = cl->compareCmd = cl->app.add_subcommand(
        "compare", "Image quality of B against A (PNG or EXR): PSNR, SSIM, RMSE, max difference; "
                   "exit 0 = compared, 1 = error, 3 = below --threshold-psnr");
    cmd->add_option("a", compare.a, "Reference image (.png or .exr)")->required();
    cmd->add_option("b", compare.b, "Image to judge, the same size")->required();
    cmd->add_option("--mask", compare.mask, "Compare only where this image (same size) is not black");
    cmd->add_option("--diff", compare.diff, "Write a false-colour (Turbo) image of |A - B| here");
    cl->diffScale = cmd->add_option("--diff-scale", compare.diffScale,
                                    "Difference shown as the top colour (display units, 0..1; default 0: the largest)")
                        ->check(FiniteFloat(true));
    cmd->add_option("--no-shadows", compare.none,
                    "The same render without shadows (--shadows none): also print each image's shadow total "
                    "(sum of no-shadow minus image, linear luminance) and B's over A's");
    cmd->add_flag("--json", compare.json, "Print one JSON line (psnr is null for identical images)");
    cmd->add_option("--threshold-psnr", compare.thresholdPsnr, "Exit with 3 if the PSNR (dB) is lower");
    // -t, -q and -v mean in every command what they mean in render.
    cmd->add_option("-t,--threads", cl->compareThreads, "Worker threads (default: all cores)")
        ->check(InRange(1, 1024, true));
    cmd->add_flag("-q,--quiet", [](int64_t) { lm::SetLogLevel(lm::LogLevel::Error); },
                  "No warnings: errors and the figures only");
    cmd->add_flag("-v,--verbose", [](int64_t) { lm::SetLogLevel(lm::LogLevel::Debug); },
                  "Print more about what is done");
}

/// bench's matrix: the scenes, sizes and values timed, or a paper's table, or a matrix file
/// (which exclude each other), and --force.
void AddBenchMatrixOptions(CLI::App* cmd, BenchCommand* bench) {
    CLI::Option* scene = cmd->add_option("--scene", bench->matrix.scenes, "Scenes (repeat the option); default builtin:gazebo");
    CLI::Option* size = cmd->add_option("--size", bench->sizes, "Image sizes WIDTHxHEIGHT (repeat); default 1024x768");
    CLI::Option* cc = cmd->add_option("--cc", bench->matrix.cc, "Light mesh CC values, comma-separated; default 100")
        ->delimiter(',')->check(SettingRange("cc"));
    CLI::Option* ki = cmd->add_option("--ki", bench->matrix.ki, "Light mesh kI values, comma-separated; default 2")
        ->delimiter(',')->check(SettingRange("ki"));
    CLI::Option* variants = cmd->add_option("--variants", bench->matrix.variants,
                         "What to time besides RT and no shadows, comma-separated: soft (the default shadow method) "
                         "and LMM variants; default soft,grid,templates,reduced,none,inside,object,consensus")
        ->delimiter(',');
    cmd->add_option("--cell-summaries", bench->matrix.cellSummaries,
                    "Light mesh cell summaries for every LMM cell: auto (consensus only, where the image is fine enough), "
                    "on or off; default auto")
        ->check(CLI::IsMember({"auto", "on", "off"}));
    cmd->add_option("--thin-check", bench->matrix.thinCheck,
                    "With --quality, the penumbra mode's thin-occluder check: all (default, as render), lit or off")
        ->check(CLI::IsMember(lm::RenderSettingFor("thin_check").choices));
    CLI::Option* table = cmd->add_option("--table", bench->table,
                         "Reproduce the paper's table 1, 2, 3 or 4 on scenes/real (replaces --scene --size --cc --ki --variants)")
        ->check(InRange(1, 4, true));
    CLI::Option* matrixFile = cmd->add_option("--matrix", bench->matrixFile,
                         "Read the matrix from JSON: {\"scenes\", \"sizes\": [[w,h]], \"cc\", \"ki\", \"variants\", \"accels\", \"repeat\"}");
    // (Not CLI::ExistingFile: LoadBenchMatrix says why a file cannot be read; CLI11 called
    // a symlink loop "File does not exist".)
    bench->variantsOption = variants;
    bench->ccOption = cc;
    bench->kiOption = ki;
    cmd->add_flag("--force", bench->force,
                  "Run a matrix estimated to take more than an hour (refused otherwise, also with -q)");
    for (CLI::Option* o : {scene, size, cc, ki, variants}) {
        o->excludes(table);
        o->excludes(matrixFile);
    }
    table->excludes(matrixFile);
}

void AddBenchCommand(CLI::App& app, BenchCommand* bench, int* threads, CLI::App** added) {
    bench->matrix.soft = true;  // the default shadow method timed too, unless --variants leaves it out
    CLI::App* cmd = *added = app.add_subcommand(
        "bench", "Time shadow methods side by side: scenes x sizes x CC x kI x variants, plus RT and no shadows");
    AddBenchMatrixOptions(cmd, bench);
    cmd->add_flag("--quick", bench->quick, "Every size divided by 4 in each dimension, --repeat 1 (a fast check)");
    cmd->add_option("--html", bench->html,
                    "Write a self-contained HTML report (tables, SVG charts, images with zoomed crops); "
                    "renders the images next to it unless --images is given");
    cmd->add_flag("--quality", bench->matrix.quality,
                  "Also judge every cell against a converged area-light reference: PSNR/SSIM, reference "
                  "radius sweep, naive soft shadows (N = 1, 2, 4, 16, 64) vs LMM, contact-hardening penumbrae (lmm with the reference's light radius), leak count; "
                  "and the default (soft) against RT, the exact mode, LMM, area N = 1, 2, 4, …, 256 (--area-samples) and "
                  "the denoiser N = 1, 2, 4 at the lights' own radii: time, PSNR, shadow total, area's N and time at "
                  "soft's PSNR, the denoiser's PSNR at soft's time");
    cmd->add_option("--area-samples", bench->matrix.competitorSamples,
                    "With --quality, the competitors' area rows: rays per light, comma-separated (default 1,2,4,8,16,32,64,128,256; "
                    "past the largest, area's PSNR is extrapolated at 3.01 dB per doubling)")
        ->delimiter(',')
        ->check(InRange(1, 4096, true));
    cmd->add_option("--ref-samples", bench->matrix.refSamples,
                    "Rays per light of the --quality references (the paper's radius sweep and the competitors' "
                    "table); default 256")
        ->check(InRange(1, 4096, true));
    cmd->add_option("--light-radius", bench->matrix.lightRadius,
                    "With --quality, the competitors' table (soft, area and its reference) gives every light this "
                    "radius instead of its own; the paper's tables keep R = kI·h")
        ->check(SettingRange("light_radius"))
        ->check(FiniteFloat(true));
    cmd->add_option("--json", bench->json, "Also write every cell and the --quality tables as JSON");
    bench->accelsOption = cmd->add_option("--accels", bench->matrix.accels,
                         std::string("Ray-query back-ends for RT (the first also serves no shadows and LMM), comma-separated; default ") +
                             lm::kDefaultAccelerator + " (grid for --table, the paper's)")
        ->delimiter(',')->check(CLI::IsMember(lm::AcceleratorNames()));
    bench->repeatOption = cmd->add_option("--repeat", bench->matrix.repeat, "Timed runs per cell after a warm-up; the median is reported (default 3; 1 with --quick)")
        ->check(InRange(1, 100, true));
    cmd->add_flag("--no-none", bench->noNone, "Skip the render without shadows");
    cmd->add_option("--images", bench->matrix.imageDir, "Write each cell's image (PNG) into this folder");
    cmd->add_option("--csv", bench->csv, "Also write every figure of every cell as CSV");
    cmd->add_option("--markdown", bench->markdown, "Also write the tables to this Markdown file");
    cmd->add_option("-t,--threads", *threads, "Worker threads (default: all cores)")->check(InRange(1, 1024, true));
    cmd->add_flag("-q,--quiet", bench->quiet, "No progress lines or warnings: errors and the tables only");
    cmd->add_flag("-v,--verbose", bench->verbose, "Print more about what is done (the scenes' notes too)");
}

/// Every command and its options, in the order the help lists them.
void DefineCommandLine(CommandLine* cl, const char* argv0) {
    CLI::App& app = cl->app;
    app.require_subcommand(1);
    app.set_version_flag("--version", "lightmesh 0.1.0");
    // Command-line mistakes read like every other error ("lightmesh: error: ...").
    app.failure_message([](const CLI::App*, const CLI::Error& e) {
        // Printable: an argument with a newline must not split the one-line error.
        return std::string("lightmesh: error: ") + lm::Printable(e.what()) + "\nRun with --help for more information.\n";
    });
    AddRenderCommand(app, &cl->render, &cl->renderCmd);
    AddInfoCommand(app, &cl->info, &cl->infoCmd);
    AddTemplatesCommand(app, &cl->templates, &cl->templatesCmd);
    AddCompareCommand(cl);
    AddBenchCommand(app, &cl->bench, &cl->benchThreads, &cl->benchCmd);
    cl->bench.argv0 = argv0;
    // A repeated option takes its last value (`--threads 1 -t 2` is 2), as in most tools;
    // lists (--scene, --size, comma-separated values) still gather every value.
    for (CLI::App* cmd : {cl->renderCmd, cl->infoCmd, cl->templatesCmd, cl->compareCmd, cl->benchCmd})
        for (CLI::Option* o : cmd->get_options())
            if (o->nonpositional() && o->get_items_expected_max() <= 1 && o->get_type_size_max() <= 1)
                o->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
}

/// `lightmesh help [COMMAND]`: the help, as --help.
bool IsHelpCommand(int argc, char** argv) { return argc >= 2 && std::string(argv[1]) == "help" && argc <= 3; }

int PrintHelp(CLI::App& app, int argc, char** argv) {
    const CLI::App* shown = &app;
    if (argc == 3)
        for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
            if (sub->get_name() == argv[2]) shown = sub;
    app.name(argv[0]);
    std::printf("%s", shown == &app ? app.help().c_str() : shown->help(argv[0]).c_str());
    return 0;
}

/// What to say about a command line CLI11 refused, and the exit code: 0 for --help and
/// --version, 1 for a mistake.
int ReportParseError(const CLI::App& app, const CLI::ParseError& e, int argc, char** argv) {
    // A missing scene whose name was taken for an option (`render -scene.json`): the
    // option is what went wrong, not the scene ("scene is required" pre-empted it).
    if (dynamic_cast<const CLI::RequiredError*>(&e))
        for (const CLI::App* sub : app.get_subcommands())
            for (const std::string& arg : sub->remaining())
                if (arg.size() > 1 && arg[0] == '-') {
                    std::fprintf(stderr,
                                 "lightmesh: error: %s: not an option of `%s`; a file whose name starts with '-' "
                                 "is given as ./%s (or after --)\nRun with --help for more information.\n",
                                 lm::Printable(arg).c_str(), sub->get_name().c_str(), lm::Printable(arg).c_str());
                    return 1;
                }
    // A mistyped command or option: the nearest one ("did you mean render?");
    // `lightmesh help [COMMAND]` prints the help.
    const CLI::App* help = nullptr;
    const std::string mistake = CommandLineMistake(app, e, argc, argv, &help);
    if (help) {
        std::printf("%s", help->help().c_str());
        return 0;
    }
    if (!mistake.empty()) {
        std::fprintf(stderr, "lightmesh: error: %s\nRun with --help for more information.\n", mistake.c_str());
        return 1;
    }
    // --help and --version exit 0; a command-line mistake exits 1 like any bad input
    // (CLI11's own codes are 100 and up).
    return app.exit(e) == 0 ? 0 : 1;
}

/// Parses the command line; the exit code when it is not a command to run (a mistake, --help).
std::optional<int> Parse(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return ReportParseError(app, e, argc, argv);
    }
    return std::nullopt;
}

/// A memory budget that is not a size is refused before any work (it was ignored, and
/// the process ran without a budget); under mpirun rank 0 says so, every rank exits 1.
bool MemoryLimitReadable() {
    try {
        lm::MemoryLimitFromEnvironment();
    } catch (...) {
        if (lm::LauncherWorldRank() == 0) std::fprintf(stderr, "lightmesh: error: %s\n", lm::CurrentExceptionLine().c_str());
        return false;
    }
    return true;
}

/// At most `threads` worker threads while it lives (none: all cores, for threads <= 0).
std::unique_ptr<tbb::global_control> ThreadLimit(int threads) {
    if (threads <= 0) return nullptr;
    return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                 static_cast<size_t>(threads));
}

/// Under mpirun: render spreads its tiles over the ranks; the other commands run once,
/// on rank 0, and the other ranks leave at once. The exit code when this process's part
/// ends here; none when it runs the command as usual.
std::optional<int> RunUnderLauncher(const CommandLine& cl, [[maybe_unused]] int* argc,
                                    [[maybe_unused]] char*** argv) {
    const int worldSize = lm::LauncherWorldSize(), worldRank = lm::LauncherWorldRank();
    if (lm::LaunchedByMpi() && cl.renderCmd->parsed()) {
#ifdef LIGHTMESH_HAS_MPI
        std::unique_ptr<lm::MpiSession> session;
        int threads = cl.render.common.threads;
        try {
            session = std::make_unique<lm::MpiSession>(argc, argv);
            if (threads == 0) threads = session->DefaultThreads();
        } catch (...) {
            std::fprintf(stderr, "lightmesh: error: %s\n", lm::CurrentExceptionLine().c_str());
            return 1;
        }
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
        return Guarded([&] { return RunRenderMpi(cl.render, *session); });
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
                             "runs once, on rank 0 (%s)\n",
                     worldSize == 2 ? "the other rank exits"
                                    : lm::StringPrintf("the other %d ranks exit", worldSize - 1).c_str());
    }
    return std::nullopt;
}

/// Runs the command parsed, in this process, with its thread limit (cmd_*.cpp).
int RunCommand(CommandLine& cl) {
    if (cl.benchCmd->parsed()) {
        const auto limit = ThreadLimit(cl.benchThreads);
        return Guarded([&] { return RunBench(cl.bench); });
    }
    if (cl.compareCmd->parsed()) {
        const auto limit = ThreadLimit(cl.compareThreads);
        cl.compare.diffScaleGiven = cl.diffScale->count() > 0;
        return Guarded([&] { return RunCompare(cl.compare); });
    }
    if (cl.templatesCmd->parsed()) {
        const TemplatesCommand& t = cl.templates;
        const auto limit = ThreadLimit(t.threads);
        return Guarded([&] { return RunTemplates(t.ns, t.ki, t.dir, t.measure); });
    }
    if (cl.renderCmd->parsed()) {
        const auto limit = ThreadLimit(cl.render.common.threads);
        return Guarded([&] { return RunRender(cl.render); });
    }
    const auto limit = ThreadLimit(cl.info.common.threads);
    return Guarded([&] { return RunInfo(cl.info.common, cl.info.accel, cl.info.grid); });
}

}  // namespace

int main(int argc, char** argv) {
    CommandLine cl;
    DefineCommandLine(&cl, argc > 0 ? argv[0] : "");
    if (IsHelpCommand(argc, argv)) return PrintHelp(cl.app, argc, argv);
    // Options every command takes (-t, -q, -v) may come before the command too:
    // `lightmesh --threads 2 render ...` is `lightmesh render --threads 2 ...`.
    std::vector<std::string> args = GlobalOptionsAfterCommand(argc, argv, CommandNamesOf(cl.app));
    std::vector<char*> argvMoved;
    for (std::string& a : args) argvMoved.push_back(a.data());
    argvMoved.push_back(nullptr);
    argv = argvMoved.data();
    if (const std::optional<int> refused = Parse(cl.app, argc, argv)) return *refused;
    if (!MemoryLimitReadable()) return 1;
    if (const std::optional<int> ended = RunUnderLauncher(cl, &argc, &argv)) return *ended;
    return RunCommand(cl);
}
