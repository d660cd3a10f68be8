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

TEST(Stiffness, WidePlatesTendToThePlateModulus)
{
  // Tip line load on plates W/L = 1, 2, 10: k per unit width rises from
  // between the beam (E) and plate (E') values to within 2 % of the plate
  // value 3 E' I / L^3 (cylindrical bending).
  std::vector<double> ratio;
  for (double w_over_l : {1.0, 2.0, 10.0})
    {
      auto p = strip(6.1e-3 * w_over_l, static_cast<unsigned>(6 * w_over_l));
      p.settings.cells_along_length = 12;
      SolveOptions o;
      o.compute_modes = false;
      const auto   r  = solve_reed(p, o);
      const double I  = analytic::second_moment(p.geometry.reed_width_m, p.geometry.reed_thickness_m);
      const double k_plate = 1.0 / analytic::tip_load_compliance(
                                     analytic::plate_modulus(p.material.youngs_modulus_Pa, p.material.poisson_ratio) * I,
                                     p.geometry.reed_length_m);
      const double k_beam = 1.0 / analytic::tip_load_compliance(p.material.youngs_modulus_Pa * I, p.geometry.reed_length_m);
      ratio.push_back(r.k_N_per_m / k_plate);
      std::printf("W/L = %g: k/k_plate = %.4f (centre %.4f), k_beam/k_plate = %.4f\n", w_over_l,
                  r.k_N_per_m / k_plate, r.k_center_N_per_m / k_plate, k_beam / k_plate);
      if (w_over_l == 1.0)
        {
          EXPECT_GT(r.k_N_per_m, k_beam);
          EXPECT_LT(r.k_N_per_m, k_plate);
        }
      if (w_over_l == 10.0)
        {
          EXPECT_NEAR(r.k_N_per_m, k_plate, 0.02 * k_plate);
          EXPECT_NEAR(r.k_center_N_per_m, k_plate, 0.02 * k_plate);
        }
    }
  EXPECT_LT(ratio[0], ratio[1]);
  EXPECT_LT(std::abs(ratio[2] - 1), std::abs(ratio[0] - 1));
}

TEST(Stiffness, ReferenceReedLiesBetweenItsBeamAndPlateBounds)
{
  const auto   p  = reference();
  const auto   r  = solve_reed(p);
  const auto  &g  = p.geometry;
  const double I  = analytic::second_moment(g.reed_width_m, g.reed_thickness_m);
  const double E  = p.material.youngs_modulus_Pa;
  const double Ep = analytic::plate_modulus(E, p.material.poisson_ratio);
  const double a = g.port_center_x_m, rad = 0.5 * g.port_diameter_m, L = g.reed_length_m;
  const double k_beam  = 1.0 / analytic::port_load_compliance(E * I, L, a, rad);
  const double k_plate = 1.0 / analytic::port_load_compliance(Ep * I, L, a, rad);
  EXPECT_GT(r.k_N_per_m, k_beam);
  EXPECT_LT(r.k_N_per_m, k_plate);
  // the applied force is the port's area times the pressure
  EXPECT_NEAR(r.force_per_level, M_PI * rad * rad, 1e-4 * M_PI * rad * rad);
  const double m_per_length = p.material.density_kg_per_m3 * g.reed_width_m * g.reed_thickness_m;
  ASSERT_EQ(r.modes.size(), 3u);
  EXPECT_GT(r.modes[0].frequency_Hz, analytic::first_frequency_Hz(E * I, m_per_length, L));
  EXPECT_LT(r.modes[0].frequency_Hz, analytic::first_frequency_Hz(Ep * I, m_per_length, L));
  EXPECT_EQ(r.modes[0].kind, "bending");
  EXPECT_EQ(r.modes[1].kind, "torsion");
  EXPECT_LT(r.modes[0].frequency_Hz, r.modes[1].frequency_Hz);
  // the deflected shape: 0 at the clamp, 1 at the tip, rising monotonically
  EXPECT_NEAR(r.shape_phi.front(), 0.0, 1e-12);
  EXPECT_NEAR(r.shape_phi.back(), 1.0, 1e-3);
  for (std::size_t i = 1; i < r.shape_phi.size(); ++i)
    EXPECT_GT(r.shape_phi[i], r.shape_phi[i - 1]);
  // linear theory: deflection proportional to the load level
  EXPECT_NEAR(r.levels[1].tip_deflection_m / r.levels[0].tip_deflection_m,
              r.levels[1].level / r.levels[0].level, 1e-9);
  std::printf("reference reed: k = %.6g N/m (beam %.6g, plate %.6g), f = %.6g, %.6g, %.6g Hz\n",
              r.k_N_per_m, k_beam, k_plate, r.modes[0].frequency_Hz, r.modes[1].frequency_Hz,
              r.modes[2].frequency_Hz);
}

