#include "stokes_solver/block_solver.h"

#include "common/case_file.h"

#include <petscksp.h>

#include <cstdio>
#include <stdexcept>
#include <utility>

namespace rectify::stokes
{
  namespace
  {
    void check_petsc(PetscErrorCode code, const char *what)
    {
      if (code != 0)
        throw std::runtime_error(std::string("PETSc failed in ") + what + " (error " + std::to_string(code) + ")");
    }

    /// Progress of the iterative solver on stderr: every 20 iterations.
    PetscErrorCode report_progress(KSP, PetscInt it, PetscReal norm, void *start_norm)
    {
      auto *r0 = static_cast<double *>(start_norm);
      if (it == 0)
        *r0 = norm;
      else if (it % 20 == 0)
        std::fprintf(stderr, "  FGMRES iteration %d: residual %.2e of the initial\n", static_cast<int>(it),
                     norm / *r0);
      return 0;
    }

    /// The Schur complement preconditioner for thin gaps (the "gap" choice):
    /// S^-1 ~ Jacobi(pressure mass / mu) + AMG(gap Laplacian)^-1. In a gap of
    /// height h the Schur complement of smooth pressures is the lubrication
    /// operator -div(h^2 / (12 mu) grad p) (per unit volume), orders of
    /// magnitude below the mass matrix / mu that holds in wide regions and
    /// for pressures varying on the scale of h; the sum of the two inverses
    /// (as Cahouet and Chabard's for Brinkman flow) holds in both.
    struct GapSchur
    {
      PC  mass = nullptr, laplace = nullptr;
      Mat block = nullptr, mass_block = nullptr;
      Vec work = nullptr;
      ~GapSchur()
      {
        PCDestroy(&mass);
        PCDestroy(&laplace);
        MatDestroy(&block);
        MatDestroy(&mass_block);
        VecDestroy(&work);
      }
    };
    PetscErrorCode apply_gap_schur(PC pc, Vec x, Vec y)
    {
      void          *context = nullptr;
      PetscErrorCode e       = PCShellGetContext(pc, &context);
      if (e != 0)
        return e;
      auto *g = static_cast<GapSchur *>(context);
      if ((e = PCApply(g->mass, x, y)) != 0 || (e = PCApply(g->laplace, x, g->work)) != 0)
        return e;
      return VecAXPY(y, -1.0, g->work); // both parts of the (negative) Schur complement's inverse
    }

    /// PETSc objects released however the solve ends.
    struct Objects
    {
      KSP ksp = nullptr;
      IS  u = nullptr, p = nullptr;
      Mat preconditioner = nullptr; ///< "mass": the system with the mass in its pressure block
      ~Objects()
      {
        KSPDestroy(&ksp);
        ISDestroy(&u);
        ISDestroy(&p);
        MatDestroy(&preconditioner);
      }
    };
    /// The solver's defaults, each unless PETSC_OPTIONS gives it: the
    /// velocity block's one BoomerAMG V-cycle, the Schur split's
    /// preconditioner, the gap Laplacian's AMG.
    void set_default_options()
    {
      const std::vector<std::pair<const char *, const char *>> defaults{
        {"-rectify_fieldsplit_u_ksp_type", "preonly"},
        {"-rectify_fieldsplit_u_pc_type", "hypre"},
        {"-rectify_fieldsplit_u_pc_hypre_type", "boomeramg"},
        // 0.7: the gap's flat cells couple far more strongly across it
        {"-rectify_fieldsplit_u_pc_hypre_boomeramg_strong_threshold", "0.7"},
        // Chebyshev smoothing: half the V-cycle's time of hybrid SOR/Jacobi
        {"-rectify_fieldsplit_u_pc_hypre_boomeramg_relax_type_all", "Chebyshev"},
        // cheap 3D hierarchies: aggressive coarsening, sparse interpolation
        {"-rectify_fieldsplit_u_pc_hypre_boomeramg_coarsen_type", "HMIS"},
        {"-rectify_fieldsplit_u_pc_hypre_boomeramg_interp_type", "ext+i"},
        {"-rectify_fieldsplit_u_pc_hypre_boomeramg_P_max", "4"},
        {"-rectify_fieldsplit_u_pc_hypre_boomeramg_agg_nl", "1"},
        {"-rectify_fieldsplit_p_ksp_type", "preonly"},
        // "gap": replaced after set-up (Jacobi takes 1 for the system's zero
        // pressure block meanwhile); the defaults persist, so they are the
        // same for both choices
        {"-rectify_fieldsplit_p_pc_type", "jacobi"},
        {"-rectify_gap_pc_hypre_boomeramg_strong_threshold", "0.5"},
        {"-rectify_gap_pc_hypre_boomeramg_coarsen_type", "HMIS"},
        {"-rectify_gap_pc_hypre_boomeramg_interp_type", "ext+i"},
        {"-rectify_gap_pc_hypre_boomeramg_P_max", "4"}};
      for (const auto &[key, value] : defaults)
        {
          PetscBool given = PETSC_FALSE; // PETSC_OPTIONS may override each default
          check_petsc(PetscOptionsHasName(nullptr, nullptr, key, &given), "PetscOptionsHasName");
          if (!given)
            check_petsc(PetscOptionsSetValue(nullptr, key, value), "PetscOptionsSetValue");
        }
    }

