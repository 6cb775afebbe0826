// report_internal.h -- what the bench's tables (tables.cpp) and its HTML report
// (html_report.cpp) share; not part of the bench's interface.
#pragma once

#include <vector>

#include "lightmesh/bench/benchmark.h"
#include "lightmesh/io/image.h"

namespace lm {

/// Rec. 709 luma of a linear colour: the leak count's and the crop window's measure.
inline float Luma(const Color& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

/// The first result of each (scene, image size), in the order they were run: the tables'
/// and the report's sections.
std::vector<const BenchResult*> SceneSizeGroups(const std::vector<BenchResult>& rs);

/// The competitors table's light radii in words: "the lights' own radii 0.173, 0.164" (the
/// range past 6 lights), or "every light of radius R (--light-radius)".
std::string RadiiText(const BenchCompetitors& c);

}  // namespace lm
