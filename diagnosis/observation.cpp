#include "diagnosis/observation.h"

#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <unsupported/Eigen/FFT>

#include "common/case_file.h"
#include "diagnosis/fourier.h"
#include "diagnosis/residuals.h"
#include "system/components/coil_dynamics.h"
#include "system/reed.h"
#include "system/simulation.h"

namespace rectify::diagnosis
{
  std::vector<double> low_pass(const std::vector<double> &t, const std::vector<double> &v,
                               double cutoff_Hz)
  {
    const std::size_t n = v.size();
    if (n < 3)
      return v;
    if (!uniformly_sampled(t))
      return v; // left as measured
    const double dt = (t.back() - t.front()) / static_cast<double>(n - 1);
    const double fc = cutoff_Hz * dt; // cycles per sample
    if (!(fc < 0.4))
      return v; // the cutoff is near Nyquist: nothing to remove
    const auto half = static_cast<long>(std::ceil(3.0 / fc));
    std::vector<double> kernel(static_cast<std::size_t>(2 * half + 1));
    for (long k = -half; k <= half; ++k)
      {
        const double x      = 2.0 * fc * static_cast<double>(k);
        const double sinc   = k == 0 ? 1.0 : std::sin(std::numbers::pi * x) / (std::numbers::pi * x);
        const double w      = static_cast<double>(k + half) / static_cast<double>(2 * half);
        const double window = 0.42 - 0.5 * std::cos(2 * std::numbers::pi * w) +
                              0.08 * std::cos(4 * std::numbers::pi * w); // Blackman
        kernel[static_cast<std::size_t>(k + half)] = sinc * window;
      }
    // even (mirror) extension at both ends: exact for a record that starts
    // (or ends) at a turning point of the drive, as a run from rest does
    const auto at = [&](long j) {
      const long last = static_cast<long>(n) - 1;
      while (j < 0 || j > last)
        j = j < 0 ? -j : 2 * last - j;
      return v[static_cast<std::size_t>(j)];
    };
    double weight = 0;
    for (double w : kernel)
      weight += w;
    std::vector<double> out(n);
    for (std::size_t i = 0; i < n; ++i)
      {
        double sum = 0;
        for (long k = -half; k <= half; ++k)
          sum += kernel[static_cast<std::size_t>(k + half)] * at(static_cast<long>(i) + k);
        out[i] = sum / weight;
      }
    return out;
  }

  namespace
  {
    /// The record's cosine series, filtered: the DFT of its even extension
    /// (length m = 2 (n - 1): real, no wrap-around jump), each term k in
    /// [0, m) kept where keep(k, m, |X_k|), transformed back to n values.
    template <typename Keep>
    std::vector<double> filter_cosine_series(const std::vector<double> &v, const Keep &keep)
    {
      const std::size_t   n = v.size(), m = 2 * (n - 1);
      std::vector<double> y(m);
      for (std::size_t i = 0; i < n; ++i)
        y[i] = v[i];
      for (std::size_t i = 1; i + 1 < n; ++i)
        y[m - i] = v[i];
      Eigen::FFT<double>                fft;
      std::vector<std::complex<double>> spectrum;
      fft.fwd(spectrum, y);
      for (std::size_t k = 0; k < spectrum.size(); ++k)
        if (!keep(k, m, std::abs(spectrum[k])))
          spectrum[k] = 0.0;
      std::vector<double> back;
      fft.inv(back, spectrum);
      back.resize(n);
      return back;
    }
  } // namespace

  std::vector<double> spectral_threshold(const std::vector<double> &t, const std::vector<double> &v,
                                         double noise_sd)
  {
    const std::size_t n = v.size();
    if (n < 8 || !(noise_sd > 0) || !uniformly_sampled(t))
      return v;
    // white noise of sd s gives each coefficient (but the first and the
    // last) an sd of s sqrt(m); the mean is always kept
    const double threshold = noise_sd * std::sqrt(2.0 * static_cast<double>(n - 1)) *
                             std::sqrt(2.0 * std::log(static_cast<double>(n)));
    return filter_cosine_series(v, [&](std::size_t k, std::size_t, double a) { return k == 0 || a >= threshold; });
  }

