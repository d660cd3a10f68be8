// The states a run may reach (issue 80): the reed's stop, the oil's
// cavitation, the reed's root stress and Goodman factor, and the validity
// flags built on them; and the thesis's model, bit for bit, with both off.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "system/cavitation.h"
#include "system/integrator.h"
#include "system/reed.h"
#include "system/simulation.h"
#include "system/sweep.h"
#include "tests/model_helpers.h"

using namespace rectify;
using namespace rectify::system;
using rectify::test_support::reference;
using rectify::test_support::reference_map;

namespace
{
  Model make(const SystemParameters &p, Scenario s, double f, double pp = 20, double bias = 10)
  {
    return Model(p, reference_map(p), ValveModel::dynamic, s, Drive::sine(f, pp, bias));
  }

  RunOptions fixed_run(const SystemParameters &p, std::size_t cycles, bool record = false)
  {
    RunOptions o = test_support::run_options(p, cycles);
    o.record     = record;
    return o;
  }

  /// A reed of mass m, damping b, stiffness k between its seat (x = 0) and a
  /// stop at x_s, driven by F(t) = F0 (1 - cos w t): reed.h's contact
  /// functions (the model's) with its energy's integrals as states: the
  /// work of F and of the damper. Impact losses are summed at the events.
  class DrivenReed : public OdeSystem
  {
  public:
    DrivenReed(ReedConstants c, double stop, double e_stop, double F0, double w)
      : c_(c), stop_(stop), e_stop_(e_stop), F0_(F0), w_(w)
    {}
    std::size_t n_states() const override { return 4; } // x, v, work, damping loss
    double      force(double t) const { return F0_ * (1 - std::cos(w_ * t)); }
    void rhs(double t, std::span<const double> y, std::span<double> d) const override
    {
      const bool held = seated_ || at_stop_;
      d[0]            = held ? 0.0 : y[1];
      d[1]            = held ? 0.0 : reed_acceleration(c_, y[0], y[1], force(t));
      d[2]            = force(t) * y[1];
      d[3]            = c_.damping * y[1] * y[1];
    }
    void jacobian(double, std::span<const double>, DenseView) const override {}
    std::size_t n_roots() const override { return 2; }
    void roots(double t, std::span<const double> y, std::span<double> g) const override
    {
      g[0] = at_stop_ ? stop_root(true, y[0], stop_, force(t) - c_.stiffness * stop_) : reed_root(seated_, y[0], force(t));
      g[1] = seated_ || at_stop_ ? 1.0 : stop_root(false, y[0], stop_, 0.0);
    }
    bool handle_events(double t, std::span<double> y, std::span<const int> found) override
    {
      const double v_in = y[1];
      if (found[1] != 0 && !seated_ && !at_stop_)
        {
          at_stop_ = reed_on_stop(e_stop_, false, force(t) - c_.stiffness * stop_, stop_, y[0], y[1]);
          ++stop_impacts;
          if (v_in > 0)
            rebounds.push_back({v_in, y[1]});
        }
      else if (at_stop_)
        at_stop_ = reed_on_stop(e_stop_, true, 0.0, stop_, y[0], y[1]);
      else
        seated_ = reed_on_root(c_, seated_, force(t), y[0], y[1]);
      impact_loss += 0.5 * c_.mass * (v_in * v_in - y[1] * y[1]);
      return true;
    }
    double      impact_loss = 0;
    std::size_t stop_impacts = 0;
    std::vector<std::pair<double, double>> rebounds; ///< (impact, rebound) velocities at the stop

  private:
    ReedConstants c_;
    double        stop_, e_stop_, F0_, w_;
    bool          seated_ = true, at_stop_ = false;
  };
} // namespace

