// cmd_templates.cpp -- `lightmesh templates`.
#include "commands.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "lightmesh/shadow/sphere_templates.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

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

}  // namespace lm::cli
