// sphere_templates_check.cpp -- what a template file read from disk must satisfy beyond its
// checksum (a forged cache with a recomputed checksum would otherwise change the image). Kept
// apart from sphere_templates.cpp, which only calls it.
#include <algorithm>
#include <cmath>
#include <string>

#include "lightmesh/shadow/sphere_templates.h"
#include "lightmesh/util/error.h"

namespace lm {

/// Throws Error unless `t` is exactly what SphereTemplates::Build(t.ns, t.ki) makes, checked
/// invariant by invariant rather than by building: for every sub-position, every offset
/// within the interpolation sphere, the boundary run holding exactly the shell nodes and the
/// inner run the others, each run strictly sorted (no duplicates), and the count equal to
/// the number of lattice nodes in the sphere (so none is missing). Assumes the index checks
/// of ParseSphereTemplates passed (begin, boundaryCount consistent; offsets within reach).
void CheckSphereTemplateGeometry(const SphereTemplates& t, const std::string& path) {
    const int ns = t.ns;
    const double limit2 = static_cast<double>(t.ki) * ns * static_cast<double>(t.ki) * ns;
    const int reach = static_cast<int>(std::ceil(t.ki)) + 1;
    auto inside = [&](int a, int b, int c, int di, int dj, int dk) {
        const double x = di * ns - a, y = dj * ns - b, z = dk * ns - c;
        return x * x + y * y + z * z <= limit2;
    };
    const int side = 2 * reach + 3;
    auto key = [&](const std::array<int8_t, 3>& o) {
        return ((o[2] + reach + 1) * side + (o[1] + reach + 1)) * side + (o[0] + reach + 1);
    };
    for (int c = 0; c <= ns; ++c) {
        for (int b = 0; b <= ns; ++b) {
            for (int a = 0; a <= ns; ++a) {
                const int s = t.SubPosition(a, b, c);
                const uint32_t first = t.begin[s], last = t.begin[s + 1];
                const uint32_t boundaryEnd = first + t.boundaryCount[s];
                int previous = -1;
                for (uint32_t e = first; e < last; ++e) {
                    const auto& o = t.offsets[e];
                    if (e == boundaryEnd) previous = -1;  // the inner run starts over
                    if (!inside(a, b, c, o[0], o[1], o[2]))
                        ThrowErrorAt({path}, "an offset lies outside the interpolation sphere (corrupt)");
                    const bool shell = !inside(a, b, c, o[0] - 1, o[1], o[2]) ||
                                       !inside(a, b, c, o[0] + 1, o[1], o[2]) ||
                                       !inside(a, b, c, o[0], o[1] - 1, o[2]) ||
                                       !inside(a, b, c, o[0], o[1] + 1, o[2]) ||
                                       !inside(a, b, c, o[0], o[1], o[2] - 1) ||
                                       !inside(a, b, c, o[0], o[1], o[2] + 1);
                    if (shell != (e < boundaryEnd))
                        ThrowErrorAt({path}, "the boundary nodes are not the sphere's shell (corrupt)");
                    const int k = key(o);
                    if (k <= previous)
                        ThrowErrorAt({path}, "offsets out of order or repeated (corrupt)");
                    previous = k;
                }
                // The nodes in the sphere, row by row: along di the inside ones are one run
                // around a/ns, found from the square root and settled by the exact test.
                uint32_t count = 0;
                for (int dk = -reach; dk <= reach; ++dk) {
                    for (int dj = -reach; dj <= reach; ++dj) {
                        const double y = dj * ns - b, z = dk * ns - c;
                        const double rest = limit2 - y * y - z * z;
                        if (rest < 0) continue;
                        const double r = std::sqrt(rest);
                        int lo = std::max(-reach, static_cast<int>(std::ceil((a - r) / ns)));
                        int hi = std::min(reach, static_cast<int>(std::floor((a + r) / ns)));
                        while (lo > -reach && inside(a, b, c, lo - 1, dj, dk)) --lo;
                        while (lo <= hi && !inside(a, b, c, lo, dj, dk)) ++lo;
                        while (hi < reach && inside(a, b, c, hi + 1, dj, dk)) ++hi;
                        while (hi >= lo && !inside(a, b, c, hi, dj, dk)) --hi;
                        if (hi >= lo) count += static_cast<uint32_t>(hi - lo + 1);
                    }
                }
                if (count != last - first)
                    ThrowErrorAt({path}, "%u nodes for a sub-position whose sphere holds %u (corrupt)", last - first, count);
            }
        }
    }
}

}  // namespace lm
