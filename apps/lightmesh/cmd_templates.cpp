// cmd_templates.cpp -- `lightmesh templates`.
#include "commands.h"

#include "lightmesh/shadow/sphere_templates.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

/// `lightmesh templates`: build (or load) and cache sphere templates; with --measure, the
/// error of snapping P to a sub-position for several ns, which is how the default was chosen.
int RunTemplates(int ns, float ki, const std::string& dir, bool measure) {
    if (ns == 0) ns = lm::kDefaultTemplateSubsteps;  // as `render --ns 0`
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
    std::printf("\n%4s %12s %14s %12s %12s\n", "ns", "entries", "mismatch/P", "mismatch %", "build ms");
    for (int n : {1, 2, 4, 8, 16, 32}) {
        const lm::TemplateSnapError e = lm::MeasureTemplateSnapping(n, ki);
        std::printf("%4d %12s %14.3f %11.2f%% %12.2f\n", n, Count(e.entries).c_str(), e.mismatchedPerPoint,
                    100.0 * e.mismatchedShare, e.buildSeconds * 1e3);
    }
    return 0;
}

}  // namespace lm::cli
