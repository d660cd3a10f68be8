// Measured data for the diagnosis workflow (diagnosis/measured_run.h):
// columns with units, the drive's frequency, clear errors for bad data.
#include <gtest/gtest.h>

#include <set>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fcntl.h>
#include <random>
#include <regex>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
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
      EXPECT_NEAR(run.drive_frequency_Hz() / f, 1.0, 1e-5) << f; // refined by least squares
      ASSERT_EQ(run.ignored_columns.size(), 1u);
      EXPECT_EQ(run.ignored_columns[0], "notes");
      EXPECT_EQ(run.signal("outlet_pressure_Pa").size(), run.time_s.size());
      EXPECT_FALSE(run.has("time_s")); // the time is apart
    }
  {
    // a noisy drive (2 % of its amplitude) over 16 cycles at 200 samples a
    // cycle, not starting at a crossing: the crossings alone are off by
    // ~3e-4 (0.1 A over a slope of 3 kA/s is 3e-5 s at each end of 0.15 s),
    // least squares by its Cramer-Rao bound, sd 1.2e-5 (sqrt(12) sd / (2 pi
    // A N^1.5 dt f))
    const double f = 100.3;
    std::mt19937_64 rng(11);
    std::normal_distribution<double> normal(0, 0.1);
    std::string text = "time_s,current_A,outlet_pressure_Pa\n";
    for (int i = 0; i <= 3200; ++i)
      {
        const double t = i / 20000.0;
        text += std::to_string(t) + "," + std::to_string(10 - 5 * std::cos(2 * M_PI * f * t + 0.4) + normal(rng)) +
                ",1e6\n";
      }
    EXPECT_NEAR(MeasuredRun::parse(text, "noisy.csv").drive_frequency_Hz() / f, 1.0, 5e-5);
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

// ------------------------------------------------------------ the workflow
#include <functional>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>

#include "cli_helpers.h"
#include "model_helpers.h"
#include "common/case_edit.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/search.h" // grid_valleys
#include "diagnosis/effect.h"
#include "diagnosis/observation.h"
#include "diagnosis/residuals.h"
#include "diagnosis/words.h"
#include "system/components/outlet_line.h"
#include "system/model.h"
#include "system/simulation.h"

using namespace rectify::test_support;

TEST(Diagnosis, DriveLowPassKeepsTheHarmonicsAndRemovesNoise)
{
  // 200 samples a cycle, cutoff at the 10th harmonic: harmonics 1 and 3 pass
  // within 0.2 %, white noise loses about sqrt(10/100) of its amplitude.
  const double f = 100, dt = 1 / (200 * f);
  std::vector<double> t, clean, noisy;
  std::mt19937_64     rng(4);
  std::normal_distribution<double> normal(0, 1);
  for (int i = 0; i <= 200 * 12; ++i)
    {
      t.push_back(i * dt);
      clean.push_back(5 - 4 * std::cos(2 * std::numbers::pi * f * t.back()) +
                      std::cos(2 * std::numbers::pi * 3 * f * t.back()));
      noisy.push_back(clean.back() + 0.1 * normal(rng));
    }
  const auto smooth = low_pass(t, clean, 10 * f);
  double     worst  = 0;
  for (std::size_t i = 0; i < t.size(); ++i)
    worst = std::max(worst, std::abs(smooth[i] - clean[i]));
  EXPECT_LT(worst, 0.002 * 5);
  const auto filtered = low_pass(t, noisy, 10 * f);
  double     left     = 0;
  for (std::size_t i = 0; i < t.size(); ++i)
    left += std::pow(filtered[i] - clean[i], 2) / static_cast<double>(t.size());
  EXPECT_LT(std::sqrt(left), 0.1 / 2.5);
  EXPECT_GT(std::sqrt(left), 0.1 / 5.0);
  // not uniformly sampled: left alone
  auto uneven = t;
  uneven[5] += 0.3 * dt;
  EXPECT_EQ(low_pass(uneven, noisy, 10 * f), noisy);
}

TEST(Diagnosis, DriveDenoisingKeepsTheDriveAndDropsNearlyAllItsNoise)
{
  // A drive over 16 cycles of 100 Hz, 200 samples a cycle: a harmonic at
  // an arbitrary phase, a 3rd harmonic, and a swell that is not periodic
  // (a supply sagging for a few cycles), with white noise of sd 0.1. The estimate keeps
  // the drive; of the noise it keeps far less than the low-pass at the 10th
  // harmonic (a tenth of its power).
  const double f = 100, dt = 1 / (200 * f), sd = 0.1;
  std::vector<double> t, clean, noisy;
  std::mt19937_64     rng(7);
  std::normal_distribution<double> normal(0, 1);
  for (int i = 0; i <= 200 * 16; ++i)
    {
      t.push_back(i * dt);
      const double x = t.back();
      clean.push_back(10 - 10 * std::cos(2 * std::numbers::pi * f * x + 0.7) +
                      0.5 * std::sin(2 * std::numbers::pi * 3 * f * x) -
                      std::exp(-std::pow((x - 0.05) / 0.01, 2)));
      noisy.push_back(clean.back() + sd * normal(rng));
    }
  const auto rms_error = [&](const std::vector<double> &x) {
    double s = 0;
    for (std::size_t i = 0; i < t.size(); ++i)
      s += std::pow(x[i] - clean[i], 2) / static_cast<double>(t.size());
    return std::sqrt(s);
  };
  // noise-free: the drive is kept (what is dropped of the swell lies below
  // the threshold, 0.4 in its cosine coefficients)
  EXPECT_LT(rms_error(denoise_periodic(t, clean, f, 10, sd)), 0.1 * sd);
  const double denoised   = rms_error(denoise_periodic(t, noisy, f, 10, sd));
  const double low_passed = rms_error(low_pass(t, noisy, 10 * f));
  EXPECT_LT(denoised, 0.2 * sd);
  EXPECT_LT(denoised, low_passed / 2);
  // a periodic drive alone (the synthesiser's): a few coefficients of noise
  // are left of 3201, against a tenth of it after the low-pass
  std::vector<double> periodic(t.size()), periodic_noisy(t.size());
  for (std::size_t i = 0; i < t.size(); ++i)
    {
      periodic[i]       = 10 - 10 * std::cos(2 * std::numbers::pi * f * t[i]);
      periodic_noisy[i] = periodic[i] + (noisy[i] - clean[i]);
    }
  double periodic_error = 0;
  const auto periodic_denoised = denoise_periodic(t, periodic_noisy, f, 10, sd);
  for (std::size_t i = 0; i < t.size(); ++i)
    periodic_error += std::pow(periodic_denoised[i] - periodic[i], 2) / static_cast<double>(t.size());
  EXPECT_LT(std::sqrt(periodic_error), low_passed / 5);
  // the noise estimate the workflow uses is close enough for the threshold
  EXPECT_NEAR(white_noise_sd(noisy), sd, 0.1 * sd);
  // pure noise: almost nothing is kept, by either step
  std::vector<double> noise(t.size());
  for (double &x : noise)
    x = sd * normal(rng);
  double left = 0;
  for (double x : denoise_periodic(t, noise, f, 10, sd))
    left = std::max(left, std::abs(x));
  EXPECT_LT(left, 0.5 * sd);
  left = 0;
  for (double x : spectral_threshold(t, noise, sd))
    left = std::max(left, std::abs(x));
  EXPECT_LT(left, 0.5 * sd);
  // not uniformly sampled, or no noise: left alone
  auto uneven = t;
  uneven[5] += 0.3 * dt;
  EXPECT_EQ(denoise_periodic(uneven, noisy, f, 10, sd), noisy);
  EXPECT_EQ(denoise_periodic(t, noisy, f, 10, 0.0), noisy);
  EXPECT_EQ(spectral_threshold(uneven, noisy, sd), noisy);
}

TEST(Diagnosis, SpectralPeaksFindARingingBetweenHarmonics)
{
  // A residual of 16 cycles of 100 Hz at 200 samples a cycle: a decaying
  // ringing at 915.3 Hz re-excited every cycle (the line after each
  // closing), a stronger fundamental and 2nd harmonic below the band
  // searched, and noise. The peak is found to 0.1 % (the bin is 6.25 Hz).
  const double f = 100, dt = 1 / (200 * f), fr = 915.3;
  std::vector<double> t, v;
  std::mt19937_64     rng(3);
  std::normal_distribution<double> normal(0, 1);
  for (int i = 0; i <= 200 * 16; ++i)
    {
      t.push_back(i * dt);
      const double x = t.back(), since = std::fmod(x, 1 / f);
      v.push_back(5 * std::sin(2 * std::numbers::pi * f * x) + 2 * std::cos(2 * std::numbers::pi * 2 * f * x) +
                  std::exp(-since / 0.004) * std::sin(2 * std::numbers::pi * fr * x) + 0.3 * normal(rng));
    }
  const auto largest = [&](const std::vector<double> &times, double f_low) {
    const auto p = spectral_peaks(times, v, f_low, 8000, 1);
    return p.empty() ? 0.0 : p.front();
  };
  EXPECT_NEAR(largest(t, 2.5 * f), fr, 0.001 * fr);
  // the band decides: below it the fundamental
  EXPECT_NEAR(largest(t, 50), f, 0.01 * f);
  // too short, or not uniformly sampled: none
  EXPECT_TRUE(spectral_peaks({0, 1e-4}, {1, 2}, 250, 8000, 1).empty());
  auto uneven = t;
  uneven[7] += 0.3 * dt;
  EXPECT_TRUE(largest(uneven, 250) == 0.0);
}

TEST(Diagnosis, SpectralPeaksFindALinesLowerModeUnderALargerHigherOne)
{
  // A line's residual rings at its lowest mode and its second, re-excited
  // every cycle; here the second (1093 Hz) is the larger, as in a bench
  // record at 150 Hz, and a weaker third harmonic of the drive (below min_share).
  // Both modes are found, the larger first, each to 0.5 %; the skirts of
  // the larger peak are not peaks of their own. The larger mode's lower
  // sideband (the ringing starts anew every cycle: a comb f apart) is the
  // third: a start tried in vain, not a wrong answer.
  const double f = 150, dt = 1 / (200 * f), f1 = 541.7, f2 = 1093.4;
  std::vector<double> t, v;
  std::mt19937_64     rng(5);
  std::normal_distribution<double> normal(0, 1);
  for (int i = 0; i <= 200 * 12; ++i)
    {
      t.push_back(i * dt);
      const double x = t.back(), since = std::fmod(x, 1 / f);
      v.push_back(0.6 * std::exp(-since / 0.003) * std::sin(2 * std::numbers::pi * f1 * x) +
                  1.0 * std::exp(-since / 0.003) * std::sin(2 * std::numbers::pi * f2 * x) +
                  0.1 * std::cos(2 * std::numbers::pi * 3 * f * x) + 0.05 * normal(rng));
    }
  const auto peaks = spectral_peaks(t, v, 2.5 * f, 6000, 3);
  ASSERT_EQ(peaks.size(), 3u);
  EXPECT_NEAR(peaks[0], f2, 0.005 * f2);
  EXPECT_NEAR(peaks[1], f1, 0.005 * f1);
  EXPECT_NEAR(peaks[2], f2 - f, 0.01 * f2);
  EXPECT_NEAR(peaks[0], spectral_peaks(t, v, 2.5 * f, 6000, 1).front(), 1e-9);
  // the two modes only, where the sideband's share (0.33) is below the floor
  EXPECT_EQ(spectral_peaks(t, v, 2.5 * f, 6000, 3, 0.4).size(), 2u);
  // one asked for: the largest only
  EXPECT_EQ(spectral_peaks(t, v, 2.5 * f, 6000, 1).size(), 1u);
}

TEST(Diagnosis, EffectLibraryNamesBoundsAndKeys)
{
  const std::vector<std::string> expected{"entrained_air",   "entrained_air_constant_modulus", "outlet_compliance",
                                          "valve_leakage",   "valve_leakage_turbulent",        "orifice_flow",
                                          "line_inertance",  "coil_dynamics",                  "piston_friction",
                                          "reed_second_mode"};
  ASSERT_EQ(effect_library().size(), expected.size());
  const auto base = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  const auto map  = system::load_valve_maps(base);
  const std::set<std::string> components{"entrained_air",  "entrained_air_constant_modulus", "outlet_compliance",
                                         "valve_leakage",  "valve_leakage_turbulent",        "orifice_flow",
                                         "line_inertance", "coil_dynamics",                  "piston_friction"};
  for (std::size_t i = 0; i < expected.size(); ++i)
    {
      const auto &e = effect_library()[i];
      EXPECT_EQ(e->name(), expected[i]);
      EXPECT_FALSE(e->physics().empty());
      EXPECT_FALSE(e->signature().empty());
      ASSERT_EQ(e->parameters().size(), 1u);
      const auto &spec = e->parameters()[0];
      EXPECT_GT(spec.upper, spec.lower);
      for (double u : {0.0, 0.3, 1.0})
        EXPECT_NEAR(spec.to_unit(spec.from_unit(u)), u, 1e-12) << e->name();
      // applying the effect sets its case key and switches its physics on
      auto p = base;
      e->apply(std::vector<double>{spec.mid()}, p);
      const auto   text = p.to_json()[spec.table][spec.key];
      EXPECT_DOUBLE_EQ(text.get<double>(), spec.mid()) << e->name();
      system::Model m(p, map, system::ValveModel::dynamic, system::Scenario::loaded,
                      e->name() == "coil_dynamics" ?
                        system::Drive::from_samples({0, 1}, {1, 1}, 100, true, "v") :
                        system::Drive::sine(100, 20, 10));
      EXPECT_TRUE(m.needs_difference_jacobian()) << e->name();
      // an effect that is a component of the model: the model holds it
      // under the effect's name, alone (the base case has none on)
      if (components.count(e->name()))
        {
          ASSERT_EQ(m.components().size(), 1u) << e->name();
          EXPECT_EQ(m.components()[0]->name(), e->name());
          EXPECT_NE(m.component(e->name()), nullptr);
        }
      else
        EXPECT_TRUE(m.components().empty()) << e->name();
    }
  EXPECT_TRUE(system::Model(base, map, system::ValveModel::dynamic, system::Scenario::loaded,
                            system::Drive::sine(100, 20, 10))
                .components()
                .empty());
  EXPECT_EQ(find_effect("coil_dynamics")->not_testable({system::Scenario::no_flow, false}).empty(), false);
  EXPECT_EQ(find_effect("coil_dynamics")->not_testable({system::Scenario::no_flow, true}), "");
  EXPECT_NE(find_effect("piston_friction")->not_testable({system::Scenario::no_flow, true}), "");
  try
    {
      find_effect("air");
      ADD_FAILURE();
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("entrained_air"), std::string::npos);
    }
}

