// The resistance map R(x) (maps/).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "common/case_file.h"
#include "common/io.h"
#include "maps/resistance_map.h"

using namespace rectify;
using maps::Interpolation;
using maps::ResistanceMap;

TEST(ResistanceMap, ThesisCurveFollowsEq340WithFloorAndClosedValue)
{
  const ResistanceMap m = maps::thesis_resistance_map(25);
  ASSERT_EQ(m.openings().size(), 27u);
  EXPECT_EQ(m.openings().front(), 0.0);
  EXPECT_EQ(m.closed_resistance(), 1e17);
  EXPECT_EQ(m.max_opening(), 5e-3);
  EXPECT_EQ(m.min_resistance(), 4.5e8);
  for (std::size_t i = 1; i + 1 < m.openings().size(); ++i)
    {
      const double x_um = m.openings()[i] * 1e6;
      EXPECT_NEAR(m.resistances()[i], std::max(2.34e11 * std::exp(-0.025 * x_um), 4.5e8),
                  1e-12 * m.resistances()[i]);
    }
  // The thesis: R falls 70 % from 2 to 49 um.
  EXPECT_NEAR(1 - m.evaluate(49e-6).resistance / m.evaluate(2e-6).resistance, 0.70, 0.01);
}

TEST(ResistanceMap, ShippedMapFileEqualsTheThesisCurve)
{
  const auto shipped = ResistanceMap::read(reference_case_path().parent_path() / "thesis-resistance.csv");
  const auto fresh   = maps::thesis_resistance_map(25);
  ASSERT_EQ(shipped.openings().size(), fresh.openings().size());
  for (std::size_t i = 0; i < fresh.openings().size(); ++i)
    {
      EXPECT_NEAR(shipped.openings()[i], fresh.openings()[i], 1e-8 * fresh.openings()[i]);
      EXPECT_NEAR(shipped.resistances()[i], fresh.resistances()[i], 1e-8 * fresh.resistances()[i]);
    }
}

class Interpolations : public ::testing::TestWithParam<Interpolation>
{};

TEST_P(Interpolations, ExactAtNodesMonotoneBetweenAndSlopeConsistent)
{
  const auto base = maps::thesis_resistance_map(12);
  const ResistanceMap m(base.openings(), base.resistances(), "t", {}, GetParam());
  for (std::size_t i = 0; i < m.openings().size(); ++i)
    EXPECT_NEAR(m.evaluate(m.openings()[i]).resistance, m.resistances()[i],
                1e-12 * m.resistances()[i]);
  double previous = m.evaluate(0.0).resistance;
  for (double x = 1e-8; x < 5e-3; x *= 1.01)
    {
      const auto v = m.evaluate(x);
      EXPECT_LE(v.resistance, previous * (1 + 1e-12)) << "not monotone at x = " << x;
      EXPECT_LE(v.slope, 0.0);
      previous = v.resistance;
      // the returned slope is the derivative (central difference, away from nodes)
      const double h  = 1e-6 * x;
      const double fd = (m.evaluate(x + h).resistance - m.evaluate(x - h).resistance) / (2 * h);
      EXPECT_NEAR(v.slope, fd, 1e-4 * std::abs(fd) + 1e-6 * v.resistance / x) << "x = " << x;
    }
}

INSTANTIATE_TEST_SUITE_P(Maps, Interpolations,
                         ::testing::Values(Interpolation::monotone_cubic, Interpolation::log_linear,
                                           Interpolation::linear, Interpolation::log_log));

TEST(ResistanceMap, MonotoneCubicHasAContinuousSlope)
{
  // A table that is not one exponential, so log-linear segments meet at kinks.
  const std::vector<double> x{0, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3};
  const std::vector<double> r{1e17, 3e11, 2e11, 1e11, 6e10, 4e10, 1e9, 1e9};
  const ResistanceMap smooth(x, r, "s", {}, Interpolation::monotone_cubic);
  const ResistanceMap kinked(x, r, "k", {}, Interpolation::log_linear);
  for (std::size_t i = 2; i + 1 < x.size(); ++i)
    {
      // the size of a slope near node i: the larger of the two neighbouring segments' mid slopes
      const double scale = std::max(std::abs(smooth.evaluate(0.5 * (x[i - 1] + x[i])).slope),
                                    std::abs(smooth.evaluate(0.5 * (x[i] + x[i + 1])).slope));
      const double below = x[i] * (1 - 1e-9), above = x[i] * (1 + 1e-9);
      EXPECT_NEAR(smooth.evaluate(below).slope, smooth.evaluate(above).slope, 1e-6 * scale)
        << "node " << i;
      const double ka = kinked.evaluate(below).slope, kb = kinked.evaluate(above).slope;
      if (r[i + 1] < r[i])
        {
          EXPECT_GT(std::abs(ka - kb), 0.05 * std::max(std::abs(ka), std::abs(kb))) << "node " << i;
        }
    }
}

