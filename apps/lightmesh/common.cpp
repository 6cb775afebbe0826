// common.cpp -- what the commands share: scene loading, options, figures.
#include "commands.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "lightmesh/scene/json_reader.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

// "1,234,567": counts are easier to read with thousands separators.
std::string Count(uint64_t n) { return lm::FormatCount(n); }
std::string Counted(uint64_t n, const char* noun) { return Count(n) + " " + noun + (n == 1 ? "" : "s"); }

void AddCommonOptions(CLI::App* cmd, CommonOptions* o) {
    cmd->add_option("scene", o->scene,
                    "Scene: a .json scene file, a mesh file (.obj, .gltf, .ply, .dae, ...), or "
                    "builtin:gazebo")
        ->required();
    cmd->add_flag("--strict", o->strict, "Unknown keys in the scene file are errors, not warnings");
    // render's result is its image: -q leaves the summary line out too (--stats keeps it and
    // the figures); info's result is its figures, which stay.
    cmd->add_flag("-q,--quiet", o->quiet,
                  cmd->get_name() == "render"
                      ? "Print errors only: no progress bar, warnings, notes or summary line (with --stats: the "
                        "summary line and the figures, on stdout)"
                      : "Print the figures and errors only: no warnings or notes");
    cmd->add_flag("-v,--verbose", o->verbose, "Print more about what is done");
    cmd->add_option("-t,--threads", o->threads, "Worker threads (default: all cores)")
        ->check(InRange(1, 1024, true));
    // A mesh file's own cameras (glTF, COLLADA, FBX, .blend): the first frames it by default.
    cmd->add_option("--camera", o->camera,
                    "Which of the mesh file's own cameras to render from: its name or its index from 0 (default: "
                    "the first; a file without cameras is framed automatically)");
    cmd->add_option("--smooth-normals", o->smoothNormals,
                    "Give the meshes of mesh files that have no normals smooth ones, keeping edges sharper than DEG "
                    "degrees as creases (0 to 180; 0: flat faces; default: 60 for a bare mesh file, a scene file's "
                    "\"smooth_normals\" per mesh, else flat)")
        ->check(CLI::Validator(
            [](std::string& text) -> std::string {
                char* end = nullptr;
                const double v = std::strtod(text.c_str(), &end);
                if (end == text.c_str() || *end != 0) return "expected a number, got " + text;
                return lm::SmoothNormalsProblem(v, text);
            },
            "FLOAT in [0 - 180]"));
}

lm::Scene LoadWithWarnings(const CommonOptions& o, int frameWidth, int frameHeight) {
    lm::SceneLoadOptions load;
    load.strict = o.strict;
    load.textures = o.textures;
    load.instancing = o.instancing;
    load.upAxis = o.upAxis;
    load.frameFovY = o.frameFovY;
    load.camera = o.camera;
    load.smoothNormals = o.smoothNormals;
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

CLI::Validator InRange(double lo, double hi, bool integer) {
    const std::string range = std::isfinite(hi) ? lm::StringPrintf("between %g and %g", lo, hi)
                                                : lm::StringPrintf(">= %g", lo);
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            const bool number = end != text.c_str() && *end == 0 && !std::isnan(v);
            if (!number) return std::string(integer ? "expected an integer" : "expected a number") + ", got " + text;
            if (integer && v != std::floor(v)) return "expected an integer, got " + text;
            // In float for a float, as it is stored and compared (0.01 is 0.0099999998f).
            const bool inside = integer ? (v >= lo && v <= hi)
                                        : (static_cast<float>(v) >= static_cast<float>(lo) &&
                                           (!std::isfinite(hi) || static_cast<float>(v) <= static_cast<float>(hi)));
            if (!inside) return "must be " + range + ", got " + text;
            return "";
        },
        std::string(integer ? "INT" : "FLOAT") +
            (std::isfinite(hi) ? lm::StringPrintf(" in [%g - %g]", lo, hi) : lm::StringPrintf(" >= %g", lo)));
}

// The range of a numeric knob of the settings table, as InRange checks it.
CLI::Validator SettingRange(const char* key) {
    const lm::RenderSetting& s = lm::RenderSettingFor(key);
    return InRange(s.lo, s.hi, s.kind == lm::RenderSetting::Kind::Int);
}

CLI::Validator FiniteFloat(bool nonNegative) {
    return CLI::Validator(
        [nonNegative](std::string& text) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            const bool number = end != text.c_str() && *end == 0;
            if (!number || !std::isfinite(v) || std::abs(v) > std::numeric_limits<float>::max() ||
                (nonNegative && !(v >= 0)))
                return std::string("must be a finite number") + (nonNegative ? " >= 0" : "") +
                       " within single precision (3.4e38), got " + text;
            return "";
        },
        nonNegative ? "FLOAT >= 0" : "FLOAT");
}

size_t EditDistance(const std::string& a, const std::string& b) { return json::EditDistance(a, b); }

std::string Nearest(const std::string& word, const std::vector<std::string>& candidates) {
    return json::Nearest(word, candidates);
}

