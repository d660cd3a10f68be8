// The reed's structural model (stiffness_solver/): beam and plate limits,
// frequencies, mesh convergence, thickness scaling.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <utility>
#include <vector>

#include "common/case_file.h"
#include "stiffness_solver/analytic.h"
#include "stiffness_solver/elasticity.h"
#include "stiffness_solver/reed_sweep.h"
#include "maps/reed_map.h"

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

// The reed map (map-stiffness): k ~ t^3 and the root stress per opening ~ t
// (beam theory: 3 E t / (a (3L - a))), each row's stress the statics of its
// own stiffness, and read back through the map as the system model reads it.
TEST(Stiffness, TheReedMapsStiffnessGoesAsThicknessCubedAndItsRootStressAsThickness)
{
  const std::vector<double> t{0.08e-3, 0.127e-3, 0.2e-3};
  const auto                dir = std::filesystem::temp_directory_path() / "rectify_test_reed_map_stress";
  std::filesystem::remove_all(dir);
  const auto base  = reference(); // three modes: bending, torsion, the second bending mode
  const auto sweep = reed_thickness_sweep(base, t, dir);
  sweep.map.write(dir / "reed-map.csv");
  const auto   map = maps::ReedMap::read(dir / "reed-map.csv");
  const auto   k = map.column("stiffness_N_per_m"), s1 = map.column("root_stress_per_opening_Pa_per_m");
  const double a = base.geometry.port_center_x_m, W = base.geometry.reed_width_m;
  for (std::size_t i = 0; i < t.size(); ++i)
    {
      const double statics = 6 * k[i] * a / (W * t[i] * t[i]);
      std::printf("t = %.4g mm: k %.5g N/m, root stress %.5g MPa/um (statics %.5g)\n", t[i] * 1e3, k[i],
                  s1[i] * 1e-12, statics * 1e-12);
      EXPECT_NEAR(s1[i] / statics, 1.0, 0.03) << t[i];
    }
  for (std::size_t i = 1; i < t.size(); ++i)
    {
      const double slope = std::log(k[i] / k[i - 1]) / std::log(t[i] / t[i - 1]);
      EXPECT_NEAR(slope, 3.0, 0.06) << "between " << t[i - 1] << " and " << t[i] << " m";
    }
  // over the whole range (between neighbours the rows' own 3 % discretisation
  // error, checked above against statics, is amplified by 1 / log(t ratio))
  EXPECT_NEAR(std::log(s1.back() / s1.front()) / std::log(t.back() / t.front()), 1.0, 0.02);
  const auto mid = map.at(0.127e-3, "effective_mass_eq321_kg", "test");
  ASSERT_TRUE(mid.has_stress());
  EXPECT_EQ(mid.root_stress_per_opening_Pa_per_m, s1[1]);
  EXPECT_GT(mid.root_stress_concentration, 1.0);
  EXPECT_LT(mid.second_mode_root_stress_per_opening_Pa_per_m, 0.0);
  std::filesystem::remove_all(dir);
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

// The reed drawn as an outline (issue 19): the reference rectangle so drawn
// gives the shorthand's stiffness, modes and shape within 0.3 %
// (the outline's unstructured grid against the structured one; the
// outline's is the closer to the converged k: docs/geometry.md).
TEST(Stiffness, TheReferenceRectangleDrawnAsAnOutlineGivesTheShorthandsReed)
{
  const auto shorthand = reference();
  const auto outline   = StiffnessParameters::from_case(
    CaseFile::load(std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases/geometries/rectangle-outline.toml"));
  ASSERT_FALSE(outline.geometry.is_shorthand());
  const auto a = solve_reed(shorthand), b = solve_reed(outline);
  std::printf("k: shorthand %.6g (%zu dofs), outline %.6g (%zu dofs)\n", a.k_N_per_m, a.n_dofs, b.k_N_per_m, b.n_dofs);
  EXPECT_NEAR(b.k_N_per_m / a.k_N_per_m, 1.0, 3e-3);
  EXPECT_NEAR(b.force_per_level / a.force_per_level, 1.0, 1e-3); // the port's area, by quadrature
  EXPECT_NEAR(b.plate_mass_kg / a.plate_mass_kg, 1.0, 1e-12);
  ASSERT_EQ(a.modes.size(), b.modes.size());
  for (std::size_t k = 0; k < a.modes.size(); ++k)
    {
      EXPECT_EQ(a.modes[k].kind, b.modes[k].kind);
      EXPECT_NEAR(b.modes[k].frequency_Hz / a.modes[k].frequency_Hz, 1.0, 3e-3) << k;
      if (a.modes[k].kind == "bending")
        {
          EXPECT_NEAR(b.modes[k].modal_mass_kg / a.modes[k].modal_mass_kg, 1.0, 3e-3) << k;
        }
    }
  ASSERT_EQ(a.shape_phi.size(), b.shape_phi.size());
  for (std::size_t i = 0; i < a.shape_phi.size(); ++i)
    EXPECT_NEAR(b.shape_phi[i], a.shape_phi[i], 3e-3) << a.shape_s_m[i];
}

// A linearly tapered cantilever, narrow (the beam limit), under a tip load:
// delta = 12 P / (E t^3) integral_0^L (L - x)^2 / b(x) dx, b from b0 at the
// clamp to b1 at the tip; within 1 %.
TEST(Stiffness, ALinearlyTaperedCantileverMatchesBeamTheory)
{
  auto         p  = reference();
  const double L = p.geometry.reed_length_m, t = p.geometry.reed_thickness_m, b0 = L / 10, b1 = L / 20;
  p.geometry.reed_outline_m      = {{0, -b0 / 2}, {L, -b1 / 2}, {L, b1 / 2}, {0, b0 / 2}};
  p.geometry.reed_fillet_radii_m = {0, 0, 0, 0};
  p.geometry.clamp_y_m           = {-b0 / 2, b0 / 2};
  p.geometry.reed_width_m        = b0;
  Port port;
  port.center_m   = {L / 2, 0};
  port.diameter_m = 0.5 * (b0 + b1) / 3;
  p.geometry.port_list           = {port};
  p.settings.load                = Load::tip_line;
  p.settings.load_levels         = {1.0};
  p.settings.cells_along_length  = 40;
  p.settings.cells_across_width  = 4;
  p.settings.n_modes             = 1;
  const auto r = solve_reed(p);
  // the integral by Simpson's rule on 2000 intervals (exact to 1e-12 here)
  const int n = 2000;
  double    integral = 0;
  for (int i = 0; i <= n; ++i)
    {
      const double x = L * i / n, w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
      integral += w * (L - x) * (L - x) / (b0 + (b1 - b0) * x / L);
    }
  integral *= L / (3 * n);
  const double k_beam = p.material.youngs_modulus_Pa * t * t * t / (12 * integral);
  std::printf("tapered cantilever: k = %.6g, beam theory %.6g (%+.3f %%), %zu dofs\n", r.k_N_per_m, k_beam,
              100 * (r.k_N_per_m / k_beam - 1), r.n_dofs);
  EXPECT_NEAR(r.k_N_per_m / k_beam, 1.0, 0.01);
  // the root stress is 6 F L / (b0 t^2) whatever the taper, F = k x the
  // deflection, with beam theory's k and with the FE's
  const double beam = 6 * L * k_beam / (b0 * t * t), statics = 6 * L * r.k_N_per_m / (b0 * t * t);
  std::printf("tapered: root stress %.5g MPa/um, beam %.5g, statics %.5g\n", r.root_stress_per_opening_Pa_per_m * 1e-12,
              beam * 1e-12, statics * 1e-12);
  EXPECT_NEAR(r.root_stress_per_opening_Pa_per_m / statics, 1.0, 0.02);
  EXPECT_NEAR(r.root_stress_per_opening_Pa_per_m / beam, 1.0, 0.02);
  EXPECT_NEAR(r.plate_mass_kg, p.material.density_kg_per_m3 * t * L * (b0 + b1) / 2, 1e-12 * r.plate_mass_kg);
  ASSERT_FALSE(r.modes.empty());
  EXPECT_EQ(r.modes[0].kind, "bending");
}

// The port load over any ports: the force per pascal is the ports' area
// (two circles; a slot drawn as a polygon), by the rim's fine quadrature.
TEST(Stiffness, ThePortLoadActsOnEveryPortsMouth)
{
  const auto dir = std::filesystem::path(RECTIFY_SOURCE_DIR) / "cases/geometries";
  for (const char *name : {"two-ports.toml", "slotted-port.toml"})
    {
      auto p = StiffnessParameters::from_case(CaseFile::load(dir / name));
      p.settings.n_modes = 1;
      const auto r       = solve_reed(p);
      std::printf("%s: force per Pa %.6g m^2, ports %.6g m^2\n", name, r.force_per_level, p.geometry.ports_area_m2());
      EXPECT_NEAR(r.force_per_level / p.geometry.ports_area_m2(), 1.0, 2e-3) << name;
      EXPECT_GT(r.k_N_per_m, 0);
    }
}

// The root's bending stress per unit tip opening. On a narrow strip under a
// tip load, beam theory's 3 E t / (2 L^2). On the reference reed under its port load,
// statics: the width-mean stress at the clamp is 6 M / (W t^2) with M the
// load's moment F a, F = k x the FE deflection; beam theory's value lies
// below, the plate's (over 1 - nu^2) above; its second bending mode's
// near beam theory's -(E t / 2)(4.694 / L)^2. The corners' concentration
// converges under refinement (24 x 20 and 36 x 30 cells in plan).
TEST(Stiffness, RootStressPerOpeningMatchesBeamTheoryAndStatics)
{
  auto strip_p = strip(6.1e-3 / 20, 2);
  strip_p.settings.cells_along_length = 40;
  strip_p.settings.n_modes            = 1;
  const auto   s   = solve_reed(strip_p);
  const double E = strip_p.material.youngs_modulus_Pa, t = strip_p.geometry.reed_thickness_m,
               L = strip_p.geometry.reed_length_m;
  const double beam = 1.5 * E * t / (L * L), beam2 = -0.5 * E * t * std::pow(4.694091132974175 / L, 2);
  std::printf("strip: root stress %.5g MPa/um (beam %.5g), corners x%.3f\n",
              s.root_stress_per_opening_Pa_per_m * 1e-12, beam * 1e-12, s.root_stress_concentration);
  EXPECT_NEAR(s.root_stress_beam_per_opening_Pa_per_m, beam, 1e-9 * beam);
  EXPECT_NEAR(s.root_stress_per_opening_Pa_per_m / beam, 1.0, 0.02);

  auto p = reference();
  p.settings.n_modes = 4; // bending, torsion, bending, ...
  const auto   r = solve_reed(p);
  const double a = p.geometry.port_center_x_m, W = p.geometry.reed_width_m, nu = p.material.poisson_ratio;
  const double statics = 6 * r.k_N_per_m * a / (W * t * t);
  const double beam_ref = 3 * E * t / (a * (3 * L - a));
  std::printf("reference: root stress %.5g MPa/um, statics %.5g, beam %.5g, plate %.5g; corners x%.4f\n",
              r.root_stress_per_opening_Pa_per_m * 1e-12, statics * 1e-12, beam_ref * 1e-12,
              beam_ref / (1 - nu * nu) * 1e-12, r.root_stress_concentration);
  // the default mesh (24 x 20) within 3 % of statics, the finer one below within 1 %
  EXPECT_NEAR(r.root_stress_per_opening_Pa_per_m / statics, 1.0, 0.03);
  EXPECT_GT(r.root_stress_per_opening_Pa_per_m, 0.99 * beam_ref);
  EXPECT_LT(r.root_stress_per_opening_Pa_per_m, 1.01 * beam_ref / (1 - nu * nu));
  EXPECT_GT(r.root_stress_concentration, 1.0);
  std::printf("reference: second bending mode %.5g MPa/um (beam %.5g)\n",
              r.second_mode_root_stress_per_opening_Pa_per_m * 1e-12, beam2 * 1e-12);
  // the wide reed's second mode is plate-like: the same sign, within a quarter of the beam's
  EXPECT_NEAR(r.second_mode_root_stress_per_opening_Pa_per_m / beam2, 1.0, 0.25);
  p.settings.n_modes = 1;

  p.settings.cells_along_length = 36;
  p.settings.cells_across_width = 30;
  const auto fine = solve_reed(p);
  std::printf("reference, 36 x 30: root stress %.5g MPa/um, corners x%.4f\n",
              fine.root_stress_per_opening_Pa_per_m * 1e-12, fine.root_stress_concentration);
  const double fine_statics = 6 * fine.k_N_per_m * a / (W * t * t);
  EXPECT_NEAR(fine.root_stress_per_opening_Pa_per_m / fine_statics, 1.0, 0.01);
  EXPECT_LT(std::abs(fine.root_stress_per_opening_Pa_per_m / fine_statics - 1),
            std::abs(r.root_stress_per_opening_Pa_per_m / statics - 1));
  EXPECT_NEAR(fine.root_stress_concentration / r.root_stress_concentration, 1.0, 0.01);
}

namespace
{
  /// The elastica of a cantilever under a vertical dead tip load: theta'' =
  /// -alpha cos(theta) on s in [0, 1], theta(0) = 0, theta'(1) = 0, alpha =
  /// P L^2 / (E I); shooting on theta'(0) (bisection, RK4). Returns the tip's
  /// (vertical, horizontal) position over L.
  std::pair<double, double> elastica_tip(double alpha)
  {
    const auto shoot = [&](double kappa, double &y, double &x) {
      const int n = 4000;
      const double h = 1.0 / n;
      double theta = 0, omega = kappa;
      y = x = 0;
      const auto f = [&](double th, double om, double &dth, double &dom) { dth = om, dom = -alpha * std::cos(th); };
      for (int k = 0; k < n; ++k)
        {
          double a1, b1, a2, b2, a3, b3, a4, b4;
          f(theta, omega, a1, b1);
          f(theta + h / 2 * a1, omega + h / 2 * b1, a2, b2);
          f(theta + h / 2 * a2, omega + h / 2 * b2, a3, b3);
          f(theta + h * a3, omega + h * b3, a4, b4);
          // the tip position by Simpson on this step
          const double t_mid = theta + h / 4 * (a1 + a2) ; // theta at h/2 (second order is enough beside Simpson's)
          const double t_end = theta + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
          y += h / 6 * (std::sin(theta) + 4 * std::sin(t_mid) + std::sin(t_end));
          x += h / 6 * (std::cos(theta) + 4 * std::cos(t_mid) + std::cos(t_end));
          omega += h / 6 * (b1 + 2 * b2 + 2 * b3 + b4);
          theta = t_end;
        }
      return omega; // theta'(1)
    };
    double lo = 0, hi = alpha, y = 0, x = 0;
    for (int k = 0; k < 60; ++k)
      {
        const double mid = 0.5 * (lo + hi);
        (shoot(mid, y, x) > 0 ? hi : lo) = mid;
      }
    shoot(0.5 * (lo + hi), y, x);
    return {y, x};
  }
} // namespace

// The large-deflection check against the elastica: a strip under a tip load
// P = E I / L^2 bends to 0.3017 L, not the linear 1/3 L; its secant
// stiffness is 1 / (3 x 0.3017) of the linear one, its tip moves 0.0566 L
// towards the clamp. At 1 % of L the two solves agree.
TEST(Stiffness, TheLargeDeflectionCheckFollowsTheElastica)
{
  const auto [y1, x1] = elastica_tip(1.0);
  std::printf("elastica, alpha = 1: tip at y = %.5f L, x = %.5f L\n", y1, x1);
  EXPECT_NEAR(y1, 0.30172, 2e-4); // Bisshopp and Drucker (1945)
  auto p                        = strip(6.1e-3 / 20, 2);
  p.settings.cells_along_length = 40;
  p.settings.n_modes            = 0;
  const double L                = p.geometry.reed_length_m;
  SolveOptions o;
  o.compute_modes              = false;
  o.large_deflection_opening_m = y1 * L;
  const auto r = solve_reed(p, o);
  ASSERT_TRUE(r.large_deflection);
  const auto &c = *r.large_deflection;
  std::printf("strip at %.4f L: secant k / linear k = %.5f (elastica %.5f), tip shortening %.5f L (%.5f); "
              "root stress x%.4f; %u load steps, %u Newton iterations\n",
              c.opening_m / L, c.stiffness_ratio, 1 / (3 * y1), c.tip_shortening_m / L, 1 - x1,
              c.root_stress_ratio, c.load_steps, c.newton_iterations);
  EXPECT_NEAR(c.opening_m / (y1 * L), 1.0, 1e-5);
  EXPECT_NEAR(c.stiffness_ratio * 3 * y1, 1.0, 0.005);
  EXPECT_NEAR(c.tip_shortening_m / ((1 - x1) * L), 1.0, 0.03);
  // the root's moment is P times the shortened arm: x1 of the linear one's per unit force
  EXPECT_NEAR(c.root_stress_ratio / (c.stiffness_ratio * x1), 1.0, 0.02);

  o.large_deflection_opening_m = 0.01 * L;
  const auto small = solve_reed(p, o);
  EXPECT_NEAR(small.large_deflection->stiffness_ratio, 1.0, 2e-3);
  EXPECT_TRUE(small.large_deflection->failure.empty());

  // A tip 1.5 L down is reached only by stretching the strip far beyond
  // small strains: the check says it has no answer, the linear results stand.
  o.large_deflection_opening_m = 1.5 * L;
  const auto beyond = solve_reed(p, o);
  ASSERT_TRUE(beyond.large_deflection);
  EXPECT_FALSE(beyond.large_deflection->failure.empty());
  EXPECT_EQ(beyond.large_deflection->stiffness_ratio, 0.0);
  EXPECT_EQ(beyond.k_N_per_m, r.k_N_per_m);
}