  namespace
  {
    /// Roughly what one length-m FFT costs per sample: the sum of m's prime
    /// factors (Eigen's kissfft handles a prime factor p in O(p) per sample).
    std::size_t fft_cost_per_sample(std::size_t m)
    {
      std::size_t cost = 0;
      for (std::size_t p = 2; p * p <= m; ++p)
        while (m % p == 0)
          {
            cost += p;
            m /= p;
          }
      return m > 1 ? cost + m : cost;
    }

    /// filter_cosine_series keeping the terms k = 0..K (and their mirrors),
    /// summed directly: the cosine coefficients X_k = v_0 + (-1)^k v_{n-1} +
    /// 2 sum_{0<i<n-1} v_i cos(pi k i / (n-1)) and back
    /// y_i = (X_0 + 2 sum_{k=1..K} X_k cos(pi k i / (n-1))) / m, m = 2 (n - 1), K < n - 1.
    std::vector<double> low_cosine_terms(const std::vector<double> &v, std::size_t K)
    {
      const std::size_t   n = v.size(), m = 2 * (n - 1);
      std::vector<double> c(m);
      for (std::size_t j = 0; j < m; ++j)
        c[j] = std::cos(std::numbers::pi * static_cast<double>(j) / static_cast<double>(n - 1));
      std::vector<double> X(K + 1);
      for (std::size_t k = 0; k <= K; ++k)
        {
          double      sum = v[0];
          std::size_t j   = 0; // k i mod m
          for (std::size_t i = 1; i < n; ++i)
            {
              j += k;
              if (j >= m)
                j -= m;
              sum += (i + 1 < n ? 2.0 : 1.0) * v[i] * c[j];
            }
          X[k] = sum;
        }
      std::vector<double> y(n);
      for (std::size_t i = 0; i < n; ++i)
        {
          double      sum = X[0];
          std::size_t j   = 0; // k i mod m
          for (std::size_t k = 1; k <= K; ++k)
            {
              j += i;
              if (j >= m)
                j -= m;
              sum += 2.0 * X[k] * c[j];
            }
          y[i] = sum / static_cast<double>(m);
        }
      return y;
    }
  } // namespace

  std::vector<double> band_limit(const std::vector<double> &t, const std::vector<double> &v, double cutoff_Hz)
  {
    const std::size_t n = v.size();
    if (n < 8 || !(cutoff_Hz > 0) || !uniformly_sampled(t))
      return v;
    const double dt = (t.back() - t.front()) / static_cast<double>(n - 1);
    if (cutoff_Hz * dt >= 0.5)
      return v;
    const double df = 1.0 / (2.0 * static_cast<double>(n - 1) * dt);
    // the terms kept: k df <= cutoff, k < n - 1 (the cutoff is below Nyquist)
    std::size_t K = 0;
    while (K + 2 < n && static_cast<double>(K + 1) * df <= cutoff_Hz)
      ++K;
    // a record whose length has a large prime factor makes the FFT slow
    // (2400 samples: m = 2 x 2399, a prime): a few low terms are cheaper summed
    if (K + 1 <= fft_cost_per_sample(2 * (n - 1)))
      return low_cosine_terms(v, K);
    return filter_cosine_series(v, [&](std::size_t k, std::size_t m, double) {
      return static_cast<double>(std::min(k, m - k)) * df <= cutoff_Hz;
    });
  }

