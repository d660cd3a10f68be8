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

  namespace
  {
    /// Where in time a signal's residual (model - data) lies: by half of
    /// the cycle and third of the record, and its mean.
    void shape_in_time(const MeasuredRun &run, const std::vector<double> &values, const std::vector<double> &data,
                       double f, SignalShape &s)
    {
      const double t0 = run.time_s.front(), duration = run.time_s.back() - t0;
      const double phase0 = drive_phase_at_start(run, f);
      const std::size_t n = values.size();
      double      e_half[2] = {0, 0}, e_third[3] = {0, 0, 0}, bias = 0;
      std::size_t n_third[3] = {0, 0, 0};
      for (std::size_t i = 0; i < n; ++i)
        {
          const double t  = run.time_s[i] - t0;
          const double e  = values[i] - data[i];
          const int    h  = phase(t + phase0 / f, f) < 0.5 ? 0 : 1;
          const int    th = std::min(2, static_cast<int>(3.0 * t / std::max(duration, 1e-300)));
          e_half[h] += e * e;
          e_third[th] += e * e;
          ++n_third[th];
          bias += e / static_cast<double>(n);
        }
      const double total = e_half[0] + e_half[1];
      s.bias = bias;
      for (int h = 0; h < 2; ++h)
        s.half_fraction[h] = total > 0 ? e_half[h] / total : 0.0;
      for (int th = 0; th < 3; ++th)
        s.rms_by_third[th] = std::sqrt(e_third[th] / std::max<double>(1, static_cast<double>(n_third[th])));
    }

    /// Over the whole cycles of the second half of the record, in one pass:
    /// the residual's harmonics and each cycle's swing (max - min) in data
    /// and model, averaged.
    void shape_in_frequency(const MeasuredRun &run, const std::vector<double> &values,
                            const std::vector<double> &data, double f, SignalShape &s)
    {
      const double t0 = run.time_s.front(), T = 1.0 / f;
      const auto   n_cycles = static_cast<std::size_t>(std::floor((run.time_s.back() - t0) / T + 1e-9));
      const std::size_t c_from = n_cycles / 2, c_to = n_cycles;
      std::vector<std::complex<double>> c(11);
      double              energy = 0;
      std::size_t         m      = 0;
      std::vector<double> dmin(c_to - c_from, 1e300), dmax(c_to - c_from, -1e300);
      std::vector<double> mmin(dmin), mmax(dmax);
      for (std::size_t i = 0; i < values.size(); ++i)
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
      auto &amp = s.harmonic_amplitudes; // 0: mean, 1..10 harmonics
      amp.assign(11, 0.0);
      if (m > 0)
        {
          energy /= static_cast<double>(m);
          for (int h = 0; h <= 10; ++h)
            amp[h] = (h == 0 ? 1.0 : 2.0) * std::abs(c[h]) / static_cast<double>(m);
        }
      double harmonic_energy = amp[0] * amp[0];
      for (int h = 1; h <= 10; ++h)
        harmonic_energy += 0.5 * amp[h] * amp[h];
      s.dominant_harmonic = 1;
      for (int h = 1; h <= 10; ++h)
        if (amp[h] > amp[s.dominant_harmonic])
          s.dominant_harmonic = h;
      s.above_10th = energy > 0 ? std::max(0.0, 1.0 - harmonic_energy / energy) : 0.0;
      std::size_t n_sw = 0;
      for (std::size_t k = 0; k < dmin.size(); ++k)
        if (dmax[k] >= dmin[k])
          {
            s.swing_data += dmax[k] - dmin[k];
            s.swing_model += mmax[k] - mmin[k];
            ++n_sw;
          }
      if (n_sw > 0)
        {
          s.swing_data /= static_cast<double>(n_sw);
          s.swing_model /= static_cast<double>(n_sw);
        }
    }
  } // namespace

  nlohmann::json Localisation::numbers() const
  {
    nlohmann::json out = nlohmann::json::object();
    for (const auto &[name, s] : signals)
      out[name] = {{"rms_normalised", s.rms_normalised},
                   {"rms", s.rms},
                   {"mean_model_minus_data", s.bias},
                   {"pressurising_fraction", s.half_fraction[0]},
                   {"refill_fraction", s.half_fraction[1]},
                   {"harmonic_amplitudes", s.harmonic_amplitudes},
                   {"dominant_harmonic", s.dominant_harmonic},
                   {"energy_above_10th_harmonic_fraction", s.above_10th},
                   {"rms_by_third_of_record", s.rms_by_third},
                   {"cycle_swing_data", s.swing_data},
                   {"cycle_swing_model", s.swing_model}};
    return out;
  }

  Localisation localise(const MeasuredRun &run, const Signals &model, double f,
                        const std::map<std::string, double> &scales)
  {
    Localisation L;
    const auto   norms = residual_norms(run, model, scales);
    double       worst = -1;
    for (const auto &[name, v] : norms)
      if (name != "overall" && v > worst)
        {
          worst             = v;
          L.dominant_signal = name;
        }
    for (const auto &[name, values] : model)
      {
        auto &s          = L.signals[name];
        s.rms_normalised = norms.at(name);
        s.rms            = norms.at(name) * scales.at(name);
        shape_in_time(run, values, run.signal(name), f, s);
        shape_in_frequency(run, values, run.signal(name), f, s);
        if (name == L.dominant_signal)
          L.dominant_half = s.half_fraction[0] >= s.half_fraction[1] ? "pressurising" : "refill";
      }
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
        out.push_back({name, v, L.signals.at(name)});
    std::stable_sort(out.begin(), out.end(),
                     [](const SignalResidual &a, const SignalResidual &b) { return a.noise_units > b.noise_units; });
    return out;
  }

} // namespace rectify::diagnosis
