// The lumped EHA model (system/): exact solutions, conservation, solver
// convergence, the analytic Jacobian, seat contact, and the tool's handling
// of bad input and interrupted sweeps.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <sstream>
#include <sundials/sundials_context.h>
#include <unistd.h>

#include "common/case_file.h"
#include "common/io.h"
#include "tests/cli_helpers.h"
#include "system/integrator.h"
#include "system/serial_vector_ops.h"
#include "model_helpers.h"
#include "system/model.h"
#include "system/reed.h"
#include "system/simulation.h"

using namespace rectify;
using namespace rectify::system;
using namespace rectify::test_support;

namespace
{
  using test_support::reference;
  using test_support::reference_map;

  Model make_model(const SystemParameters &p, ValveModel v, Scenario s, double f,
                   double pp = -1, double bias = -1)
  {
    return Model(p, reference_map(p), v, s,
                 Drive::sine(f, pp < 0 ? p.drive.current_pp_A : pp, bias < 0 ? p.drive.current_bias_A : bias));
  }

  RunOptions options(const SystemParameters &p, std::size_t cycles) { return run_options(p, cycles); }

  /// One reed (eq. 3.9) under a prescribed pressure difference dp(t), on the
  /// same reed functions and integrator as the model.
  class ReedRig : public OdeSystem
  {
  public:
    ReedRig(ReedConstants c, std::function<double(double)> dp)
      : c_(c)
      , dp_(std::move(dp))
    {}
    std::size_t n_states() const override { return 2; }
    void        rhs(double t, std::span<const double> y, std::span<double> ydot) const override
    {
      ydot[0] = seated ? 0.0 : y[1];
      ydot[1] = seated ? 0.0 : reed_acceleration(c_, y[0], y[1], dp_(t) * c_.area);
    }
    void jacobian(double, std::span<const double>, DenseView J) const override
    {
      if (seated)
        return;
      J(0, 1) = 1.0;
      J(1, 0) = -c_.stiffness / c_.mass;
      J(1, 1) = -c_.damping / c_.mass;
    }
    std::size_t n_roots() const override { return 1; }
    void        roots(double t, std::span<const double> y, std::span<double> g) const override
    {
      g[0] = reed_root(seated, y[0], dp_(t) * c_.area);
    }
    bool handle_events(double t, std::span<double> y, std::span<const int>) override
    {
      seated = reed_on_root(c_, seated, dp_(t) * c_.area, y[0], y[1]);
      return true;
    }
    bool seated = true;

  private:
    ReedConstants                 c_;
    std::function<double(double)> dp_;
  };

  IntegratorOptions rig_options()
  {
    IntegratorOptions o;
    o.relative_tolerance  = 1e-9;
    o.absolute_tolerances = {1e-15, 1e-12};
    return o;
  }
} // namespace

TEST(Integrator, OptimisedVectorOperationsEqualTheLibrarysBitForBit)
{
  // Each replaced operation against SUNDIALS's own serial one on the same
  // inputs: every special case of a x + b y (coefficients 1, -1, equal,
  // opposite, 0, general), in place and not, vectors of odd and even
  // lengths with values of every sign and size; and the reductions.
  SUNContext context = nullptr;
  ASSERT_EQ(SUNContext_Create(nullptr, &context), 0);
  std::mt19937                           rng(17);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0), exponent(-30.0, 30.0);
  const auto bits_equal = [](N_Vector a, N_Vector b) {
    return std::memcmp(N_VGetArrayPointer(a), N_VGetArrayPointer(b), N_VGetLength(a) * sizeof(double)) == 0;
  };
  const auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  const double coefficients[] = {1.0, -1.0, 0.0, 0.5, -0.5, 2.3, -2.3, 1e-7, 3.0 / 7.0};
  int          compared       = 0;
  for (sunindextype n : {1, 2, 3, 7, 16, 33})
    {
      // own[k] carries the optimised operations, lib[k] the library's; both hold the same values
      N_Vector own[3], lib[3];
      for (int k = 0; k < 3; ++k)
        {
          own[k] = N_VNew_Serial(n, context);
          lib[k] = N_VNew_Serial(n, context);
          use_optimised_serial_ops(own[k]);
        }
      const auto fill = [&]() {
        for (int k = 0; k < 3; ++k)
          for (sunindextype i = 0; i < n; ++i)
            N_VGetArrayPointer(lib[k])[i] = N_VGetArrayPointer(own[k])[i] =
              (i % 5 == 3 ? 1.0 : mantissa(rng)) * std::pow(10.0, exponent(rng) * (k == 2 ? 0.1 : 1.0));
      };
      for (double a : coefficients)
        for (double b : coefficients)
          for (int alias = 0; alias < 3; ++alias) // z separate, z == x, z == y
            {
              fill();
              const int z = alias == 0 ? 2 : alias - 1;
              own[0]->ops->nvlinearsum(a, own[0], b, own[1], own[z]);
              N_VLinearSum_Serial(a, lib[0], b, lib[1], lib[z]);
              for (int k = 0; k < 3; ++k)
                EXPECT_TRUE(bits_equal(own[k], lib[k]))
                  << "a x + b y, a = " << a << ", b = " << b << ", alias " << alias;
              ++compared;
            }
      for (double c : coefficients)
        for (bool in_place : {false, true})
          {
            fill();
            own[0]->ops->nvscale(c, own[0], own[in_place ? 0 : 2]);
            N_VScale_Serial(c, lib[0], lib[in_place ? 0 : 2]);
            EXPECT_TRUE(bits_equal(own[in_place ? 0 : 2], lib[in_place ? 0 : 2])) << "scale " << c;
            fill();
            own[0]->ops->nvconst(c, own[2]);
            N_VConst_Serial(c, lib[2]);
            EXPECT_TRUE(bits_equal(own[2], lib[2])) << "const " << c;
            fill();
            own[0]->ops->nvaddconst(own[0], c, own[2]);
            N_VAddConst_Serial(lib[0], c, lib[2]);
            EXPECT_TRUE(bits_equal(own[2], lib[2])) << "add const " << c;
          }
      fill();
      own[0]->ops->nvprod(own[0], own[1], own[2]);
      N_VProd_Serial(lib[0], lib[1], lib[2]);
      EXPECT_TRUE(bits_equal(own[2], lib[2])) << "product";
      own[0]->ops->nvdiv(own[0], own[1], own[2]);
      N_VDiv_Serial(lib[0], lib[1], lib[2]);
      EXPECT_TRUE(bits_equal(own[2], lib[2])) << "quotient";
      own[0]->ops->nvabs(own[0], own[2]);
      N_VAbs_Serial(lib[0], lib[2]);
      EXPECT_TRUE(bits_equal(own[2], lib[2])) << "abs";
      own[0]->ops->nvinv(own[0], own[2]);
      N_VInv_Serial(lib[0], lib[2]);
      EXPECT_TRUE(bits_equal(own[2], lib[2])) << "inverse";
      // reductions: the weights of CVODE's kind (1 / (rtol |y| + atol)) in own[2]
      EXPECT_TRUE(same(own[0]->ops->nvwrmsnorm(own[0], own[2]), N_VWrmsNorm_Serial(lib[0], lib[2]))) << "n " << n;
      EXPECT_TRUE(same(own[0]->ops->nvwsqrsumlocal(own[0], own[2]), N_VWSqrSumLocal_Serial(lib[0], lib[2])));
      EXPECT_TRUE(same(own[0]->ops->nvdotprod(own[0], own[1]), N_VDotProd_Serial(lib[0], lib[1])));
      EXPECT_TRUE(same(own[0]->ops->nvmaxnorm(own[0]), N_VMaxNorm_Serial(lib[0])));
      EXPECT_TRUE(same(own[0]->ops->nvmin(own[0]), N_VMin_Serial(lib[0])));
      // a clone (CVODE makes its vectors so) keeps the optimised operations
      N_Vector clone = N_VClone(own[0]);
      EXPECT_EQ(clone->ops->nvlinearsum, own[0]->ops->nvlinearsum);
      EXPECT_NE(clone->ops->nvlinearsum, lib[0]->ops->nvlinearsum);
      N_VDestroy(clone);
      for (int k = 0; k < 3; ++k)
        {
          N_VDestroy(own[k]);
          N_VDestroy(lib[k]);
        }
    }
  EXPECT_EQ(compared, 6 * 9 * 9 * 3);
  SUNContext_Free(&context);
}

