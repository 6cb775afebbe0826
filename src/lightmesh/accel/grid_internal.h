// grid_internal.h -- what the nested grid's build (grid_build.cpp) and its queries (grid.cpp)
// share; not part of the grid's interface.
#pragma once

#include <algorithm>
#include <cstdint>

#include "lightmesh/accel/grid.h"

namespace lm::grid_detail {

/// The leaf cells' triangle filters (NestedGridAccel::BlockFilter), 4 and 8 lanes at a time,
/// defined with the queries that call them (grid.cpp); the build picks one for the machine.
uint64_t FilterBlocks4(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                       float* t, uint64_t* ties, float* bary);
/// Without AVX2 (not x86) the 4-lane filter.
uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                       float* t, uint64_t* ties, float* bary);
/// The same writing the hits' barycentrics too (closest-hit queries).
uint64_t FilterBlocks4Bary(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                           float* t, uint64_t* ties, float* bary);
uint64_t FilterBlocks8Bary(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                           float* t, uint64_t* ties, float* bary);
/// The same stopping at the first block that holds a hit (occlusion queries).
uint64_t FilterBlocks4Any(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                          float* t, uint64_t* ties, float* bary);
uint64_t FilterBlocks8Any(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray,
                          float* t, uint64_t* ties, float* bary);
/// Whether this CPU runs FilterBlocks8's AVX2 code.
bool HasAvx2();

/// The empty-space pass along one axis (NestedGridAccel::ComputeEmptyReach): the minimum over
/// 0 <= j < n with |j − i| <= k of max(|j − i|, value(j)), and at most k, for value(j) >= 0.
/// Searched outward from i: a cell at distance d gives at least d, so the search stops once
/// d reaches the best found, which is the whole window's minimum in a few steps near
/// geometry instead of 2k + 1.
template <typename Value>
int WindowMinOfMax(Value&& value, int i, int n, int k) {
    int best = std::min(k, value(i));
    for (int d = 1; d < best; ++d) {
        if (i - d >= 0) best = std::min(best, std::max(d, value(i - d)));
        if (i + d < n) best = std::min(best, std::max(d, value(i + d)));
    }
    return best;
}

}  // namespace lm::grid_detail
