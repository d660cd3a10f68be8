#include "diagnosis/residuals.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>
#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include "common/case_file.h"

namespace rectify::diagnosis
{
  namespace
  {
    double rms_about_mean(const std::vector<double> &v)
    {
      double mean = 0, var = 0;
      for (double x : v)
        mean += x / static_cast<double>(v.size());
      for (double x : v)
        var += (x - mean) * (x - mean) / static_cast<double>(v.size());
      return std::sqrt(var);
    }

    std::string pretty(const std::string &signal)
    {
      if (signal == "outlet_pressure_Pa")
        return "outlet pressure";
      if (signal == "chamber_pressure_Pa")
        return "chamber pressure";
      if (signal == "outlet_valve_m")
        return "outlet valve opening";
      if (signal == "actuator_position_m")
        return "actuator position";
      if (signal == "actuator_velocity_m_per_s")
        return "actuator velocity";
      return signal;
    }

    /// Value in the signal's display unit, with the unit.
    std::string in_units(const std::string &signal, double v)
    {
      char buf[64];
      if (signal.ends_with("_Pa"))
        std::snprintf(buf, sizeof buf, "%.3g MPa", v / 1e6);
      else if (signal == "outlet_valve_m")
        std::snprintf(buf, sizeof buf, "%.3g um", v * 1e6);
      else if (signal == "actuator_position_m")
        std::snprintf(buf, sizeof buf, "%.3g mm", v * 1e3);
      else if (signal == "actuator_velocity_m_per_s")
        std::snprintf(buf, sizeof buf, "%.3g mm/s", v * 1e3);
      else
        std::snprintf(buf, sizeof buf, "%.3g", v);
      return buf;
    }

    std::string percent(double fraction)
    {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.0f %%", 100 * fraction);
      return buf;
    }

    /// Cycle phase in [0, 1) at time t (record starts at phase 0: the drive's
    /// minimum for the synthesiser's sine; the rising half is the stroke).
    double phase(double t, double f) { return t * f - std::floor(t * f); }
  } // namespace

  double drive_phase_at_start(const MeasuredRun &run, double f)
  {
    // the drive's fundamental: c + a cos(w t) + b sin(w t) = c - A cos(w t + phi)
    const auto  &d = run.signal(run.drive_column());
    const double w = 2.0 * std::numbers::pi * f;
    const double t_cycles = std::floor(run.duration_s() * f) / f; // whole cycles
    double       a = 0, b = 0;
    std::size_t  n = 0;
    for (std::size_t i = 0; i < d.size(); ++i)
      {
        const double t = run.time_s[i] - run.time_s.front();
        if (t >= t_cycles && n > 0)
          break;
        a += d[i] * std::cos(w * t);
        b += d[i] * std::sin(w * t);
        ++n;
      }
    if (n == 0 || (a == 0 && b == 0))
      return 0.0;
    const double phi = std::atan2(b, -a);
    return phase(phi / (2.0 * std::numbers::pi), 1.0);
  }

  std::map<std::string, double> signal_scales(const MeasuredRun &run)
  {
    std::map<std::string, double> s;
    for (const auto &c : signal_columns())
      if (run.has(c))
        {
          const double r = rms_about_mean(run.signal(c));
          s[c]           = r > 0 ? r : 1.0;
        }
    return s;
  }

  double white_noise_sd(const std::vector<double> &v)
  {
    if (v.size() < 5)
      return 0.0;
    std::vector<double> d(v.size() - 2);
    for (std::size_t i = 1; i + 1 < v.size(); ++i)
      d[i - 1] = v[i + 1] - 2 * v[i] + v[i - 1];
    const auto median = [](std::vector<double> x) {
      std::nth_element(x.begin(), x.begin() + static_cast<long>(x.size() / 2), x.end());
      return x[x.size() / 2];
    };
    const double m = median(d);
    for (double &x : d)
      x = std::abs(x - m);
    return 1.4826 * median(d) / std::sqrt(6.0);
  }