    /// "gap": the field split exists after set-up; then its Schur solver's
    /// preconditioner becomes the sum of the two inverses (GapSchur).
    void set_up_gap_schur(KSP ksp, PC pc, const Objects &o, Mat pressure_mass, Mat gap_laplace, MPI_Comm comm,
                          GapSchur &gap)
    {
      check_petsc(KSPSetUp(ksp), "KSPSetUp");
      KSP     *sub   = nullptr;
      PetscInt n_sub = 0;
      check_petsc(PCFieldSplitGetSubKSP(pc, &n_sub, &sub), "PCFieldSplitGetSubKSP");
      KSP schur_ksp = sub[1];
      PetscFree(sub);
      check_petsc(MatCreateSubMatrix(gap_laplace, o.p, o.p, MAT_INITIAL_MATRIX, &gap.block), "MatCreateSubMatrix");
      check_petsc(MatCreateSubMatrix(pressure_mass, o.p, o.p, MAT_INITIAL_MATRIX, &gap.mass_block),
                  "MatCreateSubMatrix");
      check_petsc(PCCreate(comm, &gap.mass), "PCCreate");
      check_petsc(PCSetType(gap.mass, PCJACOBI), "PCSetType");
      check_petsc(PCSetOperators(gap.mass, gap.mass_block, gap.mass_block), "PCSetOperators");
      check_petsc(PCSetUp(gap.mass), "PCSetUp (mass)");
      check_petsc(PCCreate(comm, &gap.laplace), "PCCreate");
      check_petsc(PCSetOptionsPrefix(gap.laplace, "rectify_gap_"), "PCSetOptionsPrefix");
      check_petsc(PCSetType(gap.laplace, PCHYPRE), "PCSetType");
      check_petsc(PCHYPRESetType(gap.laplace, "boomeramg"), "PCHYPRESetType");
      check_petsc(PCSetOperators(gap.laplace, gap.block, gap.block), "PCSetOperators");
      check_petsc(PCSetFromOptions(gap.laplace), "PCSetFromOptions");
      check_petsc(PCSetUp(gap.laplace), "PCSetUp (gap Laplacian)");
      check_petsc(MatCreateVecs(gap.block, &gap.work, nullptr), "MatCreateVecs");
      PC schur_pc;
      check_petsc(KSPGetPC(schur_ksp, &schur_pc), "KSPGetPC");
      check_petsc(PCSetType(schur_pc, PCSHELL), "PCSetType (shell)");
      check_petsc(PCShellSetContext(schur_pc, &gap), "PCShellSetContext");
      check_petsc(PCShellSetApply(schur_pc, apply_gap_schur), "PCShellSetApply");
    }
  } // namespace

  std::string block_solver_name(bool gap_schur)
  {
    return gap_schur ? "FGMRES + field-split Schur (BoomerAMG on velocity; Schur: pressure mass + thin-gap Laplacian)"
                     : "FGMRES + field-split Schur (BoomerAMG on velocity, pressure mass on Schur)";
  }

