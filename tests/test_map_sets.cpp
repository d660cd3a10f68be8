// The system model on map sets (maps/map_set.h): the thesis's valve as a map
// set gives today's numbers exactly, A_eff enters the reed's force, the
// analytic Jacobian holds with a varying A_eff(x), and map sets made for
// another valve, or in conflict with the case, are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "common/case_file.h"
#include "common/io.h"
#include "maps/map_set.h"
#include "model_helpers.h"
#include "tests/cli_helpers.h"
#include "system/model.h"
#include "system/simulation.h"

using namespace rectify;
using namespace rectify::system;
using namespace rectify::test_support;

namespace
{
  RunOptions options(const SystemParameters &p, std::size_t cycles) { return run_options(p, cycles); }

  /// The reference valve with R(x) from the thesis and a force area that
  /// falls from 2 A_r to A_r over the openings (a map set's shape), seated A_r.
  maps::MapSet varying_area_set(const SystemParameters &p)
  {
    const double A = p.reed.pressure_area_m2;
    return maps::MapSet(reference_map(p), maps::AreaMap({2e-6, 2e-5, 2e-4, 1.2e-3}, {2 * A, 1.9 * A, 1.5 * A, A}, "a"),
                        A, std::nullopt, {{"source", "test"}});
  }
} // namespace

TEST(MapSets, TheThesisValveAsAMapSetReproducesTheThesisCaseExactly)
{
  const auto p   = reference();
  const auto dir = scratch("thesis_map_set");
  maps::map_set_from_resistance(reference_map(p), p.reed.pressure_area_m2).write(dir);
  const auto set = maps::MapSet::read(dir);
  struct Case
  {
    Scenario    scenario;
    double      f, pp, bias;
    std::size_t cycles;
  };
  for (const Case k : {Case{Scenario::no_flow, 25, 20, 10, 4}, Case{Scenario::no_flow, 300, 4, 2, 10},
                       Case{Scenario::loaded, 1000, 20, 10, 30}})
    {
      Model before(p, reference_map(p), ValveModel::dynamic, k.scenario, Drive::sine(k.f, k.pp, k.bias));
      Model after(p, ValveMaps{set, set}, ValveModel::dynamic, k.scenario, Drive::sine(k.f, k.pp, k.bias));
      const auto a = run(before, options(p, k.cycles)), b = run(after, options(p, k.cycles));
      EXPECT_EQ(a.stored_pressure_Pa, b.stored_pressure_Pa) << k.f << " Hz";
      EXPECT_EQ(a.mean_velocity_m_per_s, b.mean_velocity_m_per_s) << k.f << " Hz";
      EXPECT_EQ(a.stats.steps, b.stats.steps) << k.f << " Hz";
      EXPECT_EQ(a.n_seat_impacts, b.n_seat_impacts);
    }
  // The same through a case file's [valves] map_set.
  const auto case_text = "[valves]\nmap_set = \"" + dir.string() + "\"\n";
  const auto q         = SystemParameters::from_case(CaseFile::parse(case_text, "thesis-set.toml"));
  EXPECT_EQ(q.valves.map_set[0], dir.string());
  EXPECT_EQ(q.reed.stiffness_N_per_m, p.reed.stiffness_N_per_m); // no reed in the thesis's set: the case's
  const auto loaded = load_valve_maps(q);
  EXPECT_EQ(loaded[1].resistance().resistances(), reference_map(p).resistances());
  std::filesystem::remove_all(dir);
}

TEST(MapSets, DoublingAEffLiftsTheReedAtHalfThePressureDifference)
{
  const auto p = reference();
  const double A = p.reed.pressure_area_m2, k = p.reed.stiffness_N_per_m;
  const auto single = maps::map_set_from_resistance(reference_map(p), A);
  const maps::MapSet twice(reference_map(p), maps::AreaMap::constant(2 * A, "2 A_r"), A, std::nullopt, {});
  Model m1(p, ValveMaps{single, single}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(10, 0, 0));
  Model m2(p, ValveMaps{twice, twice}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(10, 0, 0));
  for (Model *m : {&m1, &m2})
    m->set_closed(0, false);
  // The outlet reed open at x with the chamber above the high side: its
  // force is A (p_ch - p_o), and it is in equilibrium where A dp_valve = k x.
  const double x = 30e-6;
  const auto   state = [&](double p_ch) {
    std::vector<double> y(m1.n_states(), 0.0);
    y[state::outlet_reed_x] = x;
    y[state::chamber_p]     = p_ch;
    return y;
  };
  const auto f1 = m1.flows(state(2e5)), f2 = m2.flows(state(1e5));
  EXPECT_NEAR(f2.outlet_force, f1.outlet_force, 1e-12 * f1.outlet_force); // half the pressure, same force
  const double dp_valve1 = 2e5 - f1.p_outlet;
  EXPECT_NEAR(f1.outlet_force, A * dp_valve1, 1e-12 * f1.outlet_force);
  // Dynamically: a reed held by a pressure difference settles where A dp = k x,
  // the doubled area at half the difference where the single one does.
  std::vector<double> y1 = state(2e5), y2 = state(1e5), d1(m1.n_states()), d2(m2.n_states());
  y1[state::outlet_reed_x] = y2[state::outlet_reed_x] = A * dp_valve1 / k;
  m1.rhs(0, y1, d1);
  m2.rhs(0, y2, d2);
  EXPECT_NEAR(d2[state::outlet_reed_v], d1[state::outlet_reed_v], 1e-9 * k * x / p.reed.effective_mass_kg);
  // A seated reed pushes on the seated area, whatever A_eff is.
  m2.set_closed(0, true);
  EXPECT_NEAR(m2.flows(state(1e5)).outlet_force, A * (1e5 - m2.flows(state(1e5)).p_outlet), 1e-12);
}

