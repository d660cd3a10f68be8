// R(x) and A_eff(x) over tip openings, with the openings chosen by accuracy:
// a coarse log grid, then, wherever the monotone interpolant through the
// solved openings misses a solved geometric midpoint by more than the
// tolerance (log R over log x, A_eff over log x: the map set's
// interpolation), both halves are checked again. Every solve is checkpointed
// (resumable; the same settings give the same midpoints, so a resumed sweep
// reuses what it has). Every process of MPI_COMM_WORLD calls it together.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mesher/parameters.h"
#include "stokes_solver/parameters.h"
#include "stokes_solver/stokes.h"

namespace rectify::stokes
{
  struct SweepSettings
  {
    double   from_m            = 2e-6;     ///< smallest opening (reference-case.md sec. 1)
    double   to_m              = 1210e-6;  ///< largest opening
    unsigned initial_openings  = 5;        ///< the coarse log grid
    double   tolerance         = 5e-3;     ///< interpolation error allowed in R and A_eff (relative)
    double   min_ratio         = 1.05;     ///< no interval is split below this opening ratio
    unsigned max_openings      = 60;       ///< stop refining beyond this many solves
    /// Where the openings end when openings_to_m is not given: the reed's
    /// stop, or short of it by what the mesher cannot reach.
    double   stop_lift_m       = 0;        ///< [geometry]'s stop: the largest opening the reed reaches
    double   mesher_reach_m    = 0;        ///< the largest opening the mesher meshes
    std::string reach_limit;                ///< what sets it, for a message
    bool     to_stop           = false;    ///< openings_to_m was not given: to the stop (or the mesher's reach)
    /// Why the openings end short of the stop (empty when they reach it).
    std::string short_of_stop() const;
    static SweepSettings from_case(const CaseFile &file); ///< case table [design]
    nlohmann::json to_json() const;
  };

  /// One solved opening.
  struct OpeningPoint
  {
    double opening_m = 0;
    double R_Pa_s_per_m3 = 0;             ///< (mean p_in - mean p_out) / Q: the map's
    double R_dissipation_Pa_s_per_m3 = 0; ///< 2 mu e:e / Q^2
    double reed_force_N = 0;              ///< z component, pressure relative to the outlet's
    double A_eff_m2 = 0;
    double pressure_drop_Pa = 0;
    double R_thin_gap_Pa_s_per_m3 = 0;
    double reynolds_port = 0, reynolds_gap_exit = 0;
    double mass_balance_rel_error = 0;
    double n_dofs = 0, iterations = 0, wall_time_s = 0;
    // The reed's fluid loading (FluidLoading in stokes.h; zero with [flow] reed_loading = "skip"):
    double R_energy_Pa_s_per_m3 = 0;       ///< K_QQ
    double dp_per_tip_velocity_Pa_s_per_m = 0; ///< K_Qv
    double force_per_flow_Pa_s_per_m = 0;  ///< K_vQ (minus the modal force per unit flow)
    double damping_N_s_per_m = 0;          ///< K_vv: the squeeze film at Q = 0
    double damping_fixed_dp_N_s_per_m = 0; ///< at a fixed pressure drop
    double A_modal_m2 = 0;                 ///< -K_vQ / K_QQ
    double loading_asymmetry = 0;
    double added_mass_kg = 0;
    double swept_area_m2 = 0;              ///< the volume the reed sweeps per unit tip travel
    double loading_time_s = 0;
    /// Where an opening's time went: meshing, the flow's set-up (DoFs,
    /// constraints, sparsity), assembly, the linear solves (preconditioner
    /// set-up included); wall_time_s is the flow's whole, meshing excluded.
    double mesh_time_s = 0, setup_time_s = 0, assembly_time_s = 0, solve_time_s = 0;
    bool   has_loading() const { return damping_N_s_per_m > 0; }
    static const std::vector<std::string> &columns();
    std::vector<double> row() const;
    static OpeningPoint from_row(const std::vector<double> &row);
  };

