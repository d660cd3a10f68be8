// The system model with the reed's fluid loading from a map set ([reed]
// fluid_loading = "map", docs/fluid-loading.md): the reed's energy balance
// closes along a run (the pressure force's work = kinetic + elastic energy
// + what the squeeze film and the structure dissipate), the moving reed
// draws A_m v through its valve, and a map set without a loading table is
// refused with a message that says what to do.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <fstream>
#include <vector>

#include "common/io.h"
#include "maps/map_set.h"
#include "model_helpers.h"
#include "system/model.h"
#include "system/reed.h"
#include "tests/cli_helpers.h"

using namespace rectify;
using namespace rectify::system;
using namespace rectify::test_support;

namespace
{
  /// A loading map of the reference valve's sizes: m_a ~ 1/x with a floor
  /// (as `rectify design` finds it), A_m nearly constant, c ~ x^-3 with a
  /// floor but a hundredth of the reference valve's, so that the reed
  /// leaves its seat and comes back in every cycle (with the full squeeze
  /// film it hangs a micrometre open after its first opening).
  maps::LoadingMap loading_map(double c_scale = 1.0)
  {
    std::vector<maps::LoadingMap::Row> rows;
    for (int i = 0; i <= 12; ++i)
      {
        const double x = 2e-6 * std::pow(600.0, i / 12.0);
        const double c = c_scale * (30 * std::pow(1e-5 / x, 3) + 0.1);
        rows.push_back({x, c, 6e-6 * (1 - 0.02 * i / 12.0), 1e-3 * 1e-5 / x + 4e-5, 4 * c, 1e-15});
      }
    // the film's modal area of the reference valve's size (9.8 mm^2: its
    // beam shape over the reed less the port)
    return maps::LoadingMap(rows, "test loading", {{"film_modal_area_m2", 9.8e-6}});
  }

  SystemParameters loaded_reference()
  {
    auto p                          = reference();
    p.reed.fluid_loading            = "map";
    p.reed.effective_mass_kg        = 7.8e-6; // the first mode's in vacuum
    p.reed.structural_damping_ratio = 0.02;
    return p;
  }

  maps::MapSet loaded_set(const SystemParameters &p, double c_scale = 1.0)
  {
    maps::MapSet set = maps::map_set_from_resistance(reference_map(p), p.reed.pressure_area_m2);
    set.set_loading(loading_map(c_scale));
    return set;
  }
} // namespace

// Along a run at 500 Hz, over every stretch where the outlet reed is off its
// seat: the work of the pressure force, integral of F v, equals the change of
// (m_r + m_a(x)) v^2 / 2 + k x^2 / 2 plus the integral of (b + c(x)) v^2.
// The m_a'(x) v^2 / 2 term of the reed's equation is what makes it close
// with an opening-dependent added mass (leaving it out is caught: printed).
namespace
{
  struct EnergyBalance
  {
    int    n_stretches = 0;
    double worst = 0, worst_without = 0; ///< largest miss over the work; the same without the m_a' term
    double capped_share = 0;             ///< share of the samples where the film's suction limit acted (> 1 %)
  };

  EnergyBalance reed_energy_balance(const SystemParameters &p)
  {
    const auto   set = loaded_set(p);
    const auto   map = loading_map();
    Model        model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(500, 20, 10));
    const double k = p.reed.stiffness_N_per_m, m = p.reed.effective_mass_kg;
    // The map's tip-referred mass and damping in the model's port-load
    // coordinate: divided by gamma = mean A_m / A_eff (the test's A_eff is A_r).
    double g = 0;
    for (const auto &r : map.rows())
      g += r.A_modal_m2 / p.reed.pressure_area_m2 / static_cast<double>(map.rows().size());
    EXPECT_NEAR(model.loading_scale(0), g, 1e-12);
    const double b = 2 * p.reed.structural_damping_ratio * std::sqrt(k * m / g);
    EXPECT_NEAR(model.structural_damping(0), b, 1e-12 * b);
    const auto y0 = model.initial_state();
    Integrator integrator(model, 0.0, y0, tight_integration(model, 1e-9, 1e-11));