  std::vector<double> denoise_periodic(const std::vector<double> &t, const std::vector<double> &v,
                                       double frequency_Hz, int max_harmonic, double noise_sd)
  {
    const std::size_t n = v.size();
    if (n < 8 || !(noise_sd > 0) || !(frequency_Hz > 0) || max_harmonic < 1 || !uniformly_sampled(t))
      return v;
    const Eigen::MatrixXd basis = fourier_basis(t, frequency_Hz, max_harmonic);
    const Eigen::Map<const Eigen::VectorXd> b(v.data(), static_cast<Eigen::Index>(n));
    Eigen::VectorXd c = basis.colPivHouseholderQr().solve(b);
    // white noise gives each coefficient of a harmonic an sd of
    // noise_sd sqrt(2 / n); its amplitude exceeds that times sqrt(2 ln n)
    // with probability 1 / n
    const double threshold = noise_sd * std::sqrt(2.0 / static_cast<double>(n)) *
                             std::sqrt(2.0 * std::log(static_cast<double>(n)));
    for (int k = 1; k <= max_harmonic; ++k)
      if (std::hypot(c(2 * k - 1), c(2 * k)) < threshold)
        c(2 * k - 1) = c(2 * k) = 0.0;
    const Eigen::VectorXd periodic = basis * c;
    std::vector<double>   rest(n);
    for (std::size_t i = 0; i < n; ++i)
      rest[i] = v[i] - periodic(static_cast<Eigen::Index>(i));
    rest = spectral_threshold(t, rest, noise_sd);
    for (std::size_t i = 0; i < n; ++i)
      rest[i] += periodic(static_cast<Eigen::Index>(i));
    return rest;
  }

  std::string to_string(StartState s)
  {
    switch (s)
      {
        case StartState::rest:
          return "rest";
        case StartState::steady:
          return "steady";
        case StartState::periodic:
          return "periodic";
        case StartState::record:
          return "record";
        case StartState::record_mean:
          return "record-mean";
      }
    return "rest";
  }

  StartState start_state_from_string(const std::string &name)
  {
    for (auto s : {StartState::rest, StartState::steady, StartState::periodic, StartState::record,
                   StartState::record_mean})
      if (to_string(s) == name)
        return s;
    throw InputError("start state '" + name + "': expected rest, steady, periodic, record or record-mean");
  }

  system::Drive measured_drive(const MeasuredRun &run, double frequency_Hz, double extra_noise_sd,
                               unsigned long seed, StartState start, double lead_cycles)
  {
    return with_lead(measured_drive(run, frequency_Hz, extra_noise_sd, seed), run, frequency_Hz, start, lead_cycles);
  }

  system::Drive with_lead(system::Drive d, const MeasuredRun &run, double frequency_Hz, StartState start,
                          double lead_cycles)
  {
    if (start == StartState::rest || from_record(start) || !(lead_cycles > 0))
      return d;
    const auto        &t0  = run.time_s;
    const std::size_t  n   = t0.size();
    const double       dt  = (t0.back() - t0.front()) / static_cast<double>(n - 1);
    const double       T   = 1.0 / frequency_Hz;
    const double       lead = lead_cycles * T;
    const auto         m   = static_cast<std::size_t>(std::ceil(lead / dt));
    std::vector<double> times, values;
    times.reserve(m + n);
    values.reserve(m + n);
    const double first = d.value(0.0);
    for (std::size_t k = m; k > 0; --k)
      {
        const double t     = -static_cast<double>(k) * dt;
        const double since = t + lead; // time since the lead began
        const double ramp  = since >= T ? 1.0 : 0.5 * (1.0 - std::cos(std::numbers::pi * since / T));
        double       target = first;
        if (start == StartState::periodic)
          target = d.value(t - std::floor(t / T) * T); // the record's first cycle, repeated
        times.push_back(t);
        values.push_back(ramp * target);
      }
    for (std::size_t i = 0; i < n; ++i)
      {
        const double t = t0[i] - t0.front();
        times.push_back(t);
        values.push_back(d.value(t));
      }
    return system::Drive::from_samples(std::move(times), std::move(values), frequency_Hz, d.is_voltage(),
                                       run.source);
  }

