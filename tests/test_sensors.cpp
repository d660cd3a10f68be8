// The sensors' lags a diagnosis fits to its final model (diagnosis/sensors.h):
// the lag against its exact solutions, and the fit against records lagged by
// the transfer function itself (each harmonic scaled and turned), not by the
// time-stepping the fit uses.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <string>

#include "common/case_file.h"
#include "diagnosis/sensors.h"

using namespace rectify;
using namespace rectify::diagnosis;

namespace
{
  constexpr double pi = std::numbers::pi;

  /// A periodic signal: harmonics k = 1..3 of f with amplitudes a_k and
  /// phases, seen through a first-order lag of bandwidth fc (inf: none) in
  /// its steady state: each harmonic times 1 / (1 + i k f / fc).
  double through_lag(double t, double f, double fc)
  {
    const double        a[3] = {1.0, 0.4, 0.15}, phase[3] = {0.0, 0.7, -1.1};
    std::complex<double> sum = 0;
    for (int k = 1; k <= 3; ++k)
      {
        const std::complex<double> h = std::isinf(fc) ? 1.0 : 1.0 / std::complex<double>(1.0, k * f / fc);
        sum += a[k - 1] * h * std::exp(std::complex<double>(0.0, 2 * pi * k * f * t + phase[k - 1]));
      }
    return sum.real();
  }

  /// A run of `cycles` cycles at f sampled at 30 kHz (the outlet pressure
  /// held, which a record must have): its chamber pressure
  /// and strain through lags of fc_p and fc_s (steady state) plus white noise
  /// of 0.2 % of their amplitudes, the noise scales those, the first cycle
  /// skipped, three quarters trained on; and the model, the signals without
  /// lag or noise.
  std::pair<RunCase, Signals> lagged_run(double f, double cycles, double fc_p, double fc_s, unsigned seed,
                                         bool lag_held_out = true)
  {
    std::mt19937                     rng(seed);
    std::normal_distribution<double> noise(0.0, 1.0);
    const double                     dt = 1.0 / 30000, p0 = 5e6, dp = 2e6, ds = 1e-4;
    const int                        n  = static_cast<int>(std::lround(cycles / f / dt));
    const int                        n_train = static_cast<int>(0.75 * n);
    std::string                      text = "time_s,current_A,outlet_pressure_Pa,chamber_pressure_Pa,strain\n";
    Signals                          model;
    for (int i = 0; i <= n; ++i)
      {
        const double t = i * dt;
        char         row[200];
        std::snprintf(row, sizeof row, "%.12g,%.12g,%.12g,%.12g,%.12g\n", t, 10 + 10 * std::sin(2 * pi * f * t), p0,
                      p0 + dp * through_lag(t, f, i < n_train || lag_held_out ? fc_p : INFINITY) +
                        0.002 * dp * noise(rng),
                      ds * through_lag(t, f, fc_s) + 0.002 * ds * noise(rng));
        text += row;
        model["chamber_pressure_Pa"].push_back(p0 + dp * through_lag(t, f, INFINITY));
        model["strain"].push_back(ds * through_lag(t, f, INFINITY));
      }
    RunCase rc;
    rc.run     = MeasuredRun::parse(text, "lagged-" + std::to_string(static_cast<int>(f)) + ".csv");
    rc.scales  = {{"chamber_pressure_Pa", 0.002 * dp}, {"strain", 0.002 * ds}};
    rc.n_skip  = static_cast<std::size_t>(std::lround(1 / f / dt));
    rc.n_train = static_cast<std::size_t>(n_train);
    return {rc, model};
  }
} // namespace

