// The reed's fluid loading (FluidLoading, added_mass in stokes_solver/)
// against lubrication theory (squeeze films under a disc and a strip, each
// over a port), reciprocity, the volume the reed sweeps, and potential
// theory (a disc's added mass in open fluid, and in a thin gap).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "mesher/test_geometries.h"
#include "stokes_solver/stokes.h"

using namespace rectify;
using namespace rectify::stokes;

namespace
{
  const ReedMotion rigid{[](double, double) { return 1.0; }, true};

  FlowParameters oil()
  {
    FlowParameters p;
    p.settings.solver = "direct";
    return p;
  }
} // namespace

// A disc of radius r2 over a port of radius r1 (shut at its far end for the
// squeeze solve), gap h. Lubrication theory with the port's column at rest:
// p = -3 mu v (r2^2 - r^2) / h^3 outside the port, p(r1) over it, so
//   c = 3 pi mu (r2^4 - r1^4) / (2 h^3),  dp(v) = -3 mu (r2^2 - r1^2) / h^3,
// and for flow Q from the port, F = 3 mu Q (r2^2 - r1^2) / h^3 (reciprocity:
// K_Qv = K_vQ). The potential flow in the gap, phi = v (r^2 - r2^2) / (4 h),
// gives the added mass pi rho (r2^4 - r1^4) / (8 h).
TEST(FluidLoading, DiscSqueezeFilmMatchesLubricationTheory)
{
  const double D = 3.175e-3, l = 3e-3, r1 = D / 2, r2 = 4e-3;
  const auto   p  = oil();
  const double mu = p.fluid.viscosity_Pa_s, rho = p.fluid.density_kg_per_m3;
  for (double h : {5e-6, 50e-6})
    {
      const auto   mesh = mesher::radial_gap_mesh(D, l, r2, h, 2, 0.15e-3, 0.75e-3);
      const auto   r    = solve_stokes(mesh, p, {}, false, &rigid);
      const auto  &L    = r.loading;
      const double h3   = h * h * h;
      const double c    = 3 * M_PI * mu * (std::pow(r2, 4) - std::pow(r1, 4)) / (2 * h3);
      const double dp   = -3 * mu * (r2 * r2 - r1 * r1) / h3;
      const double m_a  = M_PI * rho * (std::pow(r2, 4) - std::pow(r1, 4)) / (8 * h);
      std::printf("disc h = %g um: c %.6e (lubrication %.6e, %+.3f %%), dp(v) %.6e (%+.3f %%), asymmetry %.1e, "
                  "A_modal %.4f mm^2 (A_eff %.4f), c at fixed dp %.4e, added mass %.5e kg (thin gap %.5e, %+.3f %%), "
                  "mass balance %.1e, %.2f s\n",
                  h * 1e6, L.K_vv_N_s_per_m, c, 100 * (L.K_vv_N_s_per_m / c - 1), L.K_Qv_Pa_s_per_m,
                  100 * (L.K_Qv_Pa_s_per_m / dp - 1), L.asymmetry, L.A_modal_m2 * 1e6, r.A_eff_m2 * 1e6,
                  L.damping_fixed_dp_N_s_per_m, L.added_mass_kg, m_a, 100 * (L.added_mass_kg / m_a - 1),
                  L.mass_balance_b_rel_error, r.wall_time_s);
      ASSERT_TRUE(L.computed);
      EXPECT_LT(L.asymmetry, 1e-8) << h;
      EXPECT_LT(L.mass_balance_b_rel_error, 1e-8) << h;
      EXPECT_NEAR(L.swept_flow_m3_per_s / (-M_PI * r2 * r2), 1.0, 1e-3) << h; // the polygon's area
      EXPECT_NEAR(L.K_QQ_Pa_s_per_m3 / r.R_gradient_dissipation_Pa_s_per_m3, 1.0, 1e-9) << h;
      EXPECT_NEAR(L.added_mass_boundary_kg / L.added_mass_kg, 1.0, 1e-6) << h;
      EXPECT_GT(L.damping_fixed_dp_N_s_per_m, 0) << h; // the dissipation's form is positive definite
      EXPECT_LT(L.damping_fixed_dp_N_s_per_m, L.K_vv_N_s_per_m) << h;
      if (h < 10e-6) // 50 um: the excess over thin-gap theory, printed
        {
          EXPECT_NEAR(L.K_vv_N_s_per_m / c, 1.0, 0.01) << h;
          EXPECT_NEAR(L.K_Qv_Pa_s_per_m / dp, 1.0, 0.01) << h;
          EXPECT_NEAR(L.added_mass_kg / m_a, 1.0, 0.01) << h;
          EXPECT_NEAR(L.A_modal_m2 / r.A_eff_m2, 1.0, 0.01) << h; // a rigid disc: modal force = force
        }
    }
}