TEST(Diagnosis, EveryEffectsRangeReachesNoEffect)
{
  // Issue 17: an effect's bounds must include "no effect" relative to the
  // baseline, else a fit cannot fall back to the baseline and the effect
  // absorbs whatever the baseline lacks. At one end of each range the model
  // must be the baseline's to well under a record's noise (0.6-1 % of a
  // signal's swing on the bench): here 0.2 % in the pressures, with the
  // [uncertain] line bore at its widest (the least line resistance, where
  // an inertial line's flow lags most: at L = 1e5 its L / R3 is 0.5 ms,
  // 5 % of a 100 Hz cycle, which the range's former lower end left in; the
  // range now ends at 1e4 and there the line is off). The former ends of
  // the air fractions (1e-5), the seal (1e-17 m^3/Pa), the orifice (Cd 10)
  // and the friction (0.1 N) moved this run by 0.5-1.5 %.
  auto base = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  base.lines.diameter_m                  = 7e-3;
  base.lines.outlet_line_segments        = 6;
  const auto map                         = system::load_valve_maps(base);
  const auto simulate = [&](const system::SystemParameters &p) {
    system::Model      m(p, map, system::ValveModel::dynamic, system::Scenario::loaded,
                         system::Drive::sine(100, 20, 10));
    system::RunOptions o;
    o.n_cycles           = 6;
    o.relative_tolerance = 1e-7;
    o.record             = true;
    return system::run(m, o);
  };
  const auto off     = simulate(base);
  const auto largest = [&](const system::RunResult &r) { // the largest RMS difference, per swing
    double worst = 0;
    for (const std::string name : {"chamber_pressure_Pa", "high_pressure_Pa", "outlet_pressure_Pa"})
      worst = std::max(worst, rms_difference_per_swing(off, r, name));
    return worst;
  };
  for (const auto &e : effect_library())
    {
      if (!e->not_testable({system::Scenario::loaded, false}).empty())
        continue; // the coil's inductance needs a voltage drive: off, the drive is the current
      const auto &spec = e->parameters()[0];
      if (e->name() == "reed_second_mode")
        { // the baseline has a second mode (a uniform cantilever's): no effect is inside the range
          const double f2 = 6.267 * base.reed.natural_frequency_Hz();
          EXPECT_GT(f2, spec.lower);
          EXPECT_LT(f2, spec.upper);
          continue;
        }
      double      nearest = 1e300, farthest = 0;
      for (double v : {spec.lower, spec.upper})
        {
          auto p = base;
          e->apply(std::vector<double>{v}, p);
          const double d = largest(simulate(p));
          nearest        = std::min(nearest, d);
          farthest       = std::max(farthest, d);
        }
      EXPECT_LT(nearest, 2e-3) << e->name();
      EXPECT_GT(farthest, 2e-2) << e->name() << ": its range's other end must show"; // not a range of nothing
    }
}

