// rank_report.h -- what one MPI rank did in a distributed render (mpi_render.h), in a
// header that needs no MPI, so the command line prints it in every build.
#pragma once

#include <cstdint>

#include "lightmesh/util/counters.h"

namespace lm {

/// One rank's share of a distributed render (--stats prints one line per rank).
struct RankReport {
    int rank = 0;
    int tiles = 0;
    int batches = 0;
    double seconds = 0;       ///< the rank's render loop, wall clock
    double fetchSeconds = 0;  ///< of which waiting for the counter (MPI_Fetch_and_op)
    RenderCounters counters;
    uint64_t nodesEvaluated = 0;  ///< light-mesh nodes this rank evaluated
};

}  // namespace lm
