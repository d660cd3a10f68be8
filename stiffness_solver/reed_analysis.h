// What the reed's FE solution means beside its limits: the beam (E) and plate
// (E') bounds on k and f1, the thesis's added mass (eq. 3.20) and effective
// mass (eq. 3.21), the first mode in oil, and the deflected shape as the
// mesher's "table" shape. Used by `rectify stiffness`, `map-stiffness` and
// `design`.
#pragma once

#include <string>

#include "stiffness_solver/elasticity.h"

namespace rectify::stiffness
{
  /// Beam (E) and plate (E') values for the reed under its load, and the
  /// thesis's added mass: the bounds the FE results are read against.
  struct ReedBounds
  {
    double k_beam, k_plate, f1_beam, f1_plate;
    double added_mass_kg; ///< eq. 3.20
  };
  ReedBounds reed_bounds(const StiffnessParameters &parameters);

  /// The mass and frequency of the first mode in oil. The added mass of
  /// eq. 3.20 is spread like the plate's own mass, so it scales the modal
  /// mass by (m_plate + m_added) / m_plate.
  struct InFluid
  {
    double modal_mass_kg, frequency_Hz;       ///< FE mode + eq. 3.20
    double eq321_mass_kg, eq321_frequency_Hz; ///< the thesis's eq. 3.21 with its factor
  };
  InFluid in_fluid(const StiffnessResult &result, const ReedBounds &bounds, double added_mass_factor);

  /// The deflected underside as the CSV the mesher reads (shape = "table"):
  /// a '# meta:' line, columns s_m, phi, phi_centerline.
  std::string shape_csv(const StiffnessResult &result, const StiffnessParameters &parameters);

  /// The reference "beam" shape, phi(s) of a cantilever under a point load at
  /// the port centre a (reference-case.md sec. 1), for plots beside the FE shape.
  double beam_shape(double s, double length_m, double load_at_m);
} // namespace rectify::stiffness