TEST(Stop, TheReedsEnergyBalanceClosesWithStopImpactsAndItReboundsAtTheRestitution)
{
  // The reference reed (6650 N/m, 0.364 g: 680 Hz) driven at 300 Hz to about
  // three times its stop's lift: the work of the force equals the reed's
  // energy plus what its damper and its impacts took.
  const ReedConstants c{6650.0, 0.3643e-3, 0.4, 7.9e-6, 0.3};
  const double        stop = 0.2e-3, e_stop = 0.6;
  DrivenReed          reed(c, stop, e_stop, 1.5 * 6650.0 * stop, 2 * M_PI * 300);
  IntegratorOptions   o;
  o.relative_tolerance  = 1e-10;
  o.absolute_tolerances = {1e-15, 1e-12, 1e-14, 1e-14};
  o.finite_difference_jacobian = true;
  o.quiet               = true;
  const std::vector<double> y0{0, 0, 0, 0};
  Integrator          integrator(reed, 0.0, y0, o);
  double              x_max = 0;
  for (int k = 1; k <= 4000; ++k)
    {
      integrator.advance_to(k * 1e-5);
      x_max = std::max(x_max, integrator.state()[0]);
    }
  const auto   y      = integrator.state();
  const double energy = 0.5 * c.mass * y[1] * y[1] + 0.5 * c.stiffness * y[0] * y[0];
  ASSERT_GT(reed.stop_impacts, 10u);
  EXPECT_LE(x_max, stop);
  EXPECT_NEAR(energy + y[3] + reed.impact_loss, y[2], 1e-6 * y[2]);
  EXPECT_GT(reed.impact_loss, 0.05 * y[2]); // the impacts matter to the balance
  ASSERT_FALSE(reed.rebounds.empty());
  for (const auto &[in, out] : reed.rebounds)
    {
      if (e_stop * in >= 1e-6)
        EXPECT_DOUBLE_EQ(out, -e_stop * in);
    }
}

TEST(Stop, AReedDrivenIntoItsStopNeverPassesItAndIsHeldThere)
{
  // The thesis's reeds open to 0.75-0.92 mm at 1420 Hz, loaded: a stop at
  // 0.4 mm holds them; without it they pass.
  auto p              = reference();
  p.reed.stop_lift_m  = 0.4e-3;
  Model        with   = make(p, Scenario::loaded, 1420);
  const auto   r      = run(with, fixed_run(p, 100, true));
  const auto   x_o    = r.series->column("outlet_reed_m"), x_i = r.series->column("inlet_reed_m");
  EXPECT_LE(*std::max_element(x_o.begin(), x_o.end()), p.reed.stop_lift_m);
  EXPECT_LE(*std::max_element(x_i.begin(), x_i.end()), p.reed.stop_lift_m);
  EXPECT_LE(r.valves[0].max_opening_m, p.reed.stop_lift_m);
  EXPECT_GT(r.valves[0].stop_impacts + r.valves[1].stop_impacts, 50u);
  EXPECT_GT(r.valves[0].max_stop_impact_m_per_s, 0.1);
  EXPECT_TRUE(r.validity.at_stop);
  EXPECT_FALSE(r.validity.beyond_stop);
  EXPECT_LT(r.volume_balance_rel_error, 1e-6);

  p.reed.stop = "off";
  Model      without = make(p, Scenario::loaded, 1420);
  const auto free    = run(without, fixed_run(p, 100));
  EXPECT_GT(free.valves[0].max_opening_m, 1.5 * p.reed.stop_lift_m);
  EXPECT_TRUE(free.validity.beyond_stop);
  EXPECT_FALSE(free.validity.valid());
  EXPECT_EQ(free.n_stop_impacts, 0u);
}

