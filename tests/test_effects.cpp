// The system model's optional physics (the diagnosis effects): each against
// an exact relation - a conservation law, a closed-form response, the
// algebra of its network - and off means the thesis model bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <numbers>

#include "common/case_file.h"
#include "model_helpers.h"
#include "system/components/free_air.h"
#include "system/components/outlet_line.h"
#include "system/components/piston_friction.h"
#include "system/components/valve_leakage_turbulent.h"
#include "system/integrator.h"
#include "system/model.h"
#include "system/simulation.h"

using namespace rectify;
using namespace rectify::system;

namespace
{
  using test_support::reference;
  using test_support::reference_map;

  Model make(const SystemParameters &p, Scenario s, double f, double pp = 20, double bias = 10)
  {
    return Model(p, reference_map(p), ValveModel::dynamic, s, Drive::sine(f, pp, bias));
  }

  /// Two runs of one model the same to the last bit: CVODE's counters and the end state.
  void expect_same_run(const test_support::DifferenceRun &a, const test_support::DifferenceRun &b,
                       const std::string &what)
  {
    EXPECT_EQ(a.stats.steps, b.stats.steps) << what;
    EXPECT_EQ(a.stats.rhs_evaluations, b.stats.rhs_evaluations) << what;
    EXPECT_EQ(a.stats.jacobian_evaluations, b.stats.jacobian_evaluations) << what;
    EXPECT_EQ(a.stats.error_test_failures, b.stats.error_test_failures) << what;
    EXPECT_EQ(a.stats.reinitialisations, b.stats.reinitialisations) << what;
    EXPECT_GT(a.stats.events, 2) << what;
    ASSERT_EQ(a.state.size(), b.state.size()) << what;
    for (std::size_t i = 0; i < a.state.size(); ++i)
      EXPECT_EQ(a.state[i], b.state[i]) << what << ", state " << i;
  }

  RunOptions options(std::size_t cycles)
  {
    RunOptions o;
    o.n_cycles           = cycles;
    o.relative_tolerance = 1e-8;
    return o;
  }

  /// Every effect on at once (a value where each matters).
  SystemParameters all_effects()
  {
    auto p = reference();
    p.fluid.free_air_fraction                    = 5e-3;
    p.cylinder.seal_compliance_m3_per_Pa         = 5e-12;
    p.valves.leak_resistance_Pa_s_per_m3         = 1e12;
    p.valves.leak_area_m2                        = 3e-8;
    p.valves.orifice_discharge_coefficient       = 0.6;
    p.lines.outlet_inertance_Pa_s2_per_m3        = 3e7;
    p.lines.outlet_line_segments                 = 3;
    p.load.coulomb_friction_N                    = 20;
    p.load.static_friction_ratio                 = 1.3;
    p.load.stribeck_velocity_m_per_s             = 2e-3;
    p.reed.second_mode_frequency_Hz              = 4000;
    return p;
  }

  /// A state of the valve network for testing its algebra: chamber 1.5 MPa,
  /// high side 0.4, accumulator 0.1, low side -0.2; the outlet reed open
  /// 40 um and the inlet 25 um, or both shut.
  std::vector<double> network_state(Model &m, bool shut)
  {
    m.set_closed(0, shut);
    m.set_closed(1, shut);
    std::vector<double> y(m.n_states(), 0.0);
    y[state::outlet_reed_x] = shut ? 0.0 : 40e-6;
    y[state::inlet_reed_x]  = shut ? 0.0 : 25e-6;
    y[state::chamber_p]     = 1.5e6;
    y[state::high_p]        = 0.4e6;
    y[state::accumulator_p] = 0.1e6;
    y[state::low_p]         = -0.2e6;
    return y;
  }
} // namespace

TEST(Effects, OffMeansTheThesisModelWithItsAnalyticJacobian)
{
  const auto p = reference();
  Model      m = make(p, Scenario::no_flow, 100);
  EXPECT_FALSE(m.needs_difference_jacobian());
  EXPECT_EQ(m.n_states(), state::thesis_count);
  Model e = make(all_effects(), Scenario::no_flow, 100);
  EXPECT_TRUE(e.needs_difference_jacobian());
  EXPECT_EQ(e.n_states(), state::count + 4); // the line's segments 2 and 3: a flow and a node each
}

TEST(Effects, VolumeBalancesCloseWithEveryEffectOn)
{
  // The three balances of run() hold exactly for the equations, with the
  // free air's stored volume the integral of its compliance, the leak and
  // orifice inside the valve flows and the line flows states (the line in
  // three segments, its nodes' oil in the outlet balance).
  const auto p = all_effects();
  for (auto [scenario, f] : {std::pair{Scenario::no_flow, 100.0}, std::pair{Scenario::loaded, 200.0}})
    {
      Model           m = make(p, scenario, f);
      const RunResult r = run(m, options(8));
      EXPECT_LT(r.volume_balance_rel_error, 1e-6) << to_string(scenario);
      EXPECT_GT(r.min_reed_opening_m, -1e-9);
    }
}

TEST(Effects, RhsReadsCoversEveryDependence)
{
  // The coloured Jacobian is CVODE's only if no component of f reads a
  // state rhs_reads() leaves out, in any discrete mode.
  auto one_segment                          = all_effects();
  one_segment.lines.outlet_line_segments    = 1;
  auto coil                                 = all_effects();
  coil.drive.coil_dynamics                  = "on";
  coil.transducer.coil_inductance_H         = 2e-3;
  auto laminar                              = all_effects();
  laminar.valves.leak_area_m2               = 0;
  const std::vector<double> t{0.0, 1e-3, 1.0}, v{0.0, 19.0, 19.0};
  int case_no = 0;
  for (const auto &[p, voltage] : std::vector<std::pair<SystemParameters, bool>>{
         {all_effects(), false}, {one_segment, false}, {coil, true}, {laminar, false}, {reference(), false}})
    for (auto s : {Scenario::no_flow, Scenario::loaded})
      {
        Model m = voltage ? Model(p, reference_map(p), ValveModel::dynamic, s, Drive::from_samples(t, v, 100, true, "ramp"))
                          : make(p, s, 100);
        EXPECT_EQ(test_support::rhs_reads_misses(m, m.rhs_reads(), 8, 7 + case_no), "") << "case " << case_no;
        ++case_no;
      }
  // and the check finds a dependence left out
  Model m     = make(all_effects(), Scenario::no_flow, 100);
  auto  reads = m.rhs_reads();
  std::erase(reads[state::fluid_v], std::size_t(state::chamber_p));
  EXPECT_NE(test_support::rhs_reads_misses(m, reads, 2, 1).find("reads y[" + std::to_string(state::chamber_p)), std::string::npos);
}

