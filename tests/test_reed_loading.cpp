// The system model with the reed's fluid loading from a map set ([reed]
// fluid_loading = "map", docs/fluid-loading.md): the reed's energy balance
// closes along a run (the pressure force's work = kinetic + elastic energy
// + what the squeeze film and the structure dissipate), the moving reed
// draws A_m v through its valve, and a map set without a loading table is
// refused with a message that says what to do.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include "common/io.h"
#include "maps/map_set.h"
#include "model_helpers.h"
#include "system/model.h"
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
  maps::LoadingMap loading_map()
  {
    std::vector<maps::LoadingMap::Row> rows;
    for (int i = 0; i <= 12; ++i)
      {
        const double x = 2e-6 * std::pow(600.0, i / 12.0);
        rows.push_back({x, 30 * std::pow(1e-5 / x, 3) + 0.1, 6e-6 * (1 - 0.02 * i / 12.0), 1e-3 * 1e-5 / x + 4e-5,
                        4 * (30 * std::pow(1e-5 / x, 3) + 0.1), 1e-15});
      }
    return maps::LoadingMap(rows, "test loading");
  }

  SystemParameters loaded_reference()
  {
    auto p                          = reference();
    p.reed.fluid_loading            = "map";
    p.reed.effective_mass_kg        = 7.8e-6; // the first mode's in vacuum
    p.reed.structural_damping_ratio = 0.02;
    return p;
  }

  maps::MapSet loaded_set(const SystemParameters &p)
  {
    maps::MapSet set = maps::map_set_from_resistance(reference_map(p), p.reed.pressure_area_m2);
    set.set_loading(loading_map());
    return set;
  }
} // namespace

// Along a run at 500 Hz, over every stretch where the outlet reed is off its
// seat: the work of the pressure force, integral of F v, equals the change of
// (m_r + m_a(x)) v^2 / 2 + k x^2 / 2 plus the integral of (b + c(x)) v^2.
// The m_a'(x) v^2 / 2 term of the reed's equation is what makes it close
// with an opening-dependent added mass (leaving it out is caught: printed).
TEST(ReedLoading, TheReedsEnergyBalanceCloses)
{
  const auto   p   = loaded_reference();
  const auto   set = loaded_set(p);
  const auto   map = loading_map();
  Model        model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(500, 20, 10));
  const double k = p.reed.stiffness_N_per_m, m = p.reed.effective_mass_kg;
  // The map's tip-referred mass and damping in the model's port-load
  // coordinate: divided by gamma = mean A_m / A_eff (the test's A_eff is A_r).
  double g = 0;
  for (const auto &r : map.rows())
    g += r.A_modal_m2 / p.reed.pressure_area_m2 / static_cast<double>(map.rows().size());
  ASSERT_NEAR(model.loading_scale(0), g, 1e-12);
  const double b = 2 * p.reed.structural_damping_ratio * std::sqrt(k * m / g);
  ASSERT_NEAR(model.structural_damping(0), b, 1e-12 * b);
  IntegratorOptions o;
  o.relative_tolerance = 1e-9;
  for (double s : model.typical_sizes())
    o.absolute_tolerances.push_back(1e-11 * s);
  o.finite_difference_jacobian = true;
  o.quiet                      = true;
  const auto y0 = model.initial_state();
  Integrator integrator(model, 0.0, y0, o);

  struct Sample
  {
    double E, P, D, W_mass_slope; // energy; pressure power; dissipation; what m_a' v^3 / 2 does
  };
  const auto sample = [&](std::span<const double> y) {
    const double x = y[state::outlet_reed_x], v = y[state::outlet_reed_v];
    const auto   l = map.evaluate(x);
    const double F = model.flows(y).outlet_force;
    return Sample{0.5 * (m + l.added_mass) / g * v * v + 0.5 * k * x * x, F * v, (b + l.damping / g) * v * v,
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
  std::printf("reed energy balance: %d stretches off the seat, largest miss %.2e of the work (without the "
              "m_a'(x) v^2/2 term it would be %.2e)\n",
              n_stretches, worst, worst_without);
  ASSERT_GE(n_stretches, 2);
  EXPECT_LT(worst, 1e-4);
  EXPECT_GT(worst_without, 10 * worst); // the term matters on this run
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