  system::Drive measured_drive(const MeasuredRun &run, double frequency_Hz,
                               double extra_noise_sd, unsigned long seed)
  {
    std::vector<double> t(run.time_s.size());
    for (std::size_t i = 0; i < t.size(); ++i)
      t[i] = run.time_s[i] - run.time_s.front();
    const std::string &column = run.drive_column();
    auto raw = run.signal(column);
    if (extra_noise_sd > 0)
      {
        std::mt19937_64                  rng(seed);
        std::normal_distribution<double> normal(0.0, extra_noise_sd);
        for (double &x : raw)
          x += normal(rng);
      }
    const int harmonics = static_cast<int>(drive_cutoff_harmonic);
    auto values = low_pass(t, denoise_periodic(t, raw, frequency_Hz, harmonics, white_noise_sd(raw)),
                           drive_cutoff_harmonic * frequency_Hz);
    return system::Drive::from_samples(std::move(t), std::move(values), frequency_Hz,
                                       column == "voltage_V", run.source);
  }

  RecordedState recorded_state(const MeasuredRun &run, double frequency_Hz)
  {
    RecordedState r;
    std::vector<double> t(run.time_s.size());
    for (std::size_t i = 0; i < t.size(); ++i)
      t[i] = run.time_s[i] - run.time_s.front();
    const auto first = [&](const char *column) {
      if (!run.has(column))
        return std::numeric_limits<double>::quiet_NaN();
      return band_limit(t, run.signal(column), drive_cutoff_harmonic * frequency_Hz).front();
    };
    r.chamber_pressure_Pa       = first("chamber_pressure_Pa");
    r.outlet_pressure_Pa        = first("outlet_pressure_Pa");
    r.outlet_valve_m            = first("outlet_valve_m");
    r.strain                    = first("strain");
    r.actuator_position_m       = first("actuator_position_m");
    r.actuator_velocity_m_per_s = first("actuator_velocity_m_per_s");
    if (run.has("outlet_valve_m"))
      r.outlet_valve_noise_m = white_noise_sd(run.signal("outlet_valve_m"));
    // the first cycle's samples (the noise averages out over them)
    if (run.has("outlet_pressure_Pa") && t.size() > 1 && frequency_Hz > 0)
      {
        const double dt = t.back() / static_cast<double>(t.size() - 1);
        const auto   m  = static_cast<std::size_t>(std::llround(1.0 / (frequency_Hz * dt)));
        if (m >= 2 && m <= t.size())
          {
            const auto &p   = run.signal("outlet_pressure_Pa");
            double      sum = 0;
            for (std::size_t i = 0; i < m; ++i)
              sum += p[i];
            r.outlet_pressure_mean_Pa = sum / static_cast<double>(m);
          }
      }
    return r;
  }

  double periodic_coil_current(const system::Drive &drive, double R, double L)
  {
    // L I' + R I = V(t), V the first cycle repeated: I(T) = I(0) gives
    // I(0) = (1/L) int_0^T exp(-a (T - s)) V(s) ds / (1 - exp(-a T)), a = R/L
    // (the trapezoidal rule on 4000 intervals: a cycle holds 200 samples)
    const double      T = 1.0 / drive.frequency_Hz(), a = R / L;
    constexpr int     m = 4000;
    const double      h = T / m;
    double            sum = 0;
    for (int k = 0; k <= m; ++k)
      {
        const double s = k * h;
        sum += (k == 0 || k == m ? 0.5 : 1.0) * std::exp(-a * (T - s)) * drive.value(s);
      }
    return sum * h / L / -std::expm1(-a * T);
  }