    struct Sample
    {
      double E, P, D, W_mass_slope; // energy; pressure power; dissipation; what m_a' v^3 / 2 does
    };
    std::size_t n_samples = 0, n_capped = 0;
    const auto sample = [&](std::span<const double> y) {
      const double x = y[state::outlet_reed_x], v = y[state::outlet_reed_v];
      const auto   l = map.evaluate(x + p.reed.seat_film_m); // the loading at x + the seat film
      const auto   f = model.flows(y);
      // the film's force: c v / gamma, or less while a lifting reed's suction is limited
      const double film = model.film_force(0, y, f);
      ++n_samples;
      if (film < 0.99 * l.damping / g * v)
        ++n_capped;
      return Sample{0.5 * (m + l.added_mass) / g * v * v + 0.5 * k * x * x, f.outlet_force * v, b * v * v + film * v,
                    0.5 * l.added_mass_slope / g * v * v * v};
    };
    const double dt = 1.0 / (500 * 20000);
    std::vector<Sample> stretch;
    double              worst = 0, worst_without = 0, total_work = 0;
    int                 n_stretches = 0;
    const auto close_stretch = [&]() {
      if (stretch.size() > 50)
        {
          double W = 0, D = 0, M = 0, scale = 0;
          for (std::size_t i = 1; i < stretch.size(); ++i)
            {
              W += 0.5 * dt * (stretch[i].P + stretch[i - 1].P);
              D += 0.5 * dt * (stretch[i].D + stretch[i - 1].D);
              M += 0.5 * dt * (stretch[i].W_mass_slope + stretch[i - 1].W_mass_slope);
              scale += 0.5 * dt * (std::abs(stretch[i].P) + std::abs(stretch[i - 1].P));
            }
          const double dE = stretch.back().E - stretch.front().E;
          worst           = std::max(worst, std::abs(W - D - dE) / scale);
          // Without the m_a' term the energy would change by what it does.
          worst_without = std::max(worst_without, std::abs(W - D - dE + M) / scale);
          total_work += scale;
          ++n_stretches;
        }
      stretch.clear();
    };
    for (int i = 1; i <= 4 * 20000; ++i)
      {
        integrator.advance_to(i * dt);
        if (model.closed(0))
          close_stretch();
        else
          stretch.push_back(sample(integrator.state()));
      }
    close_stretch();
    return {n_stretches, worst, worst_without,
            static_cast<double>(n_capped) / static_cast<double>(std::max<std::size_t>(n_samples, 1))};
  }
} // namespace

TEST(ReedLoading, TheReedsEnergyBalanceCloses)
{
  auto p                    = loaded_reference();
  p.reed.film_suction_limit = "none";
  const auto e              = reed_energy_balance(p);
  std::printf("reed energy balance: %d stretches off the seat, largest miss %.2e of the work (without the "
              "m_a'(x) v^2/2 term it would be %.2e)\n",
              e.n_stretches, e.worst, e.worst_without);
  ASSERT_GE(e.n_stretches, 2);
  EXPECT_LT(e.worst, 1e-4);
  EXPECT_GT(e.worst_without, 10 * e.worst); // the term matters on this run
}

// The same with the film's suction limited by cavitation, at a cavitation
// pressure 0.2 MPa below the bias (so that the limit acts on this run: the
// film may pull its pressure only about 0.2 MPa below the pocket's), and a
// seat film of 1 um (the loading read at x + 1 um): the film's force, now
// not c v, is what the reed dissipates.
TEST(ReedLoading, TheReedsEnergyBalanceClosesWithTheFilmsSuctionLimited)
{
  auto p                             = loaded_reference();
  p.reed.film_suction_limit          = "cavitation";
  p.reed.film_cavitation_pressure_Pa = p.fluid.bias_pressure_Pa - 0.2e6;
  p.reed.seat_film_m                 = 1e-6;
  const auto e                       = reed_energy_balance(p);
  std::printf("reed energy balance, suction limited: %d stretches, largest miss %.2e of the work, the limit "
              "acting in %.1f %% of the samples off the seat\n",
              e.n_stretches, e.worst, 100 * e.capped_share);
  ASSERT_GE(e.n_stretches, 2);
  EXPECT_GT(e.capped_share, 0.01); // the limit acts on this run
  EXPECT_LT(e.worst, 1e-4);
}