TEST(Effects, TheIntegratorsNewtonMatrixGivesCVODEsOwnRunBitForBit)
{
  // I - gamma J formed by the integrator, J's difference quotients a
  // colour of columns per evaluation of f, with CVODE's increments and
  // arithmetic: the same steps and end state to the last bit as CVODE's own
  // routines, in fewer evaluations of f. And with the analytic Jacobian
  // (the thesis model).
  for (auto [scenario, f] : {std::pair{Scenario::no_flow, 100.0}, std::pair{Scenario::loaded, 200.0}})
    for (bool effects : {true, false})
      {
        Model      m     = make(effects ? all_effects() : reference(), scenario, f);
        const auto cvode = test_support::run_linear_system(m, options(1), true, effects, 3.0 / f);
        const auto own   = test_support::run_linear_system(m, options(1), false, effects, 3.0 / f);
        const std::string what = to_string(scenario) + (effects ? ", every effect" : ", the thesis model");
        expect_same_run(own, cvode, what);
        if (!effects)
          continue;
        EXPECT_EQ(cvode.stats.rhs_evaluations_for_fd_jacobian,
                  cvode.stats.jacobian_evaluations * static_cast<long>(m.n_states()));
        std::cout << what << ": " << m.n_states() << " columns in "
                  << own.stats.rhs_evaluations_for_fd_jacobian / own.stats.jacobian_evaluations << " colours\n";
        EXPECT_LT(own.stats.rhs_evaluations_for_fd_jacobian, 0.7 * cvode.stats.rhs_evaluations_for_fd_jacobian)
          << own.stats.rhs_evaluations_for_fd_jacobian << " against " << cvode.stats.rhs_evaluations_for_fd_jacobian;
      }
}

TEST(Effects, TheOptimisedVectorOperationsGiveTheLibrarysRunBitForBit)
{
  // SUNDIALS's serial vector operations compiled here (Debian's are
  // unoptimised) against the library's own: the same steps, evaluations and
  // end state to the last bit, in both scenarios, with every effect (the
  // coloured difference quotients) and with the thesis model (the analytic
  // Jacobian), through valve events and reinitialisations.
  for (auto [scenario, f] : {std::pair{Scenario::no_flow, 100.0}, std::pair{Scenario::loaded, 200.0}})
    for (bool effects : {true, false})
      {
        Model      m       = make(effects ? all_effects() : reference(), scenario, f);
        const auto library = test_support::run_linear_system(m, options(1), false, effects, 3.0 / f, true);
        const auto own     = test_support::run_linear_system(m, options(1), false, effects, 3.0 / f, false);
        const std::string what = to_string(scenario) + (effects ? ", every effect" : ", the thesis model");
        expect_same_run(own, library, what);
      }
}

TEST(Effects, FreeAirStoredVolumeIsTheIntegralOfItsCompliance)
{
  FluidParameters fl;
  fl.free_air_fraction = 0.01;
  for (const char *law : {"polytropic", "constant-modulus"})
    {
      fl.free_air_law = law;
      const FreeAir air(fl);
      EXPECT_EQ(air.name(), fl.free_air_law == "polytropic" ? "entrained_air" : "entrained_air_constant_modulus");
      EXPECT_EQ(air.gas_volume_change_per_volume(0.0), 0.0);
      // at the bias: alpha / (gamma p_b), eq. 3.25's gas bulk modulus
      EXPECT_NEAR(air.gas_compliance_per_volume(0.0), 0.01 / (fl.gas_heat_capacity_ratio * fl.bias_pressure_Pa),
                  1e-20);
      for (double p : {-2e6, -5e5, 1e6, 8e6})
        {
          const double h  = 1e-5 * std::abs(p);
          const double dv = (air.gas_volume_change_per_volume(p + h) - air.gas_volume_change_per_volume(p - h)) / (2 * h);
          EXPECT_NEAR(dv, air.gas_compliance_per_volume(p), 1e-6 * air.gas_compliance_per_volume(p)) << law << " " << p;
        }
    }
  // the gas law: twice the compliance where the absolute pressure is
  // 2^(-gamma / (1 + gamma)) of the bias's
  fl.free_air_law      = "polytropic";
  const FreeAir  air(fl);
  const double   g = fl.gas_heat_capacity_ratio, pb = fl.bias_pressure_Pa;
  const double   p_half = pb * std::pow(2.0, -g / (1.0 + g)) - pb;
  EXPECT_NEAR(air.gas_compliance_per_volume(p_half), 2.0 * air.gas_compliance_per_volume(0.0),
              1e-12 * air.gas_compliance_per_volume(0.0));
}