TEST(MapSets, AnalyticJacobianHoldsWithAVaryingForceArea)
{
  const auto   p   = reference();
  const auto   set = varying_area_set(p);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 6; ++trial)
    {
      Model model(p, ValveMaps{set, set}, ValveModel::dynamic, trial % 2 ? Scenario::loaded : Scenario::no_flow,
                  Drive::sine(100, 20, 10));
      model.set_closed(0, false);
      model.set_closed(1, false);
      const auto          typical = model.typical_sizes();
      std::vector<double> y(model.n_states());
      for (std::size_t i = 0; i < y.size(); ++i)
        y[i] = typical[i] * u(rng);
      y[state::outlet_reed_x] = (1 + 300 * std::abs(u(rng))) * 1.013e-6;
      y[state::inlet_reed_x]  = (1 + 300 * std::abs(u(rng))) * 1.017e-6;
      const std::size_t   n = model.n_states();
      std::vector<double> J(n * n, 0.0), fp(n), fm(n);
      model.jacobian(0.01, y, DenseView{J.data(), n});
      for (const std::size_t j : {std::size_t{state::outlet_reed_x}, std::size_t{state::inlet_reed_x},
                                  std::size_t{state::chamber_p}, std::size_t{state::high_p}})
        {
          const double h  = 1e-4 * typical[j];
          auto         yp = y, ym = y;
          yp[j] += h;
          ym[j] -= h;
          model.rhs(0.01, yp, fp);
          model.rhs(0.01, ym, fm);
          for (const std::size_t i : {std::size_t{state::outlet_reed_v}, std::size_t{state::inlet_reed_v}})
            {
              const double fd = (fp[i] - fm[i]) / (2 * h), exact = J[j * n + i];
              EXPECT_NEAR(exact, fd, 1e-5 * std::abs(fd) + 1e-10 * std::abs(fp[i]) / typical[j])
                << "trial " << trial << " d f[" << i << "]/d y[" << j << "]";
            }
        }
    }
  // And a run with it converges to the same answer with either Jacobian.
  double stored[2];
  for (int fd = 0; fd < 2; ++fd)
    {
      Model model(p, ValveMaps{set, set}, ValveModel::dynamic, Scenario::no_flow, Drive::sine(25, 20, 10));
      auto  o                      = options(p, 4);
      o.finite_difference_jacobian = fd == 1;
      stored[fd]                   = run(model, o).stored_pressure_Pa;
    }
  EXPECT_NEAR(stored[1], stored[0], 1e-3 * std::abs(stored[0]));
}

