#include "stokes_solver/parameters.h"
#include "stokes_solver/resistance_sweep.h"

#include <algorithm>
#include <cstdio>

#include "mesher/parameters.h"

namespace rectify::stokes
{
  FlowSettings FlowSettings::from_case(const CaseFile &f)
  {
    FlowSettings      s;
    const std::string t = "flow";
    s.flow_rate_m3_per_s = f.real(t, "flow_rate_m3_per_s", s.flow_rate_m3_per_s, Bounds::positive());
    s.outlet_pressure_Pa = f.real(t, "outlet_pressure_Pa", s.outlet_pressure_Pa,
                                  Bounds::open(-101325.0, 1e9)); // gauge: above vacuum
    s.solver             = f.text(t, "solver", s.solver, {"auto", "direct", "iterative"});
    s.direct_max_dofs    = f.integer(t, "direct_max_dofs", s.direct_max_dofs, 0, 100000000);
    s.schur              = f.text(t, "schur", s.schur, {"gap", "mass"});
    s.tolerance          = f.real(t, "tolerance", s.tolerance, Bounds::open(0.0, 1e-2));
    s.max_iterations     = f.integer(t, "max_iterations", s.max_iterations, 1, 1000000);
    s.reed_loading       = f.text(t, "reed_loading", s.reed_loading, {"solve", "skip"});
    s.loading_tolerance  = f.real(t, "loading_tolerance", s.loading_tolerance, Bounds::open(0.0, 1e-2));
    return s;
  }

  FlowParameters FlowParameters::from_case(const CaseFile &file)
  {
    return {FluidParameters::from_case(file), FlowSettings::from_case(file)};
  }

  nlohmann::json FlowSettings::to_json() const
  {
    return {{"flow_rate_m3_per_s", flow_rate_m3_per_s},
            {"outlet_pressure_Pa", outlet_pressure_Pa},
            {"solver", solver},
            {"direct_max_dofs", direct_max_dofs},
            {"schur", schur},
            {"tolerance", tolerance},
            {"max_iterations", max_iterations},
            {"reed_loading", reed_loading},
            {"loading_tolerance", loading_tolerance}};
  }
  // The [design] openings of a resistance map: parsed here, with the other
  // case keys, so that reading a case does not need the solver.
  SweepSettings SweepSettings::from_case(const CaseFile &f)
  {
    SweepSettings     s;
    const std::string t = "design";
    s.from_m            = f.real(t, "openings_from_m", s.from_m, Bounds::positive());
    s.initial_openings  = static_cast<unsigned>(f.integer(t, "initial_openings", s.initial_openings, 3, 200));
    s.tolerance         = f.real(t, "tolerance", s.tolerance, Bounds::open(0.0, 1.0));
    s.min_ratio         = f.real(t, "min_ratio", s.min_ratio, Bounds{1.0, 10.0, false, true});
    s.max_openings      = static_cast<unsigned>(f.integer(t, "max_openings", s.max_openings, 3, 1000));
    const auto g     = ValveGeometry::from_case(f);
    s.stop_lift_m    = g.stop_lift_m();
    const auto mesh  = mesher::MeshParameters::from_case(f);
    s.mesher_reach_m = mesh.max_opening_m();
    s.reach_limit    = mesh.reach_limit();
    s.to_stop        = !f.has(t, "openings_to_m");
    s.to_m = s.to_stop ? std::min(s.stop_lift_m, s.mesher_reach_m) : f.real(t, "openings_to_m", s.to_m, Bounds::positive());
    if (!(s.to_m > s.from_m))
      throw InputError(f.where(t, s.to_stop ? "openings_from_m" : "openings_to_m") + " = " +
                       format_number(s.to_stop ? s.from_m : s.to_m) + ": the openings run from openings_from_m = " +
                       format_number(s.from_m) + " to " + format_number(s.to_m) +
                       (s.to_stop ? " m (the stop or the mesher's reach)" : " m") + ", which must be larger");
    if (s.to_m >= g.pocket_height_m - g.reed_thickness_m)
      throw InputError(f.where(t, "openings_to_m") + " = " + format_number(s.to_m) +
                       ": the reed's top would reach the pocket's ceiling ([geometry] pocket_height_m = " +
                       format_number(g.pocket_height_m) + ")");
    if (s.to_m > s.stop_lift_m * (1 + 1e-12))
      throw InputError(f.where(t, "openings_to_m") + " = " + format_number(s.to_m) +
                       ": beyond the reed's stop, which it cannot pass (lift " + format_number(s.stop_lift_m) +
                       " m: [geometry] stop_height_m less the reed's thickness)");
    if (s.to_m > s.mesher_reach_m)
      throw InputError(f.where(t, "openings_to_m") + " = " + format_number(s.to_m) +
                       ": beyond the mesher's reach, " + format_number(s.mesher_reach_m) + " m: " + s.reach_limit);
    if (s.max_openings < s.initial_openings)
      throw InputError(f.where(t, "max_openings") + " = " + std::to_string(s.max_openings) +
                       ": below initial_openings = " + std::to_string(s.initial_openings));
    return s;
  }

  std::string SweepSettings::short_of_stop() const
  {
    if (to_m >= stop_lift_m * (1 - 1e-12))
      return "";
    const auto um = [](double x) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.4g um", x * 1e6);
      return std::string(buf);
    };
    std::string why = "the openings end at " + um(to_m) + ", " + um(stop_lift_m - to_m) +
                      " short of the reed's stop at " + um(stop_lift_m) + ": ";
    if (!to_stop)
      return why + "[design] openings_to_m says so";
    return why + reach_limit;
  }

  nlohmann::json SweepSettings::to_json() const
  {
    return {{"openings_from_m", from_m},        {"openings_to_m", to_m},
            {"initial_openings", initial_openings}, {"tolerance", tolerance},
            {"min_ratio", min_ratio},           {"max_openings", max_openings}};
  }

} // namespace rectify::stokes
