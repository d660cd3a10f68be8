// Diagnosis on records the model did not make (issue 17): outlier spikes,
// the band the residual is compared in, noise that is not white, records that
// start mid-operation, an uncertain baseline calibrated before anything is
// named. The end-to-end check on the independent bench is
// Diagnosis.ForeignBenchLeakIsNamed (python bench, bench/foreign/).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <sstream>

#include "cli_helpers.h"
#include "common/case_file.h"
#include "diagnosis/diagnose.h"
#include "diagnosis/search.h" // uncertain_from_unit
#include "diagnosis/words.h"
#include "diagnosis/effect.h"
#include "diagnosis/measured_run.h"
#include "diagnosis/observation.h"
#include "diagnosis/residuals.h"
#include "diagnosis/uncertainty.h"
#include "system/integrator.h"
#include "system/parameters.h"
#include "system/simulation.h"

using namespace rectify;
using namespace rectify::diagnosis;
using namespace rectify::test_support;

namespace
{
  constexpr double pi = std::numbers::pi;

  /// A record at 200 samples per cycle of f: the drive (a sine from its
  /// minimum) and one signal from `signal(t)`.
  MeasuredRun record(double f, int cycles, const std::function<double(double)> &signal)
  {
    MeasuredRun run;
    run.source = "test";
    const int n = 200 * cycles;
    for (int i = 0; i < n; ++i)
      {
        const double t = i / (200.0 * f);
        run.time_s.push_back(t);
        run.signals["current_A"].push_back(10 - 10 * std::cos(2 * pi * f * t));
        run.signals["outlet_pressure_Pa"].push_back(signal(t));
      }
    return run;
  }

  /// The state of `model` (reset, from rest, tolerance 1e-8) at time t.
  std::vector<double> state_at(system::Model &model, const system::SystemParameters &p, double t)
  {
    model.reset();
    system::RunOptions ro;
    ro.relative_tolerance        = 1e-8;
    ro.absolute_tolerance_factor = p.solver.absolute_tolerance_factor;
    auto io                      = system::integrator_options(model, ro);
    io.quiet                     = true;
    io.max_steps_between_outputs = 100000000; // one output, at t
    system::Integrator integrator(model, 0.0, model.initial_state(), io);
    integrator.advance_to(t);
    const auto span = integrator.state();
    return {span.begin(), span.end()};
  }

  /// What a record of `model` at state y shows (RecordedState): the
  /// pressures, the outlet valve's opening and the strain.
  RecordedState recorded_at(const system::Model &model, const system::SystemParameters &p,
                            const std::vector<double> &y)
  {
    namespace s = rectify::system::state;
    RecordedState r;
    r.chamber_pressure_Pa = p.fluid.bias_pressure_Pa + y[s::chamber_p];
    r.outlet_pressure_Pa  = p.fluid.bias_pressure_Pa + model.flows(y).p_outlet;
    r.outlet_valve_m      = model.opening(0, y);
    r.strain              = y[s::piston_x] / p.transducer.rod_length_m;
    return r;
  }

  /// DIR/rig.toml: the reference case with each `from` text replaced by
  /// its `to` (a rig whose baseline differs from the case's), beside the
  /// case's resistance table. Fails the test if a `from` is not there.
  std::filesystem::path write_rig(const std::filesystem::path                           &dir,
                                  const std::vector<std::pair<std::string, std::string>> &changes)
  {
    std::string text = reference_text();
    for (const auto &[from, to] : changes)
      {
        const auto at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        if (at != std::string::npos)
          text.replace(at, from.size(), to);
      }
    {
      std::ofstream out(dir / "rig.toml");
      out << text;
    }
    std::filesystem::copy_file(reference_case_path().parent_path() / "thesis-resistance.csv",
                               dir / "thesis-resistance.csv", std::filesystem::copy_options::overwrite_existing);
    return dir / "rig.toml";
  }

  /// DIR/data/data.csv: `rectify synth` (no effect, 1 % noise, 100 Hz, 12
  /// cycles, seed 5) of a rig whose oil column is 0.061 m, not the case's
  /// 0.0254 m. Empty (with a test failure) if synth fails.
  std::filesystem::path long_oil_column_record(const std::filesystem::path &dir)
  {
    const auto rig = write_rig(dir, {{"wetted_length_m = 0.0254", "wetted_length_m = 0.061"}});
    const auto r   = rectify_cli("synth --case " + rig.string() +
                                 " --effect none --noise 0.01 --seed 5 --frequency 100 --cycles 12 --out " +
                                 (dir / "data").string());
    if (r.exit_code != 0)
      {
        ADD_FAILURE() << r.output;
        return {};
      }
    return dir / "data" / "data.csv";
  }

  // A record's rows from row `from` on, its time from 0 there: a record that
  // starts wherever the pump was.
  std::string rows_from(const std::filesystem::path &csv, int from)
  {
    std::ifstream in(csv);
    std::string   header, line;
    std::getline(in, header);
    std::string text = header + "\n";
    int         row  = 0;
    double      t0   = 0;
    while (std::getline(in, line))
      {
        if (row == from)
          t0 = std::stod(line.substr(0, line.find(',')));
        if (row >= from)
          text += format_number(std::stod(line.substr(0, line.find(','))) - t0) + line.substr(line.find(',')) + "\n";
        ++row;
      }
    return text;
  }
} // namespace

// One displaced sample leaves the pattern +A, -A/2, -A/2 in the offsets from
// the neighbours' mean; a valve's kink or a pressure step does not. Spikes of
// 10 and 1000 noise sd are found, replaced within the noise, and nothing else
// is touched: not the steps, not the kinks, not 16 cycles of white noise.
TEST(ForeignData, IsolatedSpikesAreFoundAndRepairedAndKinksAreLeftAlone)
{
  std::mt19937_64                  rng(7);
  std::normal_distribution<double> noise(0.0, 1e4); // 10 kPa
  const double                     f = 100;
  auto run = record(f, 16, [&](double t) {
    const double phase = t * f - std::floor(t * f);
    // a sawtooth-like pressure: a steep rise, a kink at the top, a step down
    return 5e6 + (phase < 0.3 ? 1e7 * phase : 3e6 - 2e6 * (phase - 0.3)) + noise(rng);
  });
  auto      &p     = run.signals["outlet_pressure_Pa"];
  const auto clean = p;
  p[1050] += 1e7;  // 1000 sd, on the steep rise: a 1.8 GPa-style spike, scaled
  p[2222] -= 1.2e5; // 12 sd
  const auto found = run.repair_outliers();
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].row, 1051u);
  EXPECT_EQ(found[1].row, 2223u);
  EXPECT_EQ(found[0].column, "outlet_pressure_Pa");
  EXPECT_NEAR(found[0].noise_units, 1000, 100);
  EXPECT_NEAR(found[0].time_s, 1050 / (200 * f), 1e-12);
  for (std::size_t k : {1050u, 2222u})
    EXPECT_LT(std::abs(p[k] - clean[k]), 5e4) << k; // back within a few noise sd
  for (std::size_t k = 0; k < p.size(); ++k)
    {
      if (k != 1050 && k != 2222)
        {
          ASSERT_EQ(p[k], clean[k]) << "sample " << k << " changed";
        }
    }
}

// A sharp feature at the same phase of every cycle (a pressure spike at each
// valve closing, as in the bench's strongest orifice) has the shape of an
// outlier, but it is the pump's: left alone, wherever the cycle's samples
// fall (here one sample later in every other cycle). An outlier on top of
// it (100x its size) and one elsewhere are still found.
TEST(ForeignData, ASpikeAtTheSamePhaseOfEveryCycleIsThePumpsOwnNotAnOutlier)
{
  std::mt19937_64                  rng(11);
  std::normal_distribution<double> noise(0.0, 1e4);
  const double                     f = 100;
  auto run = record(f, 16, [&](double t) {
    const double phase = t * f - std::floor(t * f);
    return 5e6 + (phase < 0.3 ? 1e7 * phase : 3e6 - 2e6 * (phase - 0.3)) + noise(rng);
  });
  auto &p = run.signals["outlet_pressure_Pa"];
  for (std::size_t c = 0; c < 16; ++c)
    p[120 + 200 * c + c % 2] += 1e5 * (1.0 + 0.1 * static_cast<double>(c % 3)); // 10-12 sd
  const auto clean = p;
  p[120 + 200 * 7 + 1] += 1e7; // on top of cycle 7's
  p[2222] -= 1.2e5;
  const auto found = run.repair_outliers(6.0, f);
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0].row, 120u + 200 * 7 + 1 + 1);
  EXPECT_EQ(found[1].row, 2223u);
  for (std::size_t k = 0; k < p.size(); ++k)
    if (k != 120 + 200 * 7 + 1 && k != 2222)
      {
        ASSERT_EQ(p[k], clean[k]) << "sample " << k << " changed";
      }
  // the pumping frequency from the drive gives the same
  auto again = record(f, 16, [&](double t) { return 5e6 + 1e6 * std::sin(2 * pi * f * t) + noise(rng); });
  auto &q    = again.signals["outlet_pressure_Pa"];
  for (std::size_t c = 0; c < 16; ++c)
    q[120 + 200 * c] += 2e6;
  EXPECT_TRUE(again.repair_outliers().empty());
}