TEST(Reed, RestsOnItsSeatWhileHeldClosedThenLiftsAndRingsAtItsDampedFrequency)
{
  const auto    p = reference();
  const ModelConstants c(p, Scenario::no_flow);
  const double  dp_open = 20e3, t_step = 2e-3;
  ReedRig       rig(c.reed, [&](double t) { return t < t_step ? -2e3 : dp_open; });
  const double  y0[2] = {0.0, 0.0};
  Integrator    integ(rig, 0.0, y0, rig_options());

  // Held closed: the reed stays exactly on its seat.
  for (double t = 1e-4; t < t_step; t += 1e-4)
    {
      integ.advance_to(t);
      EXPECT_EQ(integ.state()[0], 0.0);
      EXPECT_TRUE(rig.seated);
    }
  // Opened: it lifts, rings and settles at dp A_r / k_r.
  const double x_static = dp_open * c.reed.area / c.reed.stiffness;
  std::vector<double> up_crossings;
  double              previous = -x_static, t_prev = t_step;
  for (double t = t_step + 2e-6; t < t_step + 0.04; t += 2e-6)
    {
      integ.advance_to(t);
      const double e = integ.state()[0] - x_static;
      EXPECT_GE(integ.state()[0], 0.0);
      if (previous < 0 && e >= 0)
        up_crossings.push_back(t_prev + (t - t_prev) * (-previous) / (e - previous));
      previous = e;
      t_prev   = t;
    }
  EXPECT_FALSE(rig.seated);
  EXPECT_NEAR(integ.state()[0], x_static, 1e-4 * x_static);

  const double omega_n = std::sqrt(c.reed.stiffness / c.reed.mass);
  const double zeta    = c.reed.damping / (2 * std::sqrt(c.reed.stiffness * c.reed.mass));
  const double f_d     = omega_n * std::sqrt(1 - zeta * zeta) / (2 * std::numbers::pi);
  ASSERT_GE(up_crossings.size(), 6u);
  const double period = (up_crossings[5] - up_crossings[0]) / 5.0;
  EXPECT_NEAR(1.0 / period, f_d, 1e-3 * f_d);
  EXPECT_NEAR(f_d, 674.5, 1.0); // about 680 Hz undamped with the thesis's values
  EXPECT_NEAR(omega_n / (2 * std::numbers::pi), 680.0, 1.0);
}

TEST(Reed, ReleasedReedFallsBackOntoItsSeatAndStays)
{
  const auto    p = reference();
  ModelConstants c(p, Scenario::no_flow);
  c.reed.restitution = 0.5;
  ReedRig      rig(c.reed, [](double) { return -5e3; });
  rig.seated         = false;
  const double y0[2] = {50e-6, 0.0};
  Integrator   integ(rig, 0.0, y0, rig_options());
  double       lowest = 1.0;
  for (double t = 1e-5; t < 0.05; t += 1e-5)
    {
      integ.advance_to(t);
      lowest = std::min(lowest, integ.state()[0]);
    }
  EXPECT_TRUE(rig.seated);
  EXPECT_EQ(integ.state()[0], 0.0);
  EXPECT_GE(lowest, 0.0);
  EXPECT_GE(integ.stats().events, 3); // bounced (restitution 0.5) before it came to rest
}

TEST(Model, DerivedConstantsReproduceTableA1)
{
  // Table A.1 lists derived values beside the inputs they come from.
  const ModelConstants c(reference(), Scenario::loaded);
  EXPECT_NEAR(c.k_td, 38.8e6, 0.005 * 38.8e6);        // eq. 3.2
  EXPECT_NEAR(c.k_f, 233e6, 0.005 * 233e6);           // eq. 3.4
  EXPECT_NEAR(c.m_f, 0.561e-3, 0.002 * 0.561e-3);     // eq. 3.3
  EXPECT_NEAR(c.reed.damping, 0.4, 0.002);            // sec. 3.1.3: b_r = 0.4 N s/m
  EXPECT_NEAR(std::sqrt(c.reed.stiffness / c.reed.mass) / (2 * std::numbers::pi), 680.0, 1.0);
  EXPECT_NEAR(c.m_l, 50 * 0.45359237, 1e-4);          // sec. 5.2: 50 lb
  EXPECT_EQ(ModelConstants(reference(), Scenario::no_flow).m_l, 1e12); // sec. 5.1
  // eq. 3.28 for the chosen lines, and eq. 3.29 for the chamber
  EXPECT_NEAR(c.R3, 128 * 0.0386 * 0.3048 / (std::numbers::pi * std::pow(4.572e-3, 4)), 1e3);
  EXPECT_NEAR(c.C_ch, c.A_pi * 1.27e-3 / c.beta_eff, 1e-25);
}

