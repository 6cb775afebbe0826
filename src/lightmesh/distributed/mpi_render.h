// mpi_render.h -- one frame's tiles spread over the ranks of an MPI job (OpenMPI), the
// image gathered on rank 0. Built only when CMake finds MPI (LIGHTMESH_HAS_MPI).
//
// Image-parallel with replicated data, like OSPRay's MPI "distributed" mode: every rank
// loads the scene and builds its own back-end and light mesh; tiles are handed out in
// batches from a counter on rank 0 that the ranks advance with one-sided MPI
// (MPI_Fetch_and_op), so a rank that finishes early takes more. A light-mesh node's value
// depends on the node only (paper §2-3, and our lock-free publication), so a rank that
// evaluates a node another rank also evaluated gets the same bits, and every pixel is
// computed exactly as in one process: the image is byte-identical for any number of ranks
// and threads. The price of the replication is those nodes evaluated twice; --stats counts
// them per rank.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "lightmesh/distributed/rank_report.h"
#include "lightmesh/render/band_renderer.h"
#include "lightmesh/render/whitted.h"

namespace lm {

/// The MPI job this process belongs to: MPI_Init_thread (funneled: only the main thread
/// calls MPI) in the constructor, MPI_Finalize in the destructor.
class MpiSession {
  public:
    MpiSession(int* argc, char*** argv);
    ~MpiSession();
    MpiSession(const MpiSession&) = delete;
    MpiSession& operator=(const MpiSession&) = delete;
    int Rank() const { return rank_; }
    int Size() const { return size_; }

    /// Collective: each rank says whether its step failed (a non-empty message). Returns
    /// true when every rank succeeded; otherwise *failedRank is the lowest rank that failed
    /// and, on rank 0, *message is its message.
    bool AllSucceeded(const std::string& myError, std::string* message, int* failedRank) const;

    /// Collective: the threads this rank should use when --threads is not given: the CPUs
    /// it may run on (its affinity mask) shared among the ranks of this machine whose masks
    /// overlap it (at least 1). mpirun's default binding gives each of up to two ranks its
    /// own core (1 thread each); with --bind-to none, N ranks on C cores get C / N each.
    int DefaultThreads() const;

  private:
    int rank_ = 0, size_ = 1;
};

struct DistributedRender {
    RenderResult result;            ///< on rank 0: the whole image, every rank's counters summed
    std::vector<RankReport> ranks;  ///< on rank 0: one per rank
    std::string error;              ///< on rank 0: the message of a rank that failed while rendering
    int errorRank = -1;             ///< that rank (-1: none failed)
};

/// Collective: renders renderer's image over all ranks of the session and gathers it on
/// rank 0. `nodesEvaluated` reads the rank's light-mesh node count (empty: no light mesh).
/// A rank that throws while rendering stops taking tiles and reports its message; the
/// others finish, and rank 0 gets the error instead of an image. `progress` (rank 0's)
/// follows the tiles handed out to all ranks.
DistributedRender RenderDistributed(const MpiSession& session, const WhittedRenderer& renderer,
                                    const std::function<uint64_t()>& nodesEvaluated,
                                    ProgressReporter* progress);

/// Collective: RenderDistributed for the renderers whose pixels read their neighbours'
/// (BandRenderer: the soft default, "--shadows denoised"): rank r renders an even share of
/// the image's rows of tiles, one band, with the apron of rows it reads above and below it
/// (BandRenderer::RenderRows; the aprons are rendered twice, by both neighbours), and rank
/// 0 gathers the bands. The image is one process's, byte for byte.
DistributedRender RenderDistributedBands(const MpiSession& session, const WhittedRenderer& renderer,
                                         const BandRenderer& bands, ProgressReporter* progress);

}  // namespace lm