// The band the residual is compared in: every term of the record's cosine
// series above the cutoff goes, every one below stays (exactly, for terms
// that are cosines of whole cycles over the record).
TEST(ForeignData, BandLimitKeepsTheHarmonicsBelowTheCutoffAndRemovesTheRest)
{
  const double f = 50;
  auto         low = [&](double t) { return 3 + std::cos(2 * pi * f * t) + 0.4 * std::cos(2 * pi * 7 * f * t); };
  auto         run = record(f, 16, [&](double t) { return low(t) + 0.2 * std::cos(2 * pi * 23 * f * t); });
  const auto   out = band_limit(run.time_s, run.signal("outlet_pressure_Pa"), 10.5 * f);
  double       worst = 0;
  for (std::size_t i = 0; i < out.size(); ++i)
    worst = std::max(worst, std::abs(out[i] - low(run.time_s[i])));
  // the record ends a sample short of a whole period, so its mirror image
  // has a small kink at the end: some leakage there, none inside
  EXPECT_LT(worst, 0.1);
  double mid = 0;
  for (std::size_t i = out.size() / 4; i < 3 * out.size() / 4; ++i)
    mid = std::max(mid, std::abs(out[i] - low(run.time_s[i])));
  EXPECT_LT(mid, 1e-3);
}

// The same band by both of band_limit's ways: records whose length m = 2 (n - 1)
// has a large prime factor (n - 1 = 2399, a prime) sum the few low terms
// directly, others (n - 1 = 2048) use the FFT. Each keeps the record's own
// cosine terms cos(pi k i / (n - 1)) up to the cutoff (the last one kept
// and the first one dropped included) exactly and removes the others;
// filtering twice changes nothing.
TEST(ForeignData, BandLimitIsExactOnTheCosineTermsByBothWays)
{
  for (const std::size_t n : {std::size_t{2400}, std::size_t{2049}})
    {
      const double        dt = 1e-4, df = 1.0 / (2.0 * static_cast<double>(n - 1) * dt);
      const std::size_t   K  = 40; // the last term kept
      const double        cutoff = (static_cast<double>(K) + 0.5) * df;
      std::vector<double> t(n), v(n), kept(n), noise(n);
      std::mt19937        rng(5);
      std::normal_distribution<double> normal;
      const auto term = [&](std::size_t k, std::size_t i) {
        return std::cos(pi * static_cast<double>(k * i) / static_cast<double>(n - 1));
      };
      for (std::size_t i = 0; i < n; ++i)
        {
          t[i]    = static_cast<double>(i) * dt;
          kept[i] = 2.0 + 1.5 * term(3, i) - 0.7 * term(K, i);
          v[i]    = kept[i] + 0.9 * term(K + 1, i) + 0.3 * term(700, i) + 0.2 * term(n - 1, i);
          noise[i] = normal(rng);
        }
      const auto out   = band_limit(t, v, cutoff);
      double     worst = 0;
      for (std::size_t i = 0; i < n; ++i)
        worst = std::max(worst, std::abs(out[i] - kept[i]));
      EXPECT_LT(worst, 1e-11) << n << " samples";
      const auto once = band_limit(t, noise, cutoff), twice = band_limit(t, once, cutoff);
      double     change = 0, size = 0;
      for (std::size_t i = 0; i < n; ++i)
        {
          change = std::max(change, std::abs(twice[i] - once[i]));
          size   = std::max(size, std::abs(once[i]));
        }
      EXPECT_GT(size, 0.05) << n << " samples";
      EXPECT_LT(change, 1e-11) << n << " samples";
    }
}

// `--harmonics auto`: a loaded run is compared below half the reed's natural
// frequency (its valves flutter near it through most of every cycle); a
// no-flow run, or a number given, keeps the band asked for. The band is
// what the run case records and what it filters: a 7th harmonic (above
// half of 680 Hz at 100 Hz) is gone from a loaded run and kept in a
// no-flow one.
TEST(ForeignData, ALoadedRunIsComparedBelowTheReedsFlutter)
{
  EXPECT_EQ(compared_harmonics(10, 100, 680), 3);
  EXPECT_EQ(compared_harmonics(10, 50, 680), 6);
  EXPECT_EQ(compared_harmonics(10, 20, 680), 10); // the reed is far above the 10th harmonic
  EXPECT_EQ(compared_harmonics(10, 500, 680), 1); // at least the fundamental
  EXPECT_EQ(compared_harmonics(10, 100, 0), 10);  // no reed limit given
  EXPECT_EQ(compared_harmonics(0, 100, 680), 0);  // every sample, as asked

  // the reed frequency the band is limited with: the case's reed, loaded and auto only
  system::SystemParameters p; // the reference values: k_r 6650 N/m, m_r 0.3643 g
  DiagnoseOptions          o;
  EXPECT_NEAR(band_reed_frequency_Hz(p, system::Scenario::loaded, o), 680.0, 1.0);
  EXPECT_EQ(band_reed_frequency_Hz(p, system::Scenario::no_flow, o), 0.0);
  o.harmonics_auto = false;
  EXPECT_EQ(band_reed_frequency_Hz(p, system::Scenario::loaded, o), 0.0);

  const double f   = 100;
  auto         low = [&](double t) { return 3e6 + 1e5 * std::cos(2 * pi * f * t); };
  auto run = record(f, 16, [&](double t) { return low(t) + 5e4 * std::cos(2 * pi * 7 * f * t); });
  const auto loaded  = make_run_case(run, system::Scenario::loaded, 0, 0.75, false, 10, 680);
  const auto no_flow = make_run_case(run, system::Scenario::no_flow, 0, 0.75, false, 10, 0);
  EXPECT_EQ(loaded.harmonics, 3);
  EXPECT_NEAR(loaded.band_Hz, 350, 1e-6); // f estimated from the drive
  EXPECT_EQ(no_flow.harmonics, 10);
  EXPECT_NEAR(no_flow.band_Hz, 1050, 1e-6);
  double seventh_loaded = 0, seventh_no_flow = 0;
  const auto &pl = loaded.run.signal("outlet_pressure_Pa"), &pn = no_flow.run.signal("outlet_pressure_Pa");
  for (std::size_t i = pl.size() / 4; i < 3 * pl.size() / 4; ++i)
    {
      seventh_loaded  = std::max(seventh_loaded, std::abs(pl[i] - low(run.time_s[i])));
      seventh_no_flow = std::max(seventh_no_flow, std::abs(pn[i] - low(run.time_s[i])));
    }
  EXPECT_LT(seventh_loaded, 500);    // the 5e4 Pa 7th harmonic filtered out (to 1 %)
  EXPECT_GT(seventh_no_flow, 4.9e4); // and kept in the no-flow run
}

// A run's cleaned drive (a Fourier fit and a cosine transform of the
// record's length, a tenth of a run) is made once, by make_run_case: a run
// from it is the run made from the record, bit for bit; a drive shaken by
// extra noise is still made from the record.
TEST(ForeignData, ARunsCleanedDriveIsMadeOnceAndGivesTheSameRun)
{
  const double f   = 100;
  auto         run = record(f, 6, [&](double t) { return 3e6 + 1e5 * std::cos(2 * pi * f * t); });
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (double &x : run.signals["current_A"])
    x += noise(rng);
  const auto rc = make_run_case(run, system::Scenario::no_flow, f, 0.75, false, 0, 0);
  ASSERT_TRUE(rc.drive);
  const auto fresh = measured_drive(rc.run, f);
  for (double t : {0.0, 1.3e-3, 0.017, 0.0599})
    EXPECT_EQ(rc.drive->value(t), fresh.value(t)) << t;

  const auto p   = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  const auto map = system::load_valve_maps(p);
  auto       so  = rc.simulation(1e-6);
  const auto cached = simulate_run(p, map, rc.run, rc.setup, so);
  so.drive.reset();
  const auto made = simulate_run(p, map, rc.run, rc.setup, so);
  ASSERT_EQ(cached.size(), made.size());
  for (const auto &[name, values] : made)
    EXPECT_EQ(cached.at(name), values) << name;
  so.drive          = rc.drive;
  so.drive_noise_sd = 0.05;
  so.seed           = 7;
  EXPECT_NE(simulate_run(p, map, rc.run, rc.setup, so).at("outlet_pressure_Pa"), made.at("outlet_pressure_Pa"));
}

// A loaded run's baseline reed has its second mode (a real reed's shows when
// it is off its seat most of the time); a no-flow run's keeps the case's.
TEST(ForeignData, TheBaselineReedHasItsSecondMode)
{
  system::SystemParameters p; // reference reed: 680 Hz, no second mode
  const double             f1 = p.reed.natural_frequency_Hz();
  const double             beam = std::pow(4.6941 / 1.8751, 2); // uniform cantilever f2 / f1
  EXPECT_NEAR(baseline_second_mode(p, system::Scenario::loaded, "auto").frequency_Hz, beam * f1, 1e-9 * f1);
  EXPECT_NEAR(beam, 6.267, 1e-3);
  EXPECT_EQ(baseline_second_mode(p, system::Scenario::loaded, "auto").text().rfind("4261 Hz, a uniform cantilever's", 0), 0u);
  EXPECT_NEAR(baseline_second_mode(p, system::Scenario::no_flow, "auto").frequency_Hz, beam * f1, 1e-9 * f1);
  EXPECT_EQ(baseline_second_mode(p, system::Scenario::loaded, "case").frequency_Hz, 0.0);
  EXPECT_EQ(baseline_second_mode(p, system::Scenario::no_flow, "case").text().rfind("none:", 0), 0u);
  EXPECT_EQ(baseline_second_mode(p, system::Scenario::no_flow, "5000").frequency_Hz, 5000.0);
  p.reed.second_mode_frequency_Hz = 3900; // the case's own wins over the beam's
  EXPECT_EQ(baseline_second_mode(p, system::Scenario::loaded, "auto").frequency_Hz, 3900.0);
  EXPECT_EQ(baseline_second_mode(p, system::Scenario::no_flow, "auto").frequency_Hz, 3900.0);
  for (const char *bad : {"600", "-1", "nan", "inf", "", "4e3x", "off"})
    {
      try
        {
          baseline_second_mode(p, system::Scenario::loaded, bad);
          ADD_FAILURE() << "accepted '" << bad << "'";
        }
      catch (const InputError &e)
        {
          EXPECT_NE(std::string(e.what()).find("--reed-second-mode"), std::string::npos) << e.what();
        }
    }
}

