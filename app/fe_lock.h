// The output folder's lock for the MPI commands (stokes, map-resistance,
// design): the first process takes it for all of them, and every process
// learns whether it got it, so that a refused run stops everywhere instead
// of leaving the others waiting in a collective call.
#pragma once

#include <filesystem>
#include <string>

#include "common/case_file.h"
#include "common/output_lock.h"
#include "stokes_solver/stokes.h"

namespace rectify::app
{
  /// On the root process: lock.acquire(dir), or lock.acquire_if_exists(dir)
  /// if !create. Every process throws InputError if the root could not.
  inline void lock_on_root(OutputLock &lock, const std::filesystem::path &dir, const stokes::MpiSession &mpi,
                           bool create)
  {
    std::string error;
    if (mpi.rank() == 0)
      try
        {
          if (create)
            lock.acquire(dir);
          else
            lock.acquire_if_exists(dir);
        }
      catch (const InputError &e)
        {
          error = e.what();
        }
    if (mpi.broadcast({error.empty() ? 1.0 : 0.0})[0] == 0.0)
      throw InputError(mpi.rank() == 0 ? error :
                                         "output folder '" + dir.string() +
                                           "' could not be locked (the first process says why)");
  }
} // namespace rectify::app