// A plate of width w over a slot port of width s, gap h, the ends walls:
// per unit length, lubrication theory gives (x from the slot's centre line)
// p = -6 mu v (w^2/4 - x^2) / h^3 for s/2 < |x| < w/2, p(s/2) over the slot:
//   c / length = 2 [ 6 mu / h^3 (w^2/4 (w - s)/2 - (w^3 - s^3)/24) + s/2 6 mu (w^2 - s^2) / (4 h^3) ]
// which for s -> 0 is the strip's mu w^3 / h^3.
TEST(FluidLoading, StripSqueezeFilmMatchesLubricationTheory)
{
  const double s = 0.2e-3, w = 2e-3, length = 4e-3, h = 10e-6;
  const auto   p    = oil();
  const double mu   = p.fluid.viscosity_Pa_s;
  const auto   mesh = mesher::slot_gap_mesh(s, 1e-3, w, length, h, 2, 0.1e-3, 0.5e-3);
  const auto   r    = solve_stokes(mesh, p, {}, false, &rigid);
  const auto  &L    = r.loading;
  const double h3   = h * h * h;
  const double c_per_length =
    2 * (6 * mu / h3 * (w * w / 4 * (w - s) / 2 - (w * w * w - s * s * s) / 24) + s / 2 * 6 * mu * (w * w - s * s) / (4 * h3));
  const double c  = c_per_length * length;
  const double dp = -6 * mu * (w * w - s * s) / (4 * h3);
  std::printf("strip: c %.6e (lubrication %.6e, %+.3f %%; without the slot mu w^3 L / h^3 = %.6e), dp(v) %.6e "
              "(%+.3f %%), asymmetry %.1e, %zu DoFs\n",
              L.K_vv_N_s_per_m, c, 100 * (L.K_vv_N_s_per_m / c - 1), mu * w * w * w * length / h3, L.K_Qv_Pa_s_per_m,
              100 * (L.K_Qv_Pa_s_per_m / dp - 1), L.asymmetry, r.n_dofs);
  EXPECT_NEAR(L.K_vv_N_s_per_m / c, 1.0, 0.01);
  EXPECT_NEAR(L.K_Qv_Pa_s_per_m / dp, 1.0, 0.01);
  EXPECT_LT(L.asymmetry, 1e-8);
  EXPECT_LT(L.mass_balance_b_rel_error, 1e-8);
}

// A disc moving broadside in open fluid: added mass 8/3 rho a^3 (Lamb, sec.
// 108), half of it on each side: the half space above the disc, the
// potential zero on the plane beside it (odd in z) and far away. The
// potential is singular at the edge (phi ~ sqrt(distance)); the mesh is
// finest there. Both the discretisation and the far boundary's phi = 0 can
// only lower the energy: the value is approached from below.
TEST(FluidLoading, DiscAddedMassInOpenFluidIsEightThirdsRhoACubed)
{
  const double a = 1e-3, rho = 873;
  const auto   unit = [](double, double) { return 1.0; };
  double       previous = 0;
  for (double size : {0.1e-3, 0.05e-3})
    {
      const auto   mesh  = mesher::disc_half_space_mesh(a, 10 * a, 10 * a, size, 0.4);
      const auto [m, mb] = added_mass(mesh, unit, rho);
      const double exact = 8.0 / 3.0 * rho * a * a * a;
      std::printf("disc in open fluid, edge size %g um: %zu cells, added mass %.5e kg (8/3 rho a^3 = %.5e, %+.2f %%), "
                  "boundary form %+.1e\n",
                  size * 1e6, mesh.cells.size(), 2 * m, exact, 100 * (2 * m / exact - 1), mb / m - 1);
      EXPECT_LT(2 * m, exact * 1.001);
      EXPECT_GT(2 * m, previous); // from below
      EXPECT_NEAR(mb / m, 1.0, 1e-6);
      previous = 2 * m;
    }
  EXPECT_NEAR(previous / (8.0 / 3.0 * rho * a * a * a), 1.0, 0.02);
}