  unsigned solve_block_system(Mat system, Mat pressure_mass, Mat gap_laplace,
                              const std::vector<BlockRhs> &systems,
                              const std::vector<PetscInt> &velocity, const std::vector<PetscInt> &pressure,
                              const BlockSolverSettings &settings)
  {
    MPI_Comm comm;
    check_petsc(PetscObjectGetComm(reinterpret_cast<PetscObject>(system), &comm), "PetscObjectGetComm");
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    Objects o;
    PC      pc;
    check_petsc(KSPCreate(comm, &o.ksp), "KSPCreate");
    check_petsc(KSPSetOptionsPrefix(o.ksp, "rectify_"), "KSPSetOptionsPrefix"); // before the splits: they inherit it
    // "gap": the velocity AMG reads the system's own velocity block, the
    // Schur preconditioner the pressure matrices; "mass": PETSc's Schur
    // split reads the mass from the preconditioner's pressure block.
    if (gap_laplace == nullptr)
      {
        check_petsc(MatDuplicate(system, MAT_COPY_VALUES, &o.preconditioner), "MatDuplicate");
        check_petsc(MatAXPY(o.preconditioner, 1.0, pressure_mass, DIFFERENT_NONZERO_PATTERN), "MatAXPY");
      }
    check_petsc(KSPSetOperators(o.ksp, system, gap_laplace == nullptr ? o.preconditioner : system), "KSPSetOperators");
    check_petsc(KSPSetType(o.ksp, KSPFGMRES), "KSPSetType");
    check_petsc(KSPGMRESSetRestart(o.ksp, 300), "KSPGMRESSetRestart");
    check_petsc(KSPSetTolerances(o.ksp, settings.tolerance, 1e-300, 1e10, static_cast<PetscInt>(settings.max_iterations)),
                "KSPSetTolerances");
    check_petsc(KSPGetPC(o.ksp, &pc), "KSPGetPC");
    check_petsc(PCSetType(pc, PCFIELDSPLIT), "PCSetType");
    check_petsc(ISCreateGeneral(comm, static_cast<PetscInt>(velocity.size()), velocity.data(), PETSC_COPY_VALUES, &o.u),
                "ISCreateGeneral");
    check_petsc(ISCreateGeneral(comm, static_cast<PetscInt>(pressure.size()), pressure.data(), PETSC_COPY_VALUES, &o.p),
                "ISCreateGeneral");
    check_petsc(PCFieldSplitSetIS(pc, "u", o.u), "PCFieldSplitSetIS");
    check_petsc(PCFieldSplitSetIS(pc, "p", o.p), "PCFieldSplitSetIS");
    check_petsc(PCFieldSplitSetType(pc, PC_COMPOSITE_SCHUR), "PCFieldSplitSetType");
    check_petsc(PCFieldSplitSetSchurFactType(pc, PC_FIELDSPLIT_SCHUR_FACT_UPPER), "SchurFactType");
    check_petsc(PCFieldSplitSetSchurPre(pc, PC_FIELDSPLIT_SCHUR_PRE_A11, nullptr), "SchurPre");
    set_default_options();
    check_petsc(KSPSetFromOptions(o.ksp), "KSPSetFromOptions");
    GapSchur gap;
    if (gap_laplace != nullptr)
      set_up_gap_schur(o.ksp, pc, o, pressure_mass, gap_laplace, comm, gap);
    double initial_norm = 1;
    if (settings.verbose && rank == 0)
      check_petsc(KSPMonitorSet(o.ksp, report_progress, &initial_norm, nullptr), "KSPMonitorSet");
    // What the options left (PETSC_OPTIONS may have changed any of them).
    PetscReal rtol, abstol, dtol;
    PetscInt  max_it;
    check_petsc(KSPGetTolerances(o.ksp, &rtol, &abstol, &dtol, &max_it), "KSPGetTolerances");
    unsigned total = 0;
    for (const auto &[rhs, solution, own_tolerance, key] : systems)
      {
        const double tolerance = own_tolerance > 0 ? own_tolerance : rtol;
        check_petsc(KSPSetTolerances(o.ksp, tolerance, abstol, dtol, max_it), "KSPSetTolerances");
        check_petsc(KSPSolve(o.ksp, rhs, solution), "KSPSolve");
        KSPConvergedReason reason;
        PetscInt           its;
        check_petsc(KSPGetConvergedReason(o.ksp, &reason), "KSPGetConvergedReason");
        check_petsc(KSPGetIterationNumber(o.ksp, &its), "KSPGetIterationNumber");
        if (reason < 0)
          throw std::runtime_error("the Stokes solver did not converge: " + block_solver_name(gap_laplace != nullptr) +
                                   ", " + std::to_string(its) + " iterations, PETSc reason " +
                                   std::to_string(reason) + " (" + key + " = " + format_number(tolerance) +
                                   ", [flow] max_iterations = " + std::to_string(max_it) + ")");
        total += static_cast<unsigned>(its);
      }
    return total;
  }
} // namespace rectify::stokes