TEST(ResistanceMap, OutOfRangePolicy)
{
  const auto m = maps::thesis_resistance_map(12);
  const auto beyond = m.evaluate(6e-3);
  EXPECT_TRUE(beyond.out_of_range);
  EXPECT_EQ(beyond.resistance, m.min_resistance());
  EXPECT_EQ(beyond.slope, 0.0);
  const auto seat = m.evaluate(-1e-9);
  EXPECT_FALSE(seat.out_of_range);
  EXPECT_EQ(seat.resistance, m.closed_resistance());
  EXPECT_EQ(maps::parse_out_of_range("error"), maps::OutOfRange::error);
  EXPECT_THROW(maps::parse_out_of_range("clamp"), InputError);
}

TEST(ResistanceMap, BadTablesAreRejectedWithTheirRow)
{
  auto expect_error = [](std::vector<double> x, std::vector<double> r, const std::string &fragment) {
    try
      {
        ResistanceMap(x, r, "bad.csv");
        ADD_FAILURE() << "accepted a bad map (" << fragment << ")";
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("bad.csv"), std::string::npos) << e.what();
      }
  };
  expect_error({0, 2e-6, 1e-6}, {1e17, 1e11, 1e10}, "row 3: opening_m = 1e-06 does not increase");
  expect_error({0, 1e-6, 2e-6}, {1e17, 1e11, 1e12}, "row 3: R_Pa_s_per_m3 = 1e+12 rises");
  expect_error({1e-6, 2e-6}, {1e11, 1e10}, "first opening_m must be 0");
  expect_error({0, 1e-6}, {1e17, -5}, "must be > 0");
  expect_error({0, 1e-6}, {1e17, std::nan("")}, "not finite");
  expect_error({0}, {1e17}, "at least two nodes");
}

TEST(ResistanceMap, FileRoundTripAndFileErrors)
{
  const auto dir = std::filesystem::temp_directory_path() / "rectify_test_maps";
  std::filesystem::create_directories(dir);
  const auto m = maps::thesis_resistance_map(10);
  m.write(dir / "m.csv");
  const auto back = ResistanceMap::read(dir / "m.csv");
  EXPECT_EQ(back.metadata()["floor_R_Pa_s_per_m3"], 4.5e8);
  for (std::size_t i = 0; i < m.openings().size(); ++i)
    EXPECT_NEAR(back.resistances()[i], m.resistances()[i], 1e-8 * m.resistances()[i]);

  write_file_atomic(dir / "nan.csv", "opening_m,R_Pa_s_per_m3\n0,1e17\n1e-6,nan\n");
  EXPECT_THROW(ResistanceMap::read(dir / "nan.csv"), InputError);
  write_file_atomic(dir / "cols.csv", "x,R\n0,1e17\n1e-6,1e10\n");
  EXPECT_THROW(ResistanceMap::read(dir / "cols.csv"), InputError);
  EXPECT_THROW(ResistanceMap::read(dir / "missing.csv"), InputError);
  std::filesystem::remove_all(dir);
}

// ------------------------------------------------------------------ map sets

#include <fstream>
#include <random>

#include "common/reed_material.h"
#include "common/valve_geometry.h"
#include "maps/area_map.h"
#include "maps/map_set.h"
#include "tests/cli_helpers.h"

namespace
{
  /// R = c x^-3 (thin-gap theory's law) at log-spaced nodes, closed value at 0.
  ResistanceMap power_law_map(double c, std::size_t n, Interpolation interpolation)
  {
    std::vector<double> x{0.0}, r{1e17};
    for (std::size_t i = 0; i < n; ++i)
      {
        x.push_back(2e-6 * std::pow(600.0, static_cast<double>(i) / static_cast<double>(n - 1)));
        r.push_back(c / std::pow(x.back(), 3));
      }
    return ResistanceMap(x, r, "power law", {}, interpolation);
  }
} // namespace