// A baseline parameter fitted at its bound is written to the new case file
// inside its own [uncertain] range (the log scale's power rounded 6e-5 to
// 6.000000000000001e-5 once, and the new case file then refused itself).
TEST(ForeignData, AFitAtItsBoundStaysInsideItsRange)
{
  for (const auto &[lo, hi] : {std::pair{5e-6, 6e-5}, std::pair{3e-3, 7e-3}, std::pair{0.005, 0.3}, std::pair{6e-5, 2.5e-4}})
    {
      const system::UncertainParameter q{"accumulator", "gas_volume_m3", lo, hi};
      for (double u : {0.0, 1.0, -0.5, 1.5, 1.0 - 1e-16})
        {
          const double v = uncertain_from_unit(q, u);
          EXPECT_GE(v, lo) << u;
          EXPECT_LE(v, hi) << u;
        }
      EXPECT_EQ(uncertain_from_unit(q, 1.0), hi);
      EXPECT_EQ(uncertain_from_unit(q, 0.0), lo);
    }
  // one the case leaves out (0, the outlet passage's inertance): position
  // 0 is off, as the case has it, and every other position inside its
  // range; 0 and anything at or below the range map back to 0
  system::UncertainParameter passage{"lines", "outlet_inertance_Pa_s2_per_m3", 1e4, 5e6};
  passage.off_at_zero = true;
  EXPECT_EQ(uncertain_from_unit(passage, 0.0), 0.0);
  EXPECT_EQ(uncertain_from_unit(passage, -0.5), 0.0);
  EXPECT_GE(uncertain_from_unit(passage, 1e-9), 1e4);
  EXPECT_EQ(uncertain_from_unit(passage, 1.0), 5e6);
  EXPECT_EQ(uncertain_to_unit(passage, 0.0), 0.0);
  EXPECT_EQ(uncertain_to_unit(passage, 1e4), 0.0);
  EXPECT_NEAR(uncertain_to_unit(passage, std::sqrt(1e4 * 5e6)), 0.5, 1e-12);
  // in the reference case the passage (its value 0) is such a one, the bore is not
  const auto reference_passage =
    system::SystemParameters::from_case(CaseFile::load(reference_case_path())).uncertain;
  EXPECT_TRUE(std::any_of(reference_passage.begin(), reference_passage.end(), [](const auto &q) {
    return q.name() == "lines.outlet_inertance_Pa_s2_per_m3" && q.off_at_zero;
  }));
  EXPECT_FALSE(std::any_of(reference_passage.begin(), reference_passage.end(), [](const auto &q) {
    return q.name() == "lines.diameter_m" && q.off_at_zero;
  }));
  for (const bool log_scale : {true, false})
    {
      EffectParameter e;
      e.lower = 5e-6, e.upper = 6e-5, e.log_scale = log_scale;
      EXPECT_LE(e.from_unit(1.0), e.upper);
      EXPECT_GE(e.from_unit(0.0), e.lower);
    }
}

// Coloured noise (AR(1), correlation 0.9 from sample to sample) is nearly
// invisible in second differences; the scatter from cycle to cycle sees it,
// and does not count a build-up that has not settled.
TEST(ForeignData, CycleScatterMeasuresColouredNoiseAndIgnoresABuildUp)
{
  std::mt19937_64                  rng(3);
  const double                     sd = 2e4, rho = 0.9;
  std::normal_distribution<double> g(0.0, sd * std::sqrt(1 - rho * rho));
  double                           ar = 0;
  const double                     f  = 100;
  auto run = record(f, 32, [&](double t) {
    ar = rho * ar + g(rng);
    return 5e6 + 2e6 * (1 - std::exp(-t / 0.1)) + 1e6 * std::cos(2 * pi * f * t) + ar;
  });
  const double scatter = cycle_scatter(run.time_s, run.signal("outlet_pressure_Pa"), f);
  const double white   = white_noise_sd(run.signal("outlet_pressure_Pa"));
  EXPECT_NEAR(scatter, sd, 0.1 * sd);
  EXPECT_LT(white, 0.5 * sd); // why the cycle scatter is needed
  // no noise: the build-up alone. Over the second half (0.16-0.32 s) its
  // tail falls by 0.4 MPa; a quadratic per phase leaves about 2.6 kPa of it
  // (0.13 % of the 2 MPa build-up), well below the noise: a straight line
  // would leave 15 kPa
  auto smooth = record(f, 32, [&](double t) { return 5e6 + 2e6 * (1 - std::exp(-t / 0.1)) + 1e6 * std::cos(2 * pi * f * t); });
  EXPECT_LT(cycle_scatter(smooth.time_s, smooth.signal("outlet_pressure_Pa"), f), 0.15 * sd);
}

// [uncertain] in the case: each entry names a real parameter and bounds
// around the case's own value; anything else is refused, naming the key.
TEST(ForeignData, UncertainTableIsCheckedWhereItIsRead)
{
  // the reference case declares eight: four of the rig, the outlet
  // passage's inertance, the piston friction's shape last
  const auto p = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  ASSERT_EQ(p.uncertain.size(), 8u);
  EXPECT_EQ(p.uncertain[0].name(), "lines.diameter_m");
  EXPECT_DOUBLE_EQ(p.real_value("lines", "diameter_m"), 4.572e-3);
  // the fifth, the outlet passage's inertance, at 0 (the thesis's model
  // has none) below its range: a value the case leaves out is the one
  // allowed outside
  const auto &q = p;
  EXPECT_EQ(q.uncertain[4].name(), "lines.outlet_inertance_Pa_s2_per_m3");
  EXPECT_EQ(q.real_value("lines", "outlet_inertance_Pa_s2_per_m3"), 0.0);
  EXPECT_GT(q.uncertain[4].lower, 0.0);
  EXPECT_TRUE(q.uncertain[4].off_at_zero);
  const auto refused = [&](const std::string &entry, const std::string &words) {
    std::string text = reference_text();
    text             = text.substr(0, text.find("[uncertain]")) + "[uncertain]\n" + entry + "\n";
    try
      {
        system::SystemParameters::from_case(
          CaseFile::parse(text, "case.toml", reference_case_path().parent_path()));
        ADD_FAILURE() << entry << " accepted";
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("case.toml"), std::string::npos) << e.what();
      }
  };
  refused("\"lines.diameter\" = [1e-3, 1e-2]", "no real parameter [lines] diameter");
  refused("\"lines.diameter_m\" = [1e-3]", "[lower, upper]");
  refused("\"lines.diameter_m\" = [1e-2, 1e-3]", "[lower, upper]");
  refused("\"lines.diameter_m\" = [5e-3, 1e-2]", "outside");
  refused("\"transducer.piezomagnetic_coefficient_m_per_A\" = [6e-9, 8e-9]", "always fitted");
  refused("diameter_m = [1e-3, 1e-2]", "\"table.key\"");
  // each end inside what the key itself admits, for any key
  refused("\"load.static_friction_ratio\" = [0.5, 3]", "0.5 lies outside what [load] static_friction_ratio admits (in [1, 100])");
  refused("\"load.static_friction_ratio\" = [1, 300]", "300 lies outside");
  refused("\"cylinder.high_side_fraction\" = [0.2, 1]", "1 lies outside what [cylinder] high_side_fraction admits (in (0, 1))");
  refused("\"reed.restitution\" = [0.1, 1.5]", "1.5 lies outside");
}

// The piston friction's shape ([load] friction_velocity_scale_m_per_s,
// static_friction_ratio, stribeck_velocity_m_per_s) does nothing without
// friction, and the Stribeck velocity nothing without a Stribeck rise: a
// diagnosis holds such a key out of its fits until an effect makes it act.
TEST(ForeignData, TheFrictionsShapeActsOnlyWithFriction)
{
  auto p = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  for (const auto &q : p.uncertain)
    {
      const bool shape = q.table == "load";
      EXPECT_EQ(diagnosis::inert_reason(p, q.table, q.key).empty(), !shape) << q.name();
    }
  EXPECT_NE(diagnosis::inert_reason(p, "load", "static_friction_ratio").find("coulomb_friction_N = 0"), std::string::npos);
  p.load.coulomb_friction_N = 20;
  EXPECT_EQ(diagnosis::inert_reason(p, "load", "friction_velocity_scale_m_per_s"), "");
  EXPECT_EQ(diagnosis::inert_reason(p, "load", "static_friction_ratio"), "");
  EXPECT_NE(diagnosis::inert_reason(p, "load", "stribeck_velocity_m_per_s").find("static_friction_ratio = 1"),
            std::string::npos);
  p.load.static_friction_ratio = 1.3;
  EXPECT_EQ(diagnosis::inert_reason(p, "load", "stribeck_velocity_m_per_s"), "");
  EXPECT_EQ(diagnosis::inert_reason(p, "lines", "diameter_m"), "");
}

// [uncertain] names the real keys the parameter tables mark, and no other:
// a table's key by its name, the map's squeeze film and an unknown key
// refused with the case file and the key.
TEST(ForeignData, UncertainNamesTheKeysOfTheParameterTables)
{
  const auto text = read_text(reference_case_path());
  const auto with = [&](const std::string &line) {
    return CaseFile::parse(text + line + "\n", "u.toml", reference_case_path().parent_path());
  };
  const auto p = system::SystemParameters::from_case(with("\"cylinder.seal_compliance_m3_per_Pa\" = [1e-14, 1e-12]"));
  ASSERT_FALSE(p.uncertain.empty());
  EXPECT_EQ(p.uncertain.back().name(), "cylinder.seal_compliance_m3_per_Pa");
  EXPECT_TRUE(p.uncertain.back().off_at_zero);
  auto q = p;
  ASSERT_NE(q.real_field("cylinder", "seal_compliance_m3_per_Pa"), nullptr);
  *q.real_field("cylinder", "seal_compliance_m3_per_Pa") = 3e-13;
  EXPECT_EQ(q.cylinder.seal_compliance_m3_per_Pa, 3e-13);
  EXPECT_EQ(q.to_json()["cylinder"]["seal_compliance_m3_per_Pa"].get<double>(), 3e-13);
  for (const std::string key : {"reed.seat_film_m", "reed.no_such_key_m"})
    try
      {
        system::SystemParameters::from_case(with("\"" + key + "\" = [1e-6, 1e-5]"));
        ADD_FAILURE() << key;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find("u.toml"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("no real parameter [reed] " + key.substr(5)), std::string::npos) << e.what();
      }
}

