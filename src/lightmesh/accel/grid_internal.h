// grid_internal.h -- what the nested grid's build (grid_build.cpp) and its queries (grid.cpp)
// share; not part of the grid's interface.
#pragma once

#include <cstdint>

#include "lightmesh/accel/grid.h"

namespace lm::grid_detail {

/// The leaf cells' triangle filters (NestedGridAccel::BlockFilter), 4 and 8 lanes at a time,
/// defined with the queries that call them (grid.cpp); the build picks one for the machine.
uint64_t FilterBlocks4(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray);
/// Without AVX2 (not x86) the 4-lane filter.
uint64_t FilterBlocks8(const NestedGridAccel::TriBlock* blocks, uint32_t count, const detail::PreparedRay& ray);
/// Whether this CPU runs FilterBlocks8's AVX2 code.
bool HasAvx2();

}  // namespace lm::grid_detail
