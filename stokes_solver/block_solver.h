// The iterative solver for the (scaled) Stokes saddle-point system, in PETSc
// alone: FGMRES with PETSc's field split (upper block-triangular Schur
// factorisation), one hypre BoomerAMG V-cycle on the velocity block, and on
// the Schur complement either the pressure mass matrix / mu ("mass") or the
// sum of its inverse and a thin-gap Laplacian's ("gap"). Every default can be
// overridden through PETSC_OPTIONS with the prefix -rectify_ (velocity split
// fieldsplit_u_, Schur split fieldsplit_p_, gap Laplacian's AMG gap_).
#pragma once

#include <petscmat.h>
#include <petscvec.h>

#include <string>
#include <utility>
#include <vector>

namespace rectify::stokes
{
  struct BlockSolverSettings
  {
    double tolerance      = 1e-11; ///< relative residual
    long   max_iterations = 2000;
    bool   verbose        = false; ///< progress every 20 iterations on stderr (rank 0)
  };

  /// One right-hand side, its solution and the relative residual it needs:
  /// 0 for the solver's own (settings.tolerance, or PETSC_OPTIONS's
  /// -rectify_ksp_rtol), with the case key that sets it for messages.
  struct BlockRhs
  {
    Vec         rhs, solution;
    double      tolerance = 0;
    const char *tolerance_key = "[flow] tolerance";
  };

  /// Solves system x = rhs for each of `systems`, with one preconditioner
  /// set-up. `pressure_mass` is the (negative) scaled pressure mass matrix
  /// and `gap_laplace`, if not null, the (positive) scaled thin-gap
  /// Laplacian, each in the pressure block of a matrix of the system's size
  /// (the pressure rows alone, or a subset of the system's pattern). `velocity` and
  /// `pressure` are this process's DoF indices of each field. Returns the
  /// number of iterations, summed; throws std::runtime_error naming the solver, the
  /// iterations and PETSc's reason if it does not converge.
  unsigned solve_block_system(Mat system, Mat pressure_mass, Mat gap_laplace,
                              const std::vector<BlockRhs> &systems,
                              const std::vector<PetscInt> &velocity, const std::vector<PetscInt> &pressure,
                              const BlockSolverSettings &settings);

  /// The solver's one-line description for outputs.
  std::string block_solver_name(bool gap_schur);
} // namespace rectify::stokes