TEST(Stop, AReedWithTheFEMapsForceAreaStaysWithinTheReferenceStopAt1420Hz)
{
  // The FE map set's force area is about twice A_r (A_eff = 1.92 A_r,
  // docs/chapter5-comparison.md) and its R larger at small openings: its
  // reeds open to 1.9-2.9 mm at 1420 Hz, loaded. A reed with four times A_r
  // on the thesis's R(x), free, opens past the reference's stop (1.873 mm,
  // the ceiling less the reed); with the stop it stays within.
  auto       p    = reference();
  const auto maps = [&]() {
    const auto set = maps::map_set_from_resistance(reference_map(p), 4.0 * p.reed.pressure_area_m2);
    return ValveMaps{set, set};
  };
  const auto drive = Drive::sine(1420, 20, 10);
  Model      with(p, maps(), ValveModel::dynamic, Scenario::loaded, drive);
  const auto r = run(with, fixed_run(p, 300));
  EXPECT_LE(std::max(r.valves[0].max_opening_m, r.valves[1].max_opening_m), p.reed.stop_lift_m);
  EXPECT_GT(r.n_stop_impacts, 0u);
  EXPECT_LT(r.volume_balance_rel_error, 1e-6);
  p.reed.stop = "off";
  Model      free(p, maps(), ValveModel::dynamic, Scenario::loaded, drive);
  const auto f = run(free, fixed_run(p, 300));
  EXPECT_GT(std::max(f.valves[0].max_opening_m, f.valves[1].max_opening_m), p.reed.stop_lift_m);
}

TEST(Stop, AHeldReedLeavesWhenTheNetForceTurnsToClosingAndBouncesAtItsRestitution)
{
  auto p                  = reference();
  p.reed.stop_lift_m      = 20e-6; // R(20 um) is most of the line's drop: the force is the chamber's
  p.reed.stop_restitution = 0.4;
  Model m                 = make(p, Scenario::no_flow, 100);
  std::vector<double> y(m.n_states(), 0.0), g(m.n_roots()), ydot(m.n_states());
  std::vector<int>    found(m.n_roots(), 0);
  m.set_closed(0, false);
  y[state::outlet_reed_x] = p.reed.stop_lift_m;
  y[state::outlet_reed_v] = 0.8;
  y[state::chamber_p]     = 1e6; // opening force 7.8 N, beyond k x_stop = 0.13 N
  found[1]                = -1;  // the outlet's stop root
  ASSERT_TRUE(m.handle_events(0.0, y, found));
  EXPECT_FALSE(m.at_stop(0)); // rebounds: 0.4 x 0.8 m/s
  EXPECT_DOUBLE_EQ(y[state::outlet_reed_v], -0.32);
  EXPECT_EQ(y[state::outlet_reed_x], p.reed.stop_lift_m);

  p.reed.stop_restitution = 0.0; // now it stays, held by the opening force
  Model held              = make(p, Scenario::no_flow, 100);
  held.set_closed(0, false);
  y[state::outlet_reed_v] = 0.8;
  ASSERT_TRUE(held.handle_events(0.0, y, found));
  EXPECT_TRUE(held.at_stop(0));
  held.rhs(0.0, y, ydot);
  EXPECT_EQ(ydot[state::outlet_reed_x], 0.0);
  EXPECT_EQ(ydot[state::outlet_reed_v], 0.0);
  held.roots(0.0, y, g);
  const Flows f = held.flows(y);
  EXPECT_DOUBLE_EQ(g[0], f.outlet_force - p.reed.stiffness_N_per_m * p.reed.stop_lift_m + reed_lift_force);
  EXPECT_GT(g[0], 0.0);
  y[state::chamber_p] = 1e4; // 0.08 N: the spring's 0.13 N wins, the root has crossed
  held.roots(0.0, y, g);
  EXPECT_LT(g[0], 0.0);
  std::fill(found.begin(), found.end(), 0);
  found[0] = -1;
  ASSERT_TRUE(held.handle_events(0.0, y, found));
  EXPECT_FALSE(held.at_stop(0));
  EXPECT_EQ(y[state::outlet_reed_v], 0.0);
  EXPECT_LT(y[state::outlet_reed_x], p.reed.stop_lift_m);
}