// The film's force on a lifting reed: c v / gamma while its suction is small,
// the suction limit (p_pocket - p_cav) A_film / gamma when the reed lifts
// fast (the pocket: behind the outlet valve, the chamber for the inlet
// valve, absolute with the bias), no limit while it closes; the loading is
// read at the opening plus the seat film.
TEST(ReedLoading, TheFilmsSuctionIsLimitedByCavitation)
{
  auto p                             = loaded_reference();
  p.reed.film_cavitation_pressure_Pa = 1e5;
  p.reed.seat_film_m                 = 3e-6;
  const auto set                     = loaded_set(p);
  Model      model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 20, 10));
  model.set_closed(0, false);
  model.set_closed(1, false);
  auto y                  = model.initial_state();
  y[state::chamber_p]     = 1e6;
  y[state::high_p]        = 0.4e6;
  y[state::outlet_reed_x] = 20e-6;
  y[state::inlet_reed_x]  = 20e-6;
  const double g          = model.loading_scale(0);
  const auto   l          = loading_map().evaluate(23e-6); // x + the seat film
  ASSERT_TRUE(model.loading(0, y));
  EXPECT_DOUBLE_EQ(model.loading(0, y)->damping, l.damping);
  const double c = l.damping / g;
  for (const double v : {-10.0, -1e-3, 1e-6, 1e-3, 10.0, 100.0})
    {
      y[state::outlet_reed_v] = y[state::inlet_reed_v] = v;
      const auto   f       = model.flows(y);
      const double cap_out = (f.p_outlet + p.fluid.bias_pressure_Pa - 1e5) * 9.8e-6 / g;
      const double cap_in  = (y[state::chamber_p] + p.fluid.bias_pressure_Pa - 1e5) * 9.8e-6 / g;
      EXPECT_NEAR(model.film_suction_cap(0, y, f), cap_out, 1e-9 * cap_out);
      EXPECT_NEAR(model.film_suction_cap(1, y, f), cap_in, 1e-9 * cap_in);
      const double out = model.film_force(0, y, f), in = model.film_force(1, y, f);
      if (v < 0)
        EXPECT_DOUBLE_EQ(out, c * v) << v; // closing: the film's pressure rises, no limit
      else if (c * v < 1e-3 * cap_out)
        EXPECT_NEAR(out, c * v, 1e-6 * c * v) << v;
      else if (c * v > 20 * cap_out)
        {
          EXPECT_NEAR(out, cap_out, 1e-12 * cap_out) << v;
          EXPECT_NEAR(in, cap_in, 1e-12 * cap_in) << v;
        }
      EXPECT_LE(out, std::max(c * v, 0.0) + 1e-12) << v;
    }
  // a pocket at the cavitation pressure: no suction left but the softplus's 10 kPa rounding
  y[state::chamber_p]    = 1e5 - p.fluid.bias_pressure_Pa;
  y[state::inlet_reed_v] = 1.0;
  const auto f           = model.flows(y);
  EXPECT_NEAR(model.film_suction_cap(1, y, f), std::log(2.0) * 1e4 * 9.8e-6 / g, 1e-9);
  // "none": c v at any speed
  p.reed.film_suction_limit = "none";
  Model free(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 20, 10));
  free.set_closed(0, false);
  y[state::outlet_reed_v] = 100.0;
  EXPECT_DOUBLE_EQ(free.film_force(0, y, free.flows(y)), c * 100.0);
}

