// The reed's structural model (stiffness_solver/): beam and plate limits,
// frequencies, mesh convergence, thickness scaling.
#include <gtest/gtest.h>

#include <cmath>

#include "common/case_file.h"
#include "stiffness_solver/analytic.h"
#include "stiffness_solver/elasticity.h"

using namespace rectify;
using namespace rectify::stiffness;

namespace
{
  StiffnessParameters reference()
  {
    return StiffnessParameters::from_case(CaseFile::load(reference_case_path()));
  }

  /// A strip of the reed's thickness and length, `width` wide, tip line load.
  StiffnessParameters strip(double width, unsigned cells_across)
  {
    auto p                             = reference();
    p.geometry.reed_width_m            = width;
    p.settings.load                    = Load::tip_line;
    p.settings.load_levels             = {1.0};
    p.settings.cells_across_width      = cells_across;
    return p;
  }
} // namespace

TEST(Stiffness, NarrowStripMatchesEulerBernoulli)
{
  // L/W = 20: k within 1 % of 3 E I / L^3, f1 within 1 % of beam theory.
  auto p = strip(6.1e-3 / 20, 2);
  p.settings.cells_along_length = 40;
  p.settings.n_modes            = 1;
  const auto   r  = solve_reed(p);
  const double EI = p.material.youngs_modulus_Pa * analytic::second_moment(p.geometry.reed_width_m,
                                                                         p.geometry.reed_thickness_m);
  const double k_beam = 1.0 / analytic::tip_load_compliance(EI, p.geometry.reed_length_m);
  EXPECT_NEAR(r.k_N_per_m, k_beam, 0.01 * k_beam);
  const double m_per_length = p.material.density_kg_per_m3 * p.geometry.reed_width_m * p.geometry.reed_thickness_m;
  const double f_beam = analytic::first_frequency_Hz(EI, m_per_length, p.geometry.reed_length_m);
  ASSERT_FALSE(r.modes.empty());
  EXPECT_NEAR(r.modes[0].frequency_Hz, f_beam, 0.01 * f_beam);
  EXPECT_EQ(r.modes[0].kind, "bending");
  // a cantilever's first-mode mass at its tip is a quarter of its mass (beam theory: 0.2500)
  EXPECT_NEAR(r.modes[0].modal_mass_kg / r.plate_mass_kg, 0.25, 0.01);
  std::printf("strip: k = %.6g (beam %.6g), f1 = %.6g (beam %.6g) Hz\n", r.k_N_per_m, k_beam,
              r.modes[0].frequency_Hz, f_beam);
}