TEST(Cavitation, AClosedChamberWhosePistonIsWithdrawnHoldsTheCavitationPressureAndItsCavityIsTheVolumeLost)
{
  // Valves that stay shut (R >= 1e20 at every opening) and a current ramped
  // from 0 to -20 A over 50 ms, held 50 ms, back to 0 over 50 ms, held 50 ms:
  // the piston withdraws quasi-statically (its transducer rings at 2.9 kHz).
  // Held, the chamber stays at p_c, and statics give the piston
  // x_p = (F - p_c A_pi) / k_eff (the fluid mass's spring relaxed) and the
  // cavity C_ch (p_c - p_bias) ... = -A_pi x_p - C_ch (p_bias - p_c): what the
  // piston withdrew less what the oil expanded by to reach p_c.
  const auto           p = reference();
  maps::ResistanceMap  shut({0.0, 1e-3, 5e-3}, {1e22, 1e21, 1e20}, "shut valves");
  const std::vector<double> t{0.0, 0.05, 0.10, 0.15, 0.20}, i{0.0, -20.0, -20.0, 0.0, 0.0};
  Model      m(p, shut, ValveModel::dynamic, Scenario::no_flow, Drive::from_samples(t, i, 5.0, false, "ramp"));
  RunOptions o = fixed_run(p, 1, true);
  o.samples_per_cycle  = 2000;
  o.relative_tolerance = 1e-9;
  const auto  r  = run(m, o);
  const auto &c  = m.constants();
  const auto  ts = r.series->column("time_s"), pc = r.series->column("chamber_pressure_Pa"),
             vc = r.series->column("chamber_cavity_m3"), xp = r.series->column("piston_m");
  const double p_c = p.fluid.cavitation_pressure_Pa - p.fluid.bias_pressure_Pa; // gauge
  const double F   = c.force_per_ampere * -20.0;
  const double x_p = (F - p_c * c.A_pi) / c.k_eff;
  const double V   = -c.A_pi * x_p - c.C_ch * (0.0 - p_c);
  ASSERT_GT(V, 1e-8);
  std::size_t held = 0;
  for (std::size_t k = 0; k < ts.size(); ++k)
    {
      EXPECT_GE(pc[k], p_c) << ts[k];
      if (ts[k] > 0.07 && ts[k] < 0.10) // the hold, its ringing decayed
        {
          ++held;
          EXPECT_EQ(pc[k], p_c);
          EXPECT_NEAR(xp[k], x_p, 1e-6 * std::abs(x_p));
          EXPECT_NEAR(vc[k], V, 1e-6 * V);
        }
      if (ts[k] > 0.18) // the piston back: the cavity has closed, the oil holds the bias again
        {
          EXPECT_EQ(vc[k], 0.0);
          EXPECT_NEAR(pc[k], 0.0, 1e3);
        }
    }
  EXPECT_GT(held, 250u);
  EXPECT_FALSE(m.cavitating(0));
  EXPECT_LT(r.volume_balance_rel_error, 1e-6);
  EXPECT_TRUE(r.validity.cavitating);
  EXPECT_GE(r.volumes[0].max_cavity_volume_m3, (1 - 1e-6) * V); // with the ramp's ringing on top
}

TEST(Cavitation, NoPressureFallsBelowItInTheReferenceLoadedRunAndTheVolumeBalanceCloses)
{
  // Loaded at 1420 Hz (thesis Fig. 5.5) the thesis's model takes the chamber
  // to -1.4 MPa absolute; with cavitation it holds at p_c.
  auto       p     = reference();
  Model      model = make(p, Scenario::loaded, 1420);
  const auto r     = run(model, fixed_run(p, 200));
  EXPECT_TRUE(r.validity.cavitating);
  EXPECT_FALSE(r.validity.below_cavitation_pressure);
  for (const auto &v : r.volumes)
    EXPECT_GE(v.min_absolute_pressure_Pa, p.fluid.cavitation_pressure_Pa - 1e-3) << v.name;
  EXPECT_GT(r.volumes[0].max_cavity_volume_m3, 0.0);
  EXPECT_LT(r.volume_balance_rel_error, 1e-6);

  use_thesis_model(p);
  Model      thesis = make(p, Scenario::loaded, 1420);
  const auto t      = run(thesis, fixed_run(p, 200));
  EXPECT_LT(t.volumes[0].min_absolute_pressure_Pa, 0.0);
  EXPECT_TRUE(t.validity.below_cavitation_pressure);
  EXPECT_FALSE(t.validity.valid());
}

