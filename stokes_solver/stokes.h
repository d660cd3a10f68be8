// Stokes flow of the oil through a tetrahedral mesh with boundary ids inlet 1,
// outlet 2, walls 3, reed 4 (mesher/): Taylor-Hood P2-P1 on tetrahedra,
// deal.II 9.4 with PETSc, in parallel with MPI.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "mesher/tet_mesh.h"
#include "stokes_solver/parameters.h"

namespace rectify::stokes
{
  /// Starts MPI and PETSc (deal.II's MPI_InitFinalize) for as long as it
  /// lives; works without mpirun (one process).
  class MpiSession
  {
  public:
    MpiSession();
    ~MpiSession();
    unsigned rank() const;
    unsigned size() const;
    /// Every process gets the root's `values`.
    std::vector<double> broadcast(std::vector<double> values) const;

  private:
    struct Impl;
    Impl *impl_;
  };

  struct StokesResult
  {
    double R_pressure_Pa_s_per_m3    = 0; ///< (mean p on inlet - mean p on outlet) / Q
    double R_dissipation_Pa_s_per_m3 = 0; ///< integral of 2 mu e(u):e(u) / Q^2
    /// Integral of mu grad u : grad u / Q^2: the dissipation the Laplacian
    /// weak form balances exactly (equal to the above for a divergence-free
    /// flow with no slip, apart from terms on inlet and outlet; the discrete
    /// flow is divergence-free only weakly).
    double R_gradient_dissipation_Pa_s_per_m3 = 0;
    double inlet_pressure_Pa = 0, outlet_pressure_Pa = 0; ///< area means
    double inlet_flux_m3_per_s = 0, outlet_flux_m3_per_s = 0;
    double mass_balance_rel_error = 0; ///< |Q_out - Q_in| / Q
    std::array<double, 3> reed_force_N{}; ///< fluid on reed, pressure relative to the outlet's + viscous
    double A_eff_m2 = 0;                  ///< reed_force_N[2] / (p_in - p_out)
    /// Net outflow of kinetic energy, integral of rho |u|^2 / 2 u.n over inlet
    /// and outlet: to first order in Re, inertia adds this / Q^2 to R
    /// (the viscous dissipation is stationary at the Stokes flow).
    double kinetic_energy_flux_W = 0;
    double inlet_area_m2 = 0, outlet_area_m2 = 0;
    std::size_t n_dofs = 0, n_velocity_dofs = 0, n_pressure_dofs = 0, n_cells = 0;
    std::string solver; ///< "direct (MUMPS)" or "FGMRES + ..."
    unsigned    iterations = 0; ///< linear solver iterations, summed over Newton steps
    double      stokes_R_Pa_s_per_m3 = 0; ///< R (mean pressures) of the Stokes flow; = R without --navier-stokes
    double      stokes_R_gradient_dissipation_Pa_s_per_m3 = 0; ///< the Stokes flow's R_gradient_dissipation_Pa_s_per_m3
    unsigned    newton_iterations    = 0; ///< Navier-Stokes: Newton steps after the Stokes solve
    double      setup_time_s = 0, assembly_time_s = 0, solve_time_s = 0, wall_time_s = 0;
    unsigned    n_processes = 1;
  };

  /// Solves Stokes flow (and with settings.navier_stokes then steady
  /// Navier-Stokes, by Newton's method from it) with flow rate settings.flow_rate_m3_per_s through
  /// the inlet (a parabolic profile on the inlet face, scaled so that the
  /// discrete flux is exactly Q), traction -p_out n on the outlet, no slip
  /// elsewhere. Every process passes the same mesh. Writes velocity and
  /// pressure as VTU (with a .pvtu record) into `vtu_dir` if not empty.
  /// Throws InputError for bad parameters or a mesh without inlet or outlet,
  /// std::runtime_error if the solver does not converge.
  StokesResult solve_stokes(const mesher::TetMesh &mesh, const FlowParameters &parameters,
                            const std::filesystem::path &vtu_dir = {}, bool verbose = false);
} // namespace rectify::stokes
