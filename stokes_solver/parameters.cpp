#include "stokes_solver/parameters.h"

namespace rectify::stokes
{
  FlowSettings FlowSettings::from_case(const CaseFile &f)
  {
    FlowSettings      s;
    const std::string t = "flow";
    s.flow_rate_m3_per_s = f.real(t, "flow_rate_m3_per_s", s.flow_rate_m3_per_s, Bounds::positive());
    s.outlet_pressure_Pa = f.real(t, "outlet_pressure_Pa", s.outlet_pressure_Pa, Bounds{});
    s.solver             = f.text(t, "solver", s.solver, {"auto", "direct", "iterative"});
    s.direct_max_dofs    = f.integer(t, "direct_max_dofs", s.direct_max_dofs, 0, 100000000);
    s.schur              = f.text(t, "schur", s.schur, {"gap", "mass"});
    s.tolerance          = f.real(t, "tolerance", s.tolerance, Bounds::open(0.0, 1e-2));
    s.max_iterations     = f.integer(t, "max_iterations", s.max_iterations, 1, 1000000);
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
            {"max_iterations", max_iterations}};
  }
} // namespace rectify::stokes