// What the suction limit does: a seated reed under the squeeze film of the
// reference valve's size (c ~ x^-3, 3 kN s/m at 10 um, 3e6 on the seat)
// creeps while its pressure force is below the film's limit (v = F gamma /
// c: micrometres per second) and lifts at once when the force passes it.
// First stroke, no flow, 10 Hz, 20 A: the outlet reed, the high side behind
// it still at the bias, must lift when
//   A_r (p_ch - p_o) = (p_o + p_bias - p_cav) A_film / gamma,
// the chamber's pressure then rising about 2.4e8 Pa/s; "lifts": past
// 0.5 um (the test's thesis R(x) passes the stroke's flow at 2 um), which
// the reed's inertia (its added mass on the seat) delays by about 0.2 ms,
// 1.4 % of the pressure. Without the limit it creeps (1e-5 m/s) and is
// still below 0.5 um at the stroke's end.
TEST(ReedLoading, ASeatedReedLiftsWhenItsForcePassesTheFilmsSuctionLimit)
{
  const auto lift = [](const std::string &limit) {
    auto p                             = loaded_reference();
    p.reed.film_suction_limit          = limit;
    p.reed.film_cavitation_pressure_Pa = 1e5;
    const auto set                     = loaded_set(p, 100.0);
    Model      model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(10, 20, 10));
    Integrator integrator(model, 0.0, model.initial_state(), tight_integration(model, 1e-8, 1e-10));
    for (int i = 1; i <= 5000; ++i) // the first half cycle, 10 us apart
      {
        integrator.advance_to(i * 1e-5);
        const auto y = integrator.state();
        if (y[state::outlet_reed_x] > 0.5e-6)
          {
            const auto f = model.flows(y);
            return std::pair{y[state::chamber_p] - f.p_outlet, f.p_outlet};
          }
      }
    return std::pair{std::nan(""), std::nan("")};
  };
  const auto   p          = loaded_reference();
  const auto   [dp, p_o]  = lift("cavitation");
  double       g          = 0;
  const auto   map        = loading_map(100.0);
  for (const auto &r : map.rows())
    g += r.A_modal_m2 / p.reed.pressure_area_m2 / static_cast<double>(map.rows().size());
  const double threshold  = (p_o + p.fluid.bias_pressure_Pa - 1e5) * 9.8e-6 / (g * p.reed.pressure_area_m2);
  const auto   [dp_free, p_o_free] = lift("none");
  std::printf("outlet reed past 0.5 um at a drop of %.4g MPa; the film's suction limit %.4g MPa (ratio %.4f); "
              "without the limit: %s\n",
              dp * 1e-6, threshold * 1e-6, dp / threshold,
              std::isnan(dp_free) ? "not within the stroke" : format_number(dp_free).c_str());
  ASSERT_FALSE(std::isnan(dp));
  EXPECT_GT(dp / threshold, 1.0);
  EXPECT_LT(dp / threshold, 1.02);
  EXPECT_TRUE(std::isnan(dp_free)) << dp_free;
  (void)p_o_free;
}

// film_force itself: smooth at v = 0 (value, slope c, no curvature), bounded by the cap.
TEST(ReedLoading, FilmForceIsSmoothAndBounded)
{
  const double c = 50, cap = 2, h = 1e-6;
  EXPECT_EQ(film_force(c, 0.0, cap), 0.0);
  EXPECT_NEAR((film_force(c, h, cap) - film_force(c, -h, cap)) / (2 * h), c, 1e-6 * c);
  EXPECT_NEAR(film_force(c, h, cap) + film_force(c, -h, cap), 0.0, 1e-12);
  EXPECT_NEAR(film_force(c, 1.0, cap), cap, 1e-12);
  EXPECT_EQ(film_force(c, -1.0, cap), -c);
  EXPECT_EQ(film_force(c, 1.0, 0.0), 0.0);
  EXPECT_EQ(film_force(c, 1.0, std::numeric_limits<double>::infinity()), c);
  EXPECT_NEAR(film_suction_cap(3e6, 1e5, 1e-5), 2.9e6 * 1e-5, 1e-9);
}

// A map set made before the film's modal area was written, with the
// suction limit on: refused, saying what to do; "none" takes it.
TEST(ReedLoading, ASuctionLimitNeedsTheFilmsArea)
{
  const auto   p    = loaded_reference();
  const auto   rows = loading_map().rows();
  maps::MapSet set  = maps::map_set_from_resistance(reference_map(p), p.reed.pressure_area_m2);
  set.set_loading(maps::LoadingMap(rows, "old loading"));
  try
    {
      Model model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 20, 10));
      FAIL() << "accepted";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("no film modal area"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("rectify design"), std::string::npos) << e.what();
    }
  auto q                    = p;
  q.reed.film_suction_limit = "none";
  EXPECT_NO_THROW(Model(q, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 20, 10)));
  // and a bad area in a table's meta is refused naming it
  EXPECT_THROW(maps::LoadingMap(rows, "bad", {{"film_modal_area_m2", -1.0}}), InputError);
  EXPECT_THROW(maps::LoadingMap(rows, "bad", {{"film_modal_area_m2", "a lot"}}), InputError);
}


