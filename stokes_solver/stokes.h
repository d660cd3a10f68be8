// Stokes flow of the oil through a tetrahedral mesh with boundary ids inlet 1,
// outlet 2, walls 3, reed 4 (mesher/): Taylor-Hood P2-P1 on tetrahedra,
// deal.II 9.4 with PETSc, in parallel with MPI.
#pragma once

// MPI's C interface only: the C++ bindings (deprecated) would put static
// objects into every user of this header, the system-only front end too.
#ifndef OMPI_SKIP_MPICXX
#  define OMPI_SKIP_MPICXX 1
#endif
#ifndef MPICH_SKIP_MPICXX
#  define MPICH_SKIP_MPICXX 1
#endif
#include <mpi.h>

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "mesher/tet_mesh.h"
#include "stokes_solver/parameters.h"

namespace rectify::stokes
{
  /// Starts MPI and PETSc (deal.II's MPI_InitFinalize) for as long as it
  /// lives; works without mpirun (one process). Its solves run on
  /// MPI_COMM_WORLD, or on the communicator of a session made by `on`.
  class MpiSession
  {
  public:
    /// MPI's thread level: `multiple` for a process where one thread
    /// schedules (MPI calls) while another solves (rectify whatif).
    enum class Threads
    {
      serialized,
      multiple
    };
    explicit MpiSession(Threads threads = Threads::serialized);
    ~MpiSession();
    MpiSession(MpiSession &&other) noexcept;
    MpiSession(const MpiSession &)            = delete;
    MpiSession &operator=(const MpiSession &) = delete;
    MpiSession &operator=(MpiSession &&)      = delete;

    /// A session on `comm` (a sub-communicator of a running session's): it
    /// neither starts nor stops MPI, and does not own `comm`.
    static MpiSession on(MPI_Comm comm);

    MPI_Comm comm() const { return comm_; }
    unsigned rank() const;
    unsigned size() const;
    /// Every process gets the root's `values`.
    std::vector<double> broadcast(std::vector<double> values) const;

  private:
    MpiSession(std::nullptr_t, MPI_Comm comm);
    struct Impl;
    Impl    *impl_;
    MPI_Comm comm_;
  };

  /// What the fluid loading needs to know of the reed's motion: the
  /// velocity of its surface per unit tip velocity, w(x, y) e_z (small
  /// deflections; the mesher's shape phi(x) along the reed, 1 at the tip).
  struct ReedMotion
  {
    std::function<double(double x, double y)> shape;
    bool added_mass = true; ///< also solve the potential flow for the added mass
  };

