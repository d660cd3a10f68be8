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
                                           Interpolation::linear));

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