TEST(ResistanceMap, LogLogIsExactForAPowerLawAndCappedBelowItsFirstNode)
{
  const double c = 2.2e-1; // 2.75e16 Pa s/m^3 at 2 um, as the reference valve
  const auto   m = power_law_map(c, 6, Interpolation::log_log);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(std::log(2e-6), std::log(1.2e-3));
  for (int k = 0; k < 200; ++k)
    {
      const double x = std::exp(u(rng));
      const auto   v = m.evaluate(x);
      EXPECT_NEAR(v.resistance, c / std::pow(x, 3), 1e-10 * v.resistance) << x;
      EXPECT_NEAR(v.slope, -3 * c / std::pow(x, 4), 1e-8 * std::abs(v.slope)) << x;
    }
  // Below the first open node: the same power law, up to the closed value.
  EXPECT_NEAR(m.evaluate(1.5e-6).resistance, c / std::pow(1.5e-6, 3), 1e-10 * c / std::pow(1.5e-6, 3));
  const double x_cap = std::cbrt(c / 1e17);
  EXPECT_EQ(m.evaluate(0.9 * x_cap).resistance, 1e17);
  EXPECT_EQ(m.evaluate(0.9 * x_cap).slope, 0.0);
  EXPECT_EQ(m.evaluate(0.0).resistance, 1e17);
  // Monotone cubic on log-log: a slope-consistent, monotone interpolant of curved data too.
  const auto thesis = maps::thesis_resistance_map(9);
  const ResistanceMap t(thesis.openings(), thesis.resistances(), "t", {}, Interpolation::log_log);
  double previous = 1e300;
  for (double x = 1e-7; x < 6e-3; x *= 1.003)
    {
      const auto v = t.evaluate(x);
      EXPECT_LE(v.resistance, previous * (1 + 1e-12));
      previous = v.resistance;
      const double h = 1e-6 * x;
      if (x > 2.1e-6 && x < 4.9e-3)
        {
          EXPECT_NEAR(v.slope, (t.evaluate(x + h).resistance - t.evaluate(x - h).resistance) / (2 * h),
                      1e-5 * std::abs(v.slope) + 1e-13 * v.resistance / h); // truncation, round-off
        }
    }
  EXPECT_THROW(ResistanceMap({0.0, 1e-6}, {1e17, 1e10}, "one open node", {}, Interpolation::log_log), InputError);
}

TEST(AreaMap, ExactAtNodesHeldOutsideSlopeConsistentAndChecked)
{
  const std::vector<double> x{2e-6, 1e-5, 5e-5, 2.5e-4, 1.2e-3}, a{15.2e-6, 15.2e-6, 15.1e-6, 14.0e-6, 9.5e-6};
  const maps::AreaMap m(x, a, "a");
  for (std::size_t i = 0; i < x.size(); ++i)
    EXPECT_NEAR(m.evaluate(x[i]).area, a[i], 1e-15);
  EXPECT_EQ(m.evaluate(1e-7).area, a.front());
  EXPECT_EQ(m.evaluate(1e-7).slope, 0.0);
  EXPECT_EQ(m.evaluate(5e-3).area, a.back());
  for (double xi = 2.1e-6; xi < 1.1e-3; xi *= 1.05)
    {
      const double h = 1e-6 * xi;
      EXPECT_NEAR(m.evaluate(xi).slope, (m.evaluate(xi + h).area - m.evaluate(xi - h).area) / (2 * h),
                  1e-4 * std::abs(m.evaluate(xi).slope) + 1e-9);
      EXPECT_LE(m.evaluate(xi).area, a.front() + 1e-18); // monotone data, monotone interpolant
    }
  EXPECT_EQ(maps::AreaMap::constant(7.9e-6, "c").evaluate(3e-4).area, 7.9e-6);
  EXPECT_THROW(maps::AreaMap({1e-6, 1e-6}, {1e-5, 1e-5}, "flat x"), InputError);
  EXPECT_THROW(maps::AreaMap({0.0, 1e-6}, {1e-5, 1e-5}, "zero"), InputError);
  EXPECT_THROW(maps::AreaMap({1e-6, 2e-6}, {1e-5, -1e-5}, "negative"), InputError);
  EXPECT_THROW(maps::AreaMap({1e-6, 2e-6}, {1e-5, std::nan("")}, "nan"), InputError);
}

namespace
{
  /// A small map set made for `geometry` (the reference's unless changed).
  maps::MapSet small_map_set(const ValveGeometry &geometry = {})
  {
    maps::ReedProperties reed;
    reed.stiffness_N_per_m = 6492, reed.modal_mass_kg = 7.8e-6, reed.modal_mass_in_fluid_kg = 3.4e-5;
    reed.effective_mass_eq321_kg = 3.83e-4, reed.frequency_Hz = 2843, reed.frequency_in_fluid_Hz = 1351;
    reed.plate_mass_kg = 3.1e-5, reed.added_mass_kg = 1.08e-4;
  reed.root_stress_per_opening_Pa_per_m = 1.6e12, reed.root_stress_concentration = 1.2;
    nlohmann::json manifest = {
      {"source", "test"},
      {"depends_on", maps::hashed_tables(maps::physical_tables(geometry, FluidParameters{}, ReedMaterial{}))}};
    return maps::MapSet(power_law_map(0.22, 5, Interpolation::log_log),
                        maps::AreaMap({2e-6, 1e-4, 1.2e-3}, {15.2e-6, 15.0e-6, 9.5e-6}, "a"), 7.917e-6, reed,
                        manifest);
  }
} // namespace

