#include "stiffness_solver/parameters.h"

namespace rectify::stiffness
{
  Load parse_load(const std::string &name)
  {
    if (name == "port-pressure")
      return Load::port_pressure;
    if (name == "tip-line")
      return Load::tip_line;
    if (name == "uniform-pressure")
      return Load::uniform_pressure;
    throw InputError("unknown load '" + name + "' (port-pressure, tip-line, uniform-pressure)");
  }

  std::string to_string(Load load)
  {
    switch (load)
      {
        case Load::port_pressure:
          return "port-pressure";
        case Load::tip_line:
          return "tip-line";
        case Load::uniform_pressure:
          return "uniform-pressure";
      }
    return "?";
  }

  StiffnessSettings StiffnessSettings::from_case(const CaseFile &f)
  {
    StiffnessSettings s;
    const std::string t = "stiffness";
    s.load        = parse_load(f.text(t, "load", to_string(s.load),
                                      {"port-pressure", "tip-line", "uniform-pressure"}));
    s.load_levels = f.reals(t, "load_levels", s.load_levels, Bounds::positive());
    s.fe_degree   = static_cast<unsigned>(f.integer(t, "fe_degree", s.fe_degree, 1, 4));
    s.cells_along_length =
      static_cast<unsigned>(f.integer(t, "cells_along_length", s.cells_along_length, 1, 1000));
    s.cells_across_width =
      static_cast<unsigned>(f.integer(t, "cells_across_width", s.cells_across_width, 1, 1000));
    s.cells_through_thickness = static_cast<unsigned>(
      f.integer(t, "cells_through_thickness", s.cells_through_thickness, 1, 20));
    s.n_modes = static_cast<unsigned>(f.integer(t, "n_modes", s.n_modes, 1, 20));
    s.added_mass_factor =
      f.real(t, "added_mass_factor", s.added_mass_factor, Bounds::closed(1.0, 100.0));
    s.max_linear_deflection_ratio = f.real(t, "max_linear_deflection_ratio",
                                           s.max_linear_deflection_ratio, Bounds::open(0.0, 1.0));
    return s;
  }

  StiffnessParameters StiffnessParameters::from_case(const CaseFile &f)
  {
    return {ValveGeometry::from_case(f), ReedMaterial::from_case(f),
            StiffnessSettings::from_case(f), FluidParameters::from_case(f)};
  }

  nlohmann::json StiffnessSettings::to_json() const
  {
    return {{"load", to_string(load)},
            {"fe_degree", fe_degree},
            {"cells_along_length", cells_along_length},
            {"cells_across_width", cells_across_width},
            {"cells_through_thickness", cells_through_thickness},
            {"n_modes", n_modes},
            {"added_mass_factor", added_mass_factor}};
  }
} // namespace rectify::stiffness
