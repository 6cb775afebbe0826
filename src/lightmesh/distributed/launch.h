// launch.h -- whether this process was started by an MPI launcher, read from the launcher's
// environment, so a build without MPI can tell the user instead of rendering N copies.
#pragma once

namespace lm {

/// The job's size and this process's rank as mpirun / mpiexec announce them in the
/// environment (OpenMPI: OMPI_COMM_WORLD_*, MPICH's Hydra: PMI_*); 1 and 0 when not
/// launched that way.
int LauncherWorldSize();
/// Whether a launcher started this process (its variables are set, even for one rank).
bool LaunchedByMpi();
int LauncherWorldRank();

}  // namespace lm
