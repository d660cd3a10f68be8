// Internal to the Stokes solver: the potential flow that a moving reed
// drives in the fluid domain, for its added mass (docs/fluid-loading.md).
// Laplace's equation for the velocity potential phi on the flow's mesh,
// FE_SimplexP(2): d phi / dn = w n_z on the reed (its surface moving with
// w(x, y) e_z per unit tip velocity), phi = 0 on the outlet (the pocket
// opens into the outlet line: no pressure disturbance there), no flow
// through the walls and the inlet (the port shut, as in the squeeze solve).
#pragma once

#include <deal.II/base/mpi.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/grid/tria.h>

#include <cstddef>
#include <functional>

namespace rectify::stokes
{
  struct PotentialFlow
  {
    double      energy_integral   = 0; ///< integral of |grad phi|^2 over the fluid [m^3]
    double      boundary_integral = 0; ///< integral of phi dphi/dn over the reed (equal, a check)
    std::size_t n_dofs            = 0;
  };

  /// P2 on the flow's mesh, solved by CG with BoomerAMG (strong threshold
  /// 0.7 for the gap's flat cells, Chebyshev smoothing; 30-50 iterations
  /// from 2 um to 100 um), MUMPS if that does not converge.
  PotentialFlow solve_potential_flow(const dealii::Triangulation<3> &triangulation, const dealii::Mapping<3> &mapping,
                                     const std::function<double(double, double)> &shape, MPI_Comm comm);
} // namespace rectify::stokes
