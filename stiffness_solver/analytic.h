// Closed-form bounds for the reed (Euler-Bernoulli beam, and the plate in
// cylindrical bending with E' = E / (1 - nu^2)), and the thesis's added mass
// (eqs. 3.20, 3.21). The FE results are checked against these in tests/.
#pragma once

namespace rectify::stiffness::analytic
{
  /// I = W t^3 / 12
  double second_moment(double width, double thickness);
  /// E' = E / (1 - nu^2): the plate modulus of cylindrical bending.
  double plate_modulus(double youngs_modulus, double poisson_ratio);

  /// Tip deflection of a cantilever (length L, bending stiffness EI) per unit
  /// total force, for a line load at the tip: L^3 / (3 EI).
  double tip_load_compliance(double EI, double L);
  /// ... for a uniform pressure on a circular footprint (centre a from the
  /// clamp, radius r): the chord load 2 sqrt(r^2 - (x - a)^2) p integrated
  /// against the influence function x^2 (3L - x) / (6 EI), over p pi r^2.
  double port_load_compliance(double EI, double L, double a, double r);
  /// ... for a uniform pressure on the whole reed: L^3 / (8 EI).
  double uniform_load_compliance(double EI, double L);

  /// First bending frequency [Hz]: (1.8751^2 / 2 pi) sqrt(EI / (m' L^4)),
  /// m' the mass per unit length.
  double first_frequency_Hz(double EI, double mass_per_length, double L);

  /// eq. 3.20: added mass of a cantilever plate in its first mode,
  /// (pi / 4) rho_f a b^2 with a the length and b the width.
  double added_mass_kg(double fluid_density, double length, double width);

  /// The factor by which an added mass spread like the plate's own mass
  /// (uniformly) multiplies every modal mass: (m_plate + m_added) / m_plate.
  /// Frequencies divide by its square root. (tests/: the same as the FE modes
  /// of a plate of density rho (1 + m_added / m_plate).)
  double added_mass_scale(double plate_mass, double added_mass);
} // namespace rectify::stiffness::analytic