// The reference case's own added line is the pump's outlet passage (a few
// cm, one lumped pi section, uncertain); the effect line_inertance is a
// hose, which carries its waves in 12 sections whatever the case gives its
// passage, and says so in the new case file (a fixed key).
TEST(Diagnosis, LineInertanceIsAHoseInTwelveSectionsWhateverTheCaseGivesItsPassage)
{
  auto p = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  EXPECT_EQ(p.lines.outlet_line_segments, 1);
  EXPECT_EQ(p.lines.outlet_inertance_Pa_s2_per_m3, 0.0);
  const auto line = find_effect("line_inertance");
  line->apply(std::vector<double>{3e7}, p);
  EXPECT_EQ(p.lines.outlet_inertance_Pa_s2_per_m3, 3e7);
  EXPECT_EQ(p.lines.outlet_line_segments, 12);
  ASSERT_NE(system::outlet_line(system::ModelConstants(p, system::Scenario::no_flow)), nullptr);
  EXPECT_EQ(system::outlet_line(system::ModelConstants(p, system::Scenario::no_flow))->segments(), 12u);
  ASSERT_EQ(line->fixed_keys().size(), 1u);
  EXPECT_EQ(line->fixed_keys()[0].table, "lines");
  EXPECT_EQ(line->fixed_keys()[0].key, "outlet_line_segments");
  EXPECT_EQ(line->fixed_keys()[0].value, "12");
  EXPECT_TRUE(line->sets("lines", "outlet_inertance_Pa_s2_per_m3")); // it takes the passage's key over
}

TEST(Diagnosis, NewCaseFileSetsTheEffectKeysAndResolvesPaths)
{
  const std::string text   = reference_text();
  const auto        dir    = reference_case_path().parent_path();
  const std::string edited = edit_case_text(
    text, dir,
    {{"valves", "leak_resistance_Pa_s_per_m3", "2.5e11", "test"},
     {"valves", "interpolation", "\"log-linear\"", "test"},
     {"drive", "coil_dynamics", "\"on\"", "test"}});
  const auto out = scratch("case_edit");
  {
    std::ofstream f(out / "new.toml");
    f << edited;
  }
  const CaseFile file = CaseFile::load(out / "new.toml");
  const auto     p    = system::SystemParameters::from_case(file);
  EXPECT_DOUBLE_EQ(p.valves.leak_resistance_Pa_s_per_m3, 2.5e11);
  EXPECT_EQ(p.valves.interpolation, "log-linear");
  EXPECT_EQ(p.drive.coil_dynamics, "on");
  EXPECT_TRUE(std::filesystem::exists(p.valves.resistance_map)) << p.valves.resistance_map;
  EXPECT_NE(edited.find("(was: \"monotone-cubic\""), std::string::npos);
  // everything else as in the reference case
  const auto ref = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  EXPECT_EQ(p.transducer.coil_turns, ref.transducer.coil_turns);
  EXPECT_EQ(p.fluid.bias_pressure_Pa, ref.fluid.bias_pressure_Pa);

  // an entry without a value comments the original's line out (a quoted
  // [uncertain] key too); one the file lacks adds nothing
  const std::string cut = edit_case_text(text, dir,
                                         {{"uncertain", "lines.diameter_m", "", "gone"},
                                          {"uncertain", "reed.no_such_key", "", "gone"},
                                          {"valves", "leak_area_m2", "", "gone"}});
  EXPECT_NE(cut.find("\n# \"lines.diameter_m\" = ["), std::string::npos) << cut;
  EXPECT_NE(cut.find("\n# leak_area_m2 = 0.0"), std::string::npos);
  EXPECT_EQ(cut.find("no_such_key"), std::string::npos);
  const auto q = system::SystemParameters::from_case(CaseFile::parse(cut, "cut.toml", dir));
  EXPECT_EQ(q.uncertain.size(), ref.uncertain.size() - 1);
  for (const auto &u : q.uncertain)
    EXPECT_NE(u.name(), "lines.diameter_m");
  EXPECT_EQ(q.valves.leak_area_m2, 0.0); // the default: the key is gone, not changed
}