// The moving reed draws A_m(x) v through its valve: with the line R3 in
// series, the outlet's flow grows by R1 A_m v / (R1 + R3), and the force on
// the reed is A_eff times the valve's drop R1 (q - A_m v).
TEST(ReedLoading, AMovingReedDrawsFlowThroughItsValve)
{
  const auto p   = loaded_reference();
  const auto set = loaded_set(p);
  Model      model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 20, 10));
  model.set_closed(0, false);
  auto y                  = model.initial_state();
  y[state::chamber_p]     = 2e5;
  y[state::outlet_reed_x] = 50e-6;
  const auto still        = model.flows(y);
  y[state::outlet_reed_v] = 0.05;
  const auto   moving     = model.flows(y);
  const double A_m        = loading_map().evaluate(50e-6).A_modal;
  const double R1 = still.R1, R3 = model.constants().R3;
  EXPECT_NEAR(moving.q_outlet - still.q_outlet, R1 * A_m * 0.05 / (R1 + R3), 1e-9 * std::abs(still.q_outlet));
  EXPECT_NEAR(moving.outlet_force, p.reed.pressure_area_m2 * R1 * (moving.q_outlet - A_m * 0.05),
              1e-9 * std::abs(moving.outlet_force));
  EXPECT_DOUBLE_EQ(model.displaced_flow(0, y), A_m * 0.05);
  EXPECT_EQ(model.displaced_flow(1, y), 0.0); // the inlet reed is seated
}

// The coloured difference-quotient Jacobian with the loading: the reeds'
// velocities feed the flows (displaced flow, film), read as rhs_reads() says,
// and a run gives CVODE's own column-by-column run bit for bit.
TEST(ReedLoading, RhsReadsCoversTheLoadingAndTheColouredRunIsCVODEs)
{
  for (const char *limit : {"none", "cavitation"})
    for (auto scenario : {Scenario::no_flow, Scenario::loaded})
      {
        auto p                              = loaded_reference();
        p.reed.film_suction_limit           = limit;
        p.valves.orifice_discharge_coefficient = 0.6;
        const auto set = loaded_set(p);
        Model      model(p, ValveMaps{set, set}, ValveModel::dynamic, scenario, Drive::sine(200, 20, 10));
        EXPECT_EQ(test_support::rhs_reads_misses(model, model.rhs_reads(), 8, 3), "") << limit << " " << to_string(scenario);
        RunOptions o;
        o.relative_tolerance = 1e-7;
        const auto dense     = test_support::run_linear_system(model, o, true, true, 2.0 / 200);
        const auto fast      = test_support::run_linear_system(model, o, false, true, 2.0 / 200);
        EXPECT_EQ(fast.stats.steps, dense.stats.steps);
        for (std::size_t i = 0; i < model.n_states(); ++i)
          EXPECT_EQ(fast.state[i], dense.state[i]) << limit << " " << to_string(scenario) << " state " << i;
        EXPECT_LT(fast.stats.rhs_evaluations_for_fd_jacobian, dense.stats.rhs_evaluations_for_fd_jacobian);
      }
}

TEST(ReedLoading, AMapSetWithoutALoadingTableIsRefused)
{
  const auto p   = loaded_reference();
  const auto set = maps::map_set_from_resistance(reference_map(p), p.reed.pressure_area_m2);
  try
    {
      Model model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 20, 10));
      FAIL() << "accepted";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("has no loading table"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("reed_loading"), std::string::npos) << e.what();
    }
  // The thesis's loading needs none.
  auto q          = p;
  q.reed.fluid_loading = "thesis";
  EXPECT_NO_THROW(Model(q, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(100, 20, 10)));
}