TEST(Parameters, ReedPropertiesComeFromAReedMapByThickness)
{
  // The map `rectify map-stiffness` writes feeds the system model: k_r, m_r
  // and the root stress interpolated linearly in thickness.
  const auto dir = std::filesystem::temp_directory_path() / "rectify_test_reedmap";
  std::filesystem::create_directories(dir);
  write_file_atomic(dir / "reed-map.csv",
                    "# meta: {}\nthickness_m,stiffness_N_per_m,effective_mass_eq321_kg,modal_mass_in_fluid_kg,"
                    "root_stress_per_opening_Pa_per_m,root_stress_concentration,"
                    "second_mode_root_stress_per_opening_Pa_per_m\n"
                    "1e-4,3000,3e-4,2e-5,1.2e12,1.06,-6e12\n2e-4,24000,4e-4,3e-5,2.4e12,1.08,-12e12\n");
  const auto read = [&](const std::string &extra) {
    return ReedParameters::from_case(CaseFile::parse(
      "[reed]\nproperties_map = \"reed-map.csv\"\n" + extra, "r.toml", dir));
  };
  const auto p = read("properties_thickness_m = 1.5e-4\n");
  EXPECT_NEAR(p.stiffness_N_per_m, 13500, 1e-9);
  EXPECT_NEAR(p.effective_mass_kg, 3.5e-4, 1e-15);
  EXPECT_NE(p.source.find("reed-map.csv"), std::string::npos);
  EXPECT_NEAR(p.root_stress_per_opening_Pa_per_m, 1.8e12, 1.8e12 * 1e-12);
  EXPECT_NEAR(p.second_mode_root_stress_per_opening_Pa_per_m, -9e12, 9e12 * 1e-12);
  EXPECT_NE(p.stress_source.find("reed map"), std::string::npos) << p.stress_source;
  EXPECT_NE(p.stress_source.find("1.07 x"), std::string::npos) << p.stress_source;
  // Taken into the whole model (not replaced by [geometry]'s beam theory).
  const auto whole = SystemParameters::from_case(
    CaseFile::parse("[reed]\nproperties_map = \"reed-map.csv\"\nproperties_thickness_m = 1.5e-4\n", "r.toml", dir));
  EXPECT_NEAR(whole.reed.root_stress_per_opening_Pa_per_m, 1.8e12, 1.8e12 * 1e-12);
  // A map without the stress (an earlier version's, or one written by hand)
  // is refused: the Goodman factor needs it.
  write_file_atomic(dir / "old-map.csv", "# meta: {}\nthickness_m,stiffness_N_per_m,effective_mass_eq321_kg\n"
                                         "1e-4,3000,3e-4\n2e-4,24000,4e-4\n");
  try
    {
      ReedParameters::from_case(CaseFile::parse(
        "[reed]\nproperties_map = \"old-map.csv\"\nproperties_thickness_m = 1.5e-4\n", "r.toml", dir));
      ADD_FAILURE() << "a reed map without the root stress was accepted";
    }
  catch (const InputError &e)
    {
      for (const char *part : {"r.toml", "[reed] properties_map", "old-map.csv", "root_stress_per_opening_Pa_per_m",
                               "map-stiffness"})
        EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << part << " not in: " << e.what();
    }
  EXPECT_NEAR(read("properties_thickness_m = 1e-4\nproperties_mass = \"modal-in-fluid\"\n").effective_mass_kg,
              2e-5, 1e-15);
  EXPECT_THROW(read("properties_thickness_m = 3e-4\n"), InputError);
  EXPECT_THROW(read("properties_thickness_m = 1.5e-4\nstiffness_N_per_m = 6650\n"), InputError);
  std::filesystem::remove_all(dir);
}

TEST(Model, AnalyticJacobianMatchesFiniteDifferences)
{
  const auto   p = reference();
  std::mt19937 rng(42);
  for (auto valves : {ValveModel::dynamic, ValveModel::ideal})
    for (int trial = 0; trial < 8; ++trial)
      {
        Model model = make_model(p, valves, trial % 2 ? Scenario::loaded : Scenario::no_flow, 100);
        model.set_closed(0, trial % 4 == 0);
        model.set_closed(1, trial % 3 == 0);
        const auto               typical = model.typical_sizes();
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        std::vector<double>      y(model.n_states());
        for (std::size_t i = 0; i < y.size(); ++i)
          y[i] = typical[i] * u(rng);
        // reed openings inside the map's steep part, never on a node
        y[state::outlet_reed_x] = (1 + 200 * std::abs(u(rng))) * 1.013e-6;
        y[state::inlet_reed_x]  = (1 + 200 * std::abs(u(rng))) * 1.017e-6;
        const std::size_t   n = model.n_states();
        std::vector<double> J(n * n, 0.0);
        model.jacobian(0.01, y, DenseView{J.data(), n});
        std::vector<double> fp(n), fm(n);
        for (std::size_t j = 0; j < n; ++j)
          {
            // The rhs is linear in every state but the reed openings, whose
            // R(x) varies on a 40 um scale: h = 1e-4 of a typical size keeps
            // both the truncation and the round-off error far below 1e-5.
            const double h  = 1e-4 * typical[j];
            auto         yp = y, ym = y;
            yp[j] += h;
            ym[j] -= h;
            model.rhs(0.01, yp, fp);
            model.rhs(0.01, ym, fm);
            for (std::size_t i = 0; i < n; ++i)
              {
                const double fd    = (fp[i] - fm[i]) / (2 * h);
                const double exact = J[j * n + i];
                EXPECT_NEAR(exact, fd, 1e-5 * std::abs(fd) + 1e-10 * std::abs(fp[i]) / typical[j])
                  << to_string(valves) << " trial " << trial << " d f[" << i << "]/d y[" << j << "]";
              }
          }
      }
}

TEST(Model, ClosedChamberReachesTheStaticPressureAndHoldsIt)
{
  // A slow ramp of the current (0.5 Hz, 0 -> 10 A -> 0) in the no-flow case:
  // at the peak the outlet pressure is the static solution of
  //   k_eff x_p + p A_pi = N q k_td I,   p (C_ch + C_h) = A_pi x_p,
  // and while the current falls the closed outlet valve holds it, losing only
  // what leaks through its closed resistance R(0) = 1e17.
  const auto p      = reference();
  Model      model  = make_model(p, ValveModel::dynamic, Scenario::no_flow, 0.5, 10.0, 5.0);
  auto       o      = options(p, 1);
  o.record          = true;
  o.samples_per_cycle = 400;
  const RunResult r = run(model, o);
  const auto     &c = model.constants();
  const double    F = c.force_per_ampere * 10.0;
  const double    x = F / (c.k_eff + c.A_pi * c.A_pi / (c.C_ch + c.C_h));
  const double    p_static = c.A_pi * x / (c.C_ch + c.C_h);
  const auto      p_h      = r.series->column("high_pressure_Pa");
  const auto      p_ch     = r.series->column("chamber_pressure_Pa");
  const auto      t        = r.series->column("time_s");
  EXPECT_NEAR(p_h[199], p_static, 5e-3 * p_static); // t = 1 s, the current's peak
  // Held: the drop after the peak is the leakage through R(0) + R3, integrated.
  double leak = 0;
  for (std::size_t k = 200; k < t.size(); ++k)
    leak += 0.5 * (t[k] - t[k - 1]) *
            ((p_h[k] - p_ch[k]) + (p_h[k - 1] - p_ch[k - 1])) / (1e17 + c.R3) / c.C_h;
  const double drop = p_h[199] - p_h.back();
  EXPECT_GT(drop, 0.0);
  EXPECT_LT(drop, 0.01 * p_static);
  EXPECT_NEAR(drop, leak, 0.05 * leak);
  // The chamber refilled to the bias pressure.
  EXPECT_NEAR(p_ch.back(), 0.0, 1e-3 * p_static);
  EXPECT_LT(r.volume_balance_rel_error, 1e-8);
}