TEST(MapSet, WrittenAndReadBackExactly)
{
  const auto dir = test_support::scratch("mapset_roundtrip");
  const auto set = small_map_set();
  set.write(dir);
  const auto back = maps::MapSet::read(dir);
  EXPECT_EQ(back.resistance().openings(), set.resistance().openings());
  EXPECT_EQ(back.resistance().resistances(), set.resistance().resistances());
  EXPECT_EQ(back.resistance().interpolation(), Interpolation::log_log);
  EXPECT_EQ(back.area().areas(), set.area().areas());
  EXPECT_EQ(back.seated_area_m2(), set.seated_area_m2());
  ASSERT_TRUE(back.reed());
  EXPECT_EQ(back.reed()->stiffness_N_per_m, 6492);
  EXPECT_EQ(back.reed()->effective_mass_eq321_kg, 3.83e-4);
  for (double x : {1e-6, 3e-6, 4.4e-5, 7e-4})
    EXPECT_EQ(back.resistance().evaluate(x).resistance, set.resistance().evaluate(x).resistance);
  // the same case: accepted; the thesis's map set (no provenance): accepted by any case
  EXPECT_NO_THROW(back.check_matches(maps::physical_tables({}, {}, {}), "case.toml"));
  std::filesystem::remove_all(dir);
}

TEST(MapSet, FromAnotherGeometryFluidOrMaterialIsRefusedNamingTheKey)
{
  const auto set = small_map_set();
  ValveGeometry g;
  g.reed_thickness_m = 0.15e-3;
  try
    {
      set.check_matches(maps::physical_tables(g, {}, {}), "thick.toml");
      FAIL() << "a map set of another reed thickness was accepted";
    }
  catch (const InputError &e)
    {
      const std::string what = e.what();
      EXPECT_NE(what.find("[geometry] reed_thickness_m"), std::string::npos) << what;
      EXPECT_NE(what.find("thick.toml"), std::string::npos) << what;
    }
  FluidParameters oil;
  oil.viscosity_Pa_s = 0.048;
  EXPECT_THROW(set.check_matches(maps::physical_tables({}, oil, {}), "c"), InputError);
  ReedMaterial steel;
  steel.youngs_modulus_Pa = 190e9;
  EXPECT_THROW(set.check_matches(maps::physical_tables({}, {}, steel), "c"), InputError);
  ValveGeometry other_outlet;
  other_outlet.outlet_face = "ceiling";
  EXPECT_THROW(set.check_matches(maps::physical_tables(other_outlet, {}, {}), "c"), InputError);
}

TEST(MapSet, MissingIncompleteTamperedOrNonFiniteIsAClearError)
{
  const auto dir = test_support::scratch("mapset_bad");
  const auto expect_error = [&](const std::string &needle) {
    try
      {
        (void)maps::MapSet::read(dir);
        ADD_FAILURE() << "accepted; expected an error mentioning '" << needle << "'";
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      }
  };
  expect_error("manifest.json"); // an empty folder: not a map set
  small_map_set().write(dir);
  EXPECT_NO_THROW((void)maps::MapSet::read(dir));
  // a table changed after the map set was made
  {
    std::ofstream out(dir / "area.csv", std::ios::app);
    out << "2e-3,9e-6\n";
  }
  expect_error("area.csv does not match its manifest");
  small_map_set().write(dir);
  std::filesystem::remove(dir / "resistance.csv");
  expect_error("resistance.csv is missing");
  // NaN in a table whose hash matches (a map set written wrong): the reader's checks
  small_map_set().write(dir);
  {
    std::ifstream in(dir / "manifest.json");
    auto          m = nlohmann::json::parse(in);
    write_file_atomic(dir / "area.csv", "opening_m,A_eff_m2\n1e-6,nan\n");
    m["files"]["area.csv"]["hash"] = file_hash(dir / "area.csv");
    write_json(dir / "manifest.json", m);
  }
  expect_error("area.csv");
  // a manifest without a field
  small_map_set().write(dir);
  {
    std::ifstream in(dir / "manifest.json");
    auto          m = nlohmann::json::parse(in);
    m["area"].erase("seated_area_m2");
    write_json(dir / "manifest.json", m);
  }
  expect_error("seated_area_m2");
  write_file_atomic(dir / "manifest.json", "{ not json");
  expect_error("not valid JSON");
  std::filesystem::remove_all(dir);
  expect_error("no such folder");
}
