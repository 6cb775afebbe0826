// commands.h -- the commands of the lightmesh executable, one file each (cmd_*.cpp), and
// what they share (common.cpp). main.cpp defines the command line and dispatches.
#pragma once

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lightmesh/bench/benchmark.h"
#include "lightmesh/scene/camera_overrides.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {
class MpiSession;
}

namespace lm::cli {

using Clock = std::chrono::steady_clock;
using lm::SecondsSince;
// "1,234,567": counts are easier to read with thousands separators.
std::string Count(uint64_t n);
// "1 light", "24,614 triangles": a count with its noun, singular or plural (noun + "s").
std::string Counted(uint64_t n, const char* noun);

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
    bool textures = true;  ///< false: --no-textures (SceneLoadOptions::textures)
    bool instancing = true;  ///< false: --no-instancing (SceneLoadOptions::instancing)
    int upAxis = 1;          ///< a bare mesh's up axis: --up x|y|z (SceneLoadOptions::upAxis)
    float frameFovY = 0;     ///< a bare mesh framed for --fov (SceneLoadOptions::frameFovY)
    /// --camera NAME|INDEX: which of a mesh file's own cameras (SceneLoadOptions::camera).
    std::string camera;
    /// --smooth-normals DEG: smooth normals for meshes without (SceneLoadOptions::smoothNormals).
    float smoothNormals = -1.0f;
};
void AddCommonOptions(CLI::App* cmd, CommonOptions* o);
lm::Scene LoadWithWarnings(const CommonOptions& o, int frameWidth = 0, int frameHeight = 0);
void ApplyLogLevel(const CommonOptions& o);

// A number from lo to hi (both included), worded as the scene file's checks word it:
// "--ki: must be between 0.01 and 16, got 20"; `integer`: a whole number ("expected an
// integer, got 1.5"). Floats are compared in single precision, as they are stored.
CLI::Validator InRange(double lo, double hi, bool integer);
// The range of a numeric knob of the settings table, as InRange checks it.
CLI::Validator SettingRange(const char* key);
// A single-precision option's text that reads as a finite float (>= 0 if `nonNegative`):
// the message shows the text as given ("got 1e39", where the float it becomes said "inf").
CLI::Validator FiniteFloat(bool nonNegative);
// A `render` option from the settings table: its flag, help text and range or choices.
template <typename T>
CLI::Option* AddSetting(CLI::App* cmd, const char* key, T* value) {
    const lm::RenderSetting& s = lm::RenderSettingFor(key);
    CLI::Option* option = cmd->add_option(s.flag, *value, s.help);
    using K = lm::RenderSetting::Kind;
    // (A range without an upper end, light_radius's, is checked where the value is used;
    // beyond float it is refused here, as given.)
    if ((s.kind == K::Int || s.kind == K::Float) && std::isfinite(s.hi)) option->check(SettingRange(key));
    if (s.kind == K::Float && !std::isfinite(s.hi)) option->check(FiniteFloat(s.lo >= 0));
    if (s.kind == K::Choice) option->check(CLI::IsMember(s.choices));
    return option;
}

// Levenshtein distance (insertions, deletions, substitutions), for "did you mean".
size_t EditDistance(const std::string& a, const std::string& b);
// The candidate nearest to `word` within edit distance 2 (and less than its length), or "".
std::string Nearest(const std::string& word, const std::vector<std::string>& candidates);
// The message for a command line CLI11 refused with `e`, worded for a new user: a
// mistyped command or option gets "did you mean …?"; "" when CLI11's own is right. Sets
// *printHelp (and returns "") for `lightmesh help [COMMAND]`.
std::string CommandLineMistake(const CLI::App& app, const CLI::ParseError& e, int argc, char** argv,
                               const CLI::App** printHelp);

/// The names of `app`'s commands.
std::vector<std::string> CommandNamesOf(const CLI::App& app);
/// argv as strings, with the options every command takes (-t/--threads N, -q/--quiet,
/// -v/--verbose) given before the command moved after it: `lightmesh -t 2 render x` is
/// `lightmesh render -t 2 x`. Unchanged when what follows them is not a command.
std::vector<std::string> GlobalOptionsAfterCommand(int argc, char** argv, const std::vector<std::string>& commands);

