#include "diagnosis/sensors.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "diagnosis/golden_section.h"

namespace rectify::diagnosis
{
  SensorLimits SensorLimits::from_case(const CaseFile &file)
  {
    SensorLimits      s;
    const std::string t     = "sensors";
    const Bounds      range = Bounds::closed(0.0, 1e9);
    s.pressure_Hz           = file.real(t, "pressure_lowest_bandwidth_Hz", s.pressure_Hz, range);
    s.opening_Hz            = file.real(t, "opening_lowest_bandwidth_Hz", s.opening_Hz, range);
    s.strain_Hz             = file.real(t, "strain_lowest_bandwidth_Hz", s.strain_Hz, range);
    s.actuator_Hz           = file.real(t, "actuator_lowest_bandwidth_Hz", s.actuator_Hz, range);
    return s;
  }

  std::map<std::string, double> SensorLimits::per_signal() const
  {
    std::map<std::string, double> out;
    for (const auto &c : signal_columns())
      {
        const double f = c.ends_with("_Pa")        ? pressure_Hz :
                         c == "outlet_valve_m"     ? opening_Hz :
                         c == "strain"             ? strain_Hz :
                         c.starts_with("actuator") ? actuator_Hz :
                                                     0.0;
        if (f > 0)
          out[c] = f;
      }
    return out;
  }

  std::vector<double> first_order_lag(const std::vector<double> &t, const std::vector<double> &x, double bandwidth_Hz)
  {
    if (t.size() != x.size())
      throw std::invalid_argument("first_order_lag: " + std::to_string(t.size()) + " times for " +
                                  std::to_string(x.size()) + " values");
    if (!(bandwidth_Hz > 0))
      throw std::invalid_argument("first_order_lag: bandwidth " + std::to_string(bandwidth_Hz) + " Hz");
    if (x.empty() || std::isinf(bandwidth_Hz))
      return x;
    const double        tau = 1.0 / (2.0 * std::numbers::pi * bandwidth_Hz);
    std::vector<double> y(x.size());
    y[0] = x[0];
    for (std::size_t i = 1; i < x.size(); ++i)
      {
        // x = x[i-1] + s (t - t[i-1]) over the step: y = x - tau s + (y0 - x0 + tau s) e^(-(t - t0) / tau)
        const double h = t[i] - t[i - 1];
        const double s = h > 0 ? (x[i] - x[i - 1]) / h : 0.0;
        const double a = std::exp(-h / tau);
        y[i]           = x[i] - tau * s + (y[i - 1] - x[i - 1] + tau * s) * a;
      }
    return y;
  }

  namespace
  {
    /// A model's signal through the lag at the record's times: the whole
    /// record, or its first samples (a model simulated over part of it).
    std::vector<double> lagged(const std::vector<double> &record_times, const std::vector<double> &values,
                               double bandwidth_Hz)
    {
      if (values.size() >= record_times.size())
        return first_order_lag(record_times, values, bandwidth_Hz); // (longer: first_order_lag refuses)
      return first_order_lag({record_times.begin(), record_times.begin() + values.size()}, values, bandwidth_Hz);
    }

    /// A signal's training residual, summed over the runs, with the lag
    /// of delay tau (0: ideal), in squared noise units, and its count.
    struct SignalFit
    {
      const std::vector<RunCase> &runs;
      const std::vector<Signals> &model;
      const std::string          &signal;

      /// over the training samples [n_skip, n_train), or (held_out) those after them
      std::pair<double, std::size_t> squared(double tau, bool held_out = false) const
      {
        double      sum = 0;
        std::size_t n   = 0;
        for (std::size_t r = 0; r < runs.size(); ++r)
          {
            const auto it = model[r].find(signal);
            if (it == model[r].end() || !runs[r].run.has(signal))
              continue;
            const auto &rc = runs[r];
            const auto  y  = tau > 0 ? lagged(rc.run.time_s, it->second, 1.0 / (2 * std::numbers::pi * tau)) :
                                       it->second;
            const auto &d     = rc.run.signal(signal);
            const double scale = rc.scales.at(signal);
            const auto   end   = std::min({held_out ? d.size() : rc.n_train, y.size(), d.size()});
            for (std::size_t i = held_out ? std::max(rc.n_train, rc.n_skip) : rc.n_skip; i < end; ++i)
              {
                const double e = (y[i] - d[i]) / scale;
                sum += e * e;
                ++n;
              }
          }
        return {sum, n};
      }
    };
  } // namespace

  std::vector<SensorLag> calibrate_sensor_lags(const std::vector<RunCase> &runs, std::vector<Signals> &model,
                                               const std::map<std::string, double> &lowest_bandwidth_Hz)
  {
    if (model.size() != runs.size())
      throw std::invalid_argument("calibrate_sensor_lags: " + std::to_string(model.size()) + " models for " +
                                  std::to_string(runs.size()) + " runs");
    std::vector<SensorLag> out;
    for (const auto &[signal, lowest] : lowest_bandwidth_Hz)
      {
        if (!(lowest > 0))
          continue;
        const SignalFit fit{runs, model, signal};
        const auto [ideal, n] = fit.squared(0.0);
        if (n == 0)
          continue;
        const double tau_max = 1.0 / (2.0 * std::numbers::pi * lowest);
        // the scan: 24 delays over [0, tau_max]; then golden sections in the
        // interval around the best (a residual's square is smooth in the delay)
        constexpr int       points = 24;
        std::vector<double> value(points + 1);
        int                 best = 0;
        value[0]                 = ideal;
        for (int k = 1; k <= points; ++k)
          {
            value[k] = fit.squared(tau_max * k / points).first;
            if (value[k] < value[best])
              best = k;
          }
        double       tau = tau_max * best / points, f_tau = value[best];
        const auto end = golden_section([&](double t) { return fit.squared(t).first; },
                                        tau_max * std::max(best - 1, 0) / points,
                                        tau_max * std::min(best + 1, points) / points, 40, 1e-4 * tau_max);
        for (const auto &[t, f] : {std::pair{end.c, end.fc}, std::pair{end.d, end.fd}})
          if (f < f_tau)
            {
              tau   = t;
              f_tau = f;
            }
        SensorLag lag;
        lag.signal          = signal;
        lag.lowest_Hz       = lowest;
        lag.fitted_Hz       = tau > 0 ? 1.0 / (2.0 * std::numbers::pi * tau) : std::numeric_limits<double>::infinity();
        lag.residual_ideal  = std::sqrt(ideal / static_cast<double>(n));
        lag.residual_lagged = std::sqrt(f_tau / static_cast<double>(n));
        const auto [h_ideal, h_n] = fit.squared(0.0, true);
        if (h_n > 0)
          {
            lag.heldout_ideal  = std::sqrt(h_ideal / static_cast<double>(h_n));
            lag.heldout_lagged = std::sqrt(fit.squared(tau, true).first / static_cast<double>(h_n));
          }
        // a lag that the held-out samples do not confirm has taken up what
        // does not repeat (a valve's flutter)
        lag.kept = !(lag.heldout_lagged > lag.heldout_ideal);
        if (lag.kept && tau > 0)
          for (std::size_t r = 0; r < runs.size(); ++r)
            if (const auto it = model[r].find(signal); it != model[r].end())
              it->second = lagged(runs[r].run.time_s, it->second, lag.applied_Hz());
        out.push_back(lag);
      }
    return out;
  }
} // namespace rectify::diagnosis