  double cycle_scatter(const std::vector<double> &t, const std::vector<double> &v, double f)
  {
    const std::size_t n = v.size();
    if (n < 16 || !uniformly_sampled(t) || !(f > 0))
      return 0.0;
    const double dt     = (t.back() - t.front()) / static_cast<double>(n - 1);
    const double per    = 1.0 / (f * dt);
    const auto   period = static_cast<std::size_t>(std::llround(per));
    if (period < 4 || std::abs(per - static_cast<double>(period)) > 0.01 * per)
      return 0.0;
    const std::size_t cycles = n / period, first = cycles / 2;
    const std::size_t m      = cycles - first; // cycles used
    if (m < 5)
      return 0.0;
    // per phase, a quadratic in the cycle index (a build-up that has not
    // settled, a drift) fitted by least squares; the scatter about it
    Eigen::MatrixXd A(static_cast<Eigen::Index>(m), 3);
    for (std::size_t c = 0; c < m; ++c)
      {
        const double x = static_cast<double>(c) - 0.5 * static_cast<double>(m - 1);
        A(static_cast<Eigen::Index>(c), 0) = 1.0;
        A(static_cast<Eigen::Index>(c), 1) = x;
        A(static_cast<Eigen::Index>(c), 2) = x * x;
      }
    const auto      qr  = A.colPivHouseholderQr();
    Eigen::VectorXd y(static_cast<Eigen::Index>(m));
    double          sum = 0;
    for (std::size_t j = 0; j < period; ++j)
      {
        for (std::size_t c = 0; c < m; ++c)
          y(static_cast<Eigen::Index>(c)) = v[(first + c) * period + j];
        sum += (y - A * qr.solve(y)).squaredNorm();
      }
    return std::sqrt(sum / static_cast<double>(period * (m - 3)));
  }