TEST(Model, NoFlowStallPressureIsTheClosedChamberPressureAtFullStroke)
{
  // At stall no oil passes the outlet valve: the outlet side holds the
  // pressure a closed chamber reaches at the peak force,
  //   p = A_pi F / (k_eff C_ch + A_pi^2),  F = N q k_td I_max,
  // which is the low-frequency stored pressure of Fig. 5.3 (4 A p-p, 2 A bias).
  const auto p = reference();
  for (auto valves : {ValveModel::ideal, ValveModel::dynamic})
    {
      Model        model = make_model(p, valves, Scenario::no_flow, 10, 4, 2);
      auto         o     = options(p, 20);
      o.settle           = true;
      const auto   r     = run(model, o);
      const auto  &c     = model.constants();
      const double F     = c.force_per_ampere * 4.0;
      const double stall = c.A_pi * F / (c.k_eff * c.C_ch + c.A_pi * c.A_pi);
      EXPECT_NEAR(r.stored_pressure_Pa, stall, 5e-3 * stall) << to_string(valves);
    }
}

TEST(Model, ReedsNeverPassTheirSeatsAndTheOutletShutsDuringRefill)
{
  const auto p     = reference();
  Model      model = make_model(p, ValveModel::dynamic, Scenario::no_flow, 10);
  auto       o     = options(p, 3);
  o.record         = true;
  const RunResult r = run(model, o);
  EXPECT_GE(r.min_reed_opening_m, 0.0);
  const auto x_ro = r.series->column("outlet_reed_m");
  const auto p_ch = r.series->column("chamber_pressure_Pa");
  const auto p_o  = r.series->column("outlet_pressure_Pa");
  std::size_t n_refill = 0;
  for (std::size_t k = 0; k < x_ro.size(); ++k)
    if (p_o[k] - p_ch[k] > 1e5) // pressure holds the outlet reed on its seat
      {
        ++n_refill;
        EXPECT_EQ(x_ro[k], 0.0) << "sample " << k;
      }
  EXPECT_GT(n_refill, 100u);
  EXPECT_GT(r.n_seat_impacts, 0u);
  EXPECT_GT(r.max_outlet_reed_opening_m, 1e-6);
}

TEST(Model, VolumeBalanceClosesToSolverTolerance)
{
  const auto p = reference();
  for (auto [scenario, f] : {std::pair{Scenario::no_flow, 25.0}, std::pair{Scenario::loaded, 400.0}})
    for (auto valves : {ValveModel::dynamic, ValveModel::ideal})
      {
        Model           model = make_model(p, valves, scenario, f);
        const RunResult r     = run(model, options(p, 10));
        EXPECT_LT(r.volume_balance_rel_error, 1e-8) << to_string(scenario) << " " << to_string(valves);
        EXPECT_GT(std::abs(r.pumped_volume_m3), 0.0);
      }
}

TEST(Model, HalvingTolerancesMovesTheMetricsLessThanHalfAPercent)
{
  // Settled runs, as the sweeps make them, at operating points whose response
  // is periodic (loaded: points of the 10-3500 Hz linear sweep grid). Where
  // the loaded model flutters non-periodically or has coexisting orbits, the
  // mean depends on the trajectory, not on the tolerance: see
  // docs/chapter5-comparison.md. (No-flow at 50 and 100 Hz with 4 A p-p is
  // not used: its cycle-end states still wander by 1-3 % of their range
  // after settling, and the regime check flips with a 1e-13 m change of the
  // seat contact; the stored pressure agrees either way.)
  const auto p = reference();
  struct Case
  {
    Scenario scenario;
    double   f;
    double   pp, bias;
  };
  const double step = (3500.0 - 10.0) / 99.0;
  for (const Case &k : {Case{Scenario::no_flow, 200, 4, 2}, Case{Scenario::no_flow, 400, 4, 2},
                        Case{Scenario::loaded, 10 + 1 * step, 20, 10},
                        Case{Scenario::loaded, 10 + 11 * step, 20, 10},
                        Case{Scenario::loaded, 10 + 17 * step, 20, 10}})
    {
      double values[2];
      for (int h = 0; h < 2; ++h)
        {
          Model model = make_model(p, ValveModel::dynamic, k.scenario, k.f, k.pp, k.bias);
          auto  o     = options(p, 50);
          o.settle    = true;
          o.samples_per_cycle = 16;
          o.relative_tolerance *= h == 0 ? 1.0 : 0.5;
          const RunResult r = run(model, o);
          EXPECT_NE(r.regime, "non-periodic") << k.f << " Hz";
          values[h] = k.scenario == Scenario::no_flow ? r.stored_pressure_Pa : r.mean_velocity_m_per_s;
        }
      EXPECT_NEAR(values[1], values[0], 5e-3 * std::abs(values[0]))
        << to_string(k.scenario) << " at " << k.f << " Hz";
    }
}

TEST(Model, PeriodicResponseIsRecognisedAndHasNoSamplingError)
{
  const auto p     = reference();
  Model      model = make_model(p, ValveModel::ideal, Scenario::no_flow, 50, 4, 2);
  auto       o     = options(p, 50);
  o.settle         = true;
  const RunResult r = run(model, o);
  EXPECT_TRUE(r.settled);
  EXPECT_EQ(r.regime, "periodic");
  EXPECT_LT(r.metric_stderr, 1e-4 * r.stored_pressure_Pa);
}

TEST(Model, FiniteDifferenceJacobianGivesTheSameResults)
{
  const auto p = reference();
  double     values[2];
  for (int fd = 0; fd < 2; ++fd)
    {
      Model model = make_model(p, ValveModel::dynamic, Scenario::no_flow, 25);
      auto  o     = options(p, 5);
      o.finite_difference_jacobian = fd == 1;
      values[fd]                   = run(model, o).stored_pressure_Pa;
    }
  EXPECT_NEAR(values[1], values[0], 1e-3 * values[0]);
}

TEST(Model, IdealValvesWithoutLoadPumpTheSweptVolumeEachCycle)
{
  // eq. 3.39: with ideal valves and no load, the mean flow is A_pi * stroke * f,
  // so the actuator's mean velocity rises linearly with frequency.
  auto p         = reference();
  p.load.mass_kg = 1e-3;
  std::vector<double> v;
  for (double f : {5.0, 10.0, 20.0})
    {
      Model      model = make_model(p, ValveModel::ideal, Scenario::loaded, f);
      RunOptions o     = options(p, 10);
      o.settle         = true;
      const RunResult r = run(model, o);
      const double    ideal = model.constants().A_pi * r.piston_stroke_m * f / model.constants().A_po;
      EXPECT_NEAR(r.mean_velocity_m_per_s, ideal, 0.02 * ideal) << f << " Hz";
      v.push_back(r.mean_velocity_m_per_s);
    }
  EXPECT_NEAR(v[1] / v[0], 2.0, 0.02);
  EXPECT_NEAR(v[2] / v[1], 2.0, 0.02);
}

