// The batch's MPI transport (a part of `rectify whatif`, batch.h): rank 0's
// scheduler thread hands the next ready job (scheduler.h) to whichever
// group of ranks asks, and each group's leader asks, runs it with its group
// (jobs.h) and reports how it ended. Idle ranks wait without spinning a core.
#pragma once

#include <mpi.h>

#include <vector>

#include "whatif/batch.h"
#include "whatif/paths.h"
#include "whatif/scheduler.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  /// Rank 0's scheduler thread, until every one of `n_groups` has been
  /// told that nothing is left.
  void schedule(Scheduler &scheduler, MPI_Comm comm, unsigned n_groups);

  /// A group's loop: its leader asks rank 0 (on `sched`) for a job, the
  /// group (`group_comm`) runs it, until there is none.
  void serve(const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths, MPI_Comm sched,
             MPI_Comm group_comm);
} // namespace rectify::whatif
