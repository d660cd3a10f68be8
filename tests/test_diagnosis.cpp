// Measured data for the diagnosis workflow (diagnosis/measured_run.h):
// columns with units, the drive's frequency, clear errors for bad data.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/case_file.h"
#include "diagnosis/measured_run.h"

using namespace rectify;
using namespace rectify::diagnosis;

namespace
{
  /// A sine drive at f Hz sampled at 20 kHz for `cycles` cycles, with the
  /// columns given and each row's values from `row`.
  std::string record(double f, double cycles, const std::string &header = "time_s,current_A,outlet_pressure_Pa,notes")
  {
    std::string text = "# a test record\n" + header + "\n";
    const int   n    = static_cast<int>(std::lround(cycles / f * 20000));
    for (int i = 0; i <= n; ++i)
      {
        const double t = i / 20000.0;
        text += std::to_string(t) + "," + std::to_string(2 + 5 * std::sin(2 * M_PI * f * t)) + "," +
                std::to_string(1e6 + 1e5 * std::cos(2 * M_PI * f * t));
        for (std::size_t c = 3; c < static_cast<std::size_t>(std::count(header.begin(), header.end(), ',') + 1); ++c)
          text += ",7";
        text += "\n";
      }
    return text;
  }

  void expect_error(const std::string &text, const std::vector<std::string> &parts)
  {
    try
      {
        MeasuredRun::parse(text, "run.csv");
        ADD_FAILURE() << "accepted: " << parts.front();
      }
    catch (const InputError &e)
      {
        for (const auto &p : parts)
          EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << " (expected '" << p << "')";
      }
  }
} // namespace

TEST(MeasuredRun, ReadsColumnsWithUnitsAndTheDriveFrequency)
{
  for (double f : {5.0, 50.0, 730.0})
    {
      const auto run = MeasuredRun::parse(record(f, 6.5), "run.csv");
      EXPECT_EQ(run.drive_column(), "current_A");
      EXPECT_NEAR(run.drive_frequency_Hz() / f, 1.0, 2e-3) << f; // crossings interpolated on a 20 kHz grid
      ASSERT_EQ(run.ignored_columns.size(), 1u);
      EXPECT_EQ(run.ignored_columns[0], "notes");
      EXPECT_EQ(run.signal("outlet_pressure_Pa").size(), run.time_s.size());
      EXPECT_FALSE(run.has("time_s")); // the time is apart
    }
  const auto v = MeasuredRun::parse(record(20, 3, "time_s,voltage_V,outlet_pressure_Pa,strain"), "v.csv");
  EXPECT_EQ(v.drive_column(), "voltage_V");
  EXPECT_TRUE(v.has("strain"));
  EXPECT_TRUE(v.ignored_columns.empty());
}

TEST(MeasuredRun, BadDataNamesFileRowAndColumn)
{
  const std::string good = record(50, 4);
  // unsorted and repeated times: the data row and both times
  {
    std::string t = good;
    const auto  a = t.find("0.000100,"), b = t.find("0.000150,");
    ASSERT_NE(a, std::string::npos);
    ASSERT_NE(b, std::string::npos);
    t.replace(b, 9, "0.000050,");
    expect_error(t, {"run.csv", "data row 4", "time_s", "5e-05", "1e-04", "increase"});
    t = good;
    t.replace(b, 9, "0.000100,");
    expect_error(t, {"run.csv", "data row 4", "repeats"});
  }
  // NaN and text: parse_csv's file, line and column
  {
    std::string      t     = good;
    const std::size_t start = t.find("0.000100,") + 9;
    t.replace(start, t.find(',', start) - start, "nan");
    expect_error(t, {"run.csv", "line 5", "current_A", "not finite"});
  }
  expect_error(record(50, 4, "time_s,current_A,notes,x"), {"run.csv", "missing column 'outlet_pressure_Pa'"});
  expect_error(record(50, 4, "time_s,notes,outlet_pressure_Pa"), {"run.csv", "current_A", "voltage_V"});
  expect_error(record(50, 4, "time_ms,current_A,outlet_pressure_Pa"), {"run.csv", "time_ms", "'time_s'"});
  expect_error(record(50, 4, "time_s,current_A,outlet_pressure_psi"), {"outlet_pressure_psi", "'outlet_pressure_Pa'"});
  expect_error(record(50, 4, "time_s,current_mA,outlet_pressure_Pa"), {"current_mA", "'current_A'"});
  // too short: under 20 rows, or under 2 pumping cycles
  expect_error("time_s,current_A,outlet_pressure_Pa\n0,1,1\n1e-4,2,1\n", {"run.csv", "2 rows", "too short"});
  expect_error(record(50, 1.5), {"run.csv", "fewer than two cycles", "too short"});
  try
    {
      MeasuredRun::parse(record(50, 1.5), "run.csv", 50.0);
      ADD_FAILURE() << "1.5 cycles accepted";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("1.5 pumping cycles at 50 Hz, too short"), std::string::npos) << e.what();
    }
  EXPECT_THROW(MeasuredRun::read("/nonexistent/run.csv"), InputError);
}
