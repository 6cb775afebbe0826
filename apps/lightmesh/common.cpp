// common.cpp -- what the commands share: scene loading, options, figures.
#include "commands.h"

#include <cmath>
#include <cstdlib>
#include <limits>

#include "lightmesh/scene/scene_file.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

// "1,234,567": counts are easier to read with thousands separators.
std::string Count(uint64_t n) { return lm::FormatCount(n); }

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

lm::Scene LoadWithWarnings(const CommonOptions& o, int frameWidth, int frameHeight) {
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

// The range of a numeric knob of the settings table, as CLI11 checks it.
CLI::Range SettingRange(const char* key) {
    const lm::RenderSetting& s = lm::RenderSettingFor(key);
    if (s.kind == lm::RenderSetting::Kind::Int) return CLI::Range(static_cast<int>(s.lo), static_cast<int>(s.hi));
    return CLI::Range(static_cast<float>(s.lo), static_cast<float>(s.hi));
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

void PrintFigures(const char* title, const std::vector<std::pair<std::string, std::string>>& figures) {
    if (figures.empty()) return;
    std::printf("%-10s", title);
    for (size_t i = 0; i < figures.size(); ++i)
        std::printf("%s%s %s", i ? ", " : "", figures[i].first.c_str(), figures[i].second.c_str());
    std::printf("\n");
}

}  // namespace lm::cli