TEST(Diagnosis, LocalisationFindsTheCycleHalfAndTheHarmonic)
{
  // Data: a smooth outlet pressure; model = data + 0.3 MPa during the refill
  // half, or + 0.2 MPa cos(3 w t): the report must say so.
  const double f = 50;
  std::string  text = "time_s,current_A,outlet_pressure_Pa\n";
  for (int i = 0; i <= 200 * 10; ++i)
    {
      const double t = i / (200 * f);
      text += std::to_string(t) + "," + std::to_string(10 - 10 * std::cos(2 * std::numbers::pi * f * t)) +
              "," + std::to_string(3e6 + 1e6 * std::sin(2 * std::numbers::pi * f * t)) + "\n";
    }
  const auto run    = MeasuredRun::parse(text, "loc.csv");
  const auto scales = signal_scales(run);
  Signals    refill{{"outlet_pressure_Pa", run.signal("outlet_pressure_Pa")}};
  Signals    third  = refill;
  for (std::size_t i = 0; i < run.time_s.size(); ++i)
    {
      const double t     = run.time_s[i];
      const double phase = t * f - std::floor(t * f);
      refill["outlet_pressure_Pa"][i] += phase >= 0.5 ? 3e5 : 0.0;
      third["outlet_pressure_Pa"][i] += 2e5 * std::cos(2 * std::numbers::pi * 3 * f * t);
    }
  const auto a = localise(run, refill, f, scales);
  EXPECT_EQ(a.dominant_signal, "outlet_pressure_Pa");
  EXPECT_EQ(a.dominant_half, "refill");
  EXPECT_GT(a.numbers()["outlet_pressure_Pa"]["refill_fraction"].get<double>(), 0.99);
  EXPECT_NEAR(a.numbers()["outlet_pressure_Pa"]["mean_model_minus_data"].get<double>(), 1.5e5, 0.02e5);
  ASSERT_FALSE(diagnosis::localisation_words(a).empty());
  EXPECT_NE(diagnosis::localisation_words(a)[0].find("refill"), std::string::npos) << diagnosis::localisation_words(a)[0];
  EXPECT_NE(diagnosis::localisation_words(a)[0].find("above the data by 0.15 MPa"), std::string::npos) << diagnosis::localisation_words(a)[0];
  const auto b = localise(run, third, f, scales);
  EXPECT_EQ(b.numbers()["outlet_pressure_Pa"]["dominant_harmonic"].get<int>(), 3);
  EXPECT_NEAR(b.numbers()["outlet_pressure_Pa"]["harmonic_amplitudes"][3].get<double>(), 2e5, 0.01 * 2e5);
  EXPECT_NE(diagnosis::localisation_words(b)[0].find("harmonic 3"), std::string::npos) << diagnosis::localisation_words(b)[0];
  // the norms: RMS of (model - data) / swing
  const auto norms = residual_norms(run, third, scales);
  EXPECT_NEAR(norms.at("outlet_pressure_Pa"), (2e5 / std::sqrt(2.0)) / scales.at("outlet_pressure_Pa"), 1e-3);

  // per-cycle swing: a model at 80 % of the data's swing of 2 MPa
  Signals smaller = refill;
  for (std::size_t i = 0; i < run.time_s.size(); ++i)
    smaller["outlet_pressure_Pa"][i] = 3e6 + 0.8 * (run.signal("outlet_pressure_Pa")[i] - 3e6);
  const auto c = localise(run, smaller, f, scales);
  EXPECT_NEAR(c.numbers()["outlet_pressure_Pa"]["cycle_swing_data"].get<double>(), 2e6, 0.01 * 2e6);
  EXPECT_NEAR(c.numbers()["outlet_pressure_Pa"]["cycle_swing_model"].get<double>(), 1.6e6, 0.01 * 1.6e6);
  EXPECT_NE(diagnosis::localisation_words(c)[0].find("per cycle the data swing 2 MPa, the model 1.6 MPa"), std::string::npos)
    << diagnosis::localisation_words(c)[0];
  EXPECT_EQ(diagnosis::localisation_words(c)[0].find("over the record"), std::string::npos) << diagnosis::localisation_words(c)[0]; // steady

  // a residual whose amplitude ramps up (or down) over the record
  Signals growing = refill, fading = refill;
  const double duration = run.time_s.back();
  for (std::size_t i = 0; i < run.time_s.size(); ++i)
    {
      const double t = run.time_s[i], e = 2e5 * std::sin(2 * std::numbers::pi * f * t);
      growing["outlet_pressure_Pa"][i] = run.signal("outlet_pressure_Pa")[i] + e * t / duration;
      fading["outlet_pressure_Pa"][i]  = run.signal("outlet_pressure_Pa")[i] + e * (1 - t / duration);
    }
  const auto g = localise(run, growing, f, scales);
  // RMS over the thirds of a linear ramp: last / first -> sqrt(19) = 4.36
  // as the cycles per third grow; here, summed sample by sample:
  double e2[3] = {0, 0, 0}, n3[3] = {0, 0, 0};
  for (std::size_t i = 0; i < run.time_s.size(); ++i)
    {
      const double t = run.time_s[i];
      const int    k = std::min(2, static_cast<int>(3 * t / duration));
      e2[k] += std::pow(2e5 * std::sin(2 * std::numbers::pi * f * t) * t / duration, 2);
      n3[k] += 1;
    }
  const double growth = g.numbers()["outlet_pressure_Pa"]["rms_by_third_of_record"][2].get<double>() /
                        g.numbers()["outlet_pressure_Pa"]["rms_by_third_of_record"][0].get<double>();
  EXPECT_NEAR(growth, std::sqrt((e2[2] / n3[2]) / (e2[0] / n3[0])), 1e-3);
  EXPECT_NEAR(growth, std::sqrt(19.0), 0.15);
  EXPECT_NE(diagnosis::localisation_words(g)[0].find("grows over the record (last third " + format_number(std::round(growth * 10) / 10) +
                                " x the first)"),
            std::string::npos)
    << diagnosis::localisation_words(g)[0];
  const auto d = localise(run, fading, f, scales);
  EXPECT_NE(diagnosis::localisation_words(d)[0].find("fades over the record"), std::string::npos) << diagnosis::localisation_words(d)[0];
}

// What the verdict points at is where most of what remains lies in noise
// units, the units it counts, not the largest share of a swing: a no-flow
// record's outlet pressure hardly swings, so a residual within its noise is
// a large share of that swing (the bench's entrained_air-0: 1.07 noise
// units there, 2.72 in the strain, and the verdict named the outlet
// pressure).
TEST(Diagnosis, TheLargestResidualIsCountedInNoiseUnitsNotInShareOfTheSwing)
{
  const double f    = 100;
  std::string  text = "time_s,current_A,chamber_pressure_Pa,outlet_pressure_Pa,strain\n";
  for (int i = 0; i <= 100 * 12; ++i)
    {
      const double t = i / (100 * f), w = 2 * std::numbers::pi * f * t;
      char row[160];
      std::snprintf(row, sizeof row, "%.9g,%.9g,%.9g,%.9g,%.9g\n", t, 10 - 10 * std::cos(w),
                    5e6 + 3e6 * std::sin(w), 1e7 + 1e4 * std::sin(w), 1e-4 * std::sin(w));
      text += row;
    }
  const auto run    = MeasuredRun::parse(text, "largest.csv");
  const auto swings = signal_scales(run);
  // the model: the outlet pressure 5 kPa high (71 % of its swing, half its
  // 10 kPa noise), the strain 3e-6 high (4 % of its swing, 4 x its noise),
  // the chamber 20 kPa high (1 % of its swing, 2 x its noise)
  Signals model{{"chamber_pressure_Pa", run.signal("chamber_pressure_Pa")},
                {"outlet_pressure_Pa", run.signal("outlet_pressure_Pa")},
                {"strain", run.signal("strain")}};
  for (auto &v : model["chamber_pressure_Pa"])
    v += 2e4;
  for (auto &v : model["outlet_pressure_Pa"])
    v += 5e3;
  for (auto &v : model["strain"])
    v += 3e-6;
  const std::map<std::string, double> noise{
    {"chamber_pressure_Pa", 1e4}, {"outlet_pressure_Pa", 1e4}, {"strain", 7.5e-7}};
  // by share of the swing the outlet pressure dominates ...
  EXPECT_EQ(localise(run, model, f, swings).dominant_signal, "outlet_pressure_Pa");
  // ... in noise units the strain does, 4 units from the first sample on
  const auto all_three = residuals_in_noise_units(run, model, f, swings, noise, 0);
  ASSERT_EQ(all_three.size(), 3u);
  // the most first: strain 4, chamber 2, outlet 0.5
  EXPECT_EQ(all_three[1].signal, "chamber_pressure_Pa");
  EXPECT_NEAR(all_three[1].noise_units, 2.0, 1e-6);
  EXPECT_EQ(all_three[2].signal, "outlet_pressure_Pa");
  EXPECT_NEAR(all_three[2].noise_units, 0.5, 1e-6);
  EXPECT_EQ(residual_words(all_three[2]).rfind(
              "outlet pressure, 0.5 noise units: residual 0.005 MPa RMS (71 % of its swing)", 0),
            0u)
    << residual_words(all_three[2]);
  const auto &L = all_three.front();
  EXPECT_EQ(L.signal, "strain");
  EXPECT_NEAR(L.noise_units, 4.0, 1e-6);
  EXPECT_EQ(residual_words(L).rfind("strain, 4 noise units: residual 3e-06 RMS (4 % of its swing)", 0), 0u)
    << residual_words(L);
  EXPECT_NE(residual_words(L).find("model above the data by 3e-06 on average"), std::string::npos) << residual_words(L);
  // samples skipped at the start (a settling window) are not counted
  auto late = model;
  for (std::size_t i = 0; i < 600; ++i)
    late["strain"][i] += 1e-4; // only in the first half
  const auto skipped = residuals_in_noise_units(run, late, f, swings, noise, 600).front();
  EXPECT_EQ(skipped.signal, "strain");
  EXPECT_NEAR(skipped.noise_units, 4.0, 1e-6);
  // counted from the first sample: 600 samples at 103e-6 / 7.5e-7, the other 601 at 4
  const double all = std::sqrt((600 * std::pow(103e-6 / 7.5e-7, 2) + 601 * 16.0) / 1201);
  EXPECT_NEAR(residuals_in_noise_units(run, late, f, swings, noise, 0).front().noise_units, all, 1e-6 * all);
  // a signal within 3 % of its swing has no sentence in the localisation,
  // but the largest in noise units is described all the same
  Signals chamber_only{{"chamber_pressure_Pa", model["chamber_pressure_Pa"]}};
  EXPECT_EQ(diagnosis::localisation_words(localise(run, chamber_only, f, swings)).front(),
            "every signal within 3 % of its swing: no clear disagreement");
  const auto c = residuals_in_noise_units(run, chamber_only, f, swings, noise, 0).front();
  EXPECT_EQ(c.signal, "chamber_pressure_Pa");
  EXPECT_NEAR(c.noise_units, 2.0, 1e-6);
  EXPECT_EQ(residual_words(c).rfind("chamber pressure, 2 noise units: residual 0.02 MPa RMS (1 % of its swing)", 0),
            0u)
    << residual_words(c);
}