TEST(MapSets, CaseAndMapSetMustAgree)
{
  const auto dir = scratch("case_map_set");
  maps::ReedProperties reed;
  reed.stiffness_N_per_m = 6492, reed.modal_mass_kg = 7.8e-6, reed.modal_mass_in_fluid_kg = 3.4e-5;
  reed.effective_mass_eq321_kg = 3.83e-4, reed.frequency_Hz = 2843, reed.frequency_in_fluid_Hz = 1351;
  reed.plate_mass_kg = 3.1e-5, reed.added_mass_kg = 1.08e-4;
  reed.root_stress_per_opening_Pa_per_m = 1.6e12, reed.root_stress_concentration = 1.2;
  const auto p = reference();
  const maps::MapSet set(reference_map(p), maps::AreaMap::constant(15e-6, "A"), 7.917e-6, reed,
                         {{"depends_on", maps::hashed_tables(maps::physical_tables({}, {}, {}))}});
  set.write(dir);
  const std::string use = "[valves]\nmap_set = \"" + dir.string() + "\"\n";
  // The reed comes from the map set; the mass per [reed] properties_mass.
  auto q = SystemParameters::from_case(CaseFile::parse(use, "ok.toml"));
  EXPECT_EQ(q.reed.stiffness_N_per_m, 6492);
  EXPECT_EQ(q.reed.effective_mass_kg, 3.83e-4);
  q = SystemParameters::from_case(CaseFile::parse(use + "[reed]\nproperties_mass = \"modal-in-fluid\"\n", "ok.toml"));
  EXPECT_EQ(q.reed.effective_mass_kg, 3.4e-5);
  const auto refused = [&](const std::string &text, const std::string &needle) {
    try
      {
        (void)SystemParameters::from_case(CaseFile::parse(text, "case.toml"));
        ADD_FAILURE() << "accepted:\n" << text;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      }
  };
  refused(use + "[geometry]\nport_diameter_m = 3e-3\n", "[geometry] port_diameter_m");
  refused(use + "[fluid]\nviscosity_Pa_s = 0.05\n", "[fluid] viscosity_Pa_s");
  refused(use + "[reed_material]\npoisson_ratio = 0.3\n", "[reed_material] poisson_ratio");
  refused(use + "[reed]\nstiffness_N_per_m = 6650\n", "stiffness_N_per_m");
  refused(use + "resistance_map = \"x.csv\"\n", "resistance_map");
  refused(use + "outlet_map_set = \"" + dir.string() + "\"\n", "outlet_map_set");
  refused("[valves]\nmap_set = \"" + (dir / "nowhere").string() + "\"\n", "[valves] map_set = ");
  // The reed's FE root stress comes with it; a map set written without it
  // (before it existed) is refused where the run needs it, naming the key.
  EXPECT_EQ(q.reed.root_stress_per_opening_Pa_per_m, 1.6e12);
  EXPECT_NE(q.reed.stress_source.find("FE root stress of map set"), std::string::npos) << q.reed.stress_source;
  {
    auto old_reed = reed;
    old_reed.root_stress_per_opening_Pa_per_m = 0;
    auto old_json = old_reed.to_json();
    for (const char *key : {"root_stress_per_opening_Pa_per_m", "root_stress_beam_per_opening_Pa_per_m",
                            "root_stress_concentration", "second_mode_root_stress_per_opening_Pa_per_m"})
      old_json.erase(key);
    const auto back = maps::ReedProperties::from_json(old_json, "old");
    EXPECT_FALSE(back.has_stress());
    const auto old_dir = scratch("case_map_set_without_stress");
    maps::MapSet(reference_map(p), maps::AreaMap::constant(15e-6, "A"), 7.917e-6, back,
                 {{"depends_on", maps::hashed_tables(maps::physical_tables({}, {}, {}))}})
      .write(old_dir);
    refused("[valves]\nmap_set = \"" + old_dir.string() + "\"\n", "root_stress_per_opening_Pa_per_m");
    refused("[valves]\nmap_set = \"" + old_dir.string() + "\"\n", old_dir.string());
  }
  // One valve on the map set, the other on the thesis's R(x) and A_r.
  const auto one = SystemParameters::from_case(
    CaseFile::parse("[valves]\noutlet_map_set = \"" + dir.string() + "\"\n", "one.toml",
                    reference_case_path().parent_path())); // the inlet's thesis map beside the reference case
  const auto mixed = load_valve_maps(one);
  EXPECT_EQ(mixed[0].seated_area_m2(), 7.917e-6);
  EXPECT_EQ(mixed[0].area().evaluate(1e-4).area, 15e-6);
  EXPECT_EQ(mixed[1].seated_area_m2(), one.reed.pressure_area_m2);
  EXPECT_EQ(mixed[1].area().evaluate(1e-4).area, one.reed.pressure_area_m2);
  EXPECT_EQ(one.reed.stiffness_N_per_m, 6492); // the reed is the map set's
  Model m(one, mixed, ValveModel::dynamic, Scenario::no_flow, Drive::sine(50, 20, 10));
  const auto run_mixed = run(m, options(one, 3));
  EXPECT_GT(run_mixed.stored_pressure_Pa, 0);
  EXPECT_LT(run_mixed.volume_balance_rel_error, 1e-3);
  // A command line's --map-set wins over the case's own [reed] values.
  auto r = SystemParameters::from_case(CaseFile::load(reference_case_path()));
  use_map_set(r, CaseFile::load(reference_case_path()), dir.string());
  EXPECT_EQ(r.reed.stiffness_N_per_m, 6492);
  EXPECT_EQ(load_valve_maps(r)[0].seated_area_m2(), 7.917e-6);
  std::filesystem::remove_all(dir);
}