  std::vector<double> spectral_peaks(const std::vector<double> &t, const std::vector<double> &v,
                                     double f_low, double f_high, std::size_t count, double min_share,
                                     double separation)
  {
    const std::size_t n = v.size();
    if (n < 16 || t.size() != n || !uniformly_sampled(t) || count == 0)
      return {};
    const double dt = (t.back() - t.front()) / static_cast<double>(n - 1);
    double mean = 0;
    for (double x : v)
      mean += x / static_cast<double>(n);
    std::size_t m = 1;
    while (m < 8 * n)
      m *= 2;
    std::vector<double> x(m, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      x[i] = (v[i] - mean) * (0.5 - 0.5 * std::cos(2 * std::numbers::pi * static_cast<double>(i) /
                                                    static_cast<double>(n - 1)));
    Eigen::FFT<double>                fft;
    std::vector<std::complex<double>> X;
    fft.fwd(X, x);
    const double df = 1.0 / (static_cast<double>(m) * dt);
    const auto   lo = static_cast<std::size_t>(std::max(1.0, std::ceil(f_low / df)));
    const auto   hi = std::min(static_cast<std::size_t>(f_high / df), m / 2 - 1);
    if (lo > hi)
      return {};
    // the bins in the band, largest first; each is a peak if it is apart
    // from the peaks found so far
    std::vector<std::size_t> bins;
    for (std::size_t k = lo; k <= hi; ++k)
      bins.push_back(k);
    std::sort(bins.begin(), bins.end(), [&](auto a, auto b) { return std::abs(X[a]) > std::abs(X[b]); });
    const double largest = std::abs(X[bins.front()]);
    if (!(largest > 0))
      return {};
    std::vector<std::size_t> found;
    for (std::size_t k : bins)
      {
        if (found.size() == count || std::abs(X[k]) < min_share * largest)
          break;
        const bool apart = std::all_of(found.begin(), found.end(), [&](std::size_t j) {
          return std::abs(std::log(static_cast<double>(k) / static_cast<double>(j))) > std::log1p(separation);
        });
        // after the largest, only local maxima inside the band (not the
        // skirt of a larger peak, not a band edge)
        const bool local = k > lo && k < hi && std::abs(X[k]) >= std::abs(X[k - 1]) &&
                           std::abs(X[k]) >= std::abs(X[k + 1]);
        if (apart && (found.empty() || local))
          found.push_back(k);
      }
    std::vector<double> peaks;
    for (std::size_t k : found)
      {
        // parabola through the log magnitudes about the bin
        const double a = std::log(std::abs(X[k - 1]) + 1e-300), b = std::log(std::abs(X[k]) + 1e-300),
                     c = std::log(std::abs(X[k + 1]) + 1e-300);
        const double denom = a - 2 * b + c;
        const double shift = denom < 0 ? std::clamp(0.5 * (a - c) / denom, -0.5, 0.5) : 0.0;
        peaks.push_back((static_cast<double>(k) + shift) * df);
      }
    return peaks;
  }

  SquaredResidual squared_residual(const MeasuredRun &run, const Signals &model,
                                   const std::map<std::string, double> &scales, std::size_t from,
                                   std::size_t to)
  {
    SquaredResidual r;
    for (const auto &[name, values] : model)
      {
        const auto  &data  = run.signal(name);
        const double scale = scales.at(name);
        const auto   end   = std::min({to, values.size(), data.size()});
        for (std::size_t i = from; i < end; ++i)
          {
            const double e = (values[i] - data[i]) / scale;
            r.sum += e * e;
            ++r.n;
          }
      }
    return r;
  }

  void append_residuals(const MeasuredRun &run, const Signals &model,
                        const std::map<std::string, double> &scales, std::size_t from, std::size_t to,
                        std::vector<double> &out)
  {
    for (const auto &[name, values] : model)
      {
        const auto  &data  = run.signal(name);
        const double scale = scales.at(name);
        const auto   end   = std::min({to, values.size(), data.size()});
        for (std::size_t i = from; i < end; ++i)
          out.push_back((values[i] - data[i]) / scale);
      }
  }

  std::map<std::string, double> residual_norms(const MeasuredRun &run, const Signals &model,
                                               const std::map<std::string, double> &scales,
                                               std::size_t from)
  {
    std::map<std::string, double> out;
    double                        total = 0;
    for (const auto &[name, values] : model)
      {
        const Signals one{{name, values}};
        const auto    r = squared_residual(run, one, scales, from, values.size());
        out[name]       = std::sqrt(r.sum / static_cast<double>(std::max<std::size_t>(r.n, 1)));
        total += out[name] * out[name];
      }
    out["overall"] = std::sqrt(total / static_cast<double>(std::max<std::size_t>(model.size(), 1)));
    return out;
  }

  double half_cycle_residual(const MeasuredRun &run, const Signals &model, double f,
                             const std::string &signal, const std::string &half,
                             const std::map<std::string, double> &scales)
  {
    const auto it = model.find(signal);
    if (it == model.end())
      return 0;
    const auto  &data   = run.signal(signal);
    const double phase0 = drive_phase_at_start(run, f);
    double       sum    = 0;
    std::size_t  n      = 0;
    for (std::size_t i = 0; i < it->second.size(); ++i)
      {
        const bool stroke = phase(run.time_s[i] - run.time_s.front() + phase0 / f, f) < 0.5;
        if (stroke != (half == "pressurising"))
          continue;
        const double e = (it->second[i] - data[i]) / scales.at(signal);
        sum += e * e;
        ++n;
      }
    return std::sqrt(sum / static_cast<double>(std::max<std::size_t>(n, 1)));
  }

  Localisation localise(const MeasuredRun &run, const Signals &model, double f,
                        const std::map<std::string, double> &scales)
  {
    Localisation L;
    L.numbers        = nlohmann::json::object();
    const auto norms = residual_norms(run, model, scales);
    double     worst = -1;
    for (const auto &[name, v] : norms)
      if (name != "overall" && v > worst)
        {
          worst             = v;
          L.dominant_signal = name;
        }
    const double t0 = run.time_s.front(), T = 1.0 / f;
    const double duration = run.time_s.back() - t0;
    const double phase0   = drive_phase_at_start(run, f);
    const auto   n_cycles = static_cast<std::size_t>(std::floor(duration / T + 1e-9));

    for (const auto &[name, values] : model)
      {
        const auto  &data  = run.signal(name);
        const double scale = scales.at(name);
        const std::size_t n = values.size();
        // cycle halves, thirds of the record, mean offset
        double      e_half[2] = {0, 0}, e_third[3] = {0, 0, 0}, bias = 0;
        std::size_t n_half[2] = {0, 0}, n_third[3] = {0, 0, 0};
        for (std::size_t i = 0; i < n; ++i)
          {
            const double t  = run.time_s[i] - t0;
            const double e  = values[i] - data[i];
            const int    h  = phase(t + phase0 / f, f) < 0.5 ? 0 : 1;
            const int    th = std::min(2, static_cast<int>(3.0 * t / std::max(duration, 1e-300)));
            e_half[h] += e * e;
            ++n_half[h];
            e_third[th] += e * e;
            ++n_third[th];
            bias += e / static_cast<double>(n);
          }
        const double total = e_half[0] + e_half[1];
        // over the whole cycles of the second half of the record, in one
        // pass: the residual's harmonics and each cycle's swing (max - min)
        // in data and model
        const std::size_t c_from = n_cycles / 2, c_to = n_cycles;
        std::vector<std::complex<double>> c(11);
        double              energy = 0;
        std::size_t         m      = 0;
        std::vector<double> dmin(c_to - c_from, 1e300), dmax(c_to - c_from, -1e300);
        std::vector<double> mmin(dmin), mmax(dmax);
        for (std::size_t i = 0; i < n; ++i)
          {
            const double t = run.time_s[i] - t0;
            if (t < static_cast<double>(c_from) * T || t >= static_cast<double>(c_to) * T)
              continue;
            const auto   k = std::min(c_to - 1, static_cast<std::size_t>(t / T)) - c_from;
            const double e = values[i] - data[i];
            ++m;
            energy += e * e;
            for (int h = 0; h <= 10; ++h)
              c[h] += e * std::polar(1.0, -2 * std::numbers::pi * h * f * t);
            dmin[k] = std::min(dmin[k], data[i]);
            dmax[k] = std::max(dmax[k], data[i]);
            mmin[k] = std::min(mmin[k], values[i]);
            mmax[k] = std::max(mmax[k], values[i]);
          }
        std::vector<double> amp(11, 0.0); // 0: mean, 1..10 harmonics
        if (m > 0)
          {
            energy /= static_cast<double>(m);
            for (int h = 0; h <= 10; ++h)
              amp[h] = (h == 0 ? 1.0 : 2.0) * std::abs(c[h]) / static_cast<double>(m);
          }
        double harmonic_energy = amp[0] * amp[0];
        for (int h = 1; h <= 10; ++h)
          harmonic_energy += 0.5 * amp[h] * amp[h];
        int top = 1;
        for (int h = 1; h <= 10; ++h)
          if (amp[h] > amp[top])
            top = h;
        const double above = energy > 0 ? std::max(0.0, 1.0 - harmonic_energy / energy) : 0.0;
        double      swing_data = 0, swing_model = 0;
        std::size_t n_sw = 0;
        for (std::size_t k = 0; k < dmin.size(); ++k)
          if (dmax[k] >= dmin[k])
            {
              swing_data += dmax[k] - dmin[k];
              swing_model += mmax[k] - mmin[k];
              ++n_sw;
            }
        if (n_sw > 0)
          {
            swing_data /= static_cast<double>(n_sw);
            swing_model /= static_cast<double>(n_sw);
          }
        const double rms_third[3] = {std::sqrt(e_third[0] / std::max<double>(1, n_third[0])),
                                     std::sqrt(e_third[1] / std::max<double>(1, n_third[1])),
                                     std::sqrt(e_third[2] / std::max<double>(1, n_third[2]))};
        L.numbers[name] = {
          {"rms_normalised", norms.at(name)},
          {"rms", norms.at(name) * scale},
          {"mean_model_minus_data", bias},
          {"pressurising_fraction", total > 0 ? e_half[0] / total : 0.0},
          {"refill_fraction", total > 0 ? e_half[1] / total : 0.0},
          {"harmonic_amplitudes", amp},
          {"dominant_harmonic", top},
          {"energy_above_10th_harmonic_fraction", above},
          {"rms_by_third_of_record", {rms_third[0], rms_third[1], rms_third[2]}},
          {"cycle_swing_data", swing_data},
          {"cycle_swing_model", swing_model}};
        if (name == L.dominant_signal)
          L.dominant_half = e_half[0] >= e_half[1] ? "pressurising" : "refill";

        std::string s = "residual " + in_units(name, norms.at(name) * scale) +
                        " RMS (" + percent(norms.at(name)) + " of its swing), " +
                        percent(total > 0 ? std::max(e_half[0], e_half[1]) / total : 0) +
                        " of it in the " + (e_half[0] >= e_half[1] ? "pressurising stroke" : "refill") +
                        "; model " + (bias > 0 ? "above" : "below") + " the data by " +
                        in_units(name, std::abs(bias)) + " on average";
        s += "; per cycle the data swing " + in_units(name, swing_data) + ", the model " +
             in_units(name, swing_model);
        if (above > 0.3)
          s += "; " + percent(above) + " of the residual above the 10th harmonic (fast ringing)";
        else
          s += "; mostly at harmonic " + std::to_string(top) + " (" + in_units(name, amp[top]) + ")";
        const double growth = rms_third[0] > 0 ? rms_third[2] / rms_third[0] : 0;
        if (growth > 1.5)
          s += "; grows over the record (last third " + format_number(std::round(growth * 10) / 10) +
               " x the first)";
        else if (growth > 0 && growth < 1 / 1.5)
          s += "; fades over the record (start-up transient)";
        L.sentence_of[name] = s;
        if (norms.at(name) >= 0.03) // within a few percent of the swing: not worth a sentence of its own
          L.sentences.push_back(pretty(name) + ": " + s);
      }
    if (L.sentences.empty())
      L.sentences.push_back("every signal within 3 % of its swing: no clear disagreement");
    return L;
  }

  std::vector<SignalResidual> residuals_in_noise_units(const MeasuredRun &run, const Signals &model, double f,
                                                       const std::map<std::string, double> &swings,
                                                       const std::map<std::string, double> &noise, std::size_t from)
  {
    std::vector<SignalResidual> out;
    const auto                  L = localise(run, model, f, swings);
    for (const auto &[name, v] : residual_norms(run, model, noise, from))
      if (name != "overall")
        {
          char units[64];
          std::snprintf(units, sizeof units, ", %.3g noise units: ", v);
          out.push_back({name, v, pretty(name) + units + L.sentence_of.at(name)});
        }
    std::stable_sort(out.begin(), out.end(),
                     [](const SignalResidual &a, const SignalResidual &b) { return a.noise_units > b.noise_units; });
    return out;
  }

} // namespace rectify::diagnosis
