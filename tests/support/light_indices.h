// light_indices.h -- lists of the lights a shading point needs (ShadowMethod::Visibility's
// argument), for the shadow methods' tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

#include "lightmesh/shadow/shadow.h"

namespace lm::testing {

/// Every light of a scene of n lights: 0 .. n - 1.
inline std::vector<uint32_t> AllLights(size_t n) {
    std::vector<uint32_t> ids(n);
    std::iota(ids.begin(), ids.end(), 0u);
    return ids;
}

/// The lights whose flag is set, ascending.
template <typename Flag>
std::vector<uint32_t> FlaggedLights(const Flag* flags, size_t n) {
    std::vector<uint32_t> ids;
    for (size_t i = 0; i < n; ++i)
        if (flags[i]) ids.push_back(static_cast<uint32_t>(i));
    return ids;
}

/// method.Visibility for the flagged lights of flags[0 .. n - 1], their values scattered to
/// vis[light] (the other entries left as they are).
template <typename Flag>
void FlaggedVisibility(const ShadowMethod& method, const ShadingPoint& sp, const Flag* flags, size_t n, float* vis,
                       RenderCounters& counters) {
    const std::vector<uint32_t> ids = FlaggedLights(flags, n);
    std::vector<float> v(ids.size());
    method.Visibility(sp, ids, v.data(), counters);
    for (size_t k = 0; k < ids.size(); ++k) vis[ids[k]] = v[k];
}

/// method.VisibilityMany for `count` points, point i needing the flagged lights of
/// flags[i·n .. i·n + n - 1]; their values scattered to vis[i·n + light].
template <typename Flag>
void FlaggedVisibilityMany(const ShadowMethod& method, const ShadingPoint* sps, size_t count, const Flag* flags,
                           size_t n, float* vis, RenderCounters& counters) {
    std::vector<std::vector<uint32_t>> ids(count);
    std::vector<std::vector<float>> v(count);
    std::vector<LightIndices> lists(count);
    std::vector<float*> out(count);
    for (size_t i = 0; i < count; ++i) {
        ids[i] = FlaggedLights(flags + i * n, n);
        v[i].assign(ids[i].size(), -1.0f);
        lists[i] = ids[i];
        out[i] = v[i].data();
    }
    method.VisibilityMany(sps, lists.data(), out.data(), count, counters);
    for (size_t i = 0; i < count; ++i)
        for (size_t k = 0; k < ids[i].size(); ++k) vis[i * n + ids[i][k]] = v[i][k];
}

}  // namespace lm::testing