TEST(Effects, LeakAndOrificeFlowsSatisfyTheirBranchLawsAndKirchhoff)
{
  auto p = reference();
  p.valves.leak_resistance_Pa_s_per_m3   = 3e11;
  p.valves.orifice_discharge_coefficient = 0.5;
  Model m = make(p, Scenario::no_flow, 100);
  const auto   y   = network_state(m, false);
  const Flows  f   = m.flows(y);
  const auto  &c   = m.constants();
  const auto   map = reference_map(p);
  const double R_leak = p.valves.leak_resistance_Pa_s_per_m3;
  const auto   par    = [&](double R) { return R * R_leak / (R + R_leak); };
  const double P      = std::sqrt(4 * std::numbers::pi * p.reed.pressure_area_m2);
  const auto   K      = [&](double x) {
    const double A = P * x;
    return p.fluid.density_kg_per_m3 / (2 * 0.25 * A * A);
  };
  // outlet branch: chamber -> high side through valve (with leak) and line
  const double R1 = par(map.evaluate(40e-6).resistance);
  const double q  = f.q_outlet;
  EXPECT_NEAR((R1 + c.R3) * q + K(40e-6) * q * std::abs(q), 1.5e6 - 0.4e6, 1e-9 * 1.1e6);
  EXPECT_NEAR(f.p_outlet, 1.5e6 - R1 * q - K(40e-6) * q * std::abs(q), 1e-6);
  // inlet branch and the junction's Kirchhoff law
  const double R2 = par(map.evaluate(25e-6).resistance);
  const double qi = f.q_inlet;
  EXPECT_NEAR((R2 + c.R4) * qi + K(25e-6) * qi * std::abs(qi), f.p_junction - 1.5e6, 1e-9 * 1.5e6);
  EXPECT_NEAR(f.q_inlet + f.q_accumulator + f.q_low, 0.0, 1e-12 * std::abs(f.q_inlet));
  EXPECT_LT(qi, 0.0); // the chamber is above the junction: flow back through the open inlet
}

TEST(Effects, ATurbulentLeakSharesTheValvesDropAndTheLineTakesTheRest)
{
  // A leak orifice of area A beside each valve: its flow q_L obeys
  // rho q_L|q_L| / (2 A^2) = u above a 1 kPa laminar transition (q_L =
  // u / sqrt(K sqrt(u^2 + u_t^2))), the valve's q_v its own law at the same
  // drop u, and the line in series takes the rest: u + R3 (q_v + q_L) =
  // p_ch - p_h. Tested open, shut, with an orifice loss through the open
  // valve, and with a laminar leak path beside the turbulent one.
  for (const bool with_orifice : {false, true})
    for (const double R_lam : {0.0, 2e11})
      for (const bool shut : {false, true})
        {
          auto p = reference();
          p.valves.leak_area_m2                  = 1e-7;
          p.valves.leak_resistance_Pa_s_per_m3   = R_lam;
          p.valves.orifice_discharge_coefficient = with_orifice ? 0.5 : 0.0;
          Model m = make(p, Scenario::no_flow, 100);
          const auto   y   = network_state(m, shut);
          const Flows  f   = m.flows(y);
          const auto  &c   = m.constants();
          const auto   map = reference_map(p);
          const double rho = p.fluid.density_kg_per_m3, A = 1e-7;
          const double K_L = rho / (2 * A * A);
          const auto *leak = dynamic_cast<const ValveLeakageTurbulent *>(m.component("valve_leakage_turbulent"));
          ASSERT_NE(leak, nullptr);
          EXPECT_DOUBLE_EQ(leak->drop_coefficient(), K_L);
          // the leaks' flow at a drop u
          const auto q_leak = [&](double u) {
            const double turbulent = u / std::sqrt(K_L * std::hypot(u, 1e3));
            return turbulent + (R_lam > 0 ? u / R_lam : 0.0);
          };
          // above the transition, the square-root law
          EXPECT_NEAR(q_leak(1e6) - (R_lam > 0 ? 1e6 / R_lam : 0.0), A * std::sqrt(2e6 / rho),
                      1e-6 * A * std::sqrt(2e6 / rho));
          const double P  = std::sqrt(4 * std::numbers::pi * p.reed.pressure_area_m2);
          const auto   Kv = [&](double x) {
            if (!with_orifice || shut)
              return 0.0;
            const double a = P * x;
            return rho / (2 * 0.25 * a * a);
          };
          const auto R_valve = [&](double x) {
            return shut ? map.closed_resistance() : map.evaluate(x).resistance;
          };
          const std::string what = std::string(shut ? "shut" : "open") + (with_orifice ? ", orifice" : "") +
                                   (R_lam > 0 ? ", laminar part" : "");
          // outlet: u = p_ch - p_o across valve and leak, the line R3 after them
          const double u  = 1.5e6 - f.p_outlet;
          const double qv = f.q_outlet - q_leak(u);
          EXPECT_NEAR(R_valve(40e-6) * qv + Kv(40e-6) * qv * std::abs(qv), u, 1e-9 * 1.1e6) << what;
          EXPECT_NEAR(u + c.R3 * f.q_outlet, 1.5e6 - 0.4e6, 1e-9 * 1.1e6) << what;
          EXPECT_GT(q_leak(u), 0.0);
          if (shut) // the leak carries all but the seat's u / 1e17
            {
              EXPECT_GT(q_leak(u), 0.9999 * f.q_outlet) << what;
            }
          // inlet, junction -> chamber, and the junction's Kirchhoff law
          const double ui  = f.p_inlet - 1.5e6;
          const double qvi = f.q_inlet - q_leak(ui);
          EXPECT_NEAR(R_valve(25e-6) * qvi + Kv(25e-6) * qvi * std::abs(qvi), ui, 1e-9 * 1.5e6) << what;
          EXPECT_NEAR(ui + c.R4 * f.q_inlet, f.p_junction - 1.5e6, 1e-9 * 1.5e6) << what;
          EXPECT_NEAR(f.q_inlet + f.q_accumulator + f.q_low, 0.0, 1e-9 * std::abs(f.q_inlet)) << what;
          // the force on the reed is the drop across it
          EXPECT_DOUBLE_EQ(f.outlet_force, m.force_area(0, y).area * u) << what;
        }
}