TEST(Model, RecordedDriveWaveformReproducesTheSine)
{
  // The same current as a CSV table (2000 rows a cycle, linear interpolation)
  // gives the same stored pressure as the analytic sine.
  const auto  p   = reference();
  const auto  dir = std::filesystem::temp_directory_path() / "rectify_test_drive";
  std::filesystem::create_directories(dir);
  const double f     = 25.0;
  const Drive  sine  = Drive::sine(f, 20, 10);
  std::string  table = "time_s,current_A\n";
  for (int k = 0; k <= 4 * 2000; ++k)
    {
      const double t = k / (2000.0 * f);
      table += format_number(t) + "," + format_number(sine.current_A(t)) + "\n";
    }
  write_file_atomic(dir / "drive.csv", table);
  double values[2];
  for (int csv = 0; csv < 2; ++csv)
    {
      Model model(p, reference_map(p), ValveModel::dynamic, Scenario::no_flow,
                  csv ? Drive::from_csv(dir / "drive.csv", f) : sine);
      values[csv] = run(model, options(p, 4)).stored_pressure_Pa;
    }
  EXPECT_NEAR(values[1], values[0], 1e-3 * values[0]);
  // A run longer than the table is refused before it starts.
  Model too_long(p, reference_map(p), ValveModel::dynamic, Scenario::no_flow,
                 Drive::from_csv(dir / "drive.csv", f));
  EXPECT_THROW(run(too_long, options(p, 5)), InputError);
  write_file_atomic(dir / "bad.csv", "time_s,current_A\n0,0\n0.1,1\n0.1,2\n");
  EXPECT_THROW(Drive::from_csv(dir / "bad.csv", f), InputError);
  std::filesystem::remove_all(dir);
}

TEST(Model, EntrainedAirSoftensTheOilAsEq326Says)
{
  // Thesis sec. 3.2.1: at a 1 ksi bias, 1 % of air cuts the bulk modulus by
  // more than 60 % (with a typical mineral oil, 1.6 GPa, gamma = 1.4).
  FluidParameters fluid;
  fluid.bulk_modulus_Pa         = 1.6e9;
  fluid.bias_pressure_Pa        = 6.894757e6;
  fluid.gas_heat_capacity_ratio = 1.4;
  fluid.entrained_air_fraction  = 0.0;
  EXPECT_DOUBLE_EQ(fluid.effective_bulk_modulus_Pa(), 1.6e9);
  fluid.entrained_air_fraction = 0.01;
  const double beta            = fluid.effective_bulk_modulus_Pa();
  EXPECT_NEAR(beta, 1.0 / (0.99 / 1.6e9 + 0.01 / (1.4 * 6.894757e6)), 1.0);
  EXPECT_LT(beta, 0.4 * 1.6e9);
  EXPECT_GT(beta, 0.3 * 1.6e9);
}

// ------------------------------------------------------------------ the tool