// loading.csv in a map set: written and read back exactly, its hash in the
// manifest (a changed table is refused), and bad tables refused naming the
// file, the row and the column.
TEST(ReedLoading, TheLoadingTableRoundTripsAndBadOnesAreRefused)
{
  const auto p   = loaded_reference();
  const auto dir = scratch("loading_map_set");
  loaded_set(p).write(dir);
  const auto back = maps::MapSet::read(dir);
  ASSERT_TRUE(back.loading());
  ASSERT_EQ(back.loading()->rows().size(), loading_map().rows().size());
  ASSERT_TRUE(back.loading()->film_modal_area_m2());
  EXPECT_EQ(*back.loading()->film_modal_area_m2(), 9.8e-6);
  for (double x : {1e-6, 3e-6, 47e-6, 0.9e-3, 2e-3})
    {
      const auto a = back.loading()->evaluate(x), b = loading_map().evaluate(x);
      EXPECT_EQ(a.damping, b.damping) << x;
      EXPECT_EQ(a.added_mass, b.added_mass) << x;
      EXPECT_EQ(a.added_mass_slope, b.added_mass_slope) << x;
    }
  // below the first node: the power law, rounded off to at most 2^q (q the
  // log-log slope) on the seat; continuous in value and slope at the node
  const auto   first = loading_map().rows().front();
  const double x0    = first.opening_m;
  const auto   below = loading_map().evaluate(x0 * (1 - 1e-7)), above = loading_map().evaluate(x0 * (1 + 1e-7));
  EXPECT_NEAR(below.damping / above.damping, 1.0, 1e-5);
  EXPECT_NEAR(below.added_mass_slope / above.added_mass_slope, 1.0, 1e-4);
  const double q_c = -std::log(loading_map().evaluate(x0 * 1.001).damping / first.damping_fixed_dp_N_s_per_m) /
                     std::log(1.001);
  EXPECT_NEAR(loading_map().evaluate(0.0).damping / first.damping_fixed_dp_N_s_per_m, std::pow(2.0, q_c), 1e-2);
  EXPECT_EQ(loading_map().evaluate(0.0).added_mass_slope, 0.0);
  EXPECT_EQ(loading_map().evaluate(5e-3).damping, loading_map().rows().back().damping_fixed_dp_N_s_per_m);
  // the interpolant follows the power laws between the nodes
  const auto mid = loading_map().evaluate(std::sqrt(2e-6 * 3.4e-6));
  EXPECT_GT(mid.added_mass_slope, -1e300);
  EXPECT_LT(mid.added_mass_slope, 0.0);

  const auto refused = [&](const std::string &text, const std::string &needle) {
    const auto path = dir / "bad.csv";
    write_file_atomic(path, text);
    try
      {
        (void)maps::LoadingMap::read(path);
        ADD_FAILURE() << "accepted: " << text;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("bad.csv"), std::string::npos) << e.what();
      }
  };
  const std::string head = "opening_m,damping_fixed_dp_N_s_per_m,A_modal_m2,added_mass_kg,damping_N_s_per_m,asymmetry\n";
  refused(head + "1e-5,10,6e-6,1e-4,40,0\n2e-5,-1,6e-6,1e-4,40,0\n", "row 2: damping_fixed_dp_N_s_per_m = -1");
  refused(head + "1e-5,10,6e-6,1e-4,40,0\n1e-5,1,6e-6,1e-4,40,0\n", "does not increase");
  refused(head + "1e-5,10,6e-6,nan,40,0\n2e-5,1,6e-6,1e-4,40,0\n", "'added_mass_kg': value nan");
  refused(head + "1e-5,10,6e-6,1e-4,40,0\n", "at least two");
  refused("opening_m,damping_N_s_per_m\n1e-5,1\n", "damping_fixed_dp_N_s_per_m");
  // a changed table in a map set
  {
    std::ofstream out(dir / "loading.csv", std::ios::app);
    out << "# edited\n";
  }
  try
    {
      (void)maps::MapSet::read(dir);
      ADD_FAILURE() << "accepted a changed loading.csv";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("loading.csv does not match its manifest"), std::string::npos) << e.what();
    }
  std::filesystem::remove_all(dir);
}

// The film's keys shape the map's squeeze film: with the thesis's loading
// they are refused, in the case and on the command line, naming the key.
TEST(ReedLoading, TheFilmsKeysAreReadOnlyWithTheMapsLoading)
{
  const auto dir = scratch("film_keys");
  auto       r   = rectify_cli("simulate --seat-film-m 1e-6 --cycles 1 --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--fluid-loading map"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  r = rectify_cli("simulate --fluid-loading map --seat-film-m -1e-6 --cycles 1 --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--seat-film-m -1e-06: must be"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  const auto map = (reference_case_path().parent_path() / "thesis-resistance.csv").string();
  write_file_atomic(dir / "case.toml", replace(replace(reference_text(), "\"thesis-resistance.csv\"", "\"" + map + "\""),
                                               "fluid_loading = \"thesis\"\n",
                                               "fluid_loading = \"thesis\"\nseat_film_m = 1e-6\n"));
  r = rectify_cli("check --case " + (dir / "case.toml").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("[reed] seat_film_m"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("fluid_loading = \"map\""), std::string::npos) << r.output;
}