TEST(Effects, VolumeBalancesCloseWithATurbulentLeak)
{
  // The inlet valve, its leaks and the inlet line solved with the
  // junction's Kirchhoff law as one equation: the inlet balance (the valve's
  // volume against the accumulator's and the low side's) holds to the
  // integration's error (here 1e-11 to 1e-9). Solved as a Newton on the
  // junction's pressure with a Newton inside for the branch, these runs left
  // 2e-6 and 1.4e-5, and a 16-cycle run of a case fitted to a bench record,
  // at the diagnosis's tolerance (1e-5), 3 %.
  for (const double A : {2e-8, 1e-7})
    for (const double r2 : {0.0, 4261.0})
      {
        auto p                              = reference();
        p.valves.leak_area_m2               = A;
        p.reed.second_mode_frequency_Hz     = r2;
        Model           m = make(p, Scenario::no_flow, 50);
        const RunResult r = run(m, options(6));
        EXPECT_LT(r.volume_balance_rel_error, 1e-7) << "leak area " << A << ", second mode " << r2;
      }
}

TEST(Effects, ATurbulentLeakRecoilsAsASquareRoot)
{
  // The high side discharging through a shut outlet valve's leak into a
  // chamber held at 0: C dp/dt = -q(p). Laminar, p = p0 exp(-t / (R C));
  // turbulent (above the 1 kPa transition), sqrt(p) = sqrt(p0) - t A
  // sqrt(2/rho) / (2 C): the two forms recoil differently, which is how a
  // record tells them apart. The model's flows integrated by hand.
  auto p = reference();
  p.valves.leak_area_m2 = 2e-8;
  Model m = make(p, Scenario::no_flow, 100);
  m.set_closed(0, true);
  m.set_closed(1, true);
  std::vector<double> y(m.n_states(), 0.0);
  const double C = m.constants().C_h, rho = p.fluid.density_kg_per_m3, A = 2e-8;
  double       ph = 2e6;
  const double T  = 0.5 * std::sqrt(2e6) / (A * std::sqrt(2 / rho) / (2 * C)); // half way to empty
  const int    n  = 20000;
  for (int k = 0; k < n; ++k) // RK2 on C dp/dt = q_outlet (flow from the chamber at 0 into the high side)
    {
      const auto flow = [&](double pressure) {
        y[state::high_p] = pressure;
        return m.flows(y).q_outlet;
      };
      const double h  = T / n;
      const double k1 = flow(ph) / C;
      const double k2 = flow(ph + 0.5 * h * k1) / C;
      ph += h * k2;
    }
  const double exact = std::pow(std::sqrt(2e6) - T * A * std::sqrt(2 / rho) / (2 * C), 2); // 0.5 MPa
  // the line's resistance R3 in series (about 0.1 % of the drop) and the
  // 1 kPa transition shift it by well under 0.5 %
  EXPECT_NEAR(ph, exact, 0.005 * exact);
}

TEST(Effects, VoltageDrivenCoilFollowsItsFirstOrderStepResponse)
{
  // L dI/dt = V - R I under a constant voltage from I(0) = V0/R:
  // I(t) = V/R + (V0 - V)/R exp(-t R/L).
  auto p                         = reference();
  p.drive.coil_dynamics          = "on";
  p.transducer.coil_inductance_H = 2e-3;
  const double R = p.transducer.coil_resistance_ohm, L = 2e-3;
  const double V0 = 0.0, V = 19.0;
  std::vector<double> t{0.0, 1e-9, 1.0}, v{V0, V, V};
  Model m(p, reference_map(p), ValveModel::dynamic, Scenario::no_flow,
          Drive::from_samples(t, v, 100, true, "step"));
  RunOptions o = options(1);
  Integrator integrator(m, 0.0, m.initial_state(), integrator_options(m, o));
  for (double time : {2e-4, 1e-3, 3e-3})
    {
      integrator.advance_to(time);
      const double exact = V / R + (V0 - V) / R * std::exp(-(time - 1e-9) * R / L);
      EXPECT_NEAR(integrator.state()[state::coil_current], exact, 1e-5 * V / R) << time;
      EXPECT_NEAR(m.current_A(time, integrator.state()), integrator.state()[state::coil_current], 0.0);
    }
  // without coil dynamics the current is V/R at once
  p.drive.coil_dynamics = "off";
  Model q(p, reference_map(p), ValveModel::dynamic, Scenario::no_flow, Drive::from_samples(t, v, 100, true, "step"));
  EXPECT_DOUBLE_EQ(q.current_A(1e-3, q.initial_state()), V / R);
}

TEST(Effects, SealComplianceAddsToTheHighSide)
{
  // No flow, valve open only at the start: the high side's pressure rise
  // for a pumped volume is dV / (C_h + C_seal) (volume balance e_out).
  auto p = reference();
  Model base = make(p, Scenario::no_flow, 100);
  p.cylinder.seal_compliance_m3_per_Pa = 2e-12;
  Model soft = make(p, Scenario::no_flow, 100);
  const auto C_h = base.constants().C_h;
  EXPECT_NEAR(soft.stored_volume(1, 1e6), (C_h + 2e-12) * 1e6, 1e-20);
  const RunResult r0 = run(base, options(10)), r1 = run(soft, options(10));
  EXPECT_LT(r1.stored_pressure_Pa, r0.stored_pressure_Pa); // same pump, softer outlet: slower build-up
  EXPECT_LT(r1.volume_balance_rel_error, 1e-6);
}

TEST(Effects, FrictionSlowsTheLoadedActuatorAndSecondModeAddsTipCompliance)
{
  auto p = reference();
  Model smooth = make(p, Scenario::loaded, 100, 4, 2);
  p.load.coulomb_friction_N = 20;
  Model rough = make(p, Scenario::loaded, 100, 4, 2);
  const RunResult a = run(smooth, options(10)), b = run(rough, options(10));
  EXPECT_LT(b.mean_velocity_m_per_s, a.mean_velocity_m_per_s);
  // Under a constant opening force F the reed settles at F/k1 + F/k2 (two
  // modes in series, modal masses normalised to the tip).
  auto q = reference();
  q.reed.second_mode_frequency_Hz = 3000;
  Model       m = make(q, Scenario::no_flow, 100);
  const auto &c = m.constants();
  ASSERT_TRUE(c.second_mode);
  const double k2 = c.second_mode->stiffness();
  EXPECT_NEAR(k2, c.reed.mass * std::pow(2 * std::numbers::pi * 3000, 2), 1e-9 * k2);
  std::vector<double> y(m.n_states(), 0.0), ydot(m.n_states());
  m.set_closed(0, false);
  y[state::outlet_reed_x]  = 1e-5;
  y[state::outlet_reed2_x] = 2e-6;
  EXPECT_DOUBLE_EQ(m.opening(0, y), 1.2e-5);
  m.rhs(0.0, y, ydot);
  const Flows f = m.flows(y);
  EXPECT_NEAR(ydot[state::outlet_reed2_v], (f.outlet_force - k2 * 2e-6) / c.reed.mass, 1e-9 * std::abs(k2 * 2e-6 / c.reed.mass));
}