  std::vector<double> state_from_record(system::Model &model, const RecordedState &r, double drive_at_0,
                                        double rod_length_m)
  {
    using namespace system;
    model.reset();
    std::vector<double> y = model.initial_state();
    const auto         &c = model.constants();
    const std::size_t   n = y.size();
    const auto given = [](double v) { return std::isfinite(v); };
    const double p_ch  = given(r.chamber_pressure_Pa) ? r.chamber_pressure_Pa - c.p_bias : 0.0;
    const double p_at  = r.high_side_at_mean && given(r.outlet_pressure_mean_Pa) ? r.outlet_pressure_mean_Pa :
                                                                                  r.outlet_pressure_Pa;
    const double p_out = given(p_at) ? p_at - c.p_bias : 0.0;
    y[state::chamber_p] = p_ch;
    y[state::high_p]    = p_out;
    for (const auto &v : model.volumes())
      if (v.high_side && v.state < n)
        y[v.state] = p_out;
    // the coil current: with a voltage drive and the coil's inductance, the
    // periodic response to the record's first cycle (the record shows the
    // pump in operation, where the current lags the voltage); else the
    // drive's own value
    double current = drive_at_0 * (model.drive().is_voltage() ? 1.0 / c.R_coil : 1.0);
    if (const auto *coil = dynamic_cast<const CoilDynamics *>(model.component("coil_dynamics"));
        coil && state::coil_current < n)
      {
        current                  = periodic_coil_current(model.drive(), coil->resistance_ohm(), coil->inductance_H());
        y[state::coil_current] = current;
      }
    // the rod: measured, or in its static balance F = k_eff x_p + A_pi p_ch
    const double x_p     = given(r.strain) ? r.strain * rod_length_m :
                                             (c.force_per_ampere * current - c.A_pi * p_ch) / c.k_eff;
    y[state::piston_x] = x_p;
    y[state::fluid_x]  = x_p - c.A_pi * p_ch / c.k_f; // k_f (x_p - x_f) = A_pi p_ch
    // the outlet reed: open if its opening stands above the laser's noise
    if (given(r.outlet_valve_m) && r.outlet_valve_m > 3.0 * r.outlet_valve_noise_m && r.outlet_valve_m > 0)
      {
        model.set_closed(0, false);
        y[state::outlet_reed_x] = r.outlet_valve_m;
      }
    if (model.scenario() == Scenario::loaded)
      {
        if (given(r.actuator_position_m))
          y[state::actuator_x] = r.actuator_position_m;
        if (given(r.actuator_velocity_m_per_s))
          y[state::actuator_v] = r.actuator_velocity_m_per_s;
      }
    // the oil is conserved since rest: what the chamber (less the rod's
    // stroke), the high side and the line (its node at the valve and every
    // section's node) hold came from the accumulator and the low side (the
    // cylinder's stroke moves oil between its sides)
    const double held = model.stored_volume(0, p_ch) - c.A_pi * x_p + model.stored_volume(1, p_out) +
                        model.component_stored_volume(y);
    const double p_acc = -held / (c.C_acc + c.C_l);
    y[state::accumulator_p] = p_acc;
    y[state::low_p]         = p_acc;
    // a seated reed whose pressures already push it open lifts now: its
    // lift-off is a root of the opening force crossing the seat's, which a
    // start already past it would never see
    for (int pass = 0; pass < 2; ++pass)
      for (std::size_t v = 0; v < 2; ++v)
        if (model.closed(v) && model.valve_model() == ValveModel::dynamic)
          {
            const Flows  f     = model.flows(y);
            const double force = v == 0 ? f.outlet_force : f.inlet_force;
            if (force > reed_lift_force)
              {
                model.set_closed(v, false);
                y[v == 0 ? state::outlet_reed_x : state::inlet_reed_x] = reed_seat_tolerance;
              }
          }
    return y;
  }