TEST(Sensors, AFirstOrderLagFollowsItsExactSolutions)
{
  // a ramp from rest: y = t - tau (1 - e^(-t / tau)), exactly (the lag is
  // exact for an input linear between samples), on uneven steps
  const double        fc = 5000, tau = 1 / (2 * pi * fc);
  std::vector<double> t{0.0}, x{0.0};
  for (int i = 1; i < 400; ++i)
    t.push_back(t.back() + (i % 3 == 0 ? 3e-6 : 1.1e-6));
  x.assign(t.begin(), t.end());
  const auto y = first_order_lag(t, x, fc);
  for (std::size_t i = 0; i < t.size(); ++i)
    EXPECT_NEAR(y[i], t[i] - tau * (1 - std::exp(-t[i] / tau)), 1e-12 * std::max(t[i], 1e-6)) << i;
  // a sine of 2 kHz through a 5 kHz lag, once the start has decayed (20 tau):
  // amplitude 1 / sqrt(1 + (f / fc)^2), phase -atan(f / fc); sampled at
  // 1 MHz, the input's curvature between samples costs (w dt)^2 / 12 = 1e-5
  const double f = 2000, dt = 1e-6;
  t.clear();
  x.clear();
  for (int i = 0; i < 4000; ++i)
    {
      t.push_back(i * dt);
      x.push_back(std::sin(2 * pi * f * i * dt));
    }
  const auto   s    = first_order_lag(t, x, fc);
  const double gain = 1 / std::hypot(1.0, f / fc), phase = std::atan(f / fc);
  double       worst = 0;
  for (std::size_t i = 2000; i < t.size(); ++i)
    worst = std::max(worst, std::abs(s[i] - gain * std::sin(2 * pi * f * t[i] - phase)));
  EXPECT_LT(worst, 2e-5);
  EXPECT_GT(worst, 0.0);
  // no lag and bad input
  EXPECT_EQ(first_order_lag(t, x, INFINITY), x);
  EXPECT_THROW((void)first_order_lag(t, x, 0.0), std::invalid_argument);
  EXPECT_THROW((void)first_order_lag(t, std::vector<double>(3, 0.0), fc), std::invalid_argument);
}

TEST(Sensors, EachSignalsLagIsFoundOnceForEveryRunAndHeldAtItsLowest)
{
  // two runs (100 and 150 Hz) whose chamber pressure passed a 6 kHz
  // transducer and whose strain an ideal amplifier
  auto [a, ma] = lagged_run(100, 8, 6000, INFINITY, 1);
  auto [b, mb] = lagged_run(150, 8, 6000, INFINITY, 2);
  std::vector<RunCase> runs{a, b};
  std::vector<Signals> model{ma, mb};
  const auto           lags = calibrate_sensor_lags(runs, model, {{"chamber_pressure_Pa", 2000}, {"strain", 5000}});
  ASSERT_EQ(lags.size(), 2u);
  const auto &p = lags[0], &s = lags[1];
  ASSERT_EQ(p.signal, "chamber_pressure_Pa");
  // the lag turns the 150 Hz fundamental by 1.4 deg, 2.5 % of its amplitude:
  // 12 noise units without it, the noise with it, its bandwidth within 2 %
  EXPECT_NEAR(p.fitted_Hz, 6000, 120);
  EXPECT_FALSE(p.at_lowest());
  EXPECT_TRUE(p.kept);
  EXPECT_EQ(p.applied_Hz(), p.fitted_Hz);
  EXPECT_GT(p.residual_ideal, 8.0);
  EXPECT_NEAR(p.residual_lagged, 1.0, 0.05);
  // and on the last quarter of each run, which the fit did not see
  EXPECT_GT(p.heldout_ideal, 8.0);
  EXPECT_NEAR(p.heldout_lagged, 1.0, 0.08);
  // the model is now seen through it: at the data to within the noise
  double sum = 0;
  int    n   = 0;
  for (std::size_t i = runs[1].n_skip; i < runs[1].n_train; ++i, ++n)
    sum += std::pow((model[1]["chamber_pressure_Pa"][i] - runs[1].run.signal("chamber_pressure_Pa")[i]) / 4e3, 2);
  EXPECT_NEAR(std::sqrt(sum / n), 1.0, 0.05);
  // the strain's sensor had no lag: none that matters is fitted (above
  // 60 kHz it turns its 450 Hz harmonic by less than 0.5 deg), nothing gained
  ASSERT_EQ(s.signal, "strain");
  EXPECT_GT(s.fitted_Hz, 60000);
  EXPECT_NEAR(s.residual_lagged, s.residual_ideal, 0.01);
  EXPECT_NEAR(s.residual_ideal, 1.0, 0.05);
  EXPECT_NEAR(s.heldout_lagged, s.heldout_ideal, 0.01);

  // a 1 kHz transducer with 2 kHz the lowest allowed: held there
  auto [c, mc] = lagged_run(150, 8, 1000, INFINITY, 3);
  std::vector<RunCase> slow{c};
  std::vector<Signals> slow_model{mc};
  const auto held = calibrate_sensor_lags(slow, slow_model, {{"chamber_pressure_Pa", 2000}});
  ASSERT_EQ(held.size(), 1u);
  EXPECT_TRUE(held[0].at_lowest());
  EXPECT_NEAR(held[0].fitted_Hz, 2000, 1);
  EXPECT_TRUE(held[0].kept);
  EXPECT_LT(held[0].residual_lagged, 0.6 * held[0].residual_ideal);
  EXPECT_GT(held[0].residual_lagged, 2.0);

  // a lag in the training part only (what a lag takes up there does not
  // repeat): fitted, but the held-out samples fit worse with it, so not kept
  // and the model not touched
  auto [e, me] = lagged_run(150, 8, 6000, INFINITY, 4, false);
  std::vector<RunCase> once{e};
  std::vector<Signals> once_model{me};
  const auto           dropped = calibrate_sensor_lags(once, once_model, {{"chamber_pressure_Pa", 2000}});
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_NEAR(dropped[0].fitted_Hz, 6000, 120);
  EXPECT_LT(dropped[0].residual_lagged, 0.2 * dropped[0].residual_ideal);
  EXPECT_GT(dropped[0].heldout_lagged, 5 * dropped[0].heldout_ideal);
  EXPECT_FALSE(dropped[0].kept);
  EXPECT_TRUE(std::isinf(dropped[0].applied_Hz()));
  EXPECT_EQ(once_model[0]["chamber_pressure_Pa"], me["chamber_pressure_Pa"]);

  // a model simulated over the first part of a record only: fitted over
  // what it covers (no held-out samples: kept), its length kept
  Signals part = ma;
  for (auto &[name, v] : part)
    v.resize(v.size() * 2 / 3);
  std::vector<Signals> partial{part};
  const auto           short_fit = calibrate_sensor_lags({a}, partial, {{"chamber_pressure_Pa", 2000}});
  ASSERT_EQ(short_fit.size(), 1u);
  EXPECT_NEAR(short_fit[0].fitted_Hz, 6000, 200);
  EXPECT_TRUE(short_fit[0].kept);
  EXPECT_EQ(partial[0]["chamber_pressure_Pa"].size(), part["chamber_pressure_Pa"].size());

  // a signal without a bound stays ideal and is not touched
  std::vector<Signals> untouched{ma};
  EXPECT_TRUE(calibrate_sensor_lags({a}, untouched, {}).empty());
  EXPECT_EQ(untouched[0]["chamber_pressure_Pa"], ma["chamber_pressure_Pa"]);
}