// The friction law, F_c [1 + (r - 1) exp(-(v / v_st)^2)] tanh(v / v_s):
// Coulomb's alone at r = 1 (the former law, bit for bit), the breakaway
// rise at low speed, odd in v, F_c far above v_st; and what the actuator's
// equation of motion subtracts.
TEST(Effects, PistonFrictionHasAStribeckRiseAtLowSpeed)
{
  auto p                                 = reference();
  p.load.coulomb_friction_N              = 20;
  p.load.friction_velocity_scale_m_per_s = 0.5e-3;
  Model coulomb_model = make(p, Scenario::loaded, 100, 4, 2);
  const PistonFriction coulomb(p.load);
  for (double v : {-3e-3, -1e-4, 0.0, 2e-4, 1e-3, 5e-2})
    EXPECT_EQ(coulomb.force(v), 20 * std::tanh(v / 0.5e-3)) << v;
  p.load.static_friction_ratio     = 1.5;
  p.load.stribeck_velocity_m_per_s = 2e-3;
  Model stribeck_model = make(p, Scenario::loaded, 100, 4, 2);
  const PistonFriction stribeck(p.load);
  // at v = v_st the rise has fallen to 1/e of (r - 1)
  EXPECT_NEAR(stribeck.force(2e-3), 20 * (1 + 0.5 / std::exp(1.0)) * std::tanh(4.0), 1e-12);
  EXPECT_NEAR(stribeck.force(-2e-3), -stribeck.force(2e-3), 1e-12);
  EXPECT_EQ(stribeck.force(0.0), 0.0);
  // the breakaway peak, above F_c and below r F_c, at a velocity between v_s and v_st
  double peak = 0, at = 0;
  for (double v = 1e-5; v < 1e-2; v *= 1.01)
    if (stribeck.force(v) > peak)
      {
        peak = stribeck.force(v);
        at   = v;
      }
  EXPECT_GT(peak, 1.3 * 20);
  EXPECT_LT(peak, 1.5 * 20);
  EXPECT_GT(at, 0.5e-3);
  EXPECT_LT(at, 2e-3);
  EXPECT_NEAR(stribeck.force(5e-2), 20.0, 1e-9); // sliding fast: Coulomb's (exp(-625))
  // in the actuator's equation of motion: the two models differ by the rise alone
  std::vector<double> y(coulomb_model.n_states(), 0.0), a(coulomb_model.n_states()), b(coulomb_model.n_states());
  y[state::high_p]     = 2e6;
  y[state::actuator_v] = 1e-3;
  coulomb_model.rhs(0.0, y, a);
  stribeck_model.rhs(0.0, y, b);
  const double m_l = coulomb_model.constants().m_l;
  EXPECT_NEAR(a[state::actuator_v] - b[state::actuator_v],
              (stribeck.force(1e-3) - coulomb.force(1e-3)) / m_l, 1e-9 * std::abs(a[state::actuator_v]));
  EXPECT_NEAR(stribeck.force(1e-3) - coulomb.force(1e-3),
              20 * 0.5 * std::exp(-0.25) * std::tanh(2.0), 1e-12);
}

