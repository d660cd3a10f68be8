// The flow solver's settings: case table [flow] (reference-case.md sec. 2).
// The oil's density and viscosity are [fluid].
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "common/case_file.h"
#include "common/fluid.h"

namespace rectify::stokes
{
  struct FlowSettings
  {
    double      flow_rate_m3_per_s = 1.58e-6;   ///< thesis eq. 3.39 (20 Hz, 0.0036 in stroke)
    double      outlet_pressure_Pa = 6894.757;  ///< 1 psi
    std::string solver             = "auto";    ///< "direct" (MUMPS), "iterative" (FGMRES + AMG/Schur), "auto"
    long        direct_max_dofs    = 150000;    ///< "auto": direct up to this many unknowns
    std::string schur              = "gap";     ///< Schur complement preconditioner: "gap" (mass + thin-gap Laplacian) or "mass"
    double      tolerance          = 1e-9;      ///< relative residual of the iterative solver (R and A_eff to ~1e-7, mass balance ~1e-8)
    long        max_iterations     = 2000;
    /// "solve": the resistance sweeps also solve the reed's fluid loading at
    /// every opening (FluidLoading: a second solve on the same matrix and
    /// the added mass's potential flow); "skip": R and A_eff only.
    std::string reed_loading = "solve";
    /// The iterative solver's relative residual for the moving reed's solve:
    /// the loading's asymmetry (its two computations of one number) shows
    /// what it leaves (about 1e-9 at 1e-7; docs/fluid-loading.md).
    double      loading_tolerance = 1e-7;
    // Steady Navier-Stokes by Newton's method from the Stokes flow (`rectify
    // stokes --navier-stokes`; not a case key: the map is Stokes, linear in Q).
    bool        navier_stokes         = false;
    double      newton_tolerance      = 1e-10; ///< relative change of R between Newton steps
    long        newton_max_iterations = 20;
    /// Every setting, as `rectify check` and the map sets record them.
    nlohmann::json to_json() const;
    static FlowSettings from_case(const CaseFile &file);
  };

  struct FlowParameters
  {
    FluidParameters fluid;
    FlowSettings    settings;
    static FlowParameters from_case(const CaseFile &file);
  };
} // namespace rectify::stokes