TEST(Sensors, TheCaseGivesEachKindsLowestBandwidth)
{
  const CaseFile f = CaseFile::parse("[sensors]\npressure_lowest_bandwidth_Hz = 2000\n"
                                     "opening_lowest_bandwidth_Hz = 0\nstrain_lowest_bandwidth_Hz = 5e3\n",
                                     "sensors.toml");
  const auto per = SensorLimits::from_case(f).per_signal();
  // both pressures, the strain; the opening ideal, the actuator not given
  EXPECT_EQ(per, (std::map<std::string, double>{
                   {"chamber_pressure_Pa", 2000}, {"outlet_pressure_Pa", 2000}, {"strain", 5000}}));
  EXPECT_NO_THROW(f.check_all_keys_known());
  try
    {
      (void)SensorLimits::from_case(
        CaseFile::parse("[sensors]\npressure_lowest_bandwidth_Hz = -5\n", "negative.toml"));
      FAIL() << "a negative bandwidth was read";
    }
  catch (const InputError &e)
    {
      const std::string what = e.what();
      EXPECT_NE(what.find("negative.toml"), std::string::npos) << what;
      EXPECT_NE(what.find("pressure_lowest_bandwidth_Hz"), std::string::npos) << what;
      EXPECT_NE(what.find("-5"), std::string::npos) << what;
    }
  const CaseFile typo = CaseFile::parse("[sensors]\npresure_lowest_bandwidth_Hz = 2000\n", "typo.toml");
  (void)SensorLimits::from_case(typo);
  EXPECT_THROW(typo.check_all_keys_known(), InputError);
}