TEST(Effects, ASeatedTwoModeReedIsHeldAtItsTipAndRingsAsThePinnedReed)
{
  // The seat holds the tip (x1 + x2 = 0), not the reed. Seated, with the
  // modes' difference d = x1 - x2 (x1 = d/2, x2 = -d/2) and equal modal
  // masses m: m (a1 + a2) = 0 and m d'' = -(k1 + k2) d / 2, the tip-pinned
  // reed (for k2 = 6.27^2 k1: 4.5 f1, a clamped-pinned beam's 4.36 f1),
  // whatever the opening force; the seat's reaction is the rest.
  auto q                          = reference();
  q.reed.second_mode_frequency_Hz = 6.27 * q.reed.natural_frequency_Hz();
  Model       m                   = make(q, Scenario::no_flow, 100);
  const auto &c                   = m.constants();
  std::vector<double> y(m.n_states(), 0.0), ydot(m.n_states());
  m.set_closed(0, true);
  const double d = 3e-6;
  y[state::outlet_reed_x]  = 0.5 * d;
  y[state::outlet_reed2_x] = -0.5 * d;
  y[state::chamber_p]      = -2e5; // a closing force
  m.rhs(0.0, y, ydot);
  const double a1 = ydot[state::outlet_reed_v], a2 = ydot[state::outlet_reed2_v];
  ASSERT_TRUE(c.second_mode);
  const double k1 = c.reed.stiffness, k2 = c.second_mode->stiffness(), mr = c.reed.mass;
  EXPECT_NEAR(a1 + a2, 0.0, 1e-9 * std::abs(a1));
  EXPECT_NEAR(a1 - a2, -(k1 + k2) / (2 * mr) * d, 1e-9 * std::abs(a1 - a2));
  const Flows f = m.flows(y);
  EXPECT_LT(f.outlet_force, 0.0);
  EXPECT_NEAR(c.second_mode->seat_reaction(c.reed, f.outlet_force, 0.5 * d, 0, -0.5 * d, 0), -f.outlet_force + 0.25 * (k1 - k2) * d,
              1e-12 * std::abs(f.outlet_force));

  // At impact the tip stops: an impulse on the tip, equal on both modes,
  // takes the tip's kinetic energy m (v1 + v2)^2 / 4 and leaves the
  // difference's; the reed stays on the seat under a closing force.
  m.set_closed(0, false);
  const double v1 = -0.3, v2 = 0.1;
  y[state::outlet_reed_x] = 0.0;
  y[state::outlet_reed2_x] = 0.0;
  y[state::outlet_reed_v]  = v1;
  y[state::outlet_reed2_v] = v2;
  std::vector<int> found(m.n_roots(), 0); // the outlet valve's contact root (Model::n_roots)
  found[0] = -1;
  EXPECT_TRUE(m.handle_events(0.0, y, found));
  EXPECT_TRUE(m.closed(0));
  EXPECT_NEAR(y[state::outlet_reed_v] + y[state::outlet_reed2_v], 0.0, 1e-15);
  EXPECT_NEAR(y[state::outlet_reed_v] - y[state::outlet_reed2_v], v1 - v2, 1e-15);
  const double ke_before = 0.5 * mr * (v1 * v1 + v2 * v2);
  const double ke_after  = 0.5 * mr * (std::pow(y[state::outlet_reed_v], 2) + std::pow(y[state::outlet_reed2_v], 2));
  EXPECT_NEAR(ke_before - ke_after, 0.25 * mr * (v1 + v2) * (v1 + v2), 1e-12 * ke_before);

  // An opening force lifts it: the root is the force the seat would have to pull with.
  y[state::chamber_p] = 2e5;
  std::vector<double> g(m.n_roots());
  m.roots(0.0, y, g);
  const Flows fo = m.flows(y);
  EXPECT_NEAR(g[0], reed_lift_force + c.second_mode->seat_reaction(c.reed, fo.outlet_force, 0, y),
              1e-12 * std::abs(fo.outlet_force));
  EXPECT_LT(g[0], 0.0);
  EXPECT_TRUE(m.handle_events(0.0, y, found));
  EXPECT_FALSE(m.closed(0));
  EXPECT_NEAR(m.opening(0, y), reed_seat_tolerance, 1e-20);

  // With restitution e the tip leaves at e times its impact speed, the
  // modes' difference untouched, and the reed is not held.
  q.reed.restitution = 0.5;
  Model bouncy       = make(q, Scenario::no_flow, 100);
  bouncy.set_closed(0, false);
  y[state::outlet_reed_x] = y[state::outlet_reed2_x] = 0.0;
  y[state::outlet_reed_v]  = v1;
  y[state::outlet_reed2_v] = v2;
  y[state::chamber_p]      = -2e5;
  EXPECT_TRUE(bouncy.handle_events(0.0, y, found));
  EXPECT_FALSE(bouncy.closed(0));
  EXPECT_NEAR(y[state::outlet_reed_v] + y[state::outlet_reed2_v], -0.5 * (v1 + v2), 1e-15);
  EXPECT_NEAR(y[state::outlet_reed_v] - y[state::outlet_reed2_v], v1 - v2, 1e-15);
}

