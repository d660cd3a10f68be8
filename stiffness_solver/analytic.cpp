#include "stiffness_solver/analytic.h"

#include <cassert>
#include <cmath>
#include <numbers>

namespace rectify::stiffness::analytic
{
  double second_moment(double width, double thickness)
  {
    return width * thickness * thickness * thickness / 12.0;
  }

  double plate_modulus(double youngs_modulus, double poisson_ratio)
  {
    return youngs_modulus / (1.0 - poisson_ratio * poisson_ratio);
  }

  double tip_load_compliance(double EI, double L) { return L * L * L / (3.0 * EI); }

  double port_load_compliance(double EI, double L, double a, double r)
  {
    assert(a - r >= 0 && a + r <= L);
    // x = a + r cos(theta): the integrand is a trigonometric polynomial of
    // degree 5, which the midpoint rule with 64 points integrates exactly.
    const int n   = 64;
    double    sum = 0;
    for (int k = 0; k < n; ++k)
      {
        const double theta = (k + 0.5) * std::numbers::pi / n;
        const double x     = a + r * std::cos(theta);
        const double chord = 2.0 * r * std::sin(theta);
        sum += chord * r * std::sin(theta) * x * x * (3 * L - x) / (6 * EI);
      }
    return sum * (std::numbers::pi / n) / (std::numbers::pi * r * r);
  }

  double uniform_load_compliance(double EI, double L) { return L * L * L / (8.0 * EI); }

  double first_frequency_Hz(double EI, double mass_per_length, double L)
  {
    const double beta_L = 1.8751040687;
    return beta_L * beta_L / (2 * std::numbers::pi) *
           std::sqrt(EI / (mass_per_length * L * L * L * L));
  }

  double added_mass_kg(double fluid_density, double length, double width)
  {
    return std::numbers::pi / 4.0 * fluid_density * length * width * width;
  }
  double added_mass_scale(double plate_mass, double added_mass)
  {
    return (plate_mass + added_mass) / plate_mass;
  }
} // namespace rectify::stiffness::analytic
