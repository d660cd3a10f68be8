// Linear elasticity of the reed plate (deal.II, 3D, hexahedral Q2 elements
// with several layers through the thickness: no shear locking in bending):
// its stiffness under the chosen load, its deflected shape and its natural
// modes. The interface is plain C++; deal.II stays inside elasticity.cpp.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stiffness_solver/parameters.h"

namespace rectify::stiffness
{
  struct LoadLevel
  {
    double level;                   ///< pressure [Pa] or tip force [N]
    double force_N;                 ///< total force applied
    double tip_deflection_m;        ///< mean over the tip face
    double tip_center_deflection_m; ///< at the tip's centre (y = 0, mid-thickness)
    double deflection_ratio;        ///< tip deflection / reed length
    double root_stress_beam_Pa;     ///< bending stress at the clamp, beam theory
    bool   small_deflection;        ///< deflection_ratio <= the settings' limit
  };

  struct Mode
  {
    double      frequency_Hz;
    std::string kind;          ///< "bending" (symmetric in y) or "torsion"
    double      modal_mass_kg; ///< phi^T M phi with the tip's mean deflection 1 (bending modes)
  };

  /// The reed bent to a given mean tip opening by a geometrically nonlinear
  /// solve (St Venant-Kirchhoff, total Lagrangian: large rotations, small
  /// strains) under the same dead load as the linear one, beside the linear
  /// solve's answer for the same opening.
  struct LargeDeflectionCheck
  {
    double   opening_m = 0;                ///< the mean tip deflection reached
    double   force_N   = 0;                ///< the load's resultant that bends it there
    double   secant_stiffness_N_per_m = 0; ///< force / opening
    double   stiffness_ratio          = 0; ///< secant stiffness over the linear k_N_per_m
    double   root_stress_Pa           = 0; ///< the root's width-mean bending stress there
    double   root_stress_ratio        = 0; ///< over the linear root_stress_per_opening x opening
    double   tip_shortening_m         = 0; ///< the tip's mean displacement towards the clamp
    unsigned load_steps = 0, newton_iterations = 0;
    std::string failure; ///< why the solve did not reach the opening (empty: it did; else only opening_m is set)
  };

  struct StiffnessResult
  {
    std::size_t n_dofs = 0, n_cells = 0;
    double      force_per_level = 0; ///< F for a unit level: the loaded area [m^2], or 1 for a force
    double      k_N_per_m = 0;       ///< F / mean tip deflection
    double      k_center_N_per_m = 0; ///< F / tip-centre deflection
    std::vector<LoadLevel> levels;
    std::vector<Mode>      modes;
    double      plate_mass_kg = 0;
    /// The underside's bending stress at the clamp line per unit mean tip
    /// deflection [Pa/m] (tension while the reed opens): the width-mean from
    /// the FE section moment, beam theory's for the same load beside it, the
    /// corners' peak principal stress over the mean four thicknesses off the clamp,
    /// and the second bending mode's (0 without modes; its sign says on which
    /// side the mode's positive tip deflection pulls).
    double      root_stress_per_opening_Pa_per_m             = 0;
    double      root_stress_beam_per_opening_Pa_per_m        = 0;
    double      root_stress_concentration                    = 1;
    double      second_mode_root_stress_per_opening_Pa_per_m = 0;
    /// The deflected underside under the load, normalised to a unit mean tip
    /// deflection: s from the clamp, phi averaged across the width, and on the
    /// centre line. phi(0) = 0, phi(L) = 1.
    std::vector<double> shape_s_m, shape_phi, shape_phi_centerline;
    /// With SolveOptions::large_deflection_opening_m > 0.
    std::optional<LargeDeflectionCheck> large_deflection;
    double      wall_time_s = 0;
    /// Wall time of each phase [s], in order: for benchmarks.
    std::vector<std::pair<std::string, double>> phase_times;
  };

  struct SolveOptions
  {
    bool                  compute_modes = true;
    std::filesystem::path vtu_file; ///< empty: no VTU
    std::size_t           n_shape_points = 61;
    /// A mean tip opening [m] at which to check linear elasticity with a
    /// geometrically nonlinear solve (the reed's stop lift); 0: no check.
    double                large_deflection_opening_m = 0;
  };

  /// Solves the reed. Throws std::runtime_error if a solver fails.
  StiffnessResult solve_reed(const StiffnessParameters &parameters, const SolveOptions &options = {});
} // namespace rectify::stiffness
