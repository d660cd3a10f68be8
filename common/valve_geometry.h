// The reed valve's geometry, shared by the mesher, the Stokes solver and the
// stiffness solver: case table [geometry] (reference-case.md sec. 1).
// Coordinates: x from the clamp line along the reed, y across it (centred),
// z in the opening direction, z = 0 on the seat plane.
#pragma once

#include <string>

#include "common/case_file.h"

namespace rectify
{
  struct ValveGeometry
  {
    double reed_length_m    = 6.1e-3;   ///< L, clamp line to tip (0.240 in)
    double reed_width_m     = 5.08e-3;  ///< 0.200 in, centred on y = 0
    double reed_thickness_m = 0.127e-3; ///< 0.005 in
    double port_diameter_m  = 3.175e-3; ///< 0.125 in
    double port_center_x_m  = 3.3e-3;   ///< port axis, distance from the clamp line
    double port_length_m    = 3.0e-3;   ///< from the inlet face z = -length to the seat z = 0
    /// The pocket on the outlet side: the box [0, length] x [-width/2, width/2]
    /// x [0, height]; the clamp line lies on its wall x = 0.
    double pocket_length_m = 9.0e-3;
    double pocket_width_m  = 8.0e-3;
    double pocket_height_m = 2.0e-3;
    /// Which pocket face is the outlet: "x-max" (reference), "y-min", "y-max"
    /// or "ceiling". The inlet is the port's face z = -port_length_m.
    std::string outlet_face = "x-max";

    /// Area of the outlet face [m^2].
    double outlet_area_m2() const;

    /// Reads and checks [geometry]: the port must lie in the seat (the pocket's
    /// floor) and under the reed, the reed inside the pocket; otherwise an
    /// InputError naming the key and value.
    static ValveGeometry from_case(const CaseFile &file);
  };
} // namespace rectify