namespace {

// How many of args[from...] are options every command takes (-t N, -q, -v), from the start.
size_t LeadingGlobalOptions(const std::vector<std::string>& args, size_t from) {
    size_t i = from;
    while (i < args.size()) {
        const std::string& a = args[i];
        if (a == "-q" || a == "--quiet" || a == "-v" || a == "--verbose" || a.rfind("--threads=", 0) == 0 ||
            (a.rfind("-t", 0) == 0 && a.size() > 2 && a[2] != '-'))
            ++i;
        else if ((a == "-t" || a == "--threads") && i + 1 < args.size())
            i += 2;
        else
            break;
    }
    return i - from;
}


// The names of a command's options as typed: "--shadows", "-q".
std::vector<std::string> OptionNames(const CLI::App& cmd) {
    std::vector<std::string> names;
    for (const CLI::Option* o : cmd.get_options()) {
        for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
        for (const std::string& s : o->get_snames()) names.push_back("-" + s);
    }
    return names;
}

std::vector<std::string> CommandNames(const CLI::App& app) {
    std::vector<std::string> names;
    for (const auto* sub : app.get_subcommands([](const CLI::App*) { return true; }))
        names.push_back(sub->get_name());
    return names;
}

std::string JoinOr(const std::vector<std::string>& words) {
    std::string s;
    for (size_t i = 0; i < words.size(); ++i)
        s += (i == 0 ? "" : (i + 1 == words.size() ? " or " : ", ")) + words[i];
    return s;
}

}  // namespace

std::string CommandLineMistake(const CLI::App& app, const CLI::ParseError& e, int argc, char** argv,
                               const CLI::App** printHelp) {
    *printHelp = nullptr;
    const std::vector<std::string> commands = CommandNames(app);
    const auto parsed = app.get_subcommands();
    // No command: `lightmesh`, `lightmesh rendr x`, `lightmesh help [render]`.
    if (parsed.empty() && dynamic_cast<const CLI::RequiredError*>(&e)) {
        std::vector<std::string> words(argv, argv + argc);
        // (-t, -q and -v before the command are not the mistake.)
        words.erase(words.begin(), words.begin() + 1 + static_cast<std::ptrdiff_t>(LeadingGlobalOptions(words, 1)));
        if (words.empty()) return "a command is required: " + JoinOr(commands);
        const std::string& first = words.front();
        if (first == "help") {
            *printHelp = &app;
            if (words.size() > 1)
                for (const auto* sub : app.get_subcommands([](const CLI::App*) { return true; }))
                    if (sub->get_name() == words[1]) *printHelp = sub;
            return "";
        }
        if (!first.empty() && first[0] == '-')
            return lm::Printable(first) + ": not an option of lightmesh; a command's options go after it (" +
                   "lightmesh render SCENE --shadows rt, ...); only -t, -q and -v may also come before it";
        const std::string near = Nearest(first, commands);
        return "unknown command \"" + lm::Printable(first) + "\"" +
               (near.empty() ? " (the commands: " + JoinOr(commands) + ")" : "; did you mean " + near + "?");
    }
    if (!dynamic_cast<const CLI::ExtrasError*>(&e)) return "";
    // Unexpected arguments, in the order given: an unknown option gets the nearest of its
    // command's options.
    const CLI::App& cmd = parsed.empty() ? app : *parsed.front();
    std::vector<std::string> extras = app.remaining(true);
    std::vector<std::string> given;
    for (int i = 1; i < argc; ++i)
        if (std::find(extras.begin(), extras.end(), argv[i]) != extras.end()) given.push_back(argv[i]);
    if (given.empty()) return "";
    const std::string where = parsed.empty() ? "lightmesh" : "`" + cmd.get_name() + "`";
    // An option before the command that is not one of those every command takes.
    int commandAt = argc;
    for (int i = 1; i < argc && !parsed.empty(); ++i)
        if (argv[i] == cmd.get_name()) {
            commandAt = i;
            break;
        }
    for (int i = 1; i < commandAt; ++i) {
        const std::string arg = argv[i];
        if (arg.size() > 1 && arg[0] == '-' && std::find(extras.begin(), extras.end(), arg) != extras.end())
            return lm::Printable(arg.substr(0, arg.find('='))) + ": not an option of lightmesh; a command's options go "
                   "after it (lightmesh render SCENE --shadows rt, ...); only -t, -q and -v may also come before it";
    }
    for (const std::string& arg : given) {
        if (arg.size() < 2 || arg[0] != '-') continue;
        const std::string name = arg.substr(0, arg.find('='));
        const std::string near = Nearest(name, OptionNames(cmd));
        return lm::Printable(name) + ": not an option of " + where +
               (near.empty() ? "" : "; did you mean " + near + "?");
    }
    std::string list;
    for (const std::string& arg : given) list += (list.empty() ? "" : " ") + lm::Printable(arg);
    return (given.size() == 1 ? "unexpected argument for " : "unexpected arguments for ") + where + ": " + list;
}

std::vector<std::string> CommandNamesOf(const CLI::App& app) { return CommandNames(app); }


std::vector<std::string> GlobalOptionsAfterCommand(int argc, char** argv, const std::vector<std::string>& commands) {
    std::vector<std::string> args(argv, argv + argc);
    const size_t i = 1 + LeadingGlobalOptions(args, 1);
    const std::vector<std::string> moved(args.begin() + 1, args.begin() + static_cast<std::ptrdiff_t>(i));
    if (moved.empty() || i >= args.size() || std::find(commands.begin(), commands.end(), args[i]) == commands.end())
        return args;
    std::vector<std::string> out = {args[0], args[i]};
    out.insert(out.end(), moved.begin(), moved.end());
    out.insert(out.end(), args.begin() + static_cast<std::ptrdiff_t>(i) + 1, args.end());
    return out;
}

void PrintFigures(const char* title, const std::vector<std::pair<std::string, std::string>>& figures) {
    if (figures.empty()) return;
    std::printf("%-10s", title);
    for (size_t i = 0; i < figures.size(); ++i)
        std::printf("%s%s %s", i ? ", " : "", figures[i].first.c_str(), figures[i].second.c_str());
    std::printf("\n");
}

}  // namespace lm::cli