void PrintFigures(const char* title, const std::vector<std::pair<std::string, std::string>>& figures);

/// `lightmesh render`: options as given on the command line; unset ones keep the scene's.
struct RenderCommand {
    CommonOptions common;
    std::string output;
    std::string visibility;  ///< --visibility FILE.exr: the per-light visibility too ("": none)
    std::optional<int> width, height, aa, maxDepth, grid, cc, ns;
    std::optional<float> ki, lightRadius;
    std::optional<int> samples;
    std::optional<int> softSamples;
    std::optional<float> lightCut;
    std::optional<std::string> shadows, accel, variant, templateDir, cellSummaries, thinCheck;
    bool stats = false;
    bool noTextures = false;
    bool noInstancing = false;
    bool force = false;  ///< render one estimated past an hour
    // ---- The camera from the command line (render_view.cpp): each as given, parsed when
    // the render is prepared, so a mistake is one line naming the option.
    std::optional<std::string> cameraPosition, lookAt, up, fov;
    // ---- The image's exposure and tone curve (settings table rows).
    std::optional<float> exposure;
    std::optional<std::string> tonemap;
    // ---- --save-scene: the scene as rendered, as a scene file (scene/scene_writer.h).
    std::string saveScene;
};
// ---- render_view.cpp: the camera options, --save-scene, and --width/--height alone.
/// Adds --camera-position, --look-at, --up, --fov and --save-scene to `render`.
void AddViewOptions(CLI::App* cmd, RenderCommand* render);
/// The camera options parsed; a letter --up for a bare mesh file becomes load->upAxis (the
/// model is turned, not the camera) and --fov also load->frameFovY. Throws Error naming
/// the option.
lm::CameraOverrides CameraFromCommand(const RenderCommand& cmd, CommonOptions* load);
/// --width alone (or --height alone): the other side from the scene's aspect ratio
/// (`sceneOptions`, the file's or the defaults), written to *options with the flag as its
/// origin. Throws Error when it falls outside 1..16384.
void KeepAspectRatio(const RenderCommand& cmd, const lm::RenderOptions& sceneOptions, lm::RenderOptions* options);
int RunRender(const RenderCommand& cmd);
/// `mpirun -np N lightmesh render …` (built with MPI only).
int RunRenderMpi(const RenderCommand& cmd, const lm::MpiSession& session);

/// `lightmesh info`: the scene's figures, and a back-end's with --accel.
int RunInfo(const CommonOptions& common, const std::string& accelName, int grid);
/// `lightmesh templates`: builds (or loads) a sphere template; --measure studies ns.
int RunTemplates(int ns, float ki, const std::string& dir, bool measure);

/// `lightmesh bench`: the matrix, a progress line per cell, then the tables.
struct BenchCommand {
    lm::BenchMatrix matrix;
    std::vector<std::string> sizes;
    std::string csv, markdown, html, matrixFile, json;
    int table = 0;
    bool quick = false;
    bool quiet = false;
    bool verbose = false;
    bool noNone = false;
    bool force = false;  ///< run a matrix estimated above kBenchLimitSeconds
    CLI::Option* repeatOption = nullptr;
    CLI::Option* accelsOption = nullptr;
    CLI::Option* variantsOption = nullptr;
    CLI::Option* ccOption = nullptr;
    CLI::Option* kiOption = nullptr;
    std::string argv0;
};
int RunBench(BenchCommand& cmd);

/// `lightmesh compare A B`: image quality of B against A (lightmesh/io/compare.h).
struct CompareCommand {
    std::string a, b, mask, diff;
    std::string none;  ///< --no-shadows: the render without shadows, for the shadow totals
    float diffScale = 0;
    bool diffScaleGiven = false;
    bool json = false;
    std::optional<double> thresholdPsnr;
};
/// Exit codes: 0 compared (and PSNR >= --threshold-psnr), 1 error, 3 below the threshold.
int RunCompare(const CompareCommand& cmd);

}  // namespace lm::cli