// A distributed outlet line ([lines] outlet_line_segments = n pi sections):
// both valves shut and no drive, the 1.58 m line (L = 1.12e8) rings between
// the valve's node (its lumped oil C_a, a tenth of the high side's) and the
// high side (C_b, the rest). A lossless line of inertance L and compliance
// C_line with those end compliances rings at f = theta / (2 pi sqrt(L C_line)),
// theta the lowest root of tan(theta) = theta (a + b) / (theta^2 a b - 1),
// a = C_a / C_line, b = C_b / C_line (transmission-line theory). The n
// sections converge to it at second order (16, 32, 64 sections); one
// section is far off.
TEST(Effects, ADistributedOutletLineRingsAtItsTransmissionLineFrequency)
{
  const double L   = 1.12e8;
  const auto   lowest_root = [](double a, double b) { // bisection on (pi/2, pi] for the half-wave-like mode
    const auto g = [&](double t) { return std::sin(t) * (t * t * a * b - 1) - t * (a + b) * std::cos(t); };
    double     lo = 1e-3, hi = std::numbers::pi;
    // the first sign change of g above 0 (g > 0 just above 0 for a + b < 1)
    for (int k = 1; k <= 1000; ++k)
      {
        const double t = k * std::numbers::pi / 1000;
        if (g(t) * g(lo) <= 0)
          {
            hi = t;
            break;
          }
        lo = t;
      }
    for (int it = 0; it < 100; ++it)
      {
        const double mid = 0.5 * (lo + hi);
        (g(mid) * g(lo) <= 0 ? hi : lo) = mid;
      }
    return 0.5 * (lo + hi);
  };
  const auto ringing = [&](long n, double &f_exact, double &f_chain) {
    auto p                                = reference();
    p.lines.outlet_inertance_Pa_s2_per_m3 = L;
    p.lines.outlet_line_segments          = n;
    Model model(p, reference_map(p), ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 0, 0));
    const auto  &c      = model.constants();
    EXPECT_NE(outlet_line(c), nullptr);
    if (!outlet_line(c))
      return 0.0;
    const auto  &line   = *outlet_line(c);
    const double C_line = (line.segments() > 1 ? line.between_compliance() * static_cast<double>(n) :
                                                 2 * (line.node_compliance() - 0.1 * make(reference(), Scenario::no_flow, 1)
                                                                                       .constants()
                                                                                       .C_h));
    const double C_h0   = make(reference(), Scenario::no_flow, 1).constants().C_h;
    const double a = 0.1 * C_h0 / C_line, b = 0.9 * C_h0 / C_line;
    f_exact        = lowest_root(a, b) / (2 * std::numbers::pi * std::sqrt(L * C_line));
    f_chain        = outlet_line_ringing_Hz(c); // the chain's own lowest mode (what the diagnosis starts from)
    // the line at 1 MPa, its fundamental's shape (cos(pi s / l)) on top: the outlet valve stays shut
    std::vector<double> y = model.initial_state();
    y[state::high_p]      = 1e6 - 1e5;
    for (long k = 0; k < n; ++k)
      y[state::line_segment_node(static_cast<std::size_t>(k))] =
        1e6 + 1e5 * std::cos(std::numbers::pi * static_cast<double>(k) / static_cast<double>(n));
    // the level it rings about: the oil the line and the high side hold, conserved
    double stored = model.component_stored_volume(y) + c.C_h * y[state::high_p];
    double C_sum  = line.node_compliance() + c.C_h + line.between_compliance() * static_cast<double>(n - 1);
    const double p_mean = stored / C_sum;
    Integrator   integrator(model, 0.0, y, test_support::tight_integration(model, 1e-10, 1e-12));
    const double dt = 2e-6;
    double       prev = y[state::line_node_p] - p_mean, first = -1, last = -1;
    int          crossings = 0;
    for (int i = 1; i <= 20000; ++i) // 40 ms: five to eight periods
      {
        integrator.advance_to(i * dt);
        EXPECT_TRUE(model.closed(0) && model.closed(1));
        const double now = integrator.state()[state::line_node_p] - p_mean;
        if (prev < 0 && now >= 0)
          {
            const double t = (i - 1 + prev / (prev - now)) * dt;
            if (first < 0)
              first = t;
            last = t;
            ++crossings;
          }
        prev = now;
      }
    EXPECT_GE(crossings, 4);
    return (crossings - 1) / (last - first);
  };
  double     f_exact = 0, f_chain = 0;
  const long ns[]    = {1, 4, 16, 32, 64};
  double     err[5];
  for (int i = 0; i < 5; ++i)
    {
      const double f = ringing(ns[i], f_exact, f_chain);
      err[i]         = f / f_exact - 1;
      std::printf("outlet line of %ld section(s): rings at %.2f Hz, the transmission line at %.2f Hz (%+.3f %%), "
                  "the chain's lowest mode %.2f Hz\n",
                  ns[i], f, f_exact, 100 * err[i], f_chain);
      // the integrated chain against its eigenvalue (lossless: the line's friction the difference)
      EXPECT_NEAR(f / f_chain, 1.0, 1e-3) << ns[i];
    }
  EXPECT_GT(std::abs(err[0]), 0.05); // one section: not a distributed line
  EXPECT_LT(std::abs(err[1]), 0.03);
  EXPECT_LT(std::abs(err[2]), 0.003);
  EXPECT_LT(std::abs(err[4]), 5e-4); // what is left: the line's friction, -(R / (omega L))^2 / 8 = -0.03 %
  // second order: halving the sections quarters the change
  const double ratio = (err[2] - err[3]) / (err[3] - err[4]);
  std::printf("convergence: (f16 - f32) / (f32 - f64) = %.2f (second order: 4)\n", ratio);
  EXPECT_GT(ratio, 3.0);
  EXPECT_LT(ratio, 5.0);
}

// A short line in several sections rings lightly damped at 10^5-10^7 Hz
// (each section a few mm of oil). BDF orders 3-5 are not stable near the
// imaginary axis, so CVODE at its default order 5 keeps cutting its steps;
// orders 1-2 are A-stable. The model asks for order 2 whenever its line has
// several sections (Model::max_bdf_order), and run() passes that on: the
// answer must be as accurate (against a tight run) for far fewer steps.
TEST(Effects, AShortDistributedLineIsIntegratedAtSecondOrder)
{
  auto p                                = reference();
  p.lines.outlet_line_segments          = 6;
  p.lines.outlet_inertance_Pa_s2_per_m3 = 1e5; // 6 mm of the case's line
  EXPECT_EQ(make(p, Scenario::no_flow, 150).max_bdf_order(), 2);
  EXPECT_EQ(make(reference(), Scenario::no_flow, 150).max_bdf_order(), 0); // no line: CVODE's own
  auto one_section                      = p;
  one_section.lines.outlet_line_segments = 1;
  EXPECT_EQ(make(one_section, Scenario::no_flow, 150).max_bdf_order(), 0);

  Model        tight_model = make(p, Scenario::no_flow, 150);
  RunOptions   tight       = options(6);
  tight.relative_tolerance = 1e-9;
  tight.record             = true;
  const auto   reference_run = run(tight_model, tight);
  const auto   error = [&](const RunResult &r) {
    return test_support::rms_difference_per_swing(reference_run, r, "chamber_pressure_Pa");
  };
  RunOptions o         = options(6);
  o.relative_tolerance = 1e-5;
  o.record             = true;
  Model      m2        = make(p, Scenario::no_flow, 150);
  const auto at_two    = run(m2, o);
  EXPECT_EQ(integrator_options(m2, o).max_order, 2);
  // the same at CVODE's own order 5, through the integrator directly
  Model      m5 = make(p, Scenario::no_flow, 150);
  auto       io = integrator_options(m5, o);
  io.max_order  = 0;
  io.max_steps_between_outputs = 100000000;
  Integrator integrator(m5, 0.0, m5.initial_state(), io);
  integrator.advance_to(6.0 / 150);
  const long steps_five = integrator.stats().steps;
  std::printf("L = 1e5 in 6 sections, 6 cycles at 150 Hz: %ld CVODE steps at order 2, %ld at order 5; "
              "chamber pressure vs rtol 1e-9: %.2e of its swing\n",
              at_two.stats.steps, steps_five, error(at_two));
  EXPECT_LT(error(at_two), 2e-3);
  EXPECT_LT(3 * at_two.stats.steps, steps_five);
}