  /// The reed's quasi-static fluid loading at one opening (docs/fluid-loading.md).
  /// Stokes flow is linear in its boundary data: the inflow Q through the
  /// inlet (the parabolic profile) and the reed's tip velocity v (shape w).
  /// With the generalised forces conjugate to them - the pressure drop dp
  /// (relative to the outlet) and minus the modal force F = integral of
  /// traction . w e_z on the reed - the two solves (a) Q = 1, v = 0 and
  /// (b) Q = 0, v = 1 on the same matrix give
  ///   ( dp )   ( K_QQ  K_Qv ) ( Q )
  ///   ( -F ) = ( K_vQ  K_vv ) ( v ),
  /// symmetric by the reciprocal theorem (K_Qv from solve (b), K_vQ from
  /// solve (a): two computations of one number) and positive definite (it is
  /// the dissipation's quadratic form). Each force is the residual of the
  /// discrete momentum equation tested with the other solve's boundary data
  /// (consistent, not a face integral of the stresses).
  struct FluidLoading
  {
    bool   computed = false;
    double K_QQ_Pa_s_per_m3 = 0; ///< the dissipation's R (= R_gradient_dissipation)
    double K_Qv_Pa_s_per_m  = 0; ///< dp per unit tip velocity at Q = 0, solve (b)
    double K_vQ_Pa_s_per_m  = 0; ///< -F per unit Q at v = 0, solve (a)
    double K_vv_N_s_per_m   = 0; ///< the squeeze-film damping c at Q = 0
    double asymmetry        = 0; ///< |K_Qv - K_vQ| / sqrt(K_QQ K_vv)
    /// The modal force per unit pressure drop of flow with the reed still,
    /// -K_vQ / K_QQ: also the flow drawn through the valve per unit tip
    /// velocity at a fixed pressure drop (reciprocity).
    double A_modal_m2 = 0;
    /// The damping felt at a fixed pressure drop, K_vv - K_Qv K_vQ / K_QQ
    /// (the Schur complement; the fluid displaced may leave through the port).
    double damping_fixed_dp_N_s_per_m = 0;
    double swept_flow_m3_per_s = 0;         ///< -integral of w e_z . n over the reed (as the DoFs hold it): solve (b)'s outflow per unit v
    double outflow_b_m3_per_s  = 0;         ///< solve (b)'s outflow through the outlet
    double mass_balance_b_rel_error = 0;    ///< |outflow - swept| / swept
    double reed_force_b_N = 0;              ///< z-force on the reed in solve (b) (face integral; < 0)
    double added_mass_kg  = 0;              ///< rho integral |grad phi|^2 of the potential flow, per unit tip velocity squared
    double added_mass_boundary_kg = 0;      ///< the same from rho integral phi dphi/dn over the reed (a check)
    std::size_t potential_dofs = 0;
    double      solve_time_s = 0; ///< solve (b), the forces and the potential flow
  };

  /// One port's share of the flow. Several ports draw from one chamber: the
  /// flow splits so that every port's pressure drop is the same (the
  /// split of least dissipation). Each port's inflow is its bore's developed
  /// profile: a round port's parabola, any other section's duct flow.
  struct PortFlow
  {
    std::array<double, 3> centre_m{}; ///< of its inlet face
    double area_m2 = 0;               ///< of its inlet face
    bool   round   = false;           ///< the parabola (else the duct profile)
    double flow_m3_per_s = 0;         ///< of the Stokes flow (Navier-Stokes keeps this split)
    /// The solution's residual tested with the port's unit-flux profile
    /// (relative to the outlet): the work-conjugate pressure drop, the
    /// same for every port to the solver's precision.
    double pressure_drop_Pa = 0;
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
    FluidLoading loading; ///< with a ReedMotion only
    std::vector<PortFlow> ports; ///< one per connected patch of the inlet, in the mesh's order
  };

  /// Solves Stokes flow (and with settings.navier_stokes then steady
  /// Navier-Stokes, by Newton's method from it) with flow rate settings.flow_rate_m3_per_s through
  /// the inlet (each port's developed profile, scaled so that the discrete
  /// flux is exactly its share of Q; PortFlow), traction -p_out n on the outlet, no slip
  /// elsewhere. Every process passes the same mesh. Writes velocity and
  /// pressure as VTU (with a .pvtu record) into `vtu_dir` if not empty.
  /// Throws InputError for bad parameters or a mesh without inlet or outlet,
  /// std::runtime_error if the solver does not converge.
  /// With `motion`, also the reed's fluid loading (result.loading; of the
  /// Stokes flow, before any Navier-Stokes steps). Every process of `comm`
  /// calls it together.
  StokesResult solve_stokes(const mesher::TetMesh &mesh, const FlowParameters &parameters,
                            const std::filesystem::path &vtu_dir = {}, bool verbose = false,
                            const ReedMotion *motion = nullptr, MPI_Comm comm = MPI_COMM_WORLD);

  /// The added mass alone (the potential flow of FluidLoading) on any mesh
  /// with an outlet and a reed: rho integral |grad phi|^2, per unit tip
  /// velocity squared, and the boundary integral's value as a check
  /// ({energy form, boundary form}). One process.
  std::pair<double, double> added_mass(const mesher::TetMesh &mesh, const std::function<double(double, double)> &shape,
                                       double density_kg_per_m3);
} // namespace rectify::stokes