TEST(Diagnosis, SynthThenDiagnoseNamesAHiddenLeakAndFindsNothingInCleanData)
{
  const auto dir = scratch("diagnose_leak");
  auto       r   = rectify_cli("synth --effect valve_leakage --param leak_resistance_Pa_s_per_m3=3e11 "
                               "--noise 0.01 --seed 7 --frequency 100 --cycles 8 --out " + (dir / "leak").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = rectify_cli("synth --noise 0.015 --seed 8 --frequency 150 --cycles 8 --out " + (dir / "clean").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // synth's records come from the case's one-mode reed: diagnosed with it
  const std::string candidates = " --effects valve_leakage outlet_compliance entrained_air --reed-second-mode case ";
  r = rectify_cli("diagnose --data " + (dir / "leak" / "data.csv").string() + candidates + "--out " +
                  (dir / "d-leak").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto s = nlohmann::json::parse(std::ifstream(dir / "d-leak" / "summary.json"));
  EXPECT_EQ(s["effect"], "valve_leakage") << s["decision"];
  EXPECT_NEAR(s["parameters"]["leak_resistance_Pa_s_per_m3"].get<double>(), 3e11, 0.1 * 3e11);
  EXPECT_GT(s["residual_shrink"].get<double>(), 0.8);
  EXPECT_TRUE(s["new_case"]["matches_refit"].get<bool>()) << s["new_case"];
  EXPECT_TRUE(std::filesystem::exists(dir / "d-leak" / "case-with-valve_leakage.toml"));
  EXPECT_EQ(s["candidates"].size(), 4u); // none + the three asked for
  EXPECT_NE(r.output.find("outlet pressure"), std::string::npos) << r.output; // the localisation
  // the naming rule's dominant feature, in noise units (it said "of its
  // swing" until the forty-sixth stop): at least half of it above the
  // noise closed, as the rule asks
  {
    const auto decision = s["decision"].get<std::string>();
    const auto at       = decision.find("dominant residual feature (");
    ASSERT_NE(at, std::string::npos) << decision;
    double before = 0, after = 0;
    char   unit[16] = {};
    ASSERT_EQ(std::sscanf(decision.c_str() + decision.find(") ", at) + 2, "%lf -> %lf %15s", &before, &after, unit), 3)
      << decision;
    EXPECT_STREQ(unit, "noise") << decision;
    const auto gap = [](double v) { return std::sqrt(std::max(v * v - 1.0, 0.0)); };
    EXPECT_GT(before, 2.0) << decision;
    EXPECT_LE(gap(after), 0.5 * gap(before)) << decision;
  }
  // progress, one line per step that takes seconds: each candidate, the
  // named fit's refits, the passage's try and the profiles
  for (const char *line : {"fitted none ", "fitted valve_leakage ", "valve_leakage refitted (pass 1)",
                           "lines.outlet_inertance_Pa_s2_per_m3: ", "valve_leakage's standard errors and profiles: "})
    EXPECT_NE(r.output.find(line), std::string::npos) << line << " in\n" << r.output;
  // the model's own data, fitted to the noise: the outlet passage has
  // nothing left to explain and is not tried
  ASSERT_EQ(s["left_out_tried_at_the_named_fit"].size(), 1u);
  EXPECT_FALSE(s["left_out_tried_at_the_named_fit"][0]["on"].get<bool>());
  EXPECT_NE(s["left_out_tried_at_the_named_fit"][0]["note"].get<std::string>().find(
              "not tried: the named fit leaves no gap above the noise"),
            std::string::npos)
    << s["left_out_tried_at_the_named_fit"];
  EXPECT_LT(s["residual_after"]["overall"].get<double>(), 1.0);
  // the sensors' lags (the reference case's [sensors]), fitted to the final
  // model: the model's own record passed no sensor, so none takes up more
  // than 2 % of a signal's residual, and the residual after is not above
  // the one with ideal sensors
  ASSERT_EQ(s["sensor_lags"].size(), s["residual_after"].size() - 1) << s["sensor_lags"]; // less "overall"
  for (const auto &l : s["sensor_lags"])
    {
      const double ideal = l["training_residual_ideal"].get<double>(), lagged = l["training_residual_lagged"];
      EXPECT_LE(lagged, ideal) << l;
      EXPECT_GT(lagged, 0.98 * ideal) << l;
      EXPECT_EQ(l["lowest_bandwidth_Hz"].get<double>(), l["signal"].get<std::string>().ends_with("_Pa") ? 2000 : 5000)
        << l;
    }
  EXPECT_LE(s["residual_after"]["overall"].get<double>(), s["residual_after_ideal_sensors"]["overall"].get<double>());
  {
    std::ifstream      report(dir / "d-leak" / "report.md");
    const std::string  text((std::istreambuf_iterator<char>(report)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("## The sensors' lags"), std::string::npos);
  }

  r = rectify_cli("diagnose --data " + (dir / "clean" / "data.csv").string() + candidates + "--ideal-sensors --out " +
                  (dir / "d-clean").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto c = nlohmann::json::parse(std::ifstream(dir / "d-clean" / "summary.json"));
  EXPECT_EQ(c["effect"], "none") << c["decision"];
  EXPECT_NE(c["decision"].get<std::string>().find("no significant missing effect"), std::string::npos);
  // --ideal-sensors: no lag fitted, the residual after as the model gives it
  EXPECT_TRUE(c["sensor_lags"].empty()) << c["sensor_lags"];
  EXPECT_EQ(c["residual_after"], c["residual_after_ideal_sensors"]);
}

TEST(Diagnosis, BadDataAndBadOptionsStopBeforeWritingAnything)
{
  const auto dir = scratch("diagnose_bad");
  {
    std::ofstream f(dir / "unsorted.csv");
    f << "time_s,current_A,outlet_pressure_Pa\n";
    for (int i = 0; i < 400; ++i)
      f << (i == 200 ? 0.0 : i * 1e-4) << "," << 10 + 10 * std::sin(2 * M_PI * 100 * i * 1e-4) << ",3e6\n";
  }
  auto r = rectify_cli("diagnose --data " + (dir / "unsorted.csv").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unsorted.csv"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("time_s"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("201"), std::string::npos) << r.output; // the data row
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  r = rectify_cli("diagnose --data " + (dir / "missing.csv").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("missing.csv"), std::string::npos) << r.output;
  r = rectify_cli("synth --effect valve_leakage --param leak_resistance_Pa_s_per_m3=1e3 --out " + (dir / "s").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bounds"), std::string::npos) << r.output;
  r = rectify_cli("synth --effect valve_leakage --param stiffness=1 --out " + (dir / "s").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("not a parameter of valve_leakage"), std::string::npos) << r.output;
  r = rectify_cli("synth --effect leak --out " + (dir / "s").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("valve_leakage"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
}

namespace
{
  /// `rectify synth SYNTH_ARGS` into a scratch folder, then `rectify diagnose`
  /// of its data with `--effects EFFECTS`: the diagnosis's summary.json (null,
  /// with the command's output as a failure, if either command fails).
  nlohmann::json synth_then_diagnose(const std::string &name, const std::string &synth_args,
                                     const std::string &effects)
  {
    const auto dir = scratch(name);
    auto       r   = rectify_cli("synth " + synth_args + " --out " + (dir / "data").string());
    if (r.exit_code != 0)
      {
        ADD_FAILURE() << r.output;
        return {};
      }
    return diagnose_summary(dir / "data" / "data.csv", "--effects " + effects + " --reed-second-mode case", dir / "d");
  }
} // namespace

// An inertial outlet line rings after each closing of the outlet valve,
// nearly undamped: the residual's dependence on L is a comb of basins about
// +-1 % wide over 12 cycles, which no coarse grid finds. The fit starts from
// the ringing's frequency in the residual (docs/diagnosis.md): L comes back
// to 1 % and the residual to the noise. Without that start (the 9-point
// grid) the same data gave "none" (residual 10.0 -> 9.3 noise units).
// The ringing start in isolation: the baseline known (the reference case
// without its [uncertain] table). With the oil column and the lines' bore
// uncertain too, the line's own oil (A l / beta, l from L and the bore)
// trades against the cylinder's and this fit stopped at its evaluation
// budget 1.55 noise units from the data (L still to 0.3 %): what a
// calibrated baseline does with a line is the bench study's question.
TEST(Diagnosis, InertialLineIsFoundFromItsRinging)
{
  const auto  dir  = scratch("diagnose_line");
  std::string text = reference_text();
  text             = text.substr(0, text.find("[uncertain]"));
  {
    std::ofstream f(dir / "known.toml");
    f << edit_case_text(text, reference_case_path().parent_path(), {});
  }
  auto r = rectify_cli("synth --effect line_inertance --param outlet_inertance_Pa_s2_per_m3=1.12e8 "
                       "--noise 0.0186 --seed 1001 --frequency 100 --cycles 12 --out " +
                       (dir / "data").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto s = diagnose_summary(dir / "data" / "data.csv",
                            "--case " + (dir / "known.toml").string() +
                              " --effects line_inertance valve_leakage --reed-second-mode case",
                            dir / "d");
  ASSERT_EQ(s["effect"], "line_inertance") << s["decision"];
  EXPECT_NEAR(s["parameters"]["outlet_inertance_Pa_s2_per_m3"].get<double>(), 1.12e8, 0.01 * 1.12e8);
  EXPECT_GT(s["residual_shrink"].get<double>(), 0.8);
  EXPECT_LT(s["residual_after"]["overall"].get<double>(), 1.5);
}

// A soft outlet seal (14x the oil column's compliance) changes how the model
// answers the drive's own noise: with the residual scales of the model
// without it, the fit weighed the outlet valve 20x too lightly and stopped
// at +48 % (the study's outlet_compliance-03). Rescaled with the fitted model
// and refitted, the parameter comes back within 10 % and the residual to its
// noise.
TEST(Diagnosis, SoftSealIsRecoveredAfterRescalingTheResidualWithTheFittedModel)
{
  auto s = synth_then_diagnose("diagnose_seal",
                               "--effect outlet_compliance --param seal_compliance_m3_per_Pa=4.076e-11 "
                               "--noise 0.02 --seed 1013 --frequency 50 --cycles 16",
                               "outlet_compliance");
  ASSERT_EQ(s["effect"], "outlet_compliance") << s["decision"];
  EXPECT_NEAR(s["parameters"]["seal_compliance_m3_per_Pa"].get<double>(), 4.076e-11, 0.1 * 4.076e-11);
  // determined (20 % either way with the baseline refitted fits worse), and
  // its standard error from that profile covers the true value
  const auto &u = s["parameter_uncertainty"][0];
  EXPECT_TRUE(u["determined"].get<bool>()) << u.dump(1);
  EXPECT_GT(u["profile"]["evidence_against"][0].get<double>(), 10.0) << u.dump(1);
  EXPECT_GT(u["profile"]["evidence_against"][1].get<double>(), 10.0) << u.dump(1);
  EXPECT_LT(std::abs(std::log(u["value"].get<double>() / 4.076e-11)), 3 * u["relative_standard_error"].get<double>())
    << u.dump(1);
  EXPECT_GE(s["rounds"][0]["refits_with_rescaled_residuals"].get<int>(), 1);
  EXPECT_LT(s["residual_after"]["overall"].get<double>(), 1.5); // at the noise, every signal
  for (const auto &[signal, value] : s["residual_after"].items())
    EXPECT_LT(value.get<double>(), 2.0) << signal;
}

namespace
{
  /// A diagnosis's summary.json without what depends on the time and the
  /// cores a run had: its times, the runs evaluated ahead on an idle core,
  /// the fits taken from an interrupted run
  nlohmann::json without_timing(nlohmann::json j)
  {
    std::function<void(nlohmann::json &)> go = [&](nlohmann::json &x) {
      if (x.is_object())
        {
          for (auto it = x.begin(); it != x.end();)
            if (it.key().size() > 6 && it.key().ends_with("time_s"))
              it = x.erase(it);
            else
              go(*it++);
          x.erase("runs_evaluated_ahead");
          x.erase("resumed_fits");
        }
      else if (x.is_array())
        for (auto &y : x)
          go(y);
    };
    go(j);
    return j;
  }
} // namespace

// The thread count changes a diagnosis's time, not its result. The
// candidates fitted at once are folded in their order; a search that runs
// alone (a refit, a profile's side) has its first points evaluated ahead on
// the idle core and takes their values in its own order; the runs share
// their drives' lookup hints. Every number of the summary but the times is
// the same to the last bit with one thread and with two, and with two some
// runs were taken from the idle core.
TEST(Diagnosis, TheThreadCountChangesTheTimeNotTheResult)
{
  const auto dir = scratch("diagnose_threads");
  auto       r   = rectify_cli("synth --effect outlet_compliance --param seal_compliance_m3_per_Pa=4.076e-11 "
                               "--noise 0.02 --seed 1013 --frequency 50 --cycles 10 --out " +
                               (dir / "data").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string args = "--effects outlet_compliance valve_leakage --reed-second-mode case --threads ";
  auto one = diagnose_summary(dir / "data" / "data.csv", args + "1", dir / "one");
  auto two = diagnose_summary(dir / "data" / "data.csv", args + "2", dir / "two");
  ASSERT_FALSE(one.is_null());
  ASSERT_FALSE(two.is_null());
  EXPECT_EQ(one["effect"], "outlet_compliance") << one["decision"];
  EXPECT_EQ(one["runs_evaluated_ahead"].get<int>(), 0);
  EXPECT_GT(two["runs_evaluated_ahead"].get<int>(), 0);
  const auto differences = nlohmann::json::diff(without_timing(one), without_timing(two));
  EXPECT_TRUE(differences.empty()) << differences.dump(1);
}

// A diagnosis killed part-way keeps each candidate's fit that had ended
// (OUT/diagnosis-partial.csv); the same command again takes those fits
// instead of fitting them again and ends as an uninterrupted run does. Kept
// fits of another command, or whose none the new run fits otherwise, are
// discarded.
TEST(Diagnosis, AKilledDiagnosisResumesFromTheFitsItKeptAndEndsAsAnUninterruptedOne)
{
  const auto dir = scratch("diagnose_resume");
  auto       r   = rectify_cli("synth --effect valve_leakage --param leak_resistance_Pa_s_per_m3=5e11 "
                               "--noise 0.01 --seed 11 --frequency 100 --cycles 12 --out " + (dir / "data").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto data = dir / "data" / "data.csv";
  const std::string extra = "--reed-second-mode case --max-evaluations 12 --threads 2 "
                            "--effects valve_leakage entrained_air outlet_compliance";
  const auto command = [&](const std::filesystem::path &out) {
    return "diagnose --data " + data.string() + " " + extra + " --out " + out.string();
  };
  const auto lines = [](const std::filesystem::path &file) { // whole lines: a row being written is not one yet
    std::ifstream in(file);
    return static_cast<std::size_t>(std::count(std::istreambuf_iterator<char>(in), {}, '\n'));
  };
  // Killed once `rows` lines (the header, none's fit, then candidates') are kept
  const auto killed = [&](const std::filesystem::path &out, std::size_t rows) {
    std::vector<std::string> argv; // the command's words (no path here holds a space)
    std::istringstream       words(command(out));
    for (std::string w; words >> w;)
      argv.push_back(w);
    std::vector<char *> c_argv;
    c_argv.push_back(const_cast<char *>(RECTIFY_BINARY));
    for (auto &a : argv)
      c_argv.push_back(a.data());
    c_argv.push_back(nullptr);
    const pid_t pid = ::fork();
    if (pid == 0)
      {
        const int null = ::open("/dev/null", O_WRONLY);
        ::dup2(null, 1);
        ::dup2(null, 2);
        ::execv(RECTIFY_BINARY, c_argv.data());
        ::_exit(127);
      }
    const auto kept = out / "diagnosis-partial.csv";
    int        status = 0;
    bool       ended  = false;
    for (int i = 0; i < 60000 && lines(kept) < rows; ++i)
      {
        if (::waitpid(pid, &status, WNOHANG) == pid)
          {
            ended = true;
            break;
          }
        ::usleep(1000);
      }
    if (!ended)
      {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
      }
    return !ended && lines(kept) >= rows;
  };

  const auto whole = diagnose_summary(data, extra, dir / "whole");
  ASSERT_FALSE(whole.is_null());
  EXPECT_EQ(whole["effect"], "valve_leakage") << whole["decision"];
  EXPECT_TRUE(whole["resumed_fits"].empty());
  EXPECT_FALSE(std::filesystem::exists(dir / "whole" / "diagnosis-partial.csv")); // complete: removed
  EXPECT_FALSE(std::filesystem::exists(dir / "whole" / "diagnosis-partial.json"));

  // killed with none's fit and one candidate's kept
  ASSERT_TRUE(killed(dir / "resumed", 3)) << "the run ended before two fits were kept";
  EXPECT_FALSE(std::filesystem::exists(dir / "resumed" / "summary.json"));
  const std::size_t kept = lines(dir / "resumed" / "diagnosis-partial.csv") - 2; // the header and none
  std::filesystem::copy(dir / "resumed", dir / "tampered");
  std::filesystem::copy(dir / "resumed", dir / "other");
  std::filesystem::copy(dir / "resumed", dir / "damaged");

  r = rectify_cli(command(dir / "resumed"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("resuming: " + std::to_string(kept + 1) + " fit(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(kept by the interrupted run: not fitted again)"), std::string::npos) << r.output;
  const auto resumed = nlohmann::json::parse(std::ifstream(dir / "resumed" / "summary.json"));
  EXPECT_EQ(resumed["resumed_fits"].size(), kept) << resumed["resumed_fits"];
  EXPECT_FALSE(std::filesystem::exists(dir / "resumed" / "diagnosis-partial.csv"));
  const auto differences = nlohmann::json::diff(without_timing(whole), without_timing(resumed));
  EXPECT_TRUE(differences.empty()) << differences.dump(1);
  EXPECT_EQ(read_text(dir / "whole" / "case-with-valve_leakage.toml"),
            read_text(dir / "resumed" / "case-with-valve_leakage.toml"));

  // A copy of the killed run's folder with its kept rows edited, run again:
  // every kept fit is discarded, saying why, and the result is the whole run's
  const auto discarded = [&](const std::string &name, const std::function<void(std::string &)> &edit,
                             const std::string &why) {
    std::string csv = read_text(dir / name / "diagnosis-partial.csv");
    edit(csv);
    std::ofstream(dir / name / "diagnosis-partial.csv") << csv;
    const auto run = rectify_cli(command(dir / name));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_NE(run.output.find(why), std::string::npos) << run.output;
    const auto s = nlohmann::json::parse(std::ifstream(dir / name / "summary.json"));
    EXPECT_TRUE(s["resumed_fits"].empty()) << s["resumed_fits"];
    EXPECT_TRUE(nlohmann::json::diff(without_timing(whole), without_timing(s)).empty()) << name;
  };
  // none's kept fit (the first row) changed in its BIC's last digit
  discarded("tampered", [](std::string &csv) {
    const auto at = csv.find("\"bic\":\"", csv.find('\n'));
    ASSERT_NE(at, std::string::npos) << csv;
    const auto end = csv.find('"', at + 7);
    csv[end - 1]   = csv[end - 1] == '1' ? '2' : '1';
  }, "its none fitted otherwise");
  // a kept candidate's (the last row's) BIC not a hexadecimal float: "0q..."
  discarded("damaged", [](std::string &csv) {
    const auto at = csv.rfind("\"bic\":\"");
    ASSERT_NE(at, std::string::npos) << csv;
    csv.replace(at + 7, 2, "0q");
  }, "unreadable (");

  // another command (one evaluation fewer per candidate): discarded
  r = rectify_cli(std::regex_replace(command(dir / "other"), std::regex("--max-evaluations 12"),
                                     "--max-evaluations 11"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("another diagnosis's"), std::string::npos) << r.output;
  const auto other = nlohmann::json::parse(std::ifstream(dir / "other" / "summary.json"));
  EXPECT_TRUE(other["resumed_fits"].empty()) << other["resumed_fits"];
}

// The candidates are compared on at most DiagnoseOptions::compared_cycles
// training cycles in all: the same number from every run that has them,
// the whole training part of a shorter run (the level h with
// sum min(have, h) = cap), and every cycle where the runs hold no more.
TEST(Diagnosis, ComparedCyclesAreSharedOutOverTheRuns)
{
  const auto run_case = [](double f, double cycles, double skip_cycles) {
    auto rc = make_run_case(MeasuredRun::parse(record(f, cycles), "run.csv"), system::Scenario::no_flow, f, 0.75);
    rc.n_skip = static_cast<std::size_t>(std::lround(skip_cycles * 20000 / f));
    return rc;
  };
  // four runs of 20 cycles, 15 of them training, one with a settling cycle
  std::vector<RunCase> runs{run_case(50, 20, 1), run_case(75, 20, 0), run_case(100, 20, 0), run_case(150, 20, 0)};
  EXPECT_NEAR(screening_cycles_per_run(runs, 32), 8.0, 1e-9);
  EXPECT_EQ(screening_cycles_per_run(runs, 0), 0.0);   // 0: every cycle
  EXPECT_EQ(screening_cycles_per_run(runs, 100), 0.0); // 59 cycles held: every one
  EXPECT_NEAR(screening_cycles_per_run(runs, 4), 3.0, 1e-9); // at least 3 from each
  // a short run keeps its whole training part: 3 + 15 + 15 training cycles
  // (14 after a settling cycle), cap 24 -> 3 + 10.5 + 10.5
  std::vector<RunCase> mixed{run_case(100, 4, 0), run_case(100, 20, 0), run_case(50, 20, 1)};
  EXPECT_NEAR(screening_cycles_per_run(mixed, 24), 10.5, 1e-6);
  // one record of the study's length (12 training cycles) is compared whole
  std::vector<RunCase> one{run_case(100, 16, 0)};
  EXPECT_EQ(screening_cycles_per_run(one, 32), 0.0);
}

// A candidate's searches start from the two best valleys of its start
// grid, not its two best points: two neighbours are one basin. The values
// are piston_friction-4's objective on its two grid lines (at the
// baseline's fit, at the case's values; 12 points of Coulomb friction
// from 0.0147 to 68 N): the two best points overall (0.32 and 0.68 N on
// the first line) are one valley; the second valley is 6.8 N on the
// second line, the friction's own basin (the bench's 4.6 N).
// The settling window ends at the first cycle from which every later one is
// within the tolerance: an exponential fade 100 exp(-c / 1.5) reaches 1 at
// c = 1.5 ln 100 = 6.91, so cycle 7 is the first within it; a late bump
// above it moves the end past the bump; the window stays within its bounds.
TEST(Diagnosis, TheSettlingWindowEndsWhereEveryLaterCycleIsWithinTheTolerance)
{
  std::vector<double> fade;
  for (int c = 0; c < 12; ++c)
    fade.push_back(100 * std::exp(-c / 1.5));
  EXPECT_EQ(settled_from(fade, 1.0, 1, 6), 6u);  // at most half of the 12
  EXPECT_EQ(settled_from(fade, 1.0, 1, 10), 7u);
  EXPECT_EQ(settled_from(fade, 10.0, 1, 10), 4u); // 100 exp(-4 / 1.5) = 6.9 <= 10 < 13.5
  auto bump = fade;
  bump[9]   = 1.5;
  EXPECT_EQ(settled_from(bump, 1.0, 1, 11), 10u);
  EXPECT_EQ(settled_from(std::vector<double>(12, 0.5), 1.0, 1, 6), 1u); // within from the start: the least
  EXPECT_EQ(settled_from(std::vector<double>(12, 5.0), 1.0, 1, 6), 6u); // never: the most
}

TEST(Diagnosis, TwoStartsRunsMeetWhereTheyComeWithinTheToleranceOrHalfWayTogether)
{
  // the model's runs from two starts, noise units apart per training cycle,
  // as settle measured them on four of the bench's records (forty-fourth stop)
  const std::vector<double> slow_line{107.07, 89.22, 73.74, 57.33, 44.75, 34.04,
                                      26.92, 21.43, 15.95, 12.5, 9.94, 7.51};  // line_inertance-3
  const std::vector<double> two_orbits{72.43, 47.59, 57.66, 56.12, 56.97, 56.89,
                                       54.54, 53.41, 56.98, 56.96, 53.17, 49.23}; // line_inertance-4
  const std::vector<double> flutter{124.31, 57.24, 3.1, 1.8, 1.27, 1.13, 1.12, 1.11, 1.11, 1.11, 1.11}; // piston_friction-2
  const std::vector<double> seal{539.2, 500.85, 465.93, 435.98, 411.14, 391.12,
                                 375.27, 361.6, 347.69, 332.59, 316.12}; // outlet_compliance-0
  EXPECT_TRUE(runs_meet(slow_line, 1.0));
  EXPECT_TRUE(runs_meet(flutter, 1.0));
  EXPECT_FALSE(runs_meet(two_orbits, 1.0));
  EXPECT_FALSE(runs_meet(seal, 1.0)); // 59 % of the way left
  // a slow run meets later: the window is the most settled_from allows
  EXPECT_EQ(settled_from(slow_line, 1.0, 1, slow_line.size() / 2), 6u);
  EXPECT_EQ(settled_from(flutter, 1.0, 1, flutter.size() / 2), 5u);
  EXPECT_TRUE(runs_meet({3.0, 0.9}, 1.0));  // within the tolerance
  EXPECT_TRUE(runs_meet({0.5, 0.9}, 1.0));  // within it, even if growing
  EXPECT_FALSE(runs_meet({3.0, 1.6}, 1.0)); // above it, not half-way
  EXPECT_FALSE(runs_meet({}, 1.0));
}

TEST(Diagnosis, StartGridValleysAreTheLowestOfTheirNeighboursOnTheirOwnLine)
{
  const std::vector<double> fit_line{28.03, 27.94, 27.71, 27.37, 26.77, 26.80,
                                     34.16, 80.22, 599.2, 907.9, 6819, 20672};
  const std::vector<double> case_line{2022.8, 2015.8, 1999.1, 1963.9, 1890.5, 1742.9,
                                      1478.6, 1060.5, 317.8, 1541.5, 6488.6, 15851};
  std::vector<int>    line, at;
  std::vector<double> value;
  for (int l = 0; l < 2; ++l)
    for (int g = 0; g < 12; ++g)
      {
        line.push_back(l);
        at.push_back(g);
        value.push_back((l == 0 ? fit_line : case_line)[g]);
      }
  // a point off the grid (a ringing start) lower than all: never a valley
  line.push_back(-1);
  at.push_back(4);
  value.push_back(1.0);
  const auto valley = grid_valleys(line, at, value);
  ASSERT_EQ(valley.size(), value.size());
  std::vector<std::size_t> valleys;
  for (std::size_t i = 0; i < valley.size(); ++i)
    if (valley[i])
      valleys.push_back(i);
  // the first line: 26.77 at 0.32 N (position 4); the second: 317.8 at
  // 6.8 N (position 8); the off-grid point is no valley, though lowest,
  // and the neighbour across the lines (position 11 -> 12) is no neighbour
  EXPECT_EQ(valleys, (std::vector<std::size_t>{4, 12 + 8}));
  // a monotone line has its valley at its lower end; ties are both valleys
  EXPECT_EQ(grid_valleys({0, 0, 0}, {0, 1, 2}, {3, 2, 1}), (std::vector<bool>{false, false, true}));
  EXPECT_EQ(grid_valleys({0, 0, 0}, {0, 1, 2}, {1, 1, 2}), (std::vector<bool>{true, true, false}));
  EXPECT_THROW(grid_valleys({0, 0}, {0}, {1, 2}), std::logic_error);
}

// Two runs of a hidden leak (the model's own data: this checks the
// comparison's window, not an identification), the candidates compared on
// 4 of each run's 9 training cycles: the leak is still named, and the
// refits on every training cycle bring its value and the residual to what
// the whole record gives (within 10 % and the noise).
TEST(Diagnosis, CandidatesComparedOnFewerCyclesThenTheNamedEffectRefittedOnAll)
{
  const auto dir = scratch("diagnose_compared_cycles");
  std::string data;
  for (const char *f : {"100", "150"})
    {
      const auto r = rectify_cli(std::string("synth --effect valve_leakage --param leak_resistance_Pa_s_per_m3=3e11 "
                                             "--noise 0.01 --seed 11 --cycles 12 --frequency ") + f + " --out " +
                                 (dir / f).string());
      ASSERT_EQ(r.exit_code, 0) << r.output;
      data += " " + (dir / f / "data.csv").string();
    }
  const auto r = rectify_cli("diagnose --data" + data + " --effects valve_leakage outlet_compliance "
                             "--reed-second-mode case --compared-cycles 8 --out " + (dir / "d").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("candidates fitted and compared on the first 4 training cycles of each run"),
            std::string::npos) << r.output;
  const auto s = nlohmann::json::parse(std::ifstream(dir / "d" / "summary.json"));
  EXPECT_EQ(s["effect"], "valve_leakage") << s["decision"];
  EXPECT_NEAR(s["compared_cycles_per_run"].get<double>(), 4.0, 1e-9);
  EXPECT_NEAR(s["parameters"]["leak_resistance_Pa_s_per_m3"].get<double>(), 3e11, 0.1 * 3e11);
  EXPECT_LT(s["residual_after"]["overall"].get<double>(), 1.2);
  // every candidate scored on 4 + 4 cycles of synth's four signals at 200
  // samples per cycle, not on the 9 + 9 of the training part (a window may
  // hold one sample more, as the record's time step rounds)
  for (const auto &c : s["candidates"])
    {
      const long n = c["compared_samples"].get<long>();
      EXPECT_GE(n, 4 * 2 * (4 * 200)) << c;
      EXPECT_LE(n, 4 * 2 * (4 * 200 + 1)) << c;
    }
  std::ifstream report(dir / "d" / "report.md");
  const std::string md((std::istreambuf_iterator<char>(report)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("refitted on every training cycle"), std::string::npos);
  // a negative count is refused
  const auto bad = rectify_cli("diagnose --data" + data + " --compared-cycles -1 --out " + (dir / "bad").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--compared-cycles"), std::string::npos) << bad.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
}