TEST(Effects, InertialLineFeedsTheHighSideThroughItsOwnNode)
{
  // Valve into the node between valve and line, line out of it:
  //   q_valve = (p_ch - p_node) / R1,  C_node p_node' = q_valve - q_line,
  //   L q_line' = p_node - p_h - R3 q_line,  C_h p_h' = q_line,
  // C_node a tenth of the thesis's high side plus half the added line's
  // oil, C_h the rest plus the other half; the outlet pressure is the
  // node's. The line: L = 4/3 rho l / A at the case's bore, so
  // l = 3 L A / (4 rho), R3 grows by 128 mu l / (pi d^4), its oil A l / beta.
  auto p                                = reference();
  p.lines.outlet_inertance_Pa_s2_per_m3 = 1.12e8;
  p.lines.outlet_line_segments          = 1; // one lumped section (the default, as for a short passage)
  Model m                               = make(p, Scenario::no_flow, 150);
  ASSERT_NE(outlet_line(m.constants()), nullptr);
  const auto &line = *outlet_line(m.constants());
  EXPECT_EQ(line.segments(), 1u);
  EXPECT_EQ(m.component("line_inertance"), &line);
  m.set_closed(0, false);
  std::vector<double> y(m.n_states(), 0.0);
  y[state::outlet_reed_x] = 40e-6;
  y[state::chamber_p]     = 1.5e6;
  y[state::line_node_p]   = 0.9e6;
  y[state::high_p]        = 0.4e6;
  y[state::line_flow]     = 1e-6;
  const auto  &c      = m.constants();
  const double R1     = reference_map(p).evaluate(40e-6).resistance;
  const Model  m0     = make(reference(), Scenario::no_flow, 150);
  const auto  &c0     = m0.constants();
  const double C_h0   = c0.C_h;
  const double d = p.lines.diameter_m, A = std::numbers::pi * d * d / 4;
  const double l      = 3 * 1.12e8 * A / (4 * p.fluid.density_kg_per_m3);
  EXPECT_NEAR(l, 1.58, 0.01); // 1.58 m of the case's 4.57 mm line
  EXPECT_NEAR(line.added_length_m(), l, 1e-12 * l);
  const double C_line = A * l / p.fluid.effective_bulk_modulus_Pa();
  const double C_node = 0.1 * C_h0 + 0.5 * C_line;
  EXPECT_NEAR(line.node_compliance(), C_node, 1e-12 * C_node);
  EXPECT_NEAR(c.C_h, 0.9 * C_h0 + 0.5 * C_line, 1e-12 * C_h0);
  const double R_line = 128 * p.fluid.viscosity_Pa_s * l / (std::numbers::pi * std::pow(d, 4));
  EXPECT_NEAR(c.R3, c0.R3 + R_line, 1e-12 * c.R3);
  EXPECT_NEAR(c.R3 / c0.R3, 1 + l / p.lines.length_m, 1e-12); // the same bore: R in proportion to length
  const Flows f = m.flows(y);
  EXPECT_NEAR(f.q_outlet, 0.6e6 / R1, 1e-12 * 0.6e6 / R1);
  EXPECT_EQ(f.q_line, 1e-6);
  EXPECT_NEAR(f.p_outlet, 0.9e6, 1e-6);
  std::vector<double> ydot(m.n_states());
  m.rhs(0.0, y, ydot);
  EXPECT_NEAR(ydot[state::line_node_p], (f.q_outlet - 1e-6) / C_node, 1e-9 * std::abs((f.q_outlet - 1e-6) / C_node));
  EXPECT_NEAR(ydot[state::line_flow], (0.9e6 - 0.4e6 - c.R3 * 1e-6) / 1.12e8, 1e-12);
  EXPECT_NEAR(ydot[state::high_p], 1e-6 / c.C_h, 1e-9 / c.C_h);

  // With free air the node's oil (a tenth of the high side's) holds its
  // share of it: the node's compliance is C_node + V_node c_air(p_node).
  auto pa                    = p;
  pa.fluid.free_air_fraction = 0.01;
  Model ma                   = make(pa, Scenario::no_flow, 150);
  ma.set_closed(0, false);
  const auto  &ca   = ma.constants();
  const double V_h0 = make(reference(), Scenario::no_flow, 150).constants().V_h;
  const auto &line_a = *outlet_line(ca);
  EXPECT_NEAR(line_a.node_oil_volume(), 0.1 * V_h0 + 0.5 * A * l, 1e-12 * V_h0);
  EXPECT_NEAR(ca.V_h, 0.9 * V_h0 + 0.5 * A * l, 1e-12 * V_h0);
  m.rhs(0.0, y, ydot);
  std::vector<double> ydot_air(ma.n_states());
  ma.rhs(0.0, y, ydot_air);
  const double C_air = line_a.node_compliance() + line_a.node_oil_volume() * FreeAir(pa.fluid).gas_compliance_per_volume(0.9e6);
  EXPECT_NEAR(ydot_air[state::line_node_p], (ma.flows(y).q_outlet - 1e-6) / C_air,
              1e-9 * std::abs((ma.flows(y).q_outlet - 1e-6) / C_air));
  EXPECT_LT(ydot_air[state::line_node_p], 0.9 * ydot[state::line_node_p]); // the air softens it

  // A reed closing on the flowing line: the first version (valve and line in
  // one branch, no node) spiked the outlet pressure to 3.9 GPa at t = 64 ms
  // in `rectify synth` of this case, 500x the chamber's peak. With the node
  // the water hammer of the stopping line can lift the node above the
  // chamber (a flow q stopped in C_node rises by up to q sqrt(L / C_node))
  // but not past twice the chamber's peak, and the volume balances (the
  // node's and the line's oil included) close.
  RunOptions o = options(16);
  o.record     = true;
  o.relative_tolerance = 1e-6;
  const RunResult r = run(m, o);
  EXPECT_LT(r.volume_balance_rel_error, 1e-5);
  const auto p_out = r.series->column("outlet_pressure_Pa");
  const auto p_ch  = r.series->column("chamber_pressure_Pa");
  const double ch_max = *std::max_element(p_ch.begin(), p_ch.end());
  EXPECT_LT(*std::max_element(p_out.begin(), p_out.end()), 2.0 * ch_max);
  EXPECT_GT(*std::min_element(p_out.begin(), p_out.end()), -c.p_bias);
}