TEST(Cavitation, TheCavityModelHoldsItsPressureAndTakesUpTheVolumeBeyond)
{
  EXPECT_EQ(cavity_pressure(-3e6, -2.5e6), -2.5e6);
  EXPECT_EQ(cavity_pressure(1e5, -2.5e6), 1e5);
  EXPECT_DOUBLE_EQ(cavity_volume(-3e6, -2.5e6, 2e-15), 2e-15 * 0.5e6);
  EXPECT_EQ(cavity_volume(-2e6, -2.5e6, 2e-15), 0.0);
  EXPECT_GT(cavity_root(false, -2e6, -2.5e6), 0.0);
  EXPECT_LT(cavity_root(false, -3e6, -2.5e6), 0.0);
  EXPECT_GT(cavity_root(true, -3e6, -2.5e6), 0.0);
  EXPECT_LT(cavity_root(true, -2e6, -2.5e6), 0.0);
}

TEST(Stress, TheGoodmanFactorOfAHandComputedCycle)
{
  ReedMaterial m;
  m.endurance_limit_Pa   = 240e6;
  m.ultimate_strength_Pa = 515e6;
  // 1 / (80 / 240 + 100 / 515)
  EXPECT_NEAR(m.goodman_factor(100e6, 80e6), 1.0 / (80.0 / 240.0 + 100.0 / 515.0), 1e-15);
  EXPECT_NEAR(m.goodman_factor(0.0, 120e6), 2.0, 1e-15);           // fully reversed: S_e / amplitude
  EXPECT_NEAR(m.goodman_factor(-50e6, 120e6), 2.0, 1e-15);         // a compressive mean does not help
  EXPECT_EQ(m.goodman_factor(0.0, 0.0), std::numeric_limits<double>::infinity());
}

TEST(Stress, TheRunsRootStressPeakIsTheReedsTrueMaximumAndItsGoodmanFactorFollows)
{
  // The stress's extremum events give the peak between samples: sampled
  // 1600 times a cycle (within 2e-6 of the true peak of a smooth maximum),
  // the run's own samples reach the event's peak, never beyond; sampled 16
  // times (a sweep's) they miss it, the events do not.
  auto       p    = reference();
  const auto with = [&](std::size_t samples) {
    Model      m = make(p, Scenario::loaded, 700);
    RunOptions o = fixed_run(p, 20, true);
    o.samples_per_cycle = samples;
    return run(m, o);
  };
  for (const std::size_t samples : {1600, 16})
    {
      const auto r    = with(samples);
      double     miss = 0; // the largest relative shortfall of the samples' peak
      for (std::size_t v = 0; v < 2; ++v)
        {
          const auto &a = r.valves[v];
          const auto  x = r.series->column(v == 0 ? "outlet_reed_m" : "inlet_reed_m");
          const auto  t = r.series->column("time_s");
          double      sampled = 0;
          for (std::size_t k = 0; k < x.size(); ++k)
            if (t[k] >= r.start_time_s)
              sampled = std::max(sampled, x[k]);
          EXPECT_GE(a.max_opening_m, sampled) << samples << " " << v;
          miss = std::max(miss, (a.max_opening_m - sampled) / sampled);
          EXPECT_NEAR(a.max_root_stress_Pa, p.reed.root_stress_per_opening_Pa_per_m * a.max_opening_m,
                      1e-12 * a.max_root_stress_Pa);
          EXPECT_EQ(a.min_root_stress_Pa, 0.0); // it closes each cycle
          EXPECT_DOUBLE_EQ(a.goodman_factor,
                           p.material.goodman_factor(0.5 * a.max_root_stress_Pa, 0.5 * a.max_root_stress_Pa));
        }
      // (a window's largest opening can be its last sample, still rising: then both agree)
      if (samples == 1600)
        EXPECT_LT(miss, 1e-5);
      else
        EXPECT_GT(miss, 1e-4);
    }
}