namespace
{
  double port_stiffness(unsigned nx, unsigned ny, unsigned nz)
  {
    auto p                             = reference();
    p.settings.cells_along_length      = nx;
    p.settings.cells_across_width      = ny;
    p.settings.cells_through_thickness = nz;
    SolveOptions o;
    o.compute_modes = false;
    return solve_reed(p, o).k_N_per_m;
  }
} // namespace

TEST(Stiffness, PortLoadStiffnessConvergesUnderRefinement)
{
  // Three levels up to the default resolution (24 x 20 x 2): the changes
  // shrink and the last is below 1 %. (The slow test adds 48 x 40 x 2.)
  const double k1 = port_stiffness(6, 5, 1), k2 = port_stiffness(12, 10, 1),
               k3 = port_stiffness(24, 20, 2);
  std::printf("k: %.6g, %.6g, %.6g\n", k1, k2, k3);
  EXPECT_LT(std::abs(k3 - k2), std::abs(k2 - k1));
  EXPECT_LT(std::abs(k3 - k2), 0.01 * k3);
}

TEST(StiffnessSlow, DefaultResolutionIsWithinHalfAPercentOfTheFinerMesh)
{
  const double k_default = port_stiffness(24, 20, 2), k_fine = port_stiffness(48, 40, 2);
  std::printf("k: %.6g (default), %.6g (48 x 40 x 2)\n", k_default, k_fine);
  EXPECT_LT(std::abs(k_default - k_fine), 0.005 * k_fine);
}

TEST(Stiffness, StiffnessScalesAsThicknessCubed)
{
  std::vector<double> t{0.08e-3, 0.127e-3, 0.2e-3}, k;
  for (double thickness : t)
    {
      auto p                      = reference();
      p.geometry.reed_thickness_m = thickness;
      SolveOptions o;
      o.compute_modes = false;
      k.push_back(solve_reed(p, o).k_N_per_m);
    }
  for (std::size_t i = 1; i < t.size(); ++i)
    {
      const double slope = std::log(k[i] / k[i - 1]) / std::log(t[i] / t[i - 1]);
      EXPECT_NEAR(slope, 3.0, 0.06) << "between " << t[i - 1] << " and " << t[i] << " m";
    }
}

TEST(Stiffness, BadInputIsRejectedWithTheKey)
{
  auto expect_error = [](const std::string &text, const std::string &fragment) {
    try
      {
        StiffnessParameters::from_case(CaseFile::parse(text, "s.toml"));
        ADD_FAILURE() << "accepted: " << text;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      }
  };
  expect_error("[geometry]\nreed_thickness_m = 0\n", "[geometry] reed_thickness_m");
  expect_error("[geometry]\nreed_thickness_m = -1e-4\n", "must be > 0");
  expect_error("[reed_material]\nyoungs_modulus_Pa = 0\n", "[reed_material] youngs_modulus_Pa");
  expect_error("[reed_material]\ndensity_kg_per_m3 = -8000\n", "density_kg_per_m3");
  expect_error("[reed_material]\npoisson_ratio = 0.5\n", "poisson_ratio");
  expect_error("[reed_material]\npoisson_ratio = -1\n", "in (-1, 0.5)");
  // the port (the load patch) outside the reed
  expect_error("[geometry]\nport_center_x_m = 5.5e-3\n", "does not cover its port");
  expect_error("[geometry]\nport_diameter_m = 6e-3\n", "does not cover its port");
  expect_error("[stiffness]\nload = \"point\"\n", "'port-pressure'");
  expect_error("[stiffness]\nload_levels = [1e4, -1]\n", "entry 2 = -1");
}

TEST(Stiffness, AddedMassSpreadLikeThePlateScalesTheFirstMode)
{
  // The in-oil frequency reported by `rectify stiffness` scales the vacuum
  // mode by the added-mass factor of eq. 3.20 spread uniformly; the FE modes
  // of a plate made denser by that factor must agree.
  auto         p = reference();
  p.settings.n_modes = 1;
  const auto   vacuum = solve_reed(p);
  const double added  = analytic::added_mass_kg(p.fluid.density_kg_per_m3, p.geometry.reed_length_m,
                                               p.geometry.reed_width_m);
  const double scale  = analytic::added_mass_scale(vacuum.plate_mass_kg, added);
  p.material.density_kg_per_m3 *= scale;
  const auto heavy = solve_reed(p);
  EXPECT_NEAR(heavy.modes[0].frequency_Hz, vacuum.modes[0].frequency_Hz / std::sqrt(scale),
              1e-6 * heavy.modes[0].frequency_Hz);
  EXPECT_NEAR(heavy.modes[0].modal_mass_kg, vacuum.modes[0].modal_mass_kg * scale,
              1e-6 * heavy.modes[0].modal_mass_kg);
}