  /// One midpoint check: the interpolant without the midpoint against the solve.
  struct IntervalCheck
  {
    double from_m, to_m, midpoint_m, R_error, A_error;
    bool   passed; ///< both errors within the tolerance
    bool   limited; ///< failed, but not split further (min_ratio or max_openings)
  };

  struct SweepResult
  {
    std::vector<OpeningPoint>  points; ///< by opening
    std::vector<IntervalCheck> checks;
    /// Largest interpolation error among the checks of the final intervals'
    /// parents that passed (an upper estimate for the final map's error):
    double      max_R_error = 0, max_A_error = 0;
    bool        converged = true; ///< no check was left failing
    std::size_t n_resumed = 0; ///< openings taken from the checkpoint
  };

  /// The reed's motion for the fluid loading on the meshes of `mesh`: its
  /// surface moves as the mesher's shape phi(x) (clamp line x = 0, tip x =
  /// reed_length_m, held beyond) per unit tip velocity.
  ReedMotion reed_motion(const mesher::MeshParameters &mesh);

  /// FluidLoading as JSON (the map's entries and their checks).
  nlohmann::json to_json(const FluidLoading &loading);

  /// Meshes and solves one opening (with the fluid loading if [flow]
  /// reed_loading = "solve"); every process returns the root's numbers.
  OpeningPoint solve_opening(const mesher::MeshParameters &mesh, const FlowParameters &flow, double opening_m,
                             const MpiSession &mpi);

  /// The given openings, each solved once: checkpointed in
  /// `checkpoint_dir`/map-partial.csv (resumable). `n_resumed`: how many came from it.
  std::vector<OpeningPoint> fixed_resistance_sweep(const mesher::MeshParameters &mesh, const FlowParameters &flow,
                                                   const std::vector<double> &openings,
                                                   const std::filesystem::path &checkpoint_dir,
                                                   const nlohmann::json &fingerprint, const MpiSession &mpi,
                                                   std::size_t *n_resumed = nullptr);

  /// `checkpoint_dir`: the root's checkpoint folder (openings-partial.csv).
  /// `fingerprint`: what the solves depend on (refuses a checkpoint of others).
  SweepResult resistance_sweep(const mesher::MeshParameters &mesh, const FlowParameters &flow,
                               const SweepSettings &settings, const std::filesystem::path &checkpoint_dir,
                               const nlohmann::json &fingerprint, const MpiSession &mpi);

  /// The coarse log grid an adaptive sweep starts from.
  std::vector<double> initial_openings(const SweepSettings &settings);

  /// Where an adaptive sweep stands, given openings solved so far (any
  /// superset of what it has asked for): the openings of its next round
  /// (known before any of them is solved, so they can be solved at once, in
  /// any order, anywhere), or, when none is missing, its result.
  /// resistance_sweep is this in a loop; rectify whatif (whatif/) serves
  /// the rounds of many designs from one queue and gets the same maps.
  struct SweepPlan
  {
    std::vector<double> missing;
    SweepResult         result; ///< complete() only
    bool                complete() const { return missing.empty(); }
  };
  SweepPlan plan_resistance_sweep(const SweepSettings &settings, const std::map<double, OpeningPoint> &solved);

  /// The interpolation the map set uses, through `points` (by opening),
  /// evaluated at x: {R, A_eff}.
  std::pair<double, double> interpolate_point(const std::vector<OpeningPoint> &points, double x);

  /// Reynolds numbers of flow rate Q through the valve: in the port,
  /// 4 rho Q / (pi D mu), and at the gap's exit, 2 h U / nu with U = Q /
  /// (perimeter h), which does not depend on h: 2 rho Q / ((2 L + W) mu).
  struct ReynoldsNumbers
  {
    double port, gap_exit;
  };
  ReynoldsNumbers reynolds_numbers(const ValveGeometry &geometry, const FluidParameters &fluid, double flow_rate_m3_per_s);

  /// Thin-gap (Reynolds equation) R for the same valve, shape as the mesher
  /// samples it, closed where the mesher closes it; grid 10 um.
  double thin_gap_R(const mesher::MeshParameters &mesh, double closed_to_m, double opening_m, double viscosity_Pa_s);
} // namespace rectify::stokes