// Nothing named, but the calibrated baseline took up a seal: a no-flow
// record tells the high side's compliance, the oil column's
// (A_po x high-side share x wetted length / beta) plus the seal's, not the
// split. Where the baseline fit holds it at more than twice the case's,
// the verdict names the effect that would look the same.
TEST(Diagnosis, ABaselineThatTakesUpASealIsReported)
{
  const auto case_p = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  const auto &c     = case_p.cylinder;
  const double oil_per_metre = c.piston_area_m2 * c.high_side_fraction / case_p.fluid.effective_bulk_modulus_Pa();
  auto fitted                 = case_p;
  fitted.cylinder.wetted_length_m = 0.15; // as none's fit of the study's outlet_compliance-3 (case 0.0254)
  const auto a = absorbed_by_baseline(effect_library(), case_p, fitted, 2.0);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].effect, "outlet_compliance");
  EXPECT_EQ(a[0].quantity, "high_side_compliance_m3_per_Pa");
  EXPECT_NEAR(a[0].case_value, oil_per_metre * 0.0254, 1e-12 * a[0].case_value);
  EXPECT_NEAR(a[0].fitted, oil_per_metre * 0.15, 1e-12 * a[0].fitted);
  // the seal that holds as much on the case's column: 0.1246 m of oil
  EXPECT_NEAR(a[0].fitted - a[0].case_value, oil_per_metre * (0.15 - 0.0254), 1e-12 * a[0].fitted);
  // what to measure to tell them apart: the [uncertain] parameters the
  // column's compliance moves with (not the lines' bore or the gas), as fitted
  using Set = std::vector<std::pair<std::string, double>>;
  EXPECT_EQ(a[0].set_by, (Set{{"cylinder.wetted_length_m", 0.15}, {"cylinder.piston_area_m2", c.piston_area_m2}}));
  // within the factor, or softer than the case's column (a seal adds), or
  // no candidate with such a quantity: nothing to say
  fitted.cylinder.wetted_length_m = 0.045;
  EXPECT_TRUE(absorbed_by_baseline(effect_library(), case_p, fitted, 2.0).empty());
  fitted.cylinder.wetted_length_m = 0.005;
  EXPECT_TRUE(absorbed_by_baseline(effect_library(), case_p, fitted, 2.0).empty());
  fitted.cylinder.wetted_length_m = 0.15;
  std::vector<std::shared_ptr<const Effect>> leak_only;
  for (const auto &e : effect_library())
    if (e->name() == "valve_leakage")
      leak_only.push_back(e);
  ASSERT_EQ(leak_only.size(), 1u);
  EXPECT_TRUE(absorbed_by_baseline(leak_only, case_p, fitted, 2.0).empty());
  // the piston's area moves it too
  fitted.cylinder.wetted_length_m = 0.0254;
  fitted.cylinder.piston_area_m2  = 2.5 * c.piston_area_m2;
  EXPECT_EQ(absorbed_by_baseline(effect_library(), case_p, fitted, 2.0).size(), 1u);
}