TEST(Cli, BadCaseValuesExitWithTheKeyAndWriteNothing)
{
  const auto dir = scratch("bad");
  std::filesystem::copy(reference_case_path().parent_path() / "thesis-resistance.csv", dir);
  write_file_atomic(dir / "neg.toml", replace(reference_text(), "effective_mass_kg = 0.3643e-3",
                                              "effective_mass_kg = -0.3643e-3"));
  auto r = rectify_cli("simulate --case " + (dir / "neg.toml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("[reed] effective_mass_kg"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("-0.0003643"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));

  write_file_atomic(dir / "typo.toml", replace(reference_text(), "[load]\n", "[load]\nmas_kg = 3\n"));
  r = rectify_cli("sweep --case " + (dir / "typo.toml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("[load] mas_kg"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));

  r = rectify_cli("simulate --case " + (dir / "missing.toml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("missing.toml"), std::string::npos) << r.output;
}

TEST(Cli, CheckValidatesTheReferenceCaseAndRejectsATypo)
{
  const auto dir = scratch("check");
  auto       r   = rectify_cli("check --out " + (dir / "ok").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "ok" / "summary.json");
  EXPECT_TRUE(nlohmann::json::parse(in)["valid"].get<bool>());
  write_file_atomic(dir / "typo.toml", "[geometry]\nreed_thicknes_m = 1e-4\n");
  r = rectify_cli("check --case " + (dir / "typo.toml").string() + " --out " + (dir / "bad").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("[geometry] reed_thicknes_m"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
}

TEST(Cli, NonMonotoneMapIsRejectedWithFileAndRow)
{
  const auto dir = scratch("map");
  write_file_atomic(dir / "map.csv", "opening_m,R_Pa_s_per_m3\n0,1e17\n2e-6,2e11\n1e-6,1e11\n");
  write_file_atomic(dir / "case.toml", replace(reference_text(), "\"thesis-resistance.csv\"", "\"map.csv\""));
  const auto r = rectify_cli("simulate --case " + (dir / "case.toml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("map.csv"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("row 3"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out" / "summary.json"));
}

TEST(Cli, SimulateWritesSummaryTableAndPlot)
{
  const auto dir = scratch("sim");
  const auto r   = rectify_cli("simulate --scenario no-flow --frequency 25 --cycles 3 --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "summary.json");
  const auto    s = nlohmann::json::parse(in);
  for (const char *key : {"stored_pressure_Pa", "mean_velocity_m_per_s", "wall_time_s"})
    EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_GT(s["stored_pressure_Pa"].get<double>(), 0.0);
  const auto csv = read_csv(dir / "timeseries.csv");
  EXPECT_EQ(csv.rows.size(), 3u * 200u);
  for (const auto &e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().string().find(".tmp."), std::string::npos) << e.path();
}

TEST(Cli, StiffnessWritesSummaryShapeAndVtu)
{
  const auto dir = scratch("stiffness");
  // a stop 1.2 mm above the seat: a tip lift of 1.073 mm, beyond 10 % of L,
  // so checked there and said on the console
  const std::string mesh = "[stiffness]\ncells_along_length = 12\ncells_across_width = 10\n"
                           "cells_through_thickness = 1\nn_modes = 2\n";
  write_file_atomic(dir / "coarse.toml", "[geometry]\nstop_height_m = 1.2e-3\n" + mesh);
  const auto r = rectify_cli("stiffness --case " + (dir / "coarse.toml").string() + " --out " + (dir / "out").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "out" / "summary.json");
  const auto    s = nlohmann::json::parse(in);
  for (const char *key : {"k_N_per_m", "tip_deflection_m", "frequencies_Hz", "modal_mass_kg",
                          "frequency_in_fluid_Hz", "n_dofs", "wall_time_s"})
    EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_EQ(s["frequencies_Hz"].size(), 2u);
  const auto &check = s.at("large_deflection_at_stop");
  ASSERT_TRUE(check.is_object()) << s.dump(1);
  ASSERT_FALSE(check.contains("failure")) << check.dump(1);
  EXPECT_NEAR(check.at("opening_m").get<double>(), 1.073e-3, 1e-8);
  EXPECT_GT(check.at("stiffness_ratio").get<double>(), 1.0);
  EXPECT_NE(r.output.find("at the stop's lift 1.073 mm"), std::string::npos) << r.output;

  // a stop 3 mm up in a 3 mm pocket: the root strains over 2 %, no elastic
  // answer there: said, and the linear results kept
  write_file_atomic(dir / "tall.toml", "[geometry]\npocket_height_m = 3e-3\nstop_height_m = 3e-3\n" + mesh);
  const auto tall = rectify_cli("stiffness --case " + (dir / "tall.toml").string() + " --out " + (dir / "tall").string());
  ASSERT_EQ(tall.exit_code, 0) << tall.output;
  std::ifstream tall_in(dir / "tall" / "summary.json");
  const auto    t = nlohmann::json::parse(tall_in);
  EXPECT_NEAR(t.at("large_deflection_at_stop").at("opening_m").get<double>(), 2.873e-3, 1e-8);
  EXPECT_NE(t.at("large_deflection_at_stop").at("failure").get<std::string>().find("beyond small strains"),
            std::string::npos);
  EXPECT_NEAR(t.at("k_N_per_m").get<double>(), s.at("k_N_per_m").get<double>(), 1e-9 * s.at("k_N_per_m").get<double>());
  EXPECT_NE(tall.output.find("no large-deflection check"), std::string::npos) << tall.output;
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "reed.vtu"));
  // the shape table the mesher reads: s from 0 to L, phi from 0 to 1, monotone
  const auto shape = read_csv(dir / "out" / "shape.csv");
  const auto cs = shape.column_index("s_m", "shape.csv"), cp = shape.column_index("phi", "shape.csv");
  EXPECT_EQ(shape.rows.front()[cs], 0.0);
  EXPECT_NEAR(shape.rows.back()[cs], 6.1e-3, 1e-12);
  EXPECT_NEAR(shape.rows.back()[cp], 1.0, 1e-3);
  for (std::size_t i = 1; i < shape.rows.size(); ++i)
    EXPECT_GT(shape.rows[i][cp], shape.rows[i - 1][cp]);
}

TEST(Cli, MapStiffnessResumesAndRejectsBadRanges)
{
  const auto dir = scratch("map_stiffness");
  write_file_atomic(dir / "coarse.toml", "[stiffness]\ncells_along_length = 8\ncells_across_width = 6\n"
                                         "cells_through_thickness = 1\nn_modes = 1\n");
  const std::string args = "map-stiffness --case " + (dir / "coarse.toml").string() +
                           " --thickness 0.1e-3:0.2e-3:3 --out " + (dir / "out").string();
  auto r = rectify_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in1(dir / "out" / "summary.json");
  const auto    first = nlohmann::json::parse(in1);
  EXPECT_NEAR(first["k_loglog_slope"].get<double>(), 3.0, 0.06);
  r = rectify_cli(args); // everything finished: nothing is recomputed
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in2(dir / "out" / "summary.json");
  const auto    second = nlohmann::json::parse(in2);
  EXPECT_EQ(second["runs_resumed"], 3);
  EXPECT_EQ(second["k_N_per_m"], first["k_N_per_m"]);
  r = rectify_cli("map-stiffness --thickness 0.2e-3:0.1e-3:3 --out " + (dir / "bad").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("FROM <= TO"), std::string::npos) << r.output;
  r = rectify_cli("map-stiffness --thickness 1e-4:2e-4 --out " + (dir / "bad").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
}

TEST(Cli, InterruptedSweepResumesWithoutRepeatingOrLosingRuns)
{
  const auto  dir  = scratch("sweep");
  const std::string args = "sweep --scenario no-flow --from 100 --to 400 --n 3 --cycles 5 "
                           "--series ideal --jobs 2 --quiet --out " + dir.string();
  auto r = rectify_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in1(dir / "summary.json");
  const auto    first = nlohmann::json::parse(in1);

  // Simulate a kill during the third run: its line never made it, the last one is cut.
  std::ifstream          partial(dir / "sweep-partial.csv");
  std::vector<std::string> lines;
  for (std::string line; std::getline(partial, line);)
    lines.push_back(line);
  ASSERT_EQ(lines.size(), 4u); // header and three runs
  write_file_atomic(dir / "sweep-partial.csv",
                    lines[0] + "\n" + lines[1] + "\n" + lines[2] + "\n" + lines[3].substr(0, 10));
  std::filesystem::remove(dir / "summary.json");

  r = rectify_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in2(dir / "summary.json");
  const auto    second = nlohmann::json::parse(in2);
  EXPECT_EQ(second["runs_resumed"], 2);
  EXPECT_EQ(second["stored_pressure_Pa"], first["stored_pressure_Pa"]);

  // Other settings into the same folder: refused, nothing mixed.
  r = rectify_cli("sweep --scenario no-flow --from 100 --to 400 --n 3 --cycles 6 --series ideal --quiet --out " +
                  dir.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("other settings"), std::string::npos) << r.output;
}

// A run the integrator cannot finish does not stop a sweep: it is recorded
// (regime "failed: why", NaN in the tables, listed in the summary) and the
// other frequencies finish. Here the 10 Hz loaded run needs some 3500 CVODE
// steps per quarter cycle and the case allows 500 between its outputs
// (samples_per_cycle 4, max_steps_per_cycle 1000); the 2 kHz run needs
// about 60. Started again,
// the sweep resumes both, the failed one included (not re-run).
TEST(Cli, ASweepRecordsAFailedRunAndGoesOn)
{
  const auto  dir  = scratch("sweep_failure");
  const auto  map  = (reference_case_path().parent_path() / "thesis-resistance.csv").string();
  std::string text = replace(reference_text(), "\"thesis-resistance.csv\"", "\"" + map + "\"");
  text             = replace(text, "samples_per_cycle = 200", "samples_per_cycle = 4");
  text             = replace(text, "max_steps_per_cycle = 1e6", "max_steps_per_cycle = 1000");
  write_file_atomic(dir / "case.toml", text);
  const std::string args = "sweep --case " + (dir / "case.toml").string() +
                           " --scenario loaded --from 10 --to 2010 --n 2 --cycles 3 --series dynamic --quiet --out " +
                           (dir / "out").string();
  auto r = rectify_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("warning: dynamic at 10 Hz: failed: CVODE"), std::string::npos) << r.output;
  auto summary = nlohmann::json::parse(std::ifstream(dir / "out" / "summary.json"));
  EXPECT_EQ(summary["runs_failed"], 1);
  ASSERT_EQ(summary["failures"].size(), 1u);
  EXPECT_EQ(summary["failures"][0]["frequency_Hz"], 10.0);
  EXPECT_NE(summary["failures"][0]["why"].get<std::string>().find("CVODE"), std::string::npos);
  EXPECT_TRUE(summary["mean_velocity_m_per_s"][0].is_null());
  ASSERT_TRUE(summary["mean_velocity_m_per_s"][1].is_number());
  EXPECT_GT(std::abs(summary["mean_velocity_m_per_s"][1].get<double>()), 1e-3);
  std::ifstream runs(dir / "out" / "sweep-runs.csv");
  std::string   header, first;
  std::getline(runs, header);
  std::getline(runs, first);
  EXPECT_NE(first.find("nan"), std::string::npos) << first;
  EXPECT_NE(first.find("failed: CVODE"), std::string::npos) << first;

  r = rectify_cli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  summary = nlohmann::json::parse(std::ifstream(dir / "out" / "summary.json"));
  EXPECT_EQ(summary["runs_resumed"], 2);
  EXPECT_EQ(summary["runs_failed"], 1);
}

TEST(Model, ARunFromAnotherRunsEndContinuesItsTrajectory)
{
  // 6 cycles from rest, against 3 cycles from rest and then 3 more from the
  // first part's end state (what a sweep's continuation does): the same
  // trajectory to the integration tolerance, and the continued part's own
  // volume balances close (they are taken over the run, not from rest).
  const auto p = reference();
  for (auto scenario : {Scenario::no_flow, Scenario::loaded})
    {
      Model      whole = make_model(p, ValveModel::dynamic, scenario, 200);
      Model      first = make_model(p, ValveModel::dynamic, scenario, 200);
      Model      then  = make_model(p, ValveModel::dynamic, scenario, 200);
      auto       o     = options(p, 6);
      o.relative_tolerance = 1e-8;
      const auto a     = run(whole, o);
      o.n_cycles       = 3;
      const auto b     = run(first, o);
      const auto c     = run(then, o, &b.end_state);
      ASSERT_EQ(c.end_state.y.size(), a.end_state.y.size());
      // each state to 1e-3 of its kind's size (velocities 0.01 m/s: the
      // model's typical sizes of the fast velocities are coarser)
      auto scale = whole.typical_sizes();
      for (auto i : {state::piston_v, state::fluid_v, state::outlet_reed_v, state::inlet_reed_v})
        scale[i] = 1e-2;
      for (std::size_t i = 0; i < a.end_state.y.size(); ++i)
        EXPECT_NEAR(c.end_state.y[i], a.end_state.y[i], 1e-3 * scale[i]) << "state " << i;
      EXPECT_LT(c.volume_balance_rel_error, 1e-8) << to_string(scenario);
      EXPECT_GT(std::abs(c.end_state.y[state::outlet_volume] - b.end_state.y[state::outlet_volume]), 0.0);
      // The window's means are the second half's: 2 x whole - first.
      const double second_half = 2 * a.stored_pressure_Pa - b.stored_pressure_Pa;
      EXPECT_NEAR(c.stored_pressure_Pa, second_half, 1e-3 * std::abs(a.stored_pressure_Pa));
    }
  // A state of the wrong size is a programming error, not a silent restart.
  Model      m = make_model(p, ValveModel::dynamic, Scenario::no_flow, 200);
  StartState wrong;
  wrong.y.assign(3, 0.0);
  EXPECT_THROW(run(m, options(p, 1), &wrong), std::logic_error);
}

TEST(Model, ALooserStartUpToleranceKeepsThePeriodicAnswer)
{
  // Settling at rtol 1e-4 and measuring at the case's rtol: the same stored
  // pressure and velocity (periodic points, within the 0.5 % of the
  // tolerance study) in fewer steps.
  const auto p = reference();
  for (auto [scenario, f] : {std::pair{Scenario::no_flow, 300.0}, std::pair{Scenario::loaded, 150.0}})
    {
      Model      m1 = make_model(p, ValveModel::ideal, scenario, f);
      Model      m2 = make_model(p, ValveModel::ideal, scenario, f);
      auto       o  = options(p, 20);
      o.settle      = true;
      const auto tight = run(m1, o);
      o.startup_relative_tolerance = 1e-4;
      const auto loose = run(m2, o);
      ASSERT_EQ(tight.regime, "periodic") << to_string(scenario);
      const double a = scenario == Scenario::no_flow ? tight.stored_pressure_Pa : tight.mean_velocity_m_per_s;
      const double b = scenario == Scenario::no_flow ? loose.stored_pressure_Pa : loose.mean_velocity_m_per_s;
      EXPECT_NEAR(b, a, 5e-3 * std::abs(a)) << to_string(scenario);
      EXPECT_LT(loose.stats.steps, tight.stats.steps) << to_string(scenario);
      EXPECT_LT(loose.volume_balance_rel_error, 1e-6);
    }
}

TEST(Cli, AContinuedSweepResumesExactlyAsAnUninterruptedOne)
{
  // --chains 1: every frequency starts where its lower neighbour ended. Cut
  // after two runs (the third's state written, its result not), a resumed
  // sweep continues from the second's checkpointed state: the same numbers
  // to the last digit. Ideal valves: periodic, so continuation must also
  // agree with starts from rest (0.5 %), in fewer start-up cycles.
  const auto dir = scratch("sweep_chain");
  const std::string common = "sweep --scenario no-flow --from 100 --to 400 --n 4 --spacing linear --cycles 10 "
                             "--series ideal --quiet --jobs 1";
  auto r = rectify_cli(common + " --chains 1 --out " + (dir / "chain").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in1(dir / "chain" / "summary.json");
  const auto    first = nlohmann::json::parse(in1);

  const auto cut = [&](const std::filesystem::path &file, std::size_t keep) {
    std::ifstream            in(file);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);)
      lines.push_back(line);
    ASSERT_EQ(lines.size(), 5u) << file; // header and four runs
    std::string text;
    for (std::size_t i = 0; i <= keep; ++i)
      text += lines[i] + "\n";
    write_file_atomic(file, text);
  };
  cut(dir / "chain" / "sweep-partial.csv", 2);
  cut(dir / "chain" / "sweep-states.csv", 3);
  std::filesystem::remove(dir / "chain" / "summary.json");
  r = rectify_cli(common + " --chains 1 --out " + (dir / "chain").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in2(dir / "chain" / "summary.json");
  const auto    second = nlohmann::json::parse(in2);
  EXPECT_EQ(second["runs_resumed"], 2);
  EXPECT_EQ(second["stored_pressure_Pa"], first["stored_pressure_Pa"]);

  r = rectify_cli(common + " --out " + (dir / "cold").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in3(dir / "cold" / "summary.json");
  const auto    cold = nlohmann::json::parse(in3);
  for (std::size_t i = 0; i < 4; ++i)
    EXPECT_NEAR(first["stored_pressure_Pa"][i].get<double>(), cold["stored_pressure_Pa"][i].get<double>(),
                5e-3 * cold["stored_pressure_Pa"][i].get<double>());
  const auto startup = [](const std::filesystem::path &runs) {
    std::ifstream in(runs);
    std::string   line;
    std::getline(in, line);
    std::size_t total = 0;
    while (std::getline(in, line))
      {
        std::vector<std::string> cell;
        std::stringstream        s(line);
        for (std::string c; std::getline(s, c, ',');)
          cell.push_back(c);
        total += std::stoul(cell.at(7));
      }
    return total;
  };
  EXPECT_LT(startup(dir / "chain" / "sweep-runs.csv"), startup(dir / "cold" / "sweep-runs.csv"));
}

TEST(Model, TheCaseToleranceGivesTheAnswerOfATightRunWhereTheAnswerIsDefined)
{
  // The typical sizes weigh each state's error (Model::typical_sizes; the
  // fast oscillators' velocities are sized by how fast they ring). At the
  // loaded sweep's points whose response is periodic (45 Hz) or period 3
  // (327 Hz; grid points 1 and 9 of the 10-3500 Hz linear sweep), after the
  // same 400 start-up cycles, the mean velocity at the case's rtol 1e-5 is
  // that of rtol 3e-7 within 0.1 % (measured: 0.0014 % and 0.017 %).
  const auto   p    = reference();
  const double step = (3500.0 - 10.0) / 99.0;
  for (const double f : {10 + 1 * step, 10 + 9 * step})
    {
      double values[2];
      for (int h = 0; h < 2; ++h)
        {
          Model model = make_model(p, ValveModel::dynamic, Scenario::loaded, f);
          auto  o     = options(p, 51); // whole periods of a period-3 orbit
          // 400 start-up cycles, whatever the settling test says (its blocks
          // of five do not settle a period-3 orbit's means tightly).
          o.settle             = true;
          o.settle_tolerance   = 1e-6;
          o.max_startup_cycles = 400;
          o.samples_per_cycle  = 16;
          if (h == 1)
            o.relative_tolerance = 3e-7;
          const RunResult r = run(model, o);
          values[h] = r.mean_velocity_m_per_s;
        }
      EXPECT_NEAR(values[0], values[1], 1e-3 * std::abs(values[1])) << f << " Hz";
    }
}

TEST(Cli, EveryCaseFileInTheRepositoryPassesCheck)
{
  // cases/ holds the reference, the examples and the benchmarks' levels; a
  // user starts from any of them (cases/flow-levels/ once looked for the
  // R(x) table beside themselves).
  const auto dir   = scratch("check_all");
  int        count = 0;
  for (const auto &entry : std::filesystem::recursive_directory_iterator(reference_case_path().parent_path()))
    if (entry.path().extension() == ".toml")
      {
        ++count;
        const auto out = dir / std::to_string(count);
        const auto r   = rectify_cli("check --case " + entry.path().string() + " --out " + out.string());
        EXPECT_EQ(r.exit_code, 0) << entry.path() << "\n" << r.output;
      }
  EXPECT_GE(count, 11);
}

namespace
{
  /// m damped oscillators z_k'' + 2 zeta w_k z_k' + w_k^2 z_k = 0 seen
  /// through a dense, well-conditioned change of variables y = P z (P = I +
  /// 0.3 random / sqrt(n)): y' = P D P^-1 y couples every state to every
  /// other, so the linear solver's pivoting and fill are exercised.
  class MixedOscillators : public OdeSystem
  {
  public:
    explicit MixedOscillators(std::size_t m)
      : m_(m)
      , P_(Eigen::MatrixXd::Identity(2 * m, 2 * m))
    {
      std::mt19937                           rng(11);
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      const double                           scale = 0.3 / std::sqrt(2.0 * static_cast<double>(m));
      for (Eigen::Index i = 0; i < P_.rows(); ++i)
        for (Eigen::Index j = 0; j < P_.cols(); ++j)
          P_(i, j) += scale * u(rng);
      Eigen::MatrixXd D = Eigen::MatrixXd::Zero(2 * m, 2 * m);
      for (std::size_t k = 0; k < m; ++k)
        {
          const auto i = static_cast<Eigen::Index>(2 * k);
          D(i, i + 1)     = 1.0;
          D(i + 1, i)     = -w(k) * w(k);
          D(i + 1, i + 1) = -2.0 * zeta * w(k);
        }
      A_ = P_ * D * P_.inverse();
    }
    static constexpr double zeta = 0.05;
    double w(std::size_t k) const { return 2.0 * std::numbers::pi * (1.0 + 0.37 * static_cast<double>(k)); }
    std::size_t n_states() const override { return 2 * m_; }
    void rhs(double, std::span<const double> y, std::span<double> ydot) const override
    {
      Eigen::Map<Eigen::VectorXd>(ydot.data(), static_cast<Eigen::Index>(ydot.size())) =
        A_ * Eigen::Map<const Eigen::VectorXd>(y.data(), static_cast<Eigen::Index>(y.size()));
    }
    void jacobian(double, std::span<const double>, DenseView J) const override
    {
      for (std::size_t i = 0; i < J.n; ++i)
        for (std::size_t j = 0; j < J.n; ++j)
          J(i, j) = A_(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
    }
    /// y(t) from z(0) = (1, 0) for each oscillator: the damped cosine and its derivative.
    Eigen::VectorXd exact(double t) const
    {
      Eigen::VectorXd z(2 * m_);
      for (std::size_t k = 0; k < m_; ++k)
        {
          const double s = zeta * w(k), wd = w(k) * std::sqrt(1.0 - zeta * zeta), e = std::exp(-s * t);
          z(static_cast<Eigen::Index>(2 * k)) = e * (std::cos(wd * t) + s / wd * std::sin(wd * t));
          z(static_cast<Eigen::Index>(2 * k + 1)) = -e * (w(k) * w(k) / wd) * std::sin(wd * t);
        }
      return P_ * z;
    }

  private:
    std::size_t     m_;
    Eigen::MatrixXd P_, A_;
  };
} // namespace

// The integrator's linear solver, both ways it is built: up to 32 states in
// fixed-capacity storage, above (a twelve-section outlet line: 46 states) on
// the heap. A damped oscillator's exact solution through a dense mixing of
// the states, to the tolerance asked for.
TEST(Integrator, DenseMixedDampedOscillatorsMatchTheirExactSolutionAtEverySize)
{
  for (const std::size_t m : {std::size_t{8}, std::size_t{16}, std::size_t{23}})
    {
      MixedOscillators sys(m);
      const auto       y0 = sys.exact(0.0);
      IntegratorOptions o;
      o.relative_tolerance  = 1e-9;
      o.absolute_tolerances = std::vector<double>(2 * m, 1e-11);
      Integrator integ(sys, 0.0, std::span<const double>(y0.data(), 2 * m), o);
      double     worst = 0, size = 0;
      for (double t = 0.25; t <= 2.0 + 1e-12; t += 0.25)
        {
          integ.advance_to(t);
          const auto y = integ.state();
          const auto e = sys.exact(t);
          for (std::size_t i = 0; i < 2 * m; ++i)
            {
              worst = std::max(worst, std::abs(y[i] - e(static_cast<Eigen::Index>(i))));
              size  = std::max(size, std::abs(e(static_cast<Eigen::Index>(i))));
            }
        }
      EXPECT_LT(worst, 1e-6 * size) << 2 * m << " states";
      EXPECT_GT(integ.stats().steps, 0);
    }
}
