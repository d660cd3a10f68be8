// Parameters of the reed's structural model: material ([reed_material]) and
// the solver's settings ([stiffness]). The geometry is [geometry]
// (common/valve_geometry.h), the oil's density [fluid].
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "common/case_file.h"
#include "common/fluid.h"
#include "common/reed_material.h"
#include "common/valve_geometry.h"

namespace rectify::stiffness
{
  using rectify::ReedMaterial; ///< common/reed_material.h

  /// Where the load sits.
  enum class Load
  {
    port_pressure,   ///< uniform pressure on the port's footprint on the underside (thesis)
    tip_line,        ///< uniform shear on the tip face: a line load along the tip
    uniform_pressure ///< uniform pressure on the whole underside
  };
  Load        parse_load(const std::string &name);
  std::string to_string(Load load);

  struct StiffnessSettings
  {
    Load                load = Load::port_pressure;
    /// Load levels: pressures [Pa] (port or uniform pressure) or forces [N]
    /// (tip line load). Thesis: 12.7 kPa to 12.7 MPa, four cases.
    std::vector<double> load_levels{12.7e3, 127e3, 1.27e6, 12.7e6};
    unsigned            fe_degree               = 2;  ///< Q2: no shear locking in bending
    unsigned            cells_along_length      = 24;
    unsigned            cells_across_width      = 20;
    unsigned            cells_through_thickness = 2;
    unsigned            n_modes                 = 3;
    double              added_mass_factor       = 2.75; ///< eq. 3.21
    /// Small-deflection criterion: tip deflection / reed length at most this.
    double              max_linear_deflection_ratio = 0.1;
    /// Every setting, as `rectify check` and the map sets record them.
    nlohmann::json to_json() const;
    static StiffnessSettings from_case(const CaseFile &file);
  };

  struct StiffnessParameters
  {
    ValveGeometry     geometry;
    ReedMaterial      material;
    StiffnessSettings settings;
    FluidParameters   fluid;
    static StiffnessParameters from_case(const CaseFile &file);
  };
} // namespace rectify::stiffness