// A record cut from the middle of a run (cycle 30 of 46, at a third of a
// cycle) is simulated from its own periodic state or its recorded one: with the start from rest
// the model's first cycles are a start-up the record never had. The data
// come from the model itself: this checks the start, not an identification.
TEST(ForeignData, ARecordFromMidOperationStartsFromItsPeriodicState)
{
  const auto dir = scratch("foreign_mid");
  auto       r   = rectify_cli("synth --effect none --noise 0.01 --frequency 100 --cycles 46 --out " +
                       (dir / "full").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // rows from cycle 30 + 1/3 on
  const auto run = MeasuredRun::parse(rows_from(dir / "full" / "data.csv", 30 * 200 + 67), "mid.csv");
  const auto p   = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  const auto map = system::load_valve_maps(p);
  std::vector<RunCase> runs{make_run_case(run, system::Scenario::no_flow, 0, 0.75, true, 10)};
  DiagnoseOptions      options;
  choose_start(p, map, runs, options, 2);
  // from its own periodic state or from the state its first samples show
  // (its high side at the first value or the first cycle's mean), all far
  // closer than from rest
  EXPECT_TRUE(runs[0].start == StartState::periodic || runs[0].start == StartState::record ||
              runs[0].start == StartState::record_mean)
    << runs[0].start_scores.dump();
  EXPECT_GT(runs[0].n_skip, 0u);
  const double rest = runs[0].start_scores["rest"], periodic = runs[0].start_scores["periodic"];
  EXPECT_LT(periodic, 0.1 * rest) << runs[0].start_scores.dump();
  EXPECT_LT(runs[0].start_scores["record"].get<double>(), 0.2 * rest) << runs[0].start_scores.dump();
  // the drive's phase at the record's start: a third of a cycle in
  EXPECT_NEAR(drive_phase_at_start(runs[0].run, 100), 67.0 / 200.0, 0.01);
}


// A record cut from a run from rest during its charge-up (cycle 2 of 24, a
// third of a cycle in) and simulated from the state its first samples show:
// what they do not show (the accumulator's and the low side's oil, the
// reeds' and the lines' motion) is off, and the model carries that error
// for as long as it remembers its start. The settling window is measured
// from the model alone (its runs from this start and from its periodic
// orbit) and must cover the error the record itself shows: past the window
// every cycle's residual is within the noise. The data come from the model
// itself: this checks the window, not an identification.
TEST(ForeignData, TheSettlingWindowCoversWhatTheStartsErrorLeavesInTheRecord)
{
  const auto dir = scratch("foreign_settling");
  auto       r   = rectify_cli("synth --effect none --noise 0.01 --frequency 100 --cycles 24 --out " +
                       (dir / "full").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto run = MeasuredRun::parse(rows_from(dir / "full" / "data.csv", 2 * 200 + 67), "charging.csv");
  const auto p   = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  const auto map = system::load_valve_maps(p);
  std::vector<RunCase> runs{make_run_case(run, system::Scenario::no_flow, 0, 0.75, true, 10)};
  DiagnoseOptions      options;
  options.start = "record";
  choose_start(p, map, runs, options, 2);
  calibrate_noise(p, map, runs, options.relative_tolerance, 2);
  ASSERT_EQ(runs[0].n_skip, 200u); // one cycle until the memory is measured
  settle(p, map, runs, options, 2);
  const auto &rc = runs[0];
  ASSERT_FALSE(rc.start_memory.empty()) << diagnosis::settling_words(rc);
  const std::size_t window = rc.n_skip / 200;
  EXPECT_EQ(rc.n_skip % 200, 0u);
  EXPECT_GE(window, 2u) << diagnosis::settling_words(rc);
  EXPECT_LE(rc.n_skip, rc.n_train / 2);
  EXPECT_LE(rc.start_memory[window], options.settling_tolerance);
  // the record's own residual (the case is the rig), cycle by cycle
  auto       so    = rc.simulation(options.relative_tolerance);
  so.n_samples     = rc.n_train;
  const auto model = simulate_run(p, map, rc.run, rc.setup, so);
  std::vector<double> per_cycle;
  for (std::size_t c = 0; c + 1 <= rc.n_train / 200; ++c)
    {
      const auto q = squared_residual(rc.run, model, rc.scales, 200 * c, 200 * (c + 1));
      per_cycle.push_back(std::sqrt(q.sum / static_cast<double>(q.n)));
    }
  std::string seen;
  for (double v : per_cycle)
    seen += format_number(v) + " ";
  // the start's error is there in the first cycle, and past the window the
  // record is the model's within the noise
  EXPECT_GT(per_cycle.front(), 2.0) << seen;
  for (std::size_t c = window; c < per_cycle.size(); ++c)
    EXPECT_LT(per_cycle[c], 1.5) << "cycle " << c << ": " << seen << "; " << diagnosis::settling_words(rc);
  std::cout << "per cycle: " << seen << "\nmemory: " << diagnosis::settling_words(rc) << "\n";
}

// A rig whose oil column is 2.4x the case's (a baseline gap, not an effect),
// diagnosed with the reference case (which declares an outlet passage; the
// rig has none, nothing is named: it stays off): the calibration finds it (only the product of the cylinder's area and oil
// column is determined in a no-flow run: one of the two is held) and the
// verdict is "no missing effect" where the uncalibrated model was far off.
TEST(ForeignData, AnUncertainBaselineIsCalibratedNotMistakenForAnEffect)
{
  const auto dir = scratch("foreign_baseline");
  const auto data = long_oil_column_record(dir);
  ASSERT_FALSE(data.empty());
  // the reference case declares the outlet passage; the rig has none,
  // nothing is named, so the passage stays off
  const auto s = diagnose_summary(data,
                                  "--effects valve_leakage outlet_compliance entrained_air --reed-second-mode case",
                                  dir / "d");
  ASSERT_FALSE(s.is_null());
  EXPECT_EQ(s["effect"], "none") << s["decision"];
  EXPECT_EQ(s["verdict"], "no missing effect") << s["verdict_sentence"];
  const double volume = s["baseline"]["cylinder.wetted_length_m"].get<double>() *
                        s["baseline"]["cylinder.piston_area_m2"].get<double>();
  EXPECT_NEAR(volume, 0.061 * 1.29032e-4, 0.05 * 0.061 * 1.29032e-4);
  EXPECT_GT(s["residual_before"]["overall"].get<double>(), 10.0); // the case's own baseline was far off
  int  held        = 0; // of those in the model: the passage, left off, is listed as not identifiable too
  bool passage_off = false;
  for (const auto &b : s["baseline_fit"])
    {
      held += b["identifiable"].get<bool>() || b["fitted"].get<double>() == 0.0 ? 0 : 1;
      if (b["parameter"] == "lines.outlet_inertance_Pa_s2_per_m3")
        passage_off = b["fitted"].get<double>() == 0.0 &&
                      b["note"].get<std::string>().find("left out until an effect is named") != std::string::npos;
    }
  EXPECT_GE(held, 1);
  EXPECT_TRUE(passage_off) << s["baseline_fit"].dump(1);
  EXPECT_TRUE(s["left_out_tried_at_the_named_fit"].empty()); // nothing named: not tried at all
  EXPECT_EQ(s["baseline"]["lines.outlet_inertance_Pa_s2_per_m3"].get<double>(), 0.0);
}

// A rig with more oil on the high side (a 0.061 m column) than the case's
// declared ranges allow (column at most 0.04 m, area at most 1.4e-4 m^2):
// the baseline fit pins the column at the top of its range, and the report
// says so for it and for nothing that lies inside its range.
TEST(ForeignData, ABaselineParameterFittedAtTheEndOfItsRangeIsReportedSo)
{
  const auto dir  = scratch("foreign_bound");
  const auto data = long_oil_column_record(dir);
  ASSERT_FALSE(data.empty());
  std::filesystem::create_directories(dir / "case");
  const auto narrow = write_rig(dir / "case", {{"\"cylinder.wetted_length_m\" = [0.005, 0.3]",
                                                "\"cylinder.wetted_length_m\" = [0.005, 0.04]"},
                                               {"\"cylinder.piston_area_m2\" = [0.6e-4, 2.5e-4]",
                                                "\"cylinder.piston_area_m2\" = [1.2e-4, 1.4e-4]"}});
  const auto s = diagnose_summary(data,
                                  "--case " + narrow.string() + " --effects outlet_compliance --reed-second-mode case",
                                  dir / "d");
  ASSERT_FALSE(s.is_null());
  bool column = false;
  for (const auto &b : s["baseline_fit"])
    {
      const double v = b["fitted"].get<double>(), lo = b["bounds"][0].get<double>(), hi = b["bounds"][1].get<double>();
      const auto   note = b["note"].get<std::string>();
      if (v == 0.0) // one the case leaves out (the outlet passage), off: not fitted, at no end
        {
          EXPECT_NE(note.find("off, as the case has it"), std::string::npos) << b.dump();
          EXPECT_EQ(note.find("end of its range"), std::string::npos) << b.dump();
          continue;
        }
      if (note.find("freed with a named effect that makes it act") != std::string::npos)
        { // one that does nothing in this model (the friction's shape without friction): held at the case's value, not fitted
          EXPECT_EQ(note.find("end of its range"), std::string::npos) << b.dump();
          EXPECT_EQ(v, b["case_value"].get<double>()) << b.dump();
          continue;
        }
      // its position in the range as the fit sees it: the gain linear, the
      // [uncertain] parameters logarithmic; the ends' last 1e-3 count
      const double unit   = b["parameter"] == "force_gain" ? (v - lo) / (hi - lo) : std::log(v / lo) / std::log(hi / lo);
      const bool   at_end = unit >= 1 - 1e-3 || unit <= 1e-3;
      EXPECT_EQ(note.find("end of its range") != std::string::npos, at_end) << b.dump();
      if (b["parameter"] == "cylinder.wetted_length_m")
        {
          column = true;
          EXPECT_DOUBLE_EQ(v, 0.04) << b.dump();
          EXPECT_NE(note.find("at the upper end of its range"), std::string::npos) << b.dump();
        }
    }
  EXPECT_TRUE(column) << s["baseline_fit"].dump(1);
  // within 10 harmonics of 100 Hz (to 1050 Hz) at 200 samples per cycle (a
  // Nyquist band of 10 kHz): the standard error per independent value is
  // sqrt(10000 / 1050) times the one printed
  EXPECT_NEAR(s["baseline_standard_error_factor"].get<double>(), std::sqrt(10000.0 / 1050.0), 1e-3)
    << s["localisation"][0]["band_Hz"];
}

// A strong leak on a rig whose accumulator holds 3.0e-5 m^3 of gas, not the
// case's 1.64e-5 (and whose lines' bore is 5.6 mm, not 4.57): the baseline
// fit without the leak is hundreds of noise units off, which inflates every
// standard error, and holds at least one [uncertain] parameter at the
// case's value. Judged again at the leak's fit, a held parameter the data
// now determine is freed for the refits and lands on the rig's value within
// its standard error. Which one that is depends on the far-off baseline
// fit's details (with the solver's tolerance weights of 2026-11-24 the
// cylinder's area, held for its -0.997 correlation with the oil column;
// before, the gas volume, whose standard error of range went from 0.21 to
// 0.14 against the limit 0.15): the test asserts the mechanism.
TEST(ForeignData, ABaselineParameterHeldWithoutTheEffectIsFreedWhereTheEffectsFitDeterminesIt)
{
  const auto dir = scratch("foreign_freed");
  const auto rig_case = write_rig(dir, {{"diameter_m = 4.572e-3", "diameter_m = 5.6e-3"},
                                        {"gas_volume_m3 = 1.6387e-5", "gas_volume_m3 = 3.0e-5"}});
  auto r = rectify_cli("synth --case " + rig_case.string() +
                       " --effect valve_leakage --param leak_resistance_Pa_s_per_m3=1e11 --noise 0.01 --seed 7 "
                       "--frequency 150 --cycles 12 --out " + (dir / "data").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto s = diagnose_summary(dir / "data" / "data.csv", "--effects valve_leakage --reed-second-mode case",
                                  dir / "d");
  ASSERT_FALSE(s.is_null());
  ASSERT_EQ(s["effect"], "valve_leakage") << s["decision"];
  const std::map<std::string, double> rig{{"accumulator.gas_volume_m3", 3.0e-5},
                                          {"cylinder.piston_area_m2", 1.29032e-4},
                                          {"cylinder.wetted_length_m", 0.0254},
                                          {"lines.diameter_m", 5.6e-3}};
  std::map<std::string, std::array<double, 2>> held; // parameter -> bounds
  for (const auto &b : s["baseline_fit"])
    if (!b["identifiable"].get<bool>() && b["parameter"] != "force_gain")
      held[b["parameter"].get<std::string>()] = {b["bounds"][0].get<double>(), b["bounds"][1].get<double>()};
  ASSERT_GE(held.size(), 1u) << s["baseline_fit"].dump(1);
  ASSERT_GE(s["freed_at_the_named_fit"].size(), 1u) << s["freed_at_the_named_fit"].dump(1);
  for (const auto &f : s["freed_at_the_named_fit"])
    {
      const auto name = f["parameter"].get<std::string>();
      ASSERT_TRUE(held.count(name)) << name << " was not held";
      ASSERT_TRUE(rig.count(name)) << name;
      const double sd = f["standard_error_of_range"].get<double>() * (held[name][1] - held[name][0]);
      EXPECT_LT(f["standard_error_of_range"].get<double>(), 0.15) << name;
      EXPECT_NEAR(s["baseline"][name].get<double>(), rig.at(name), 3 * sd) << name;
    }
  EXPECT_NEAR(s["baseline"]["lines.diameter_m"].get<double>(), 5.6e-3, 0.03 * 5.6e-3);
  EXPECT_NEAR(s["parameters"]["leak_resistance_Pa_s_per_m3"].get<double>(), 1e11, 0.03 * 1e11);
  // determined, and its reported standard error (from its profile) covers the rig's value
  const auto &u = s["parameter_uncertainty"][0];
  EXPECT_TRUE(u["determined"].get<bool>()) << u.dump(1);
  EXPECT_LT(std::abs(std::log(u["value"].get<double>() / 1e11)), 3 * u["relative_standard_error"].get<double>())
    << u.dump(1);
  EXPECT_LT(s["residual_after"]["overall"].get<double>(), 1.5);
}

// The covariance against closed forms: two parameters with one column of
// information each, J = [a, a] (only their sum is seen), s2 and a uniform
// prior (precision 12) on both. With A = a.a / s2 the information is
// [[A + 12, A], [A, A + 12]]: each one's variance (A + 12) / (24 A + 144)
// stays near the prior's half (1/24) however many data there are, their
// sum's is 1 / (A + 6), and one given the other is 1 / (A + 12).
TEST(Uncertainty, ACollinearPairDeterminesItsSumNotItsSplit)
{
  std::mt19937                     rng(5);
  std::normal_distribution<double> normal;
  for (const int n : {3, 50, 2000})
    {
      Eigen::VectorXd a(n);
      for (int i = 0; i < n; ++i)
        a(i) = normal(rng);
      const double    s2 = 0.37;
      Eigen::MatrixXd J(n, 2);
      J << a, a;
      const Eigen::MatrixXd F = fit_information(J, s2, Eigen::Vector2d::Constant(uniform_prior_precision));
      const Eigen::MatrixXd C = covariance(F);
      const double          A = a.squaredNorm() / s2;
      EXPECT_NEAR(C(0, 0), (A + 12) / (24 * A + 144), 1e-12 * C(0, 0)) << n;
      EXPECT_NEAR(C(1, 1), C(0, 0), 1e-12 * C(0, 0)) << n;
      EXPECT_NEAR(C(0, 1), -A / (24 * A + 144), 1e-12 * C(0, 0)) << n;
      EXPECT_NEAR(propagated_variance(C, Eigen::Vector2d(1, 1)), 1 / (A + 6), 1e-9 / (A + 6)) << n;
      EXPECT_NEAR(covariance(F.topLeftCorner(1, 1))(0, 0), 1 / (A + 12), 1e-12 / (A + 12)) << n;
    }
  // independent columns, no prior: the textbook s2 (J^T J)^-1
  Eigen::MatrixXd J(3, 2);
  J << 1, 0, 0, 2, 0, 0;
  const Eigen::MatrixXd C = covariance(fit_information(J, 2.0, Eigen::Vector2d::Zero()));
  EXPECT_NEAR(C(0, 0), 2.0, 1e-12);
  EXPECT_NEAR(C(1, 1), 0.5, 1e-12);
  EXPECT_NEAR(C(0, 1), 0.0, 1e-12);
  // no data and no prior in a direction: infinite variance there only
  J << 1, 0, 1, 0, 1, 0;
  const Eigen::MatrixXd D = covariance(fit_information(J, 1.0, Eigen::Vector2d::Zero()));
  EXPECT_NEAR(D(0, 0), 1.0 / 3.0, 1e-12);
  EXPECT_TRUE(std::isinf(D(1, 1)));
  EXPECT_THROW(fit_information(J, 0.0, Eigen::Vector2d::Zero()), std::invalid_argument);
  EXPECT_THROW(fit_information(J, 1.0, Eigen::Vector3d::Zero()), std::invalid_argument);
}

// A soft seal beside an oil column of uncertain length (the study's
// outlet_compliance-1): the two compliances add, so a record tells their
// sum and not the split. Rig: oil column 0.1 m (the case says 0.0254), seal
// 8e-14 m^3/Pa, more than the longest oil column of the case's range could
// hold, so the baseline alone cannot explain it. The report must say the
// seal is not determined, that it trades with the oil column, and give the
// high side's compliance, determined, at the rig's; then hold the column at
// the case's value and report the seal there, with its span over the
// column's declared range.
TEST(ForeignData, ASealTradedAgainstTheOilColumnIsReportedAsUndeterminedWithTheirSum)
{
  const auto   dir  = scratch("foreign_seal_split");
  const auto   rig_case = write_rig(dir, {{"wetted_length_m = 0.0254", "wetted_length_m = 0.1"}});
  const double seal     = 8e-14;
  auto r = rectify_cli("synth --case " + rig_case.string() +
                       " --effect outlet_compliance --param seal_compliance_m3_per_Pa=8e-14 --noise 0.01 --seed 11 "
                       "--frequency 150 --cycles 12 --out " + (dir / "data").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto s = diagnose_summary(dir / "data" / "data.csv", "--effects outlet_compliance --reed-second-mode case",
                                  dir / "d");
  ASSERT_FALSE(s.is_null());
  ASSERT_EQ(s["effect"], "outlet_compliance") << s["decision"];
  // the rig's high side: the oil column (area x high-side share x length /
  // bulk modulus, the case's numbers) and the seal
  const double oil  = 1.29032e-4 * 0.5 * 0.1 / 586.054e6;
  const double rig  = oil + seal;
  const auto  &p    = s["parameter_uncertainty"];
  ASSERT_EQ(p.size(), 1u) << s.dump(1);
  EXPECT_FALSE(p[0]["determined"].get<bool>()) << p.dump(1);
  EXPECT_EQ(p[0]["most_correlated_with"], "cylinder.wetted_length_m") << p.dump(1);
  EXPECT_LT(p[0]["correlation"].get<double>(), -0.5) << p.dump(1);
  // known, the baseline would pin it: the trade is what makes it uncertain
  EXPECT_LT(p[0]["local_relative_standard_error_given_baseline"].get<double>(), 0.05) << p.dump(1);
  // its profile: 20 % lower with a longer oil column fits as well, within
  // the naming's evidence (higher needs a column shorter than the case's
  // range allows). It is taken at the held column (below), where the lower
  // side's evidence is about 5: its standard error then reads 9 %, at the
  // fit's own split it read "more than 20 %"; either way not determined
  const auto &profile = p[0]["profile"];
  EXPECT_FALSE(profile["determined"].get<bool>()) << profile.dump(1);
  EXPECT_LT(profile["evidence_against"][0].get<double>(), 10.0) << profile.dump(1);
  EXPECT_NEAR(profile["values"][0].get<double>(), p[0]["value"].get<double>() * std::exp(-0.2),
              1e-6 * p[0]["value"].get<double>());
  const auto &c = s["combined"];
  ASSERT_TRUE(c.is_object()) << s.dump(1);
  EXPECT_EQ(c["quantity"], "high_side_compliance_m3_per_Pa");
  EXPECT_TRUE(c["determined"].get<bool>()) << c.dump(1);
  EXPECT_LT(c["relative_standard_error"].get<double>(), 0.05) << c.dump(1);
  EXPECT_NEAR(c["value"].get<double>(), rig, 0.05 * rig) << c.dump(1);
  EXPECT_NE(s["uncertainty_sentence"].get<std::string>().find("not determined"), std::string::npos);
  // held, not traded: the oil column at the case's 0.0254 m and the seal
  // refitted, which in the diagnosis model's own record fits as well; the
  // seal is then the rig's high side less the case's column, and over the
  // column's declared range (0.005-0.3 m) the rig's less that column's oil
  const auto  oil_at = [](double l) { return 1.29032e-4 * 0.5 * l / 586.054e6; };
  const auto &h      = s["held_partner"];
  ASSERT_TRUE(h.is_object()) << s.dump(1);
  EXPECT_EQ(h["parameter"], "cylinder.wetted_length_m");
  EXPECT_DOUBLE_EQ(h["case_value"].get<double>(), 0.0254);
  EXPECT_TRUE(h["kept"].get<bool>()) << h.dump(1);
  EXPECT_LT(h["evidence"].get<double>(), 10.0) << h.dump(1);
  const double held = rig - oil_at(0.0254);
  EXPECT_NEAR(s["parameters"]["seal_compliance_m3_per_Pa"].get<double>(), held, 0.05 * held) << h.dump(1);
  EXPECT_DOUBLE_EQ(h["held_value"].get<double>(), s["parameters"]["seal_compliance_m3_per_Pa"].get<double>());
  const auto &range = h["effect_over_its_range"];
  ASSERT_TRUE(range[0].is_number() && range[1].is_number()) << h.dump(1);
  EXPECT_NEAR(range[0].get<double>(), rig - oil_at(0.3), 0.05 * (rig - oil_at(0.3))) << h.dump(1);
  EXPECT_NEAR(range[1].get<double>(), rig - oil_at(0.005), 0.05 * (rig - oil_at(0.005))) << h.dump(1);
  // the split the fit had found is kept in the report beside it
  EXPECT_TRUE(h["split"]["cylinder.wetted_length_m"].is_number()) << h.dump(1);
  EXPECT_NE(s["uncertainty_sentence"].get<std::string>().find("held at the case's"), std::string::npos);
}

// When the library has nothing that fits (a hidden leak, candidates that
// cannot make one), the verdict says so and says where the gap is, instead
// of "explains".
TEST(ForeignData, TheVerdictSaysBeyondTheLibraryWhenNothingFits)
{
  const auto dir = scratch("foreign_beyond");
  auto       r   = rectify_cli("synth --effect valve_leakage --param leak_resistance_Pa_s_per_m3=3e11 --noise 0.01 "
                               "--seed 9 --frequency 100 --cycles 8 --out " + (dir / "data").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto s =
    diagnose_summary(dir / "data" / "data.csv", "--effects orifice_flow reed_second_mode --reed-second-mode case", dir / "d");
  ASSERT_FALSE(s.is_null());
  EXPECT_EQ(s["effect"], "none") << s["decision"];
  EXPECT_EQ(s["verdict"], "beyond the library") << s["verdict_sentence"];
  EXPECT_NE(s["verdict_sentence"].get<std::string>().find("noise units remain"), std::string::npos);
  // and where: the signal with the most noise units left, with how many.
  // A leak drains the blocked high side, which a model without one holds
  // up: the outlet pressure, the model above the data (in noise units
  // about 700 there against 300 in the chamber; until the forty-sixth stop
  // the sentence named the first signal above 3 % of its swing, the
  // chamber's)
  std::string most;
  for (const auto &[name, v] : s["residual_after"].items())
    if (name != "overall" && (most.empty() || v.get<double>() > s["residual_after"][most].get<double>()))
      most = name;
  EXPECT_EQ(most, "outlet_pressure_Pa") << s["residual_after"].dump();
  char said[96];
  std::snprintf(said, sizeof said, "Largest remaining residual: outlet pressure, %.3g noise units: ",
                s["residual_after"][most].get<double>());
  const auto sentence = s["verdict_sentence"].get<std::string>();
  EXPECT_NE(sentence.find(said), std::string::npos) << sentence;
  EXPECT_NE(sentence.find("model above the data"), std::string::npos) << sentence;
  const auto &largest = s["largest_residual_after"];
  EXPECT_EQ(largest["signal"], most) << largest.dump();
  EXPECT_DOUBLE_EQ(largest["noise_units"].get<double>(), s["residual_after"][most].get<double>());
  EXPECT_NE(sentence.find(largest["description"].get<std::string>()), std::string::npos) << largest.dump();
  // the report lists every signal after the fit, the most first
  std::ifstream     in(dir / "d" / "report.md");
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // the verdict once, then why (not "beyond the library. beyond the library: ...")
  EXPECT_NE(report.find("**Verdict: beyond the library.** no effect of the library earns its parameters"),
            std::string::npos)
    << report.substr(0, 2000);
  const auto        after = report.find("## Where the final model still disagrees (after)");
  ASSERT_NE(after, std::string::npos) << report;
  const auto first = report.find("\n- ", after);
  ASSERT_NE(first, std::string::npos) << report.substr(after);
  EXPECT_EQ(report.compare(first + 3, largest["description"].get<std::string>().size(),
                           largest["description"].get<std::string>()),
            0)
    << report.substr(after);
  std::size_t listed = 0;
  for (auto at = first; at != std::string::npos && at < report.find("New case file", after);
       at = report.find("\n- ", at + 1))
    ++listed;
  EXPECT_EQ(listed, s["residual_after"].size() - 1) << report.substr(after); // every signal, not "overall"
  // and before any fit, the case's model as given, in the same units and
  // order (until the forty-eighth stop: the signals above 3 % of their
  // swing, alphabetically)
  std::string most_before;
  for (const auto &[name, v] : s["residual_before"].items())
    if (name != "overall" &&
        (most_before.empty() || v.get<double>() > s["residual_before"][most_before].get<double>()))
      most_before = name;
  const auto &largest_before = s["largest_residual_before"];
  EXPECT_EQ(largest_before["signal"], most_before) << largest_before.dump();
  EXPECT_DOUBLE_EQ(largest_before["noise_units"].get<double>(), s["residual_before"][most_before].get<double>());
  const auto before = report.find("## Where the model disagrees with the data (before)");
  ASSERT_NE(before, std::string::npos) << report;
  const auto end_before = report.find("\n## ", before + 1);
  const auto first_before = report.find("\n- ", before);
  ASSERT_LT(first_before, end_before) << report.substr(before);
  EXPECT_EQ(report.compare(first_before + 3, largest_before["description"].get<std::string>().size(),
                           largest_before["description"].get<std::string>()),
            0)
    << report.substr(before, end_before - before);
  std::vector<double> units; // each listed signal's noise units, as the line gives them
  for (auto at = first_before; at < end_before; at = report.find("\n- ", at + 1))
    {
      const auto comma = report.find(", ", at);
      units.push_back(std::stod(report.substr(comma + 2)));
    }
  EXPECT_EQ(units.size(), s["residual_before"].size() - 1) << report.substr(before, end_before - before);
  EXPECT_TRUE(std::is_sorted(units.rbegin(), units.rend())) << report.substr(before, end_before - before);
  // summary.json gives both lists per run, as the report does (one run here)
  ASSERT_EQ(s["localisation"].size(), 1u);
  const auto &run = s["localisation"][0];
  for (const char *which : {"before_in_noise_units", "after_in_noise_units"})
    {
      const auto &list = run[which];
      const auto &all  = s[std::string(which) == "before_in_noise_units" ? "residual_before" : "residual_after"];
      const auto &top  = std::string(which) == "before_in_noise_units" ? largest_before : largest;
      ASSERT_EQ(list.size(), all.size() - 1) << which << ": " << list.dump(1);
      EXPECT_EQ(list[0]["signal"], top["signal"]) << which;
      EXPECT_EQ(list[0]["description"], top["description"]) << which;
      for (std::size_t k = 0; k < list.size(); ++k)
        {
          const auto name = list[k]["signal"].get<std::string>();
          EXPECT_DOUBLE_EQ(list[k]["noise_units"].get<double>(), all[name].get<double>()) << which << " " << name;
          if (k > 0)
            {
              EXPECT_GE(list[k - 1]["noise_units"].get<double>(), list[k]["noise_units"].get<double>()) << which;
            }
        }
    }
}

// The state a record shows at its first sample (--start record): pressures
// and rod as measured, the chamber's oil column in its static balance, the
// accumulator and low side where the oil conserved since rest puts them.
// Against the model's own state 30 cycles into a run with a soft seal (the
// high side then holds 100x the thesis's oil): the oil the estimate gives
// the accumulator and low side is what they hold.
TEST(ForeignData, TheRecordedStateIsWhatWasMeasuredAndConservesTheOil)
{
  namespace s = rectify::system::state;
  auto p      = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  p.cylinder.seal_compliance_m3_per_Pa = 3e-13;
  const auto   map   = system::load_valve_maps(p);
  const double f     = 100;
  const auto   drive = system::Drive::sine(f, 20, 10);
  system::Model model(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const double  t1 = 30.0 / f; // the drive's minimum: the outlet valve shut
  const auto    y  = state_at(model, p, t1);
  ASSERT_TRUE(model.closed(0));
  const double  rod = p.transducer.rod_length_m;
  const auto    r   = recorded_at(model, p, y);

  system::Model fresh(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const auto    e = state_from_record(fresh, r, drive.value(t1), rod);
  const auto   &c = fresh.constants();
  EXPECT_TRUE(fresh.closed(0));
  EXPECT_NEAR(e[s::chamber_p], y[s::chamber_p], 1e-6);
  EXPECT_NEAR(e[s::high_p], y[s::high_p], 1e-6 * std::abs(y[s::high_p]));
  EXPECT_GT(y[s::high_p], 3e5); // the soft seal has stored something by now
  EXPECT_NEAR(e[s::piston_x], y[s::piston_x], 1e-15);
  // the oil column's compression A_pi p_ch / k_f, within 10 % (the column
  // is not quite at rest)
  const double squeeze = c.A_pi * y[s::chamber_p] / c.k_f;
  EXPECT_NEAR(e[s::piston_x] - e[s::fluid_x], y[s::piston_x] - y[s::fluid_x], 0.1 * std::abs(squeeze));
  // the oil: what accumulator and low side gave is what they hold
  const double given = c.C_acc * y[s::accumulator_p] + c.C_l * y[s::low_p];
  EXPECT_LT(given, 0);
  EXPECT_NEAR((c.C_acc + c.C_l) * e[s::accumulator_p], given, 1e-3 * std::abs(given));
  EXPECT_EQ(e[s::accumulator_p], e[s::low_p]);
  // and nothing else moves
  for (std::size_t k : {s::piston_v, s::fluid_v, s::outlet_reed_x, s::outlet_reed_v, s::inlet_reed_x})
    EXPECT_EQ(e[k], 0.0) << k;
}

// The same with a hose on the outlet (line_inertance: 12 sections, each
// node holding its share of the line's oil): the oil the estimate puts in
// the line is in every section, not only at its first node (before the
// thirty-eighth stop only that node's was counted: 16 kPa on the
// accumulator for line_inertance-4's hose). The model's own run 30 cycles
// in, whose volume balance over all nodes holds (a check of the balance
// itself), against the estimate's balance, which must hold to rounding.
TEST(ForeignData, TheRecordedStateCountsTheOilInEveryLineSection)
{
  namespace s = rectify::system::state;
  auto p      = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  p.lines.outlet_inertance_Pa_s2_per_m3 = 1.4e7;
  p.lines.outlet_line_segments          = 12;
  const auto   map   = system::load_valve_maps(p);
  const double f     = 150;
  const auto   drive = system::Drive::sine(f, 20, 10);
  system::Model model(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const double  t1 = 30.0 / f;
  const auto    y  = state_at(model, p, t1);
  const auto   &c  = model.constants();
  // the circuit's oil relative to rest: zero at every state
  const auto oil = [&](system::Model &m, const std::vector<double> &z) {
    return m.stored_volume(0, z[s::chamber_p]) - c.A_pi * z[s::piston_x] + m.stored_volume(1, z[s::high_p]) +
           m.component_stored_volume(z) + c.C_acc * z[s::accumulator_p] + m.stored_volume(2, z[s::low_p]);
  };
  // the oil the line's sections beyond its first node hold
  const auto sections = [&](const std::vector<double> &z) {
    return model.component_stored_volume(z) - model.stored_volume(3, z[s::line_node_p]);
  };
  ASSERT_GT(y[s::high_p], 1e6);
  EXPECT_NEAR(oil(model, y), 0.0, 1e-3 * sections(y));
  const double rod = p.transducer.rod_length_m;
  const auto   r   = recorded_at(model, p, y);
  system::Model fresh(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const auto    e = state_from_record(fresh, r, drive.value(t1), rod);
  for (std::size_t k = 0; k < 12; ++k)
    EXPECT_EQ(e[s::line_segment_node(k)], e[s::high_p]) << k;
  // what leaving them out would put on the accumulator: over 1 kPa here
  EXPECT_GT(sections(e) / (c.C_acc + c.C_l), 1e3);
  EXPECT_NEAR(oil(fresh, e), 0.0, 1e-9 * sections(e));
}

// A record that starts mid-operation shows no coil current: with a voltage
// drive and the coil's inductance the start takes the periodic current.
// Against the exact periodic response of L I' + R I = V0 + V1 sin(w t)
// (I = V0/R + V1 (R sin w t - w L cos w t) / (R^2 + w^2 L^2)), and against
// the model's own coil current 30 cycles into a run under that voltage.
TEST(ForeignData, AVoltageDrivenCoilStartsAtItsPeriodicCurrent)
{
  namespace s = rectify::system::state;
  auto p      = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  p.drive.coil_dynamics          = "on";
  p.transducer.coil_inductance_H = 2e-3;
  const double R = p.transducer.coil_resistance_ohm, L = 2e-3, f = 150, w = 2 * std::numbers::pi * f;
  const double V0 = 10 * R, V1 = 9 * R; // about the reference drive's 10 A bias and 18 A p-p
  std::vector<double> t, v;
  for (int i = 0; i <= 200 * 40; ++i)
    {
      t.push_back(i / (200.0 * f));
      v.push_back(V0 + V1 * std::sin(w * t.back()));
    }
  const auto   drive = system::Drive::from_samples(t, v, f, true, "test");
  const double exact = V0 / R - V1 * w * L / (R * R + w * w * L * L);
  // the drive's linear interpolation between 200 samples a cycle: 1e-4
  EXPECT_NEAR(periodic_coil_current(drive, R, L), exact, 1e-4 * V0 / R);
  EXPECT_LT(exact, V0 / R - 0.4 * V1 / R); // the lag matters here: 150 Hz is the coil's corner

  const auto    map = system::load_valve_maps(p);
  system::Model model(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const double  running = state_at(model, p, 30.0 / f)[s::coil_current];
  RecordedState r; // nothing measured: the state's other parts as at rest
  system::Model fresh(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const auto    e = state_from_record(fresh, r, drive.value(0.0), p.transducer.rod_length_m);
  EXPECT_NEAR(e[s::coil_current], running, 2e-4 * V0 / R);
  // the rod's static balance takes that current, not V(0)/R
  const auto &c = fresh.constants();
  EXPECT_NEAR(e[s::piston_x], c.force_per_ampere * e[s::coil_current] / c.k_eff, 1e-12);
  // without the coil's inductance no such state
  p.drive.coil_dynamics = "off";
  system::Model plain(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const auto    q = state_from_record(plain, r, drive.value(0.0), p.transducer.rod_length_m);
  EXPECT_NEAR(q[s::piston_x], c.force_per_ampere * (V0 / R) / c.k_eff, 1e-12);
}

// A no-flow record of a pump with an outlet line: at one instant the
// line's ringing puts the outlet pressure off the high side's, and the oil
// that error stores on the high side stays there (the outlet valve only
// adds oil). The record-mean start takes the high side at the outlet
// pressure's mean over the first cycle. A record whose outlet pressure is
// the high side's 10 MPa plus a 0.15 MPa ringing at 1200 Hz (the 8th
// harmonic of 150 Hz, as the bench's line_inertance-4), starting at its
// crest: the instant is 0.15 MPa off, the cycle's mean exact.
TEST(ForeignData, ARecordMeanStartPutsTheHighSideAtTheOutletPressuresCycleMean)
{
  namespace s = rectify::system::state;
  auto p      = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  p.lines.outlet_inertance_Pa_s2_per_m3 = 1.4e7;
  p.lines.outlet_line_segments          = 12;
  const auto   map = system::load_valve_maps(p);
  const double f = 150, p_high = 10e6, ring = 0.15e6, w = 2 * std::numbers::pi * 1200;
  MeasuredRun  run;
  run.source = "test";
  for (int i = 0; i < 200 * 3; ++i)
    {
      const double t = i / (200.0 * f);
      run.time_s.push_back(t);
      run.signals["current_A"].push_back(10 + 10 * std::sin(2 * std::numbers::pi * f * t));
      run.signals["outlet_pressure_Pa"].push_back(p_high + ring * std::cos(w * t));
      run.signals["chamber_pressure_Pa"].push_back(6e6);
      run.signals["outlet_valve_m"].push_back(0.0);
    }
  auto r = recorded_state(run, f);
  EXPECT_NEAR(r.outlet_pressure_mean_Pa, p_high, 1e-9 * p_high);
  EXPECT_GT(r.outlet_pressure_Pa - p_high, 0.9 * ring); // the instant: the crest, within the band
  const auto drive = system::Drive::sine(f, 20, 10);
  system::Model model(p, map, system::ValveModel::dynamic, system::Scenario::no_flow, drive);
  const auto    instant = state_from_record(model, r, 10.0, p.transducer.rod_length_m);
  r.high_side_at_mean   = true;
  const auto mean       = state_from_record(model, r, 10.0, p.transducer.rod_length_m);
  const double p_bias   = p.fluid.bias_pressure_Pa;
  EXPECT_NEAR(instant[s::high_p], r.outlet_pressure_Pa - p_bias, 1e-9 * p_high);
  EXPECT_NEAR(mean[s::high_p], p_high - p_bias, 1e-9 * p_high);
  // the line starts at rest at that pressure; the chamber as measured
  for (std::size_t k = 0; k < static_cast<std::size_t>(p.lines.outlet_line_segments); ++k)
    EXPECT_EQ(mean[s::line_segment_node(k)], mean[s::high_p]) << k;
  EXPECT_EQ(mean[s::chamber_p], instant[s::chamber_p]);
  // the high side holds less oil: the accumulator gave less
  EXPECT_GT(mean[s::accumulator_p], instant[s::accumulator_p]);
  // a record without a whole cycle has no mean: the instant stands
  MeasuredRun short_run = run;
  short_run.time_s.resize(100);
  for (auto &[name, values] : short_run.signals)
    values.resize(100);
  auto q = recorded_state(short_run, f);
  EXPECT_TRUE(std::isnan(q.outlet_pressure_mean_Pa));
  q.high_side_at_mean = true;
  EXPECT_NEAR(state_from_record(model, q, 10.0, p.transducer.rod_length_m)[s::high_p], q.outlet_pressure_Pa - p_bias,
              1e-9 * p_high);
  EXPECT_EQ(start_state_from_string("record-mean"), StartState::record_mean);
  EXPECT_EQ(to_string(StartState::record_mean), "record-mean");
}

// A position sensor has no absolute zero: the model's actuator position is
// compared after a shift by the mean of (data - model), its initial
// position fitted in closed form. Data: the model's own loaded run (4 A
// p-p at 75 Hz) read 1.5 mm off zero; this checks the shift, not a fit.
TEST(ForeignData, TheActuatorPositionIsComparedUpToItsSensorsZero)
{
  const auto   p     = system::SystemParameters::from_case(CaseFile::load(reference_case_path()));
  const auto   map   = system::load_valve_maps(p);
  const double f     = 75;
  const auto   drive = system::Drive::sine(f, 4, 2);
  MeasuredRun  run;
  run.source = "test";
  for (int i = 0; i < 200 * 6; ++i)
    {
      run.time_s.push_back(i / (200.0 * f));
      run.signals["current_A"].push_back(drive.value(run.time_s.back()));
    }
  for (auto &[name, values] :
       simulate_drive(p, map, drive, system::Scenario::loaded, run.time_s, 1e-8))
    run.signals[name] = values;
  const double offset = 1.5e-3;
  for (double &x : run.signals["actuator_position_m"])
    x += offset;
  const RunSetup    setup{system::Scenario::loaded, f};
  SimulationOptions so;
  so.relative_tolerance = 1e-8;
  const auto shifted    = simulate_run(p, map, run, setup, so).at("actuator_position_m");
  so.position_offset    = false;
  const auto raw        = simulate_run(p, map, run, setup, so).at("actuator_position_m");
  const auto &data      = run.signal("actuator_position_m");
  double      worst = 0, mean_gap = 0;
  for (std::size_t i = 0; i < data.size(); ++i)
    {
      worst = std::max(worst, std::abs(shifted[i] - data[i]));
      mean_gap += (data[i] - raw[i]) / static_cast<double>(data.size());
    }
  EXPECT_LT(worst, 0.01 * offset);
  EXPECT_NEAR(mean_gap, offset, 0.01 * offset);
}

// A case can declare the reed's second mode [uncertain]; the effect
// reed_second_mode sets the same key and supersedes it: in the effect's
// fits it is neither fitted nor applied, and the named value stays (the
// baseline's value, applied after the effect's at the round's end and in
// the profiles, once overwrote it). The new case file comments the range
// out (the named value lies outside it) and reads back. Plumbing, on the
// model's own record (synth): a mode far below the declared range.
TEST(ForeignData, AnUncertainSecondModeIsSupersededByTheNamedEffect)
{
  const auto dir = scratch("foreign_second_mode");
  std::string text;
  {
    std::ifstream     in(reference_case_path());
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  const auto replace = [&](const std::string &from, const std::string &to) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace("second_mode_frequency_Hz = 0.0", "second_mode_frequency_Hz = 4261.0");
  replace("resistance_map = \"thesis-resistance.csv\"",
          "resistance_map = \"" + (reference_case_path().parent_path() / "thesis-resistance.csv").string() + "\"");
  replace("[uncertain]\n", "[uncertain]\n\"reed.second_mode_frequency_Hz\" = [3874.0, 4688.0]\n");
  const auto rig = dir / "case.toml";
  std::ofstream(rig) << text;
  const auto declared = system::SystemParameters::from_case(CaseFile::load(rig));
  ASSERT_TRUE(std::any_of(declared.uncertain.begin(), declared.uncertain.end(),
                          [](const auto &q) { return q.name() == "reed.second_mode_frequency_Hz"; }));

  const double truth = 2600;
  auto r = rectify_cli("synth --case " + rig.string() + " --effect reed_second_mode --param second_mode_frequency_Hz=" +
                       std::to_string(truth) + " --scenario loaded --noise 0.01 --seed 4 --cycles 8 --out " +
                       (dir / "data").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto out = dir / "d";
  const auto s   = diagnose_summary(dir / "data" / "data.csv",
                                    "--case " + rig.string() + " --scenario loaded --effects reed_second_mode "
                                    "--reed-second-mode case", out);
  ASSERT_FALSE(s.is_null());
  bool listed = false; // the baseline's fit had it
  for (const auto &b : s["baseline_fit"])
    listed = listed || b["parameter"] == "reed.second_mode_frequency_Hz";
  EXPECT_TRUE(listed) << s["baseline_fit"].dump(1);
  ASSERT_EQ(s["effect"], "reed_second_mode") << s["decision"];
  const double fitted = s["parameters"]["second_mode_frequency_Hz"].get<double>();
  EXPECT_NEAR(fitted, truth, 0.01 * truth);
  EXPECT_FALSE(s["baseline"].contains("reed.second_mode_frequency_Hz")) << s["baseline"].dump(1);

  std::ifstream     in(out / s["new_case"]["file"].get<std::string>());
  std::stringstream written_text;
  written_text << in.rdbuf();
  const std::string w = written_text.str();
  EXPECT_EQ(w.find("second_mode_frequency_Hz = ", w.find("second_mode_frequency_Hz = ") + 1), std::string::npos)
    << "written twice";
  EXPECT_NE(w.find("# \"reed.second_mode_frequency_Hz\" = [3874.0, 4688.0]"), std::string::npos) << w;
  const auto written = system::SystemParameters::from_case(CaseFile::parse(w, "new.toml", dir));
  EXPECT_NEAR(written.reed.second_mode_frequency_Hz, fitted, 1e-6 * fitted);
  EXPECT_EQ(written.uncertain.size(), declared.uncertain.size() - 1);
  EXPECT_TRUE(s["new_case"]["matches_refit"].get<bool>()) << s["new_case"].dump(1);
}
