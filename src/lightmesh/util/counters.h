// counters.h -- what a render did, counted per thread and summed at the end.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace lm {

/// Slots in RenderCounters::method.
inline constexpr size_t kMethodCounterSlots = 16;

/// Work counters. Each render task owns one and they are added up once the image is done,
/// so counting costs no synchronisation on the hot path and the sums do not depend on
/// the thread count.
///
/// The renderer's own counts are named fields. `method` is the shadow method's: what each
/// slot counts belongs to the method that fills it (it names its slots with an enum next
/// to its code and formats them for --stats itself); everything here only adds them up.
/// Only uint64_t members, without padding: the distributed render sends it as a run of
/// uint64_t words.
struct RenderCounters {
    uint64_t cameraRays = 0;      ///< primary rays (aa² per pixel)
    uint64_t reflectionRays = 0;  ///< mirror rays
    uint64_t shadowRays = 0;      ///< shadow rays from shading points, by any shadow method
    uint64_t shadingPoints = 0;   ///< hits that were shaded
    uint64_t cutEntries = 0;      ///< entries of the light cuts made (render/light_cut.h)
    uint64_t cutLargest = 0;      ///< the largest cut (a maximum, not a sum)
    std::array<uint64_t, kMethodCounterSlots> method{};  ///< the shadow method's own counts

    RenderCounters& operator+=(const RenderCounters& o) {
        cameraRays += o.cameraRays;
        reflectionRays += o.reflectionRays;
        shadowRays += o.shadowRays;
        shadingPoints += o.shadingPoints;
        cutEntries += o.cutEntries;
        cutLargest = cutLargest > o.cutLargest ? cutLargest : o.cutLargest;
        for (size_t i = 0; i < kMethodCounterSlots; ++i) method[i] += o.method[i];
        return *this;
    }
};

static_assert(sizeof(RenderCounters) == (6 + kMethodCounterSlots) * sizeof(uint64_t),
              "RenderCounters must be uint64_t words only");

}  // namespace lm
