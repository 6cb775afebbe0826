#include "lightmesh/settings/render_settings.h"

#include <cstdarg>
#include <limits>
#include <string>
#include <stdexcept>

namespace lm {

const std::vector<RenderSetting>& RenderSettings() {
    using K = RenderSetting::Kind;
    constexpr double kNoLimit = std::numeric_limits<double>::infinity();
    static const std::vector<RenderSetting> rows = {
        {"width", "--width", K::Int, 1, 16384, {}, "Image width in pixels (default 640, or the scene file's); given alone, the height keeps the aspect ratio",
         nullptr, {}},
        {"height", "--height", K::Int, 1, 16384, {}, "Image height in pixels (default 480, or the scene file's); given alone, the width keeps the aspect ratio",
         nullptr, {}},
        {"aa", "--aa", K::Int, 1, 16, {}, "Anti-aliasing: N x N camera rays per pixel (default 1)", nullptr, {}},
        {"max_depth", "--max-depth", K::Int, 1, 64, {}, "Mirror recursion limit (1: no reflections; default 5)",
         nullptr, {}},
        {"shadows", "--shadows", K::Choice, 0, 0, {"soft", "exact", "none", "rt", "lmm", "area", "denoised"},
         "Shadows: soft (soft shadows of the lights' spheres: one ray per pixel and light, penumbrae "
         "found between neighbouring pixels and sampled), exact (the same, exact per point from the cells' "
         "occluder lists), none, rt (hard: one shadow ray per light), lmm (the paper's light mesh method), "
         "area (soft reference: --samples shadow rays per light) or denoised (area's --samples rays, then a "
         "shadow denoiser); default soft",
         nullptr, {}},
        {"accel", "--accel", K::Choice, 0, 0, {"brute", "grid", "embree"},
         std::string("Ray-query back-end: brute, grid (the paper's nested grid) or embree; default ") +
             kDefaultAccelerator,
         nullptr,
         {}},
        {"grid", "--grid", K::Int, 0, 4096, {},
         "Nested grid: top-level cells along the longest side (default 0: automatic)",
         "accel", {"grid"}},
        {"cc", "--cc", K::Int, 1, 4096, {},
         "Light mesh: cells across the longest side of the scene (the paper's CC; default 100 for lmm, 64 for exact)",
         "shadows", {"lmm", "exact"}},
        {"ki", "--ki", K::Float, 0.01, 16, {}, "Light mesh: interpolation radius in mesh steps, r = kI*h (default 2)",
         "shadows", {"lmm"}},
        {"variant", "--variant", K::String, 0, 0, {},
         "Light mesh variant, as in the paper's tables: grid (Grid), templates (Ш), "
         "reduced (У), none (Нет), inside (СТ), object (ОТ); not in the paper: consensus "
         "(ОТ's image, segments only where nodes disagree; default) and grid-none. "
         "The paper's names are accepted too",
         "shadows",
         {"lmm"}},
        {"ns", "--ns", K::Int, 0, 64, {}, "Light mesh templates: sub-steps per cell side (default 8; 0: the default)",
         "shadows", {"lmm"}},
        {"template_dir", "--template-dir", K::String, 0, 0, {},
         "Folder caching the sphere templates (default: $XDG_CACHE_HOME/lightmesh/templates)", "shadows", {"lmm"}},
        {"cell_summaries", "--cell-summaries", K::Choice, 0, 0, {"auto", "on", "off"},
         "Light mesh: per-cell summaries (exact; ours): auto (for consensus only, where a cell meets about 8 camera "
         "rays or more), on (every cell; also none, inside) or off; default auto",
         "shadows", {"lmm"}},
        {"light_radius", "--light-radius", K::Float, 0, kNoLimit, {},
         "Overrides every light's own radius (scene key \"radius\"; default 2% of its distance to the "
         "scene's centre) with this one (default: no override); 0: point lights. Soft and area shadows use "
         "spheres of it; lmm sizes "
         "its penumbrae by it (contact hardening), which only this option turns on, not the lights' own radii",
         "shadows", {"soft", "exact", "area", "denoised", "lmm"}},
        {"thin_check", "--thin-check", K::Choice, 0, 0, {"off", "lit", "all"},
         "Light mesh with --light-radius: P's own shadow ray checks where the nodes agree, so occluders (lit) "
         "and also gaps (all) thinner than the mesh step keep their effect; off: the nodes decide (default all)",
         "shadows", {"lmm"}},
        {"samples", "--samples", K::Int, 1, 4096, {},
         "Area and denoised shadows: stratified shadow rays per light and shading point (default 16)", "shadows",
         {"area", "denoised"}},
        {"soft_samples", "--soft-samples", K::Int, 4, 256, {},
         "Soft shadows in a penumbra, per light: rays (soft: a multiple of 4, default 16) or directions "
         "(exact: a multiple of 16, a quarter first, the rest only in a penumbra; default 64)",
         "shadows", {"soft", "exact"}},
        {"light_cut", "--light-cut", K::Float, 0, 1, {},
         "Soft shadows of many lights: each point's lights clustered in a hierarchy, a cluster shaded and shadowed as one of its "
         "lights, no cluster's error above this share of the point's total (Lightcuts); 0: every light; default "
         "0.01 where 512 lights or more have no range, else 0",
         "shadows", {"soft"}},
        {"textures", "--no-textures", K::Bool, 0, 0, {},
         "Leave the materials' images out (colour textures and alpha cut-outs): flat colours and solid "
         "surfaces (default: textures on)",
         nullptr, {}},
        {"instancing", "--no-instancing", K::Bool, 0, 0, {},
         "Copy every reference to a mesh file into the scene's triangles instead of placing a file referenced "
         "many times as instances of one import (default: instancing on)",
         nullptr, {}},
        // ---- The image's exposure and tone curve (io/tonemap.h) ----
        {"exposure", "--exposure", K::Float, -32, 32, {},
         "Exposure in stops: the linear radiance times 2^EV, in EXR and PNG alike (default 0)", nullptr, {}},
        {"tonemap", "--tonemap", K::Choice, 0, 0, {"clamp", "reinhard", "aces"},
         "PNG tone curve: clamp (values above 1 are white), reinhard (x/(1+x)) or aces (Narkowicz's filmic "
         "fit); EXR stays linear (default clamp)",
         nullptr, {}},
    };
    return rows;
}

const RenderSetting& RenderSettingFor(std::string_view key) {
    for (const RenderSetting& s : RenderSettings())
        if (key == s.key) return s;
    throw std::logic_error("no render setting \"" + std::string(key) + "\"");
}

std::string UnusedSettingWarning(std::string_view key, std::string_view value) {
    const RenderSetting& s = RenderSettingFor(key);
    if (!s.usedWith) return {};
    std::string users;
    for (size_t i = 0; i < s.usedBy.size(); ++i) {
        if (value == s.usedBy[i]) return {};
        users += (i == 0 ? "" : (i + 1 == s.usedBy.size() ? " and " : ", ")) + s.usedBy[i];
    }
    return std::string(s.flag) + " is not used by " + RenderSettingFor(s.usedWith).flag + " " + std::string(value) +
           " (only by " + users + "); ignored";
}

void ThrowSettingError(const char* key, const char* fmt, ...) {
    va_list args;
    va_start(args, fmt);
    std::string reason = StringVPrintf(fmt, args);
    va_end(args);
    throw SettingError(key, reason);
}

}  // namespace lm