  Signals simulate_drive(const system::SystemParameters &p, const system::ValveMaps &map,
                         const system::Drive &drive, system::Scenario scenario,
                         const std::vector<double> &times, double relative_tolerance, double t_start,
                         const RecordedState *from)
  {
    using namespace system;
    Model model(p, map, ValveModel::dynamic, scenario, drive);
    model.reset();
    RunOptions ro;
    ro.relative_tolerance        = relative_tolerance;
    ro.absolute_tolerance_factor = p.solver.absolute_tolerance_factor;
    ro.samples_per_cycle         = 200;
    const auto y0 = from ? state_from_record(model, *from, drive.value(t_start), p.transducer.rod_length_m) :
                           model.initial_state();
    model.sync_cavitation(y0);
    auto       io = integrator_options(model, ro);
    io.quiet      = true; // a fit explores parameters where the model may fail: it says so itself
    Integrator integrator(model, t_start, y0, io);

    const bool loaded = scenario == Scenario::loaded;
    Signals    out;
    for (const auto &c : signal_columns())
      if (loaded || (c != "actuator_position_m" && c != "actuator_velocity_m_per_s"))
        out[c].reserve(times.size());
    const double p_bias = p.fluid.bias_pressure_Pa, rod = p.transducer.rod_length_m;
    for (double t : times)
      {
        if (t > integrator.time())
          integrator.advance_to(t);
        const auto  y = integrator.state();
        const Flows f = model.flows(y);
        out["outlet_pressure_Pa"].push_back(p_bias + f.p_outlet);
        const double p_ch = model.cavity_nodes().empty() ? y[state::chamber_p] : // a cavity holds its pressure
                              std::max(y[state::chamber_p], model.cavitation_gauge_pressure());
        out["chamber_pressure_Pa"].push_back(p_bias + p_ch);
        out["outlet_valve_m"].push_back(model.opening(0, y));
        out["strain"].push_back(y[state::piston_x] / rod);
        if (loaded)
          {
            out["actuator_position_m"].push_back(y[state::actuator_x]);
            out["actuator_velocity_m_per_s"].push_back(y[state::actuator_v]);
          }
      }
    return out;
  }

  Signals simulate_run(const system::SystemParameters &p, const system::ValveMaps &map,
                       const MeasuredRun &run, const RunSetup &setup,
                       const SimulationOptions &options)
  {
    const std::size_t n =
      options.n_samples > 0 ? std::min(options.n_samples, run.time_s.size()) : run.time_s.size();
    std::vector<double> times(n);
    for (std::size_t i = 0; i < n; ++i)
      times[i] = run.time_s[i] - run.time_s.front();
    const bool   lead    = options.start != StartState::rest && !from_record(options.start) && options.lead_cycles > 0;
    const double t_start = lead ? -options.lead_cycles / setup.frequency_Hz : 0.0;
    std::optional<RecordedState> recorded;
    if (from_record(options.start))
      {
        recorded = options.recorded ? *options.recorded : recorded_state(run, setup.frequency_Hz);
        recorded->high_side_at_mean = options.start == StartState::record_mean;
      }
    system::Drive cleaned = options.drive && !(options.drive_noise_sd > 0) ?
                              *options.drive :
                              measured_drive(run, setup.frequency_Hz, options.drive_noise_sd, options.seed);
    Signals       all     = simulate_drive(p, map,
                                 with_lead(std::move(cleaned), run, setup.frequency_Hz, options.start,
                                           options.lead_cycles),
                                 setup.scenario, times, options.relative_tolerance, t_start,
                                 recorded ? &*recorded : nullptr);
    Signals out;
    for (auto &[name, values] : all)
      if (run.has(name))
        out[name] = options.band_Hz > 0 ? band_limit(times, values, options.band_Hz) : std::move(values);
    if (const auto it = out.find("actuator_position_m"); it != out.end() && options.position_offset)
      {
        const auto &data = run.signal("actuator_position_m");
        double      sum  = 0;
        for (std::size_t i = 0; i < n; ++i)
          sum += data[i] - it->second[i];
        const double shift = sum / static_cast<double>(n);
        for (double &x : it->second)
          x += shift;
      }
    return out;
  }
} // namespace rectify::diagnosis