TEST(Stress, BeamTheorysRootStressOfTheReferenceReed)
{
  // 3 E t / (a (3L - a)) with E 200 GPa, t 0.127 mm, a 3.3 mm, L 6.1 mm:
  // 1.54 MPa per um; the second mode's -(E t / 2)(4.694 / L)^2.
  const auto p = reference();
  EXPECT_NEAR(p.reed.root_stress_per_opening_Pa_per_m, 3 * 200e9 * 0.127e-3 / (3.3e-3 * (3 * 6.1e-3 - 3.3e-3)), 1.0);
  EXPECT_NEAR(p.reed.second_mode_root_stress_per_opening_Pa_per_m,
              -0.5 * 200e9 * 0.127e-3 * std::pow(4.694091132974175 / 6.1e-3, 2), 1.0);
  EXPECT_NEAR(p.reed.stop_lift_m, 2.0e-3 - 0.127e-3, 1e-15);
  EXPECT_NEAR(p.reed.large_deflection_opening_m, 0.1 * 6.1e-3, 1e-15);
}

TEST(Validity, TheThesisModelIsReproducedToTheBitWhereNeitherStopNorCavitationActs)
{
  // No flow at 10 Hz, 20 A p-p: the reeds open 94 um and the chamber stays
  // above 0.9 MPa absolute: with the stop and cavitation on or off the run
  // is the same to the last bit (their root functions change no step).
  auto thesis = reference();
  use_thesis_model(thesis);
  const auto p = reference();
  Model      a = make(thesis, Scenario::no_flow, 10), b = make(p, Scenario::no_flow, 10);
  const auto ra = run(a, fixed_run(thesis, 3, true)), rb = run(b, fixed_run(p, 3, true));
  EXPECT_EQ(ra.stats.steps, rb.stats.steps);
  EXPECT_EQ(ra.stats.rhs_evaluations, rb.stats.rhs_evaluations);
  EXPECT_EQ(ra.end_state.y, rb.end_state.y);
  for (const char *column : {"chamber_pressure_Pa", "outlet_reed_m", "actuator_m"})
    EXPECT_EQ(ra.series->column(column), rb.series->column(column)) << column;
  EXPECT_FALSE(rb.validity.cavitating);
  EXPECT_FALSE(rb.validity.at_stop);
}

TEST(Validity, ASweepRowCarriesItsFlagsAndReadsBack)
{
  auto       p = reference();
  Model      m = make(p, Scenario::loaded, 1420);
  const auto r = run(m, fixed_run(p, 50));
  SweepPoint pt{"dynamic", 1420, r.stored_pressure_Pa, r.mean_velocity_m_per_s, true, 0, r.regime, 0, 50, 0, 0, 0, 0, 0, 0, 0};
  pt.set_validity(r);
  EXPECT_EQ(pt.valid, r.validity.valid());
  EXPECT_TRUE(pt.cavitating);
  EXPECT_TRUE(pt.goodman_below_1);
  EXPECT_EQ(pt.goodman_factor, std::min(r.valves[0].goodman_factor, r.valves[1].goodman_factor));
  const std::string row = to_csv_row(pt), header = sweep_point_csv_header();
  EXPECT_EQ(std::count(row.begin(), row.end(), ','), std::count(header.begin(), header.end(), ','));
}
